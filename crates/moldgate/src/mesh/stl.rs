//! STL, binary and ASCII.
//!
//! Binary is recognised by its size rule before the word `solid` is looked at: a file of
//! exactly 84 + 50 n bytes (a trailing newline allowed) for the n its header declares is
//! binary, whatever its first bytes. Otherwise a file that starts with `solid` and whose
//! first kilobyte is text is ASCII; anything else is a binary file with a wrong size, and the
//! error says whether it is cut short or too long.
//!
//! ASCII is read tolerantly: keywords in any case, several `solid` blocks, facets with more
//! than three corners (split into a fan), a missing final `endsolid` (with a warning). The
//! facet normal is ignored; orientation comes from the corner order.

use std::io::{BufRead, Read, Seek, SeekFrom, Write};

use rayon::prelude::*;

use super::text::Lines;
use super::weld32::{key_bits, Key, Welder32, BATCH};
use super::{sniff, Format, Mesh, RawMesh, Units, Welder, MAX_COORDINATE_MM, MAX_POLYGON_CORNERS};
use crate::error::{excerpt, LoadError, Place};
use crate::math::DVec3;

const HEADER: u64 = 84;
const RECORD: u64 = 50;

/// Reads an STL of `len` bytes written in `units` (whose coordinates must lie within
/// [`MAX_COORDINATE_MM`] once in millimetres).
pub fn read(mut reader: impl BufRead, len: u64, units: Units) -> Result<RawMesh, LoadError> {
    if len == 0 {
        return Err(LoadError::Empty);
    }
    let mut head = Vec::with_capacity(1024);
    (&mut reader).take(1024).read_to_end(&mut head)?;
    if head.is_empty() {
        return Err(LoadError::Empty);
    }
    let declared = if head.len() >= HEADER as usize {
        Some(u32::from_le_bytes([head[80], head[81], head[82], head[83]]) as u64)
    } else {
        None
    };
    if let Some(n) = declared {
        let expected = HEADER + RECORD * n;
        if len >= expected && len - expected <= 2 {
            return read_binary((&head[..]).chain(reader), n, units);
        }
    }
    if looks_ascii(&head) {
        return read_ascii((&head[..]).chain(reader), units);
    }
    if let Some(e) = sniff::not_a_mesh(&head, true) {
        return Err(e);
    }
    let Some(declared) = declared else {
        return Err(LoadError::TruncatedHeader { len });
    };
    let expected = HEADER + RECORD * declared;
    if len < expected {
        let triangle = (len - HEADER) / RECORD;
        Err(LoadError::Truncated {
            declared,
            expected,
            len,
            triangle,
            offset: HEADER + RECORD * triangle,
        })
    } else {
        Err(LoadError::CountMismatch {
            declared,
            expected,
            len,
        })
    }
}

/// True when the file starts (after a byte-order mark and white space) with `solid`, and
/// either its first bytes hold no control characters, which the floats of a binary STL
/// almost always do, or the keywords `facet` and `vertex` follow in the first kilobyte (an
/// ASCII file with a stray control character: the ASCII reader then names its line).
fn looks_ascii(head: &[u8]) -> bool {
    let head = head.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(head);
    let text = head.trim_ascii_start();
    let has = |word: &[u8]| {
        head.windows(word.len())
            .any(|w| w.eq_ignore_ascii_case(word))
    };
    text.len() >= 5
        && text[..5].eq_ignore_ascii_case(b"solid")
        && (sniff::is_text(head) || (has(b"facet") && has(b"vertex")))
}

/// The largest coordinate of a file in `units`, in those units.
fn coordinate_limit(units: Units) -> f64 {
    MAX_COORDINATE_MM / units.mm_per_unit()
}

/// The error for a coordinate `value` (in `units`) that is not finite or beyond the limit.
pub(super) fn bad_coordinate(place: Place, triangle: u64, value: f64, units: Units) -> LoadError {
    if value.is_finite() {
        LoadError::OutOfRange {
            place,
            value,
            mm: value * units.mm_per_unit(),
            limit_mm: MAX_COORDINATE_MM,
        }
    } else {
        LoadError::NonFinite {
            place,
            triangle,
            value,
        }
    }
}

fn read_binary(mut reader: impl Read, declared: u64, units: Units) -> Result<RawMesh, LoadError> {
    let mut header = [0u8; HEADER as usize];
    reader.read_exact(&mut header)?;
    let mut welder = Welder32::for_run(declared as usize, declared as usize);
    weld_records(reader, 0..declared, &mut welder, units)?;
    Ok(binary_mesh(welder.finish(), declared))
}

/// The raw mesh of a binary STL of `declared` facets, welded to `mesh` with
/// `collapsed_facets` dropped.
fn binary_mesh((mesh, collapsed_facets): (Mesh, u64), declared: u64) -> RawMesh {
    RawMesh {
        format: Format::StlBinary,
        solids: 1,
        facets_read: declared,
        corners_read: 3 * declared,
        collapsed_facets,
        mesh,
        warnings: Vec::new(),
    }
}

/// Reads the binary records `range` from `reader`, which is positioned at the first of them,
/// into `welder`, on the bits of their `f32` corners.
fn weld_records(
    mut reader: impl Read,
    range: std::ops::Range<u64>,
    welder: &mut Welder32,
    units: Units,
) -> Result<(), LoadError> {
    const CHUNK: usize = 4096;
    // NaN, the infinities and the out of range refused by one test a coordinate: on the
    // bits of its magnitude, which order finite values as they compare and put the
    // infinities and NaN above every finite limit.
    let limit = (coordinate_limit(units) as f32).to_bits();
    let mut buf = vec![0u8; CHUNK * RECORD as usize];
    let mut batch = [[[0u32; 3]; 3]; BATCH];
    let mut filled = 0;
    let mut done = range.start;
    while done < range.end {
        let count = (range.end - done).min(CHUNK as u64) as usize;
        let bytes = &mut buf[..count * RECORD as usize];
        reader.read_exact(bytes)?;
        for (i, rec) in bytes.chunks_exact(RECORD as usize).enumerate() {
            let corners: &[u8; 36] = rec[12..48].try_into().expect("36 bytes");
            let bits: [u32; 9] = std::array::from_fn(|n| {
                u32::from_le_bytes([
                    corners[4 * n],
                    corners[4 * n + 1],
                    corners[4 * n + 2],
                    corners[4 * n + 3],
                ])
            });
            // One test for the facet, without a branch per coordinate.
            if bits.iter().fold(0, |worst, &b| worst.max(b & 0x7FFF_FFFF)) > limit {
                let triangle = done + i as u64;
                let (at, v) = (0..9)
                    .map(|n| (12 + 4 * n, f32::from_bits(bits[n])))
                    .find(|(_, v)| v.is_nan() || v.abs().to_bits() > limit)
                    .expect("a coordinate failed the test");
                return Err(bad_coordinate(
                    Place::Byte(HEADER + RECORD * triangle + at as u64),
                    triangle,
                    v as f64,
                    units,
                ));
            }
            let key =
                |k: usize| -> Key { [bits[3 * k], bits[3 * k + 1], bits[3 * k + 2]].map(key_bits) };
            batch[filled] = [key(0), key(1), key(2)];
            filled += 1;
            if filled == BATCH {
                welder.push_batch(&batch);
                filled = 0;
            }
        }
        done += count as u64;
    }
    for &facet in &batch[..filled] {
        welder.push(facet);
    }
    Ok(())
}

/// Binary files with fewer triangles than this are read on one thread.
const PARALLEL_MIN_TRIANGLES: u64 = 32 * 1024;

/// Reads an STL of `len` bytes from a source that `open` can open several times (a file).
///
/// A large binary file is split into as many runs of consecutive records as there are
/// threads; each run is read through its own handle and welded on its own, then the runs are
/// merged in order. Vertices are numbered by first appearance in the file, as the
/// single-threaded reader numbers them, so the result is the same. Anything else is read by
/// [`read`] through one handle.
pub fn read_reopen<R, F>(open: F, len: u64, units: Units) -> Result<RawMesh, LoadError>
where
    R: BufRead + Seek,
    F: Fn() -> std::io::Result<R> + Sync,
{
    let mut first = open()?;
    let mut head = [0u8; HEADER as usize];
    let declared = match first.read_exact(&mut head) {
        Ok(()) => Some(u32::from_le_bytes([head[80], head[81], head[82], head[83]]) as u64),
        Err(_) => None,
    };
    first.seek(SeekFrom::Start(0))?;
    let runs = rayon::current_num_threads().min(8) as u64;
    let Some(n) = declared.filter(|&n| {
        let expected = HEADER + RECORD * n;
        n >= PARALLEL_MIN_TRIANGLES && runs > 1 && len >= expected && len - expected <= 2
    }) else {
        return read(first, len, units);
    };
    drop(first);
    let per_run = n.div_ceil(runs);
    let welded: Vec<Result<Welder32, LoadError>> = (0..runs)
        .into_par_iter()
        .map(|r| {
            let range = (r * per_run).min(n)..((r + 1) * per_run).min(n);
            let mut reader = open()?;
            reader.seek(SeekFrom::Start(HEADER + RECORD * range.start))?;
            // The first run's triangle list has room for the whole file: the others are
            // joined to it without reallocating (room never written costs no memory).
            let room = if r == 0 { n } else { 0 };
            let mut welder = Welder32::for_run((range.end - range.start) as usize, room as usize);
            weld_records(reader, range, &mut welder, units)?;
            Ok(welder)
        })
        .collect();
    let runs = welded.into_iter().collect::<Result<Vec<_>, _>>()?;
    Ok(binary_mesh(Welder32::join(runs), n))
}

/// What the ASCII parser expects next.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Expect {
    Solid,
    FacetOrEnd,
    Normal,
    NormalValues(u8),
    Outer,
    Loop,
    VertexOrEndloop,
    VertexValues(u8),
    Endfacet,
}

fn read_ascii(reader: impl BufRead, units: Units) -> Result<RawMesh, LoadError> {
    let limit = coordinate_limit(units);
    let mut lines = Lines::new(reader);
    let mut welder = Welder::with_capacity(1024);
    let mut expect = Expect::Solid;
    let mut line_no = 0u64;
    let mut line = Vec::new();
    let mut solids = 0u64;
    let mut facets = 0u64;
    let mut corners_read = 0u64;
    let mut corners: Vec<DVec3> = Vec::with_capacity(3);
    let mut xyz = [0.0f64; 3];
    let mut warnings = Vec::new();
    let syntax = |line: u64, message: String| LoadError::Syntax {
        place: Place::Line(line),
        message,
    };
    while lines.next_into(&mut line)? {
        line_no = lines.line_no;
        let tokens = line
            .split(|b| b.is_ascii_whitespace())
            .filter(|t| !t.is_empty());
        for tok in tokens {
            let is = |word: &str| tok.eq_ignore_ascii_case(word.as_bytes());
            let shown = || excerpt(tok);
            match expect {
                Expect::Solid => {
                    if !is("solid") {
                        return Err(syntax(
                            line_no,
                            format!("expected 'solid', found '{}'", shown()),
                        ));
                    }
                    solids += 1;
                    expect = Expect::FacetOrEnd;
                    break; // the rest of the line is the solid's name
                }
                Expect::FacetOrEnd => {
                    if is("facet") {
                        expect = Expect::Normal;
                    } else if is("endsolid") {
                        expect = Expect::Solid;
                        break; // the rest of the line is the solid's name
                    } else {
                        return Err(syntax(
                            line_no,
                            format!("expected 'facet' or 'endsolid', found '{}'", shown()),
                        ));
                    }
                }
                Expect::Normal => {
                    if is("normal") {
                        expect = Expect::NormalValues(0);
                    } else if is("outer") {
                        expect = Expect::Loop;
                    } else {
                        return Err(syntax(
                            line_no,
                            format!("expected 'normal', found '{}'", shown()),
                        ));
                    }
                }
                Expect::NormalValues(i) => {
                    // The normal is not used, but it must be a number.
                    parse_number(tok, line_no)?;
                    expect = if i == 2 {
                        Expect::Outer
                    } else {
                        Expect::NormalValues(i + 1)
                    };
                }
                Expect::Outer => {
                    if !is("outer") {
                        return Err(syntax(
                            line_no,
                            format!("expected 'outer loop', found '{}'", shown()),
                        ));
                    }
                    expect = Expect::Loop;
                }
                Expect::Loop => {
                    if !is("loop") {
                        return Err(syntax(
                            line_no,
                            format!("expected 'loop' after 'outer', found '{}'", shown()),
                        ));
                    }
                    corners.clear();
                    expect = Expect::VertexOrEndloop;
                }
                Expect::VertexOrEndloop => {
                    if is("vertex") {
                        if corners.len() == MAX_POLYGON_CORNERS {
                            return Err(syntax(
                                line_no,
                                format!(
                                    "facet {facets} has more than {MAX_POLYGON_CORNERS} corners, the limit of a polygon"
                                ),
                            ));
                        }
                        expect = Expect::VertexValues(0);
                    } else if is("endloop") {
                        if corners.len() < 3 {
                            return Err(syntax(
                                line_no,
                                format!("facet {facets} has {} corners, needs 3", corners.len()),
                            ));
                        }
                        expect = Expect::Endfacet;
                    } else {
                        return Err(syntax(
                            line_no,
                            format!("expected 'vertex' or 'endloop', found '{}'", shown()),
                        ));
                    }
                }
                Expect::VertexValues(i) => {
                    let v = parse_number(tok, line_no)?;
                    if v.is_nan() || v.abs() > limit {
                        return Err(bad_coordinate(Place::Line(line_no), facets, v, units));
                    }
                    xyz[i as usize] = v;
                    expect = if i == 2 {
                        corners.push(DVec3::from_array(xyz));
                        Expect::VertexOrEndloop
                    } else {
                        Expect::VertexValues(i + 1)
                    };
                }
                Expect::Endfacet => {
                    if !is("endfacet") {
                        return Err(syntax(
                            line_no,
                            format!("expected 'endfacet', found '{}'", shown()),
                        ));
                    }
                    if corners.len() > 3 {
                        warnings.push(format!(
                            "line {line_no}: facet {facets} has {} corners; split into a fan of triangles",
                            corners.len()
                        ));
                    }
                    for k in 1..corners.len() - 1 {
                        welder.push([corners[0], corners[k], corners[k + 1]]);
                    }
                    facets += 1;
                    corners_read += corners.len() as u64;
                    expect = Expect::FacetOrEnd;
                }
            }
        }
    }
    match expect {
        Expect::Solid if solids > 0 => {}
        Expect::Solid => return Err(syntax(line_no.max(1), "no 'solid' in the file".into())),
        Expect::FacetOrEnd => {
            warnings.push(format!("line {line_no}: the file ends without 'endsolid'"))
        }
        _ => {
            return Err(syntax(
                line_no,
                format!("the file ends inside facet {facets} (truncated?)"),
            ))
        }
    }
    let (mesh, collapsed_facets) = welder.finish();
    Ok(RawMesh {
        format: Format::StlAscii,
        solids,
        facets_read: facets,
        corners_read,
        collapsed_facets,
        mesh,
        warnings,
    })
}

/// Reads an ASCII number in f64, the precision of the text (a binary STL holds f32).
fn parse_number(tok: &[u8], line: u64) -> Result<f64, LoadError> {
    std::str::from_utf8(tok)
        .ok()
        .and_then(|s| s.parse::<f64>().ok())
        .ok_or_else(|| LoadError::Syntax {
            place: Place::Line(line),
            message: format!("expected a number, found '{}'", excerpt(tok)),
        })
}

/// Writes `mesh` as a binary STL, with facet normals from the corner order.
pub fn write_binary(mesh: &Mesh, out: &mut impl Write) -> std::io::Result<()> {
    let mut header = [b' '; 80];
    let title = b"binary STL written by moldgate (units: mm)";
    header[..title.len()].copy_from_slice(title);
    out.write_all(&header)?;
    out.write_all(&(mesh.triangles.len() as u32).to_le_bytes())?;
    let mut rec = [0u8; RECORD as usize];
    for t in 0..mesh.triangles.len() {
        let n = mesh.normal(t);
        let corners = mesh.corners(t);
        let values = [n]
            .iter()
            .chain(corners.iter())
            .flat_map(|v| v.to_array())
            .collect::<Vec<_>>();
        for (i, v) in values.iter().enumerate() {
            rec[4 * i..4 * i + 4].copy_from_slice(&(*v as f32).to_le_bytes());
        }
        out.write_all(&rec)?;
    }
    Ok(())
}
