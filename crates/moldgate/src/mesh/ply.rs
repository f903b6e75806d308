//! PLY reader (format 1.0: `ascii`, `binary_little_endian`, `binary_big_endian`).
//!
//! Read: the `x`, `y`, `z` properties of `element vertex` (any scalar type, usually `float`
//! or `double`) and the `vertex_indices` (or `vertex_index`) list of `element face`, whose
//! polygons are fanned into triangles from their first corner. Every other property and
//! element is read past by its declared type. Errors name the 1-based line in the header and
//! in an ASCII body, and the 0-based byte offset in a binary body.
//!
//! The triangles go through the same [`Welder`] as an STL's facets, so a part saved as PLY
//! and as STL gives the same mesh, vertex numbers and counts.

use std::io::{BufRead, ErrorKind};

use super::text::Lines;
use super::{sniff, Format, RawMesh, Units, Welder, MAX_COORDINATE_MM, MAX_POLYGON_CORNERS};
use crate::error::{excerpt, LoadError, Place};
use crate::math::DVec3;

/// A PLY scalar type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(word: &str) -> Option<Scalar> {
        Some(match word {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    /// The range of an integer type; `None` for floats.
    fn integer_range(self) -> Option<(i64, i64)> {
        Some(match self {
            Scalar::I8 => (i8::MIN.into(), i8::MAX.into()),
            Scalar::U8 => (0, u8::MAX.into()),
            Scalar::I16 => (i16::MIN.into(), i16::MAX.into()),
            Scalar::U16 => (0, u16::MAX.into()),
            Scalar::I32 => (i32::MIN.into(), i32::MAX.into()),
            Scalar::U32 => (0, u32::MAX.into()),
            Scalar::F32 | Scalar::F64 => return None,
        })
    }
}

/// A property's declared type.
#[derive(Debug, Clone, Copy)]
enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

/// What the reader does with a property.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Role {
    /// Coordinate 0, 1 or 2 of a vertex.
    Axis(usize),
    /// The corner list of a face.
    Corners,
    /// Read past.
    Skip,
}

#[derive(Debug)]
struct Element {
    name: String,
    count: u64,
    properties: Vec<(String, Kind, Role)>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Encoding {
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
}

fn syntax(place: Place, message: impl Into<String>) -> LoadError {
    LoadError::Syntax {
        place,
        message: message.into(),
    }
}

/// A bad token, quoted short and escaped.
fn shown(tok: &[u8]) -> String {
    excerpt(tok)
}

/// Reads a PLY written in `units` from `reader` into a welded mesh in file units.
pub fn read(mut reader: impl BufRead, units: Units) -> Result<RawMesh, LoadError> {
    let limit = MAX_COORDINATE_MM / units.mm_per_unit();
    let (encoding, elements, lines, bytes) = read_header(&mut reader)?;
    let vertex_count = elements
        .iter()
        .find(|e| e.name == "vertex")
        .map_or(0, |e| e.count);
    let mut body = match encoding {
        Encoding::Ascii => Body::Ascii {
            lines: {
                let mut body = Lines::new(reader);
                body.line_no = lines;
                body
            },
            line: Vec::new(),
            pos: 0,
        },
        _ => Body::Binary {
            reader,
            offset: bytes,
            big_endian: encoding == Encoding::BinaryBigEndian,
        },
    };
    let mut positions: Vec<DVec3> = Vec::with_capacity(vertex_count.min(1 << 20) as usize);
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut corners: Vec<u32> = Vec::new();
    let mut next_memory_check = super::TRIANGLES_PER_MEMORY_CHECK;
    for element in &elements {
        // A binary element without properties takes no bytes: however large its count, there
        // is nothing to read (counting through 10^15 of them would never end).
        if element.properties.is_empty() && !matches!(body, Body::Ascii { .. }) {
            continue;
        }
        for index in 0..element.count {
            let what = Instance {
                element: &element.name,
                index,
                count: element.count,
            };
            body.begin(&what)?;
            let mut xyz = [0.0f64; 3];
            for &(_, kind, role) in &element.properties {
                match (kind, role) {
                    (Kind::Scalar(ty), Role::Axis(axis)) => {
                        let place = body.place();
                        let value = body.value(ty, &what)?;
                        if !value.is_finite() {
                            return Err(syntax(
                                place,
                                format!(
                                    "{what} has a non-finite coordinate ({})",
                                    crate::error::non_finite(&value)
                                ),
                            ));
                        }
                        if value.abs() > limit {
                            return Err(LoadError::OutOfRange {
                                place,
                                value,
                                mm: value * units.mm_per_unit(),
                                limit_mm: MAX_COORDINATE_MM,
                            });
                        }
                        xyz[axis] = value;
                    }
                    (Kind::Scalar(ty), _) => {
                        body.value(ty, &what)?;
                    }
                    (Kind::List { count, item }, role) => {
                        let place = body.place();
                        let n = body.value(count, &what)?;
                        if n < 0.0 {
                            return Err(syntax(
                                place,
                                format!("{what} has a negative list length"),
                            ));
                        }
                        let n = n as u64;
                        if role != Role::Corners {
                            for _ in 0..n {
                                body.value(item, &what)?;
                            }
                            continue;
                        }
                        if n < 3 {
                            return Err(syntax(
                                place,
                                format!("{what} has {n} corners, a face needs at least 3"),
                            ));
                        }
                        if n > MAX_POLYGON_CORNERS as u64 {
                            return Err(syntax(
                                place,
                                format!(
                                    "{what} has {n} corners, more than {MAX_POLYGON_CORNERS}, the limit of a polygon"
                                ),
                            ));
                        }
                        corners.clear();
                        for _ in 0..n {
                            let place = body.place();
                            let v = body.value(item, &what)?;
                            if v.fract() != 0.0 || v < 0.0 || v >= vertex_count as f64 {
                                return Err(syntax(
                                    place,
                                    format!(
                                        "{what}: vertex index {v} is out of range (the file has {vertex_count} vertices)"
                                    ),
                                ));
                            }
                            corners.push(v as u32);
                        }
                        // A fan from the first corner: (0, k, k + 1).
                        for k in 1..corners.len() - 1 {
                            triangles.push([corners[0], corners[k], corners[k + 1]]);
                        }
                        if triangles.len() >= next_memory_check {
                            super::check_triangle_memory(triangles.len(), place)?;
                            next_memory_check += super::TRIANGLES_PER_MEMORY_CHECK;
                        }
                    }
                }
            }
            body.end(&what)?;
            if element.name == "vertex" {
                positions.push(DVec3::from_array(xyz));
            }
        }
    }
    let mut warnings = Vec::new();
    if let Some(w) = body.trailing()? {
        warnings.push(w);
    }
    let mut welder = Welder::with_capacity(triangles.len());
    for &[a, b, c] in &triangles {
        welder.push([
            positions[a as usize],
            positions[b as usize],
            positions[c as usize],
        ]);
    }
    let facets = triangles.len() as u64;
    let (mesh, collapsed_facets) = welder.finish();
    Ok(RawMesh {
        format: match encoding {
            Encoding::Ascii => Format::PlyAscii,
            Encoding::BinaryLittleEndian => Format::PlyBinaryLittleEndian,
            Encoding::BinaryBigEndian => Format::PlyBinaryBigEndian,
        },
        solids: 1,
        facets_read: facets,
        corners_read: 3 * facets,
        collapsed_facets,
        mesh,
        warnings,
    })
}

/// Reads the header up to and including `end_header`: the encoding, the elements, the
/// number of header lines and of header bytes.
fn read_header(reader: &mut impl BufRead) -> Result<(Encoding, Vec<Element>, u64, u64), LoadError> {
    let head = reader.fill_buf()?;
    if !head.starts_with(b"ply") {
        let head = &head[..head.len().min(1024)];
        if let Some(e) = sniff::not_a_mesh(head, false).or_else(|| sniff::stl_by_another_name(head))
        {
            return Err(e);
        }
    }
    let mut lines = Lines::new(reader);
    let mut line = Vec::new();
    let mut line_no;
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        if !lines.next_into(&mut line)? {
            if lines.line_no == 0 {
                return Err(LoadError::Empty);
            }
            return Err(syntax(
                Place::Line(lines.line_no),
                "the file ends inside the PLY header (no end_header)",
            ));
        }
        line_no = lines.line_no;
        let place = Place::Line(line_no);
        // A comment is free text, often in an exporter's own 8-bit encoding: skipped
        // before the header's lines are read as text.
        let first_word = line
            .trim_ascii_start()
            .split(|b| b.is_ascii_whitespace())
            .next()
            .unwrap_or_default();
        if line_no > 1 && matches!(first_word, b"comment" | b"obj_info") {
            continue;
        }
        let text = std::str::from_utf8(&line).map_err(|_| {
            syntax(
                place,
                format!("the PLY header is not text: '{}'", excerpt(&line)),
            )
        })?;
        let mut words = text.split_ascii_whitespace();
        let keyword = words.next().unwrap_or("");
        if line_no == 1 {
            if keyword != "ply" || words.next().is_some() {
                return Err(syntax(
                    place,
                    "not a PLY file: the first line must be 'ply'",
                ));
            }
            continue;
        }
        match keyword {
            // Comments were skipped above, as free text.
            "" => {}
            "format" => {
                let enc = match words.next() {
                    Some("ascii") => Encoding::Ascii,
                    Some("binary_little_endian") => Encoding::BinaryLittleEndian,
                    Some("binary_big_endian") => Encoding::BinaryBigEndian,
                    other => {
                        return Err(syntax(
                            place,
                            format!(
                                "unknown PLY format '{}': expected ascii, binary_little_endian or binary_big_endian",
                                shown(other.unwrap_or("").as_bytes())
                            ),
                        ))
                    }
                };
                match words.next() {
                    Some("1.0" | "1") => {}
                    other => {
                        return Err(syntax(
                            place,
                            format!(
                                "unsupported PLY version '{}': expected 1.0",
                                shown(other.unwrap_or("").as_bytes())
                            ),
                        ))
                    }
                }
                encoding = Some(enc);
            }
            "element" => {
                let (Some(name), Some(count), None) = (words.next(), words.next(), words.next())
                else {
                    return Err(syntax(place, "expected 'element NAME COUNT'"));
                };
                let count: u64 = count.parse().map_err(|_| {
                    let digits = !count.is_empty() && count.bytes().all(|b| b.is_ascii_digit());
                    syntax(
                        place,
                        match digits {
                            // A whole number past u64: far past every limit below.
                            true => format!(
                                "element count '{}' is too large (more than 2^64)",
                                shown(count.as_bytes())
                            ),
                            false => format!(
                                "element count '{}' is not a whole number",
                                shown(count.as_bytes())
                            ),
                        },
                    )
                })?;
                if (name == "vertex" || name == "face") && elements.iter().any(|e| e.name == name) {
                    return Err(syntax(place, format!("element {name} is declared twice")));
                }
                if name == "vertex" && count > u64::from(u32::MAX) {
                    return Err(syntax(
                        place,
                        format!("{count} vertices are more than 2^32"),
                    ));
                }
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    properties: Vec::new(),
                });
            }
            "property" => {
                let Some(element) = elements.last_mut() else {
                    return Err(syntax(place, "a property before any element"));
                };
                let scalar = |word: Option<&str>| {
                    let word = word.unwrap_or("");
                    Scalar::parse(word).ok_or_else(|| {
                        syntax(
                            place,
                            format!("unknown PLY type '{}'", shown(word.as_bytes())),
                        )
                    })
                };
                let first = words.next();
                let kind = if first == Some("list") {
                    Kind::List {
                        count: scalar(words.next())?,
                        item: scalar(words.next())?,
                    }
                } else {
                    Kind::Scalar(scalar(first)?)
                };
                let (Some(name), None) = (words.next(), words.next()) else {
                    return Err(syntax(
                        place,
                        "expected 'property TYPE NAME' or 'property list TYPE TYPE NAME'",
                    ));
                };
                let role = match (element.name.as_str(), name, kind) {
                    ("vertex", "x" | "y" | "z", Kind::Scalar(_)) => {
                        Role::Axis(usize::from(name.as_bytes()[0] - b'x'))
                    }
                    ("vertex", "x" | "y" | "z", Kind::List { .. }) => {
                        return Err(syntax(place, format!("vertex property {name} is a list")))
                    }
                    ("face", "vertex_indices" | "vertex_index", Kind::List { count, item }) => {
                        if count.integer_range().is_none() || item.integer_range().is_none() {
                            return Err(syntax(
                                place,
                                "the face's corner list must have integer count and index types",
                            ));
                        }
                        Role::Corners
                    }
                    ("face", "vertex_indices" | "vertex_index", Kind::Scalar(_)) => {
                        return Err(syntax(place, format!("face property {name} is not a list")))
                    }
                    _ => Role::Skip,
                };
                if role != Role::Skip && element.properties.iter().any(|p| p.2 == role) {
                    return Err(syntax(place, format!("property {name} is declared twice")));
                }
                element.properties.push((name.to_string(), kind, role));
            }
            "end_header" => break,
            other => {
                return Err(syntax(
                    place,
                    format!("unknown PLY header line '{}'", shown(other.as_bytes())),
                ))
            }
        }
    }
    let place = Place::Line(line_no);
    let Some(encoding) = encoding else {
        return Err(syntax(place, "the PLY header has no format line"));
    };
    let Some(vertex) = elements.iter().find(|e| e.name == "vertex") else {
        return Err(syntax(place, "the PLY header has no 'element vertex'"));
    };
    for axis in 0..3 {
        if !vertex.properties.iter().any(|p| p.2 == Role::Axis(axis)) {
            return Err(syntax(
                place,
                format!("element vertex has no property {}", ["x", "y", "z"][axis]),
            ));
        }
    }
    let Some(face) = elements.iter().find(|e| e.name == "face") else {
        return Err(syntax(place, "the PLY header has no 'element face'"));
    };
    if !face.properties.iter().any(|p| p.2 == Role::Corners) {
        return Err(syntax(
            place,
            "element face has no 'property list ... vertex_indices'",
        ));
    }
    Ok((encoding, elements, line_no, lines.bytes))
}

/// One instance of an element, for messages: `vertex 12`, `face 3`.
struct Instance<'a> {
    element: &'a str,
    index: u64,
    /// How many the header declares.
    count: u64,
}

impl std::fmt::Display for Instance<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} {}", self.element, self.index)
    }
}

impl Instance<'_> {
    /// The instance with the count its header declares, for the messages of a file whose
    /// data does not match its header ("face 1 of the 1000 the header declares").
    fn of_declared(&self) -> String {
        format!("{self} of the {} the header declares", self.count)
    }
}

/// The data after the header, read value by value.
enum Body<R> {
    /// One element instance per line.
    Ascii {
        lines: Lines<R>,
        line: Vec<u8>,
        pos: usize,
    },
    /// Packed values.
    Binary {
        reader: R,
        offset: u64,
        big_endian: bool,
    },
}

impl<R: BufRead> Body<R> {
    /// Where the next value is.
    fn place(&self) -> Place {
        match self {
            Body::Ascii { lines, .. } => Place::Line(lines.line_no),
            Body::Binary { offset, .. } => Place::Byte(*offset),
        }
    }

    /// Starts an instance: in ASCII, moves to the next line that is not blank.
    fn begin(&mut self, what: &Instance) -> Result<(), LoadError> {
        let Body::Ascii { lines, line, pos } = self else {
            return Ok(());
        };
        loop {
            if !lines.next_into(line)? {
                return Err(syntax(
                    Place::Line(lines.line_no),
                    format!("the file ends before {}", what.of_declared()),
                ));
            }
            *pos = 0;
            if line.iter().any(|b| !b.is_ascii_whitespace()) {
                return Ok(());
            }
        }
    }

    /// Ends an instance: in ASCII, its line must hold nothing more.
    fn end(&mut self, what: &Instance) -> Result<(), LoadError> {
        if let Body::Ascii { lines, line, pos } = self {
            if line[*pos..].iter().any(|b| !b.is_ascii_whitespace()) {
                return Err(syntax(
                    Place::Line(lines.line_no),
                    format!("too many values on the line of {}", what.of_declared()),
                ));
            }
        }
        Ok(())
    }

    /// The next value, of type `ty`.
    fn value(&mut self, ty: Scalar, what: &Instance) -> Result<f64, LoadError> {
        match self {
            Body::Ascii { lines, line, pos } => {
                let place = Place::Line(lines.line_no);
                let rest = &line[*pos..];
                let start = rest
                    .iter()
                    .position(|b| !b.is_ascii_whitespace())
                    .ok_or_else(|| {
                        syntax(place, format!("too few values on the line of {what}"))
                    })?;
                let len = rest[start..]
                    .iter()
                    .position(|b| b.is_ascii_whitespace())
                    .unwrap_or(rest.len() - start);
                let tok = &rest[start..start + len];
                *pos += start + len;
                let text = std::str::from_utf8(tok).ok();
                match ty.integer_range() {
                    Some((lo, hi)) => text
                        .and_then(|s| s.parse::<i64>().ok())
                        .filter(|v| (lo..=hi).contains(v))
                        .map(|v| v as f64)
                        .ok_or_else(|| {
                            syntax(
                                place,
                                format!(
                                    "{what}: expected an integer of type {ty:?}, found '{}'",
                                    shown(tok)
                                ),
                            )
                        }),
                    None => text.and_then(|s| s.parse::<f64>().ok()).ok_or_else(|| {
                        syntax(
                            place,
                            format!("{what}: expected a number, found '{}'", shown(tok)),
                        )
                    }),
                }
            }
            Body::Binary {
                reader,
                offset,
                big_endian,
            } => {
                let mut buf = [0u8; 8];
                let size = ty.size();
                let bytes = &mut buf[..size];
                if let Err(e) = reader.read_exact(bytes) {
                    return Err(if e.kind() == ErrorKind::UnexpectedEof {
                        syntax(
                            Place::Byte(*offset),
                            format!("the file ends inside {}", what.of_declared()),
                        )
                    } else {
                        LoadError::Io(e)
                    });
                }
                *offset += size as u64;
                if !*big_endian {
                    bytes.reverse();
                }
                // Now big-endian in the first `size` bytes.
                Ok(match ty {
                    Scalar::I8 => f64::from(i8::from_be_bytes([buf[0]])),
                    Scalar::U8 => f64::from(buf[0]),
                    Scalar::I16 => f64::from(i16::from_be_bytes([buf[0], buf[1]])),
                    Scalar::U16 => f64::from(u16::from_be_bytes([buf[0], buf[1]])),
                    Scalar::I32 => f64::from(i32::from_be_bytes([buf[0], buf[1], buf[2], buf[3]])),
                    Scalar::U32 => f64::from(u32::from_be_bytes([buf[0], buf[1], buf[2], buf[3]])),
                    Scalar::F32 => f64::from(f32::from_be_bytes([buf[0], buf[1], buf[2], buf[3]])),
                    Scalar::F64 => f64::from_be_bytes(buf),
                })
            }
        }
    }

    /// A warning when data follows the last element.
    fn trailing(&mut self) -> Result<Option<String>, LoadError> {
        match self {
            Body::Ascii { lines, line, .. } => loop {
                if !lines.next_into(line)? {
                    return Ok(None);
                }
                if line.iter().any(|b| !b.is_ascii_whitespace()) {
                    return Ok(Some(format!(
                        "the PLY file continues after its last element (line {}); the rest was ignored",
                        lines.line_no
                    )));
                }
            },
            Body::Binary { reader, offset, .. } => {
                let extra = std::io::copy(reader, &mut std::io::sink())?;
                Ok((extra > 0).then(|| {
                    format!(
                        "the PLY file has {extra} bytes after its last element (from byte {offset}); they were ignored"
                    )
                }))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn place_of(err: LoadError) -> Place {
        match err {
            LoadError::Syntax { place, .. } => place,
            other => panic!("expected a syntax error with a place, got {other:?}"),
        }
    }

    const HEADER: &str = "ply\nformat ascii 1.0\ncomment made by hand\nelement vertex 4\n\
        property float x\nproperty float y\nproperty float z\nproperty uchar red\n\
        element face 1\nproperty list uchar int vertex_indices\nelement edge 1\n\
        property int vertex1\nproperty int vertex2\nend_header\n";

    #[test]
    fn ascii_quad_is_fanned_and_extra_properties_skipped() {
        let text = format!("{HEADER}0 0 0 9\n1 0 0 9\n1 1 0 9\n0 1 0 9\n4 0 1 2 3\n0 1\n");
        let raw = read(text.as_bytes(), Units::Mm).unwrap();
        assert_eq!(raw.format, Format::PlyAscii);
        assert_eq!(raw.mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(raw.mesh.vertices[2], DVec3::new(1.0, 1.0, 0.0));
        assert!(raw.warnings.is_empty());
    }

    /// A comment in an exporter's 8-bit encoding (Latin-1 "café") is skipped, not refused
    /// as a header that is not text.
    #[test]
    fn a_comment_not_in_utf8_is_skipped() {
        let text = format!("{HEADER}0 0 0 9\n1 0 0 9\n1 1 0 9\n0 1 0 9\n4 0 1 2 3\n0 1\n")
            .replace("comment made by hand", "comment caf\u{1}");
        let bytes = text.replace('\u{1}', "").into_bytes();
        let mut latin1 = bytes.clone();
        let at = latin1.windows(4).position(|w| w == b"caf\n").unwrap() + 3;
        latin1.insert(at, 0xE9);
        assert!(std::str::from_utf8(&latin1).is_err());
        let raw = read(&latin1[..], Units::Mm).unwrap();
        assert_eq!(raw.mesh.triangles.len(), 2);
    }

    #[test]
    fn ascii_errors_name_their_line() {
        let good = [
            "0 0 0 9",
            "1 0 0 9",
            "1 1 0 9",
            "0 1 0 9",
            "4 0 1 2 3",
            "0 1",
        ];
        // Line 15 is the first body line.
        for (row, bad, line) in [
            (1, "1 x 0 9", 16),
            (2, "1 1 0", 17),
            (2, "1 1 0 9 9", 17),
            (4, "4 0 1 2 4", 19),
            (4, "2 0 1", 19),
            (4, "3 0 1 -1", 19),
            (0, "0 0 0 300", 15),
            (0, "0 0 inf 1", 15),
        ] {
            let mut rows = good.map(String::from).to_vec();
            rows[row] = bad.to_string();
            let text = format!("{HEADER}{}\n", rows.join("\n"));
            let err = read(text.as_bytes(), Units::Mm).unwrap_err();
            assert_eq!(place_of(err), Place::Line(line), "{bad:?}");
        }
        let short = format!("{HEADER}0 0 0 9\n");
        assert_eq!(
            place_of(read(short.as_bytes(), Units::Mm).unwrap_err()),
            Place::Line(15)
        );
    }

    #[test]
    fn header_errors_name_their_line() {
        for (header, line) in [
            ("plx\n", 1),
            ("ply\nformat binary 1.0\n", 2),
            ("ply\nformat ascii 2.0\n", 2),
            ("ply\nformat ascii 1.0\nproperty float x\n", 3),
            ("ply\nformat ascii 1.0\nelement vertex many\n", 3),
            (
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\n",
                4,
            ),
            (
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n",
                5,
            ),
            ("ply\nformat ascii 1.0\nelement vertex 1\n", 3),
            (
                "ply\nformat ascii 1.0\nelement vertex 1\nelement vertex 2\n",
                4,
            ),
        ] {
            let err = read(header.as_bytes(), Units::Mm).unwrap_err();
            assert_eq!(place_of(err), Place::Line(line), "{header:?}");
        }
    }

    #[test]
    fn binary_errors_name_their_byte() {
        let header = "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty double x\n\
            property double y\nproperty double z\nelement face 1\n\
            property list uchar uint vertex_indices\nend_header\n";
        let mut data = header.as_bytes().to_vec();
        let body = data.len() as u64;
        for v in [[0.0f64, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
            for c in v {
                data.extend(c.to_be_bytes());
            }
        }
        data.push(3);
        for i in [0u32, 1, 2] {
            data.extend(i.to_be_bytes());
        }
        let raw = read(&data[..], Units::Mm).unwrap();
        assert_eq!(raw.format, Format::PlyBinaryBigEndian);
        assert_eq!(raw.mesh.triangles, vec![[0, 1, 2]]);
        assert_eq!(raw.mesh.vertices[1], DVec3::X);

        // An index out of range: the third index starts 72 + 1 + 8 bytes into the body.
        let mut bad = data.clone();
        let at = (body + 81) as usize;
        bad[at..at + 4].copy_from_slice(&3u32.to_be_bytes());
        assert_eq!(
            place_of(read(&bad[..], Units::Mm).unwrap_err()),
            Place::Byte(body + 81)
        );
        // Cut inside the face's second index.
        let cut = &data[..(body + 72 + 1 + 6) as usize];
        assert_eq!(
            place_of(read(cut, Units::Mm).unwrap_err()),
            Place::Byte(body + 77)
        );
        // A NaN coordinate: vertex 1's y.
        let mut nan = data.clone();
        let at = (body + 32) as usize;
        nan[at..at + 8].copy_from_slice(&f64::NAN.to_be_bytes());
        assert_eq!(
            place_of(read(&nan[..], Units::Mm).unwrap_err()),
            Place::Byte(body + 32)
        );
        // Extra bytes are a warning.
        let mut long = data.clone();
        long.extend([0u8; 5]);
        assert_eq!(read(&long[..], Units::Mm).unwrap().warnings.len(), 1);
    }
}
