//! Reading STL files, binary and ASCII: format detection, welding, defects counted beside the
//! mesh, and every malformed file refused with its place (line, byte offset, triangle).
//!
//! The files are built in code, so each test shows the bytes it feeds the reader.

use std::io::Cursor;

use moldgate::error::{LoadError, Place};
use moldgate::mesh::{read_stl, Format, LoadedMesh, Units};

use crate::common::SplitMix;

/// A facet as its three corners, in the file's units.
type Facet = [[f32; 3]; 3];

/// Asserts that two lengths agree within a tolerance scaled to the size of the part.
macro_rules! assert_close {
    ($actual:expr, $expected:expr, $size:expr) => {{
        let (actual, expected, size): (f64, f64, f64) = ($actual, $expected, $size);
        assert!(
            (actual - expected).abs() <= 1e-9 * size.abs().max(1.0),
            "{} = {actual}, expected {expected}",
            stringify!($actual)
        );
    }};
}

// ---------------------------------------------------------------------------------------------
// Building files

/// The 12 facets of the axis-aligned cube `[min, min + size]^3`, wound outwards.
fn cube(min: [f32; 3], size: f32) -> Vec<Facet> {
    let [x0, y0, z0] = min;
    let [x1, y1, z1] = [x0 + size, y0 + size, z0 + size];
    let p = |i: u8, j: u8, k: u8| {
        [
            if i == 0 { x0 } else { x1 },
            if j == 0 { y0 } else { y1 },
            if k == 0 { z0 } else { z1 },
        ]
    };
    // Each face as a quad seen from outside, counter-clockwise.
    let quads = [
        [p(0, 0, 0), p(0, 1, 0), p(1, 1, 0), p(1, 0, 0)], // -z
        [p(0, 0, 1), p(1, 0, 1), p(1, 1, 1), p(0, 1, 1)], // +z
        [p(0, 0, 0), p(1, 0, 0), p(1, 0, 1), p(0, 0, 1)], // -y
        [p(0, 1, 0), p(0, 1, 1), p(1, 1, 1), p(1, 1, 0)], // +y
        [p(0, 0, 0), p(0, 0, 1), p(0, 1, 1), p(0, 1, 0)], // -x
        [p(1, 0, 0), p(1, 1, 0), p(1, 1, 1), p(1, 0, 1)], // +x
    ];
    quads
        .iter()
        .flat_map(|[a, b, c, d]| [[*a, *b, *c], [*a, *c, *d]])
        .collect()
}

/// A binary STL: the header (padded with spaces to 80 bytes), `declared` as the triangle
/// count, then one 50-byte record per facet with a zero normal and attribute.
fn binary_declaring(header: &[u8], declared: u32, facets: &[Facet]) -> Vec<u8> {
    let mut bytes = header.to_vec();
    bytes.resize(80, b' ');
    bytes.extend_from_slice(&declared.to_le_bytes());
    for facet in facets {
        bytes.extend_from_slice(&[0u8; 12]);
        for corner in facet {
            for v in corner {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
        bytes.extend_from_slice(&[0u8; 2]);
    }
    bytes
}

/// A well-formed binary STL.
fn binary(header: &[u8], facets: &[Facet]) -> Vec<u8> {
    binary_declaring(header, facets.len() as u32, facets)
}

/// Byte offset of coordinate `axis` of corner `corner` of triangle `triangle`.
fn coordinate_offset(triangle: usize, corner: usize, axis: usize) -> usize {
    84 + 50 * triangle + 12 + 12 * corner + 4 * axis
}

/// One ASCII `solid ... endsolid` block.
fn ascii_solid(name: &str, facets: &[Facet]) -> String {
    let mut s = format!("solid {name}\n");
    for facet in facets {
        s += &ascii_facet(facet);
    }
    s + &format!("endsolid {name}\n")
}

/// One ASCII facet with any number of corners.
fn ascii_facet(corners: &[[f32; 3]]) -> String {
    let mut s = String::from("  facet normal 0 0 0\n    outer loop\n");
    for [x, y, z] in corners {
        s += &format!("      vertex {x:e} {y:e} {z:e}\n");
    }
    s + "    endloop\n  endfacet\n"
}

fn read(bytes: &[u8], units: Units) -> Result<LoadedMesh, LoadError> {
    read_stl(Cursor::new(bytes), bytes.len() as u64, units)
}

fn read_mm(bytes: &[u8]) -> LoadedMesh {
    read(bytes, Units::Mm).unwrap_or_else(|e| panic!("the file should load: {e}"))
}

fn read_err(bytes: &[u8]) -> LoadError {
    match read(bytes, Units::Mm) {
        Ok(part) => panic!("the file should be refused, got {:?}", part.stats),
        Err(e) => e,
    }
}

/// The 1-based line of the first line of `text` that contains `needle`.
fn line_of(text: &str, needle: &str) -> u64 {
    1 + text
        .lines()
        .position(|l| l.contains(needle))
        .unwrap_or_else(|| panic!("'{needle}' is not in the text")) as u64
}

// ---------------------------------------------------------------------------------------------
// Format detection

#[test]
fn binary_whose_header_starts_with_solid_is_read_as_binary() {
    for header in [
        &b"solid cube"[..],
        b"solid",
        b"  SOLID exported by a CAD system",
    ] {
        let part = read_mm(&binary(header, &cube([0.0; 3], 10.0)));
        assert_eq!(part.stats.format, Format::StlBinary, "header {header:?}");
        assert_eq!(part.stats.facets_read, 12);
        assert_eq!(part.stats.triangles, 12);
    }
}

#[test]
fn binary_header_may_hold_facet_keywords() {
    // A header that reads like the start of an ASCII file still does not make it ASCII: the
    // size rule 84 + 50 n is checked first.
    let header = b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n";
    let part = read_mm(&binary(header, &cube([0.0; 3], 10.0)));
    assert_eq!(part.stats.format, Format::StlBinary);
    assert_eq!(part.stats.vertices, 8);
}

#[test]
fn binary_with_a_trailing_newline_is_accepted() {
    for tail in [&b"\n"[..], b"\r\n"] {
        let mut bytes = binary(b"cube", &cube([0.0; 3], 10.0));
        bytes.extend_from_slice(tail);
        let part = read_mm(&bytes);
        assert_eq!(part.stats.format, Format::StlBinary);
        assert_eq!(part.stats.triangles, 12);
    }
}

#[test]
fn ascii_is_recognised_by_solid_and_text() {
    let part = read_mm(ascii_solid("cube", &cube([0.0; 3], 10.0)).as_bytes());
    assert_eq!(part.stats.format, Format::StlAscii);
    assert_eq!(part.stats.solids, 1);
    assert_eq!(part.stats.facets_read, 12);
    assert_eq!(part.stats.corners_read, 36);
    assert_eq!(part.stats.vertices, 8);
    assert!(part.warnings.is_empty(), "{:?}", part.warnings);
}

#[test]
fn ascii_and_binary_of_the_same_cube_agree() {
    let facets = cube([-5.0, 2.5, 1.0], 4.0);
    let a = read_mm(ascii_solid("c", &facets).as_bytes());
    let b = read_mm(&binary(b"c", &facets));
    assert_eq!(a.mesh.vertices, b.mesh.vertices);
    assert_eq!(a.mesh.triangles, b.mesh.triangles);
    assert_eq!(a.stats.bounds_min, [-5.0, 2.5, 1.0]);
    assert_eq!(a.stats.bounds_max, [-1.0, 6.5, 5.0]);
}

#[test]
fn ascii_keywords_in_any_case_with_crlf_and_no_normal() {
    let text = "SOLID part\r\n\
                Facet Normal 0 0 1\r\n Outer Loop\r\n  Vertex 0 0 0\r\n  VERTEX 1 0 0\r\n  vertex 0 1 0\r\n EndLoop\r\nEndFacet\r\n\
                facet outer loop vertex 0 0 0 vertex 0 1 0 vertex 0 0 1 endloop endfacet\r\n\
                EndSolid part\r\n";
    let part = read_mm(text.as_bytes());
    assert_eq!(part.stats.format, Format::StlAscii);
    assert_eq!(part.stats.facets_read, 2);
    assert_eq!(part.stats.triangles, 2);
    assert_eq!(part.stats.vertices, 4);
}

#[test]
fn ascii_with_several_solids() {
    let text = ascii_solid("first", &cube([0.0; 3], 10.0))
        + &ascii_solid("second", &cube([20.0, 0.0, 0.0], 10.0))
        + &ascii_solid("third", &cube([40.0, 0.0, 0.0], 5.0));
    let part = read_mm(text.as_bytes());
    assert_eq!(part.stats.solids, 3);
    assert_eq!(part.stats.facets_read, 36);
    assert_eq!(part.stats.triangles, 36);
    assert_eq!(part.stats.vertices, 24);
    assert_eq!(part.stats.bodies, 3);
    assert_eq!(part.stats.bounds_max, [45.0, 10.0, 10.0]);
}

#[test]
fn ascii_solids_that_share_vertices_weld_into_one_body() {
    // A cube split into two solids (bottom half of its facets and top half) is still one
    // closed body once welded.
    let facets = cube([0.0; 3], 10.0);
    let text = ascii_solid("a", &facets[..6]) + &ascii_solid("b", &facets[6..]);
    let part = read_mm(text.as_bytes());
    assert_eq!(part.stats.solids, 2);
    assert_eq!(part.stats.vertices, 8);
    assert_eq!(part.stats.bodies, 1);
    assert!(part.stats.is_closed());
}

#[test]
fn ascii_facets_with_more_than_three_corners_are_split_into_fans() {
    let c = |i: u8, j: u8, k: u8| {
        [
            f32::from(i) * 10.0,
            f32::from(j) * 10.0,
            f32::from(k) * 10.0,
        ]
    };
    let quads = [
        [c(0, 0, 0), c(0, 1, 0), c(1, 1, 0), c(1, 0, 0)],
        [c(0, 0, 1), c(1, 0, 1), c(1, 1, 1), c(0, 1, 1)],
        [c(0, 0, 0), c(1, 0, 0), c(1, 0, 1), c(0, 0, 1)],
        [c(0, 1, 0), c(0, 1, 1), c(1, 1, 1), c(1, 1, 0)],
        [c(0, 0, 0), c(0, 0, 1), c(0, 1, 1), c(0, 1, 0)],
        [c(1, 0, 0), c(1, 1, 0), c(1, 1, 1), c(1, 0, 1)],
    ];
    let mut text = String::from("solid quads\n");
    for q in &quads {
        text += &ascii_facet(q);
    }
    // A pentagon on its own, away from the cube: a fan of three triangles.
    let pentagon: Vec<[f32; 3]> = (0..5)
        .map(|i| {
            let a = std::f32::consts::TAU * i as f32 / 5.0;
            [50.0 + 5.0 * a.cos(), 5.0 * a.sin(), 0.0]
        })
        .collect();
    text += &ascii_facet(&pentagon);
    text += "endsolid quads\n";

    let part = read_mm(text.as_bytes());
    assert_eq!(part.stats.facets_read, 7);
    assert_eq!(part.stats.triangles, 12 + 3);
    assert_eq!(part.stats.corners_read, 6 * 4 + 5);
    assert_eq!(part.stats.vertices, 8 + 5);
    assert_eq!(part.stats.bodies, 2);
    // The cube from quads is closed: the fan diagonals pair up within each face.
    assert_eq!(part.stats.open_edges, 5, "only the pentagon's rim is open");
    let area_cube = 6.0 * 100.0;
    let area_pentagon = 2.5 * 25.0 * (std::f64::consts::TAU / 5.0).sin();
    assert!((part.stats.area_mm2 - area_cube - area_pentagon).abs() < 1e-3);
    let fan_warnings = part.warnings.iter().filter(|w| w.contains("fan")).count();
    assert_eq!(fan_warnings, 7, "{:?}", part.warnings);
    assert!(part.warnings.iter().any(|w| w.contains("5 corners")));
}

#[test]
fn missing_endsolid_is_a_warning_not_an_error() {
    let text = ascii_solid("open", &cube([0.0; 3], 10.0));
    let cut = text.trim_end().trim_end_matches("endsolid open");
    let part = read_mm(cut.as_bytes());
    assert_eq!(part.stats.triangles, 12);
    assert!(part.stats.is_closed());
    let line = cut.lines().count();
    assert!(
        part.warnings
            .iter()
            .any(|w| w.contains("endsolid") && w.contains(&format!("line {line}"))),
        "{:?}",
        part.warnings
    );
}

#[test]
fn ascii_normals_may_be_nan() {
    // Some exporters write `nan` normals for slivers; the normal is not used.
    let text = ascii_solid("c", &cube([0.0; 3], 10.0)).replacen(
        "facet normal 0 0 0",
        "facet normal nan -nan NaN",
        3,
    );
    let part = read_mm(text.as_bytes());
    assert_eq!(part.stats.triangles, 12);
}

#[test]
fn binary_normals_are_not_read() {
    let mut bytes = binary(b"c", &cube([0.0; 3], 10.0));
    for t in 0..12 {
        bytes[84 + 50 * t..84 + 50 * t + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    }
    let part = read_mm(&bytes);
    assert_eq!(part.stats.triangles, 12);
}

// ---------------------------------------------------------------------------------------------
// Malformed binary files

#[test]
fn truncated_binary_names_the_declared_count_and_the_byte_offset() {
    let full = binary(b"solid cut", &cube([0.0; 3], 10.0));
    // Cut in the middle of triangle 5.
    let len = 84 + 50 * 5 + 20;
    let e = read_err(&full[..len]);
    match e {
        LoadError::Truncated {
            declared,
            expected,
            len: got,
            triangle,
            offset,
        } => {
            assert_eq!(declared, 12);
            assert_eq!(expected, 84 + 50 * 12);
            assert_eq!(got, len as u64);
            assert_eq!(triangle, 5);
            assert_eq!(offset, 84 + 50 * 5);
        }
        other => panic!("expected Truncated, got {other:?}"),
    }
    let message = read_err(&full[..len]).to_string();
    assert!(message.contains("12 triangles"), "{message}");
    assert!(message.contains("triangle 5"), "{message}");
    assert!(message.contains("byte 334"), "{message}");
}

#[test]
fn binary_cut_at_a_record_boundary_is_truncated() {
    let full = binary(b"cube", &cube([0.0; 3], 10.0));
    let e = read_err(&full[..84 + 50 * 7]);
    assert!(
        matches!(
            e,
            LoadError::Truncated {
                declared: 12,
                triangle: 7,
                offset: 434,
                ..
            }
        ),
        "{e:?}"
    );
}

#[test]
fn binary_shorter_than_its_header() {
    let full = binary(b"cube", &cube([0.0; 3], 10.0));
    for len in [82, 83] {
        let e = read_err(&full[..len]);
        assert!(
            matches!(e, LoadError::TruncatedHeader { len: l } if l == len as u64),
            "{len}: {e:?}"
        );
        assert!(e.to_string().contains(&format!("{len} bytes")), "{e}");
    }
}

#[test]
fn short_text_is_named_as_text_not_a_cut_binary_header() {
    for text in [
        &b"hello this is some text\n"[..],
        b"mesh exported 2026-12-04",
        b" x",
    ] {
        let e = read_err(text);
        assert!(matches!(e, LoadError::NotAMesh { .. }), "{e:?}");
        let message = e.to_string();
        assert!(message.contains("short text file"), "{message}");
        assert!(message.contains("84-byte header"), "{message}");
    }
    // Bytes that are not text (a control character, or not UTF-8) stay a binary header
    // cut short.
    let e = read_err(b"cube\0\0\0");
    assert!(matches!(e, LoadError::TruncatedHeader { len: 7 }), "{e:?}");
    let e = read_err(b"\xc3\xa9\xff\xfe abcdefgh");
    assert!(matches!(e, LoadError::TruncatedHeader { len: 13 }), "{e:?}");
}

#[test]
fn header_only_with_a_count_is_truncated_at_triangle_0() {
    let full = binary(b"cube", &cube([0.0; 3], 10.0));
    let e = read_err(&full[..84]);
    assert!(
        matches!(
            e,
            LoadError::Truncated {
                declared: 12,
                triangle: 0,
                offset: 84,
                ..
            }
        ),
        "{e:?}"
    );
}

#[test]
fn a_file_far_shorter_than_its_header_declares_may_not_be_an_stl() {
    // Random bytes read as a binary STL: a count of some billions in a few kilobytes.
    let mut bytes = vec![7u8; 5000];
    bytes[80..84].copy_from_slice(&1_203_711_037u32.to_le_bytes());
    let e = read_err(&bytes);
    assert!(matches!(e, LoadError::Truncated { .. }), "{e:?}");
    assert!(
        e.to_string()
            .ends_with("the file may not be an STL at all)"),
        "{e}"
    );
    // A download cut at half its length is only truncated.
    let full = binary(b"cube", &cube([0.0; 3], 10.0));
    let e = read_err(&full[..full.len() / 2]);
    assert!(!e.to_string().contains("may not be an STL"), "{e}");
}

#[test]
fn binary_longer_than_its_count_is_a_count_mismatch() {
    let facets = cube([0.0; 3], 10.0);
    // The header says 10 but 12 records follow.
    let bytes = binary_declaring(b"cube", 10, &facets);
    let e = read_err(&bytes);
    match &e {
        LoadError::CountMismatch {
            declared,
            expected,
            len,
        } => {
            assert_eq!(*declared, 10);
            assert_eq!(*expected, 84 + 500);
            assert_eq!(*len, bytes.len() as u64);
        }
        other => panic!("expected CountMismatch, got {other:?}"),
    }
    let message = e.to_string();
    assert!(message.contains("10 triangles"), "{message}");
    assert!(message.contains("byte 584"), "{message}");
}

#[test]
fn three_extra_bytes_are_a_count_mismatch() {
    // Two bytes of slack are allowed for a trailing newline; three are not.
    let mut bytes = binary(b"cube", &cube([0.0; 3], 10.0));
    bytes.extend_from_slice(b"abc");
    assert!(matches!(
        read_err(&bytes),
        LoadError::CountMismatch { declared: 12, .. }
    ));
}

#[test]
fn binary_declaring_zero_triangles_has_no_area() {
    let bytes = binary(b"solid empty", &[]);
    assert!(matches!(read_err(&bytes), LoadError::NoArea { facets: 0 }));
}

#[test]
fn binary_nan_and_infinite_coordinates_name_the_byte_offset() {
    for (value, shown) in [
        (f32::NAN, "NaN"),
        (f32::INFINITY, "inf"),
        (f32::NEG_INFINITY, "-inf"),
    ] {
        let mut bytes = binary(b"solid cube", &cube([0.0; 3], 10.0));
        let at = coordinate_offset(7, 2, 1);
        bytes[at..at + 4].copy_from_slice(&value.to_le_bytes());
        let e = read_err(&bytes);
        match &e {
            LoadError::NonFinite {
                place, triangle, ..
            } => {
                assert_eq!(*place, Place::Byte(at as u64));
                assert_eq!(*triangle, 7);
            }
            other => panic!("expected NonFinite, got {other:?}"),
        }
        let message = e.to_string();
        assert!(message.contains(&format!("byte {at}")), "{message}");
        assert!(message.contains("triangle 7"), "{message}");
        assert!(message.contains(shown), "{message}");
    }
}

#[test]
fn binary_nan_in_a_later_chunk_names_the_right_triangle() {
    // The reader takes records in chunks of 4096; the place must count across chunks.
    let facets: Vec<Facet> = (0..5000)
        .flat_map(|i| cube([20.0 * i as f32, 0.0, 0.0], 10.0))
        .take(5000)
        .collect();
    let mut bytes = binary(b"many", &facets);
    let at = coordinate_offset(4500, 0, 0);
    bytes[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    assert!(matches!(
        read_err(&bytes),
        LoadError::NonFinite { place: Place::Byte(b), triangle: 4500, .. } if b == at as u64
    ));
}

// ---------------------------------------------------------------------------------------------
// Malformed ASCII files

#[test]
fn ascii_nan_and_infinite_coordinates_name_the_line() {
    for bad in ["nan", "NaN", "-nan", "inf", "-inf", "Infinity"] {
        let good = ascii_solid("c", &cube([0.0; 3], 10.0));
        // Replace the third vertex line of the fifth facet.
        let target = good
            .lines()
            .enumerate()
            .filter(|(_, l)| l.trim_start().starts_with("vertex"))
            .nth(4 * 3 + 2)
            .map(|(i, _)| i)
            .unwrap();
        let text: String = good
            .lines()
            .enumerate()
            .map(|(i, l)| {
                if i == target {
                    format!("      vertex 1 {bad} 2\n")
                } else {
                    format!("{l}\n")
                }
            })
            .collect();
        let line = target as u64 + 1;
        let e = read_err(text.as_bytes());
        match &e {
            LoadError::NonFinite {
                place, triangle, ..
            } => {
                assert_eq!(*place, Place::Line(line), "{bad}");
                assert_eq!(*triangle, 4, "{bad}");
            }
            other => panic!("{bad}: expected NonFinite, got {other:?}"),
        }
        assert!(e.to_string().starts_with(&format!("line {line}: ")), "{e}");
    }
}

#[test]
fn ascii_syntax_errors_name_the_line() {
    let good = ascii_solid("c", &cube([0.0; 3], 10.0));
    let cases = [
        // (text replaced, replacement, what the message says)
        ("outer loop", "outer lop", "expected 'loop'"),
        ("endloop", "endlop", "expected 'vertex' or 'endloop'"),
        ("endfacet", "endfacte", "expected 'endfacet'"),
        (
            "vertex 0e0 0e0 1e1",
            "vertex 0e0 zero 1e1",
            "expected a number, found 'zero'",
        ),
        (
            "vertex 0e0 0e0 1e1",
            "vertex 0e0 0.0.0 1e1",
            "expected a number",
        ),
        (
            "facet normal 0 0 0",
            "facet normal 0 x 0",
            "expected a number",
        ),
        (
            "facet normal 0 0 0",
            "facet nromal 0 0 0",
            "expected 'normal'",
        ),
        (
            "facet normal 0 0 0",
            "facte normal 0 0 0",
            "expected 'facet' or 'endsolid'",
        ),
    ];
    for (from, to, says) in cases {
        let line = line_of(&good, from);
        let text = good.replacen(from, to, 1);
        let e = read_err(text.as_bytes());
        assert!(
            matches!(&e, LoadError::Syntax { place: Place::Line(l), .. } if *l == line),
            "{to}: expected a syntax error at line {line}, got {e:?}"
        );
        let message = e.to_string();
        assert!(message.starts_with(&format!("line {line}: ")), "{message}");
        assert!(message.contains(says), "{message}");
    }
}

#[test]
fn short_vertex_line_is_an_error_on_the_next_line() {
    // A vertex with two numbers must not be read as a short line and indexed past its end.
    let text = "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid s\n";
    let e = read_err(text.as_bytes());
    assert!(
        matches!(&e, LoadError::Syntax { place: Place::Line(6), message } if message.contains("'vertex'")),
        "{e:?}"
    );
}

#[test]
fn facet_with_two_corners_is_an_error() {
    let text = "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\nendsolid s\n";
    let e = read_err(text.as_bytes());
    assert!(
        matches!(&e, LoadError::Syntax { place: Place::Line(6), message } if message.contains("2 corners")),
        "{e:?}"
    );
}

#[test]
fn ascii_cut_inside_a_facet_is_an_error_at_the_last_line() {
    let good = ascii_solid("c", &cube([0.0; 3], 10.0));
    let lines: Vec<&str> = good.lines().collect();
    for keep in [2, 3, 4, 6, 7] {
        let text = lines[..keep].join("\n") + "\n";
        let e = read_err(text.as_bytes());
        assert!(
            matches!(&e, LoadError::Syntax { place: Place::Line(l), message }
                if *l == keep as u64 && message.contains("ends inside facet 0")),
            "{keep} lines: {e:?}"
        );
    }
}

#[test]
fn text_that_does_not_start_with_solid_is_refused() {
    for text in [
        "hello\n",
        "# an OBJ file, not an STL\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n# padding padding padding padding\n",
    ] {
        let e = read_err(text.as_bytes());
        assert!(
            !matches!(e, LoadError::Io(_) | LoadError::NoArea { .. }),
            "{text:?}: {e:?}"
        );
    }
}

#[test]
fn solid_without_facets_has_no_area() {
    let e = read_err(b"solid nothing\nendsolid nothing\n");
    assert!(matches!(e, LoadError::NoArea { facets: 0 }), "{e:?}");
}

#[test]
fn empty_file() {
    assert!(matches!(read_err(b""), LoadError::Empty));
    assert_eq!(read_err(b"").to_string(), "empty file");
}

// ---------------------------------------------------------------------------------------------
// Defects that do not stop loading, and those that do

#[test]
fn facets_that_all_have_zero_area_are_refused() {
    // Collinear corners: three distinct vertices, no area.
    let collinear: Vec<Facet> = (0..4)
        .map(|i| {
            let y = i as f32;
            [[0.0, y, 0.0], [1.0, y, 0.0], [2.0, y, 0.0]]
        })
        .collect();
    // Two equal corners: dropped by welding.
    let collapsed: Vec<Facet> = vec![[[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 1.0, 1.0]]; 3];
    for (facets, n) in [(&collinear, 4), (&collapsed, 3)] {
        for bytes in [
            binary(b"flat", facets),
            ascii_solid("flat", facets).into_bytes(),
        ] {
            let e = read_err(&bytes);
            assert!(
                matches!(e, LoadError::NoArea { facets } if facets == n),
                "{e:?}"
            );
            assert!(e.to_string().contains(&format!("{n} facets")), "{e}");
        }
    }
}

#[test]
fn binary_cube_welds_to_8_vertices_closed_one_body() {
    let part = read_mm(&binary(b"cube", &cube([0.0; 3], 10.0)));
    let s = &part.stats;
    assert_eq!(s.facets_read, 12);
    assert_eq!(s.corners_read, 36);
    assert_eq!(s.vertices, 8);
    assert_eq!(s.triangles, 12);
    assert_eq!(s.open_edges, 0);
    assert_eq!(s.non_manifold_edges, 0);
    assert_eq!(s.bodies, 1);
    assert_eq!(s.collapsed_facets, 0);
    assert_eq!(s.zero_area_triangles, 0);
    assert!(s.is_closed());
    assert_close!(s.area_mm2, 600.0, 10.0);
    assert_eq!(part.topology.edges, 18);
    assert!(part.warnings.is_empty(), "{:?}", part.warnings);
}

#[test]
fn negative_zero_welds_with_zero() {
    // Every other facet writes its zeros as -0.0, so both signs meet at each corner.
    let mut facets = cube([0.0; 3], 10.0);
    for facet in facets.iter_mut().step_by(2) {
        for v in facet.iter_mut().flatten() {
            if *v == 0.0 {
                *v = -0.0;
            }
        }
    }
    assert!(facets[0][0][0].is_sign_negative());
    let part = read_mm(&binary(b"cube", &facets));
    assert_eq!(part.stats.vertices, 8);
    assert!(part.stats.is_closed());
}

#[test]
fn welding_is_exact_not_by_tolerance() {
    // A corner one float step away is another vertex: the cube opens along its edges.
    let mut facets = cube([0.0; 3], 10.0);
    let (f, c, k) = (0..facets.len())
        .flat_map(|f| (0..3).flat_map(move |c| (0..3).map(move |k| (f, c, k))))
        .find(|&(f, c, k)| facets[f][c][k] == 10.0)
        .expect("a corner at 10");
    facets[f][c][k] = 10.0f32.next_up();
    let part = read_mm(&binary(b"cube", &facets));
    assert_eq!(part.stats.vertices, 9);
    assert!(part.stats.open_edges > 0);
    // Only at zero is there noise, 2^-40 wide (an exporter's rotations): the smallest
    // subnormal, or -2.7e-16, instead of 0.0 is the corner at 0.
    for noise in [f32::from_bits(1), -2.731_848e-16] {
        let mut facets = cube([0.0; 3], 10.0);
        facets[0][0][0] = noise;
        assert_eq!(facets[0][0][0] == 0.0, noise == 0.0);
        let part = read_mm(&binary(b"cube", &facets));
        assert_eq!(part.stats.vertices, 8, "{noise:e}");
        assert!(part.stats.is_closed(), "{noise:e}");
    }
}

#[test]
fn a_large_file_welds_corners_shared_far_apart_in_the_file() {
    // 2000 cubes in a row, 24 000 facets: readers and welders that work in chunks must still
    // weld the corners of facets in different chunks, wherever the chunk boundaries fall.
    let cubes = 2000;
    let facets: Vec<Facet> = (0..cubes)
        .flat_map(|i| cube([20.0 * i as f32, 0.0, 0.0], 10.0))
        .collect();
    // The same cube's bottom face at the start, its top face at the end.
    let mut shuffled = facets.clone();
    shuffled.swap(0, facets.len() - 1);
    for bytes in [binary(b"row", &facets), binary(b"row", &shuffled)] {
        let part = read_mm(&bytes);
        assert_eq!(part.stats.triangles, 12 * cubes);
        assert_eq!(part.stats.vertices, 8 * cubes);
        assert_eq!(part.stats.bodies, cubes);
        assert!(part.stats.is_closed());
        assert_close!(part.stats.area_mm2, 600.0 * cubes as f64, 1e4);
    }
}

#[test]
fn two_separate_cubes_are_two_bodies() {
    let mut facets = cube([0.0; 3], 10.0);
    facets.extend(cube([30.0, 0.0, 0.0], 10.0));
    let part = read_mm(&binary(b"two", &facets));
    assert_eq!(part.stats.vertices, 16);
    assert_eq!(part.stats.bodies, 2);
    assert!(part.stats.is_closed());
    assert!(
        part.warnings
            .iter()
            .any(|w| w.contains("2 separate bodies")),
        "{:?}",
        part.warnings
    );
    let body = moldgate::mesh::topology::body_of_triangle(&part.mesh);
    assert!(body[..12].iter().all(|&b| b == body[0]));
    assert!(body[12..].iter().all(|&b| b != body[0]));
}

#[test]
fn cubes_touching_at_one_corner_are_one_body() {
    // Bodies are linked through shared vertices, so a common corner joins them.
    let mut facets = cube([0.0; 3], 10.0);
    facets.extend(cube([10.0, 10.0, 10.0], 10.0));
    let part = read_mm(&binary(b"two", &facets));
    assert_eq!(part.stats.vertices, 15);
    assert_eq!(part.stats.bodies, 1);
}

#[test]
fn cube_missing_one_face_reports_open_edges() {
    let mut facets = cube([0.0; 3], 10.0);
    facets.drain(2..4); // the +z face
    let part = read_mm(&binary(b"open box", &facets));
    let s = &part.stats;
    assert_eq!(s.triangles, 10);
    assert_eq!(s.vertices, 8);
    assert_eq!(s.open_edges, 4);
    assert_eq!(s.non_manifold_edges, 0);
    assert_eq!(s.bodies, 1);
    assert!(!s.is_closed());
    assert!(
        part.warnings
            .iter()
            .any(|w| w.contains("open") && w.contains("4 edges")),
        "{:?}",
        part.warnings
    );
}

#[test]
fn an_edge_shared_by_three_facets_is_non_manifold() {
    let mut facets = cube([0.0; 3], 10.0);
    // A fin on the edge from (0,0,0) to (10,0,0).
    facets.push([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [5.0, -5.0, -5.0]]);
    let part = read_mm(&binary(b"fin", &facets));
    assert_eq!(part.stats.non_manifold_edges, 1);
    assert_eq!(part.stats.open_edges, 2);
    assert!(!part.stats.is_closed());
}

#[test]
fn facet_with_two_equal_corners_is_counted_as_collapsed() {
    let mut facets = cube([0.0; 3], 10.0);
    facets.insert(5, [[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [10.0, 0.0, 0.0]]);
    facets.push([[3.0, 3.0, 3.0], [3.0, 3.0, 3.0], [3.0, 3.0, 3.0]]);
    for bytes in [
        binary(b"d", &facets),
        ascii_solid("d", &facets).into_bytes(),
    ] {
        let part = read_mm(&bytes);
        let s = &part.stats;
        assert_eq!(s.facets_read, 14);
        assert_eq!(s.corners_read, 42);
        assert_eq!(s.collapsed_facets, 2);
        assert_eq!(s.triangles, 12);
        assert!(s.is_closed(), "collapsed facets leave no edges behind");
        assert!(
            part.warnings
                .iter()
                .any(|w| w.contains("2 degenerate facets")),
            "{:?}",
            part.warnings
        );
    }
}

#[test]
fn facet_with_collinear_corners_is_kept_and_counted_as_zero_area() {
    let mut facets = cube([0.0; 3], 10.0);
    facets.push([[0.0, 0.0, 0.0], [5.0, 0.0, 0.0], [10.0, 0.0, 0.0]]);
    let part = read_mm(&binary(b"sliver", &facets));
    assert_eq!(part.stats.triangles, 13);
    assert_eq!(part.stats.zero_area_triangles, 1);
    assert_eq!(part.stats.collapsed_facets, 0);
    assert_close!(part.stats.area_mm2, 600.0, 10.0);
    assert!(part.warnings.iter().any(|w| w.contains("zero area")));
}

// ---------------------------------------------------------------------------------------------
// Units

#[test]
fn metres_are_multiplied_by_1000() {
    let bytes = binary(b"cube in metres", &cube([0.5, 0.0, -0.25], 0.125));
    let part = read(&bytes, Units::M).unwrap();
    assert_eq!(part.stats.units, Units::M);
    let [x0, y0, z0] = part.stats.bounds_min;
    let [x1, y1, z1] = part.stats.bounds_max;
    assert_close!(x0, 500.0, 125.0);
    assert_close!(y0, 0.0, 125.0);
    assert_close!(z0, -250.0, 125.0);
    assert_close!(x1, 625.0, 125.0);
    assert_close!(y1, 125.0, 125.0);
    assert_close!(z1, -125.0, 125.0);
    assert_close!(part.stats.area_mm2, 6.0 * 125.0 * 125.0, 125.0 * 125.0);
    assert_close!(part.mesh.bounds().max.x, 625.0, 125.0);
    assert!(part.warnings.is_empty(), "{:?}", part.warnings);
}

#[test]
fn every_unit_converts_to_millimetres() {
    let bytes = ascii_solid("c", &cube([0.0; 3], 2.0)).into_bytes();
    for (units, text, mm) in [
        (Units::Mm, "mm", 2.0),
        (Units::Cm, "cm", 20.0),
        (Units::M, "m", 2000.0),
        (Units::In, "in", 50.8),
    ] {
        assert_eq!(text.parse::<Units>().unwrap(), units);
        let part = read(&bytes, units).unwrap();
        assert_close!(part.stats.bounds_max[2], mm, mm);
    }
    assert!("furlong".parse::<Units>().is_err());
}

#[test]
fn a_tiny_part_in_millimetres_suggests_other_units() {
    // A 50 mm cube exported in metres and read as millimetres.
    let bytes = binary(b"cube", &cube([0.0; 3], 0.05));
    let part = read(&bytes, Units::Mm).unwrap();
    assert!(
        part.warnings.iter().any(|w| w.contains("only")
            && w.ends_with("; if the file is in metres, set its units to m (--units)")),
        "{:?}",
        part.warnings
    );
    // Read in metres, the same file is a plausible part.
    let part = read(&bytes, Units::M).unwrap();
    assert!(part.warnings.is_empty(), "{:?}", part.warnings);
}

#[test]
fn a_huge_part_warns_about_units() {
    // A 300 mm cube read as centimetres is 3 m across.
    let bytes = binary(b"cube", &cube([0.0; 3], 300.0));
    let part = read(&bytes, Units::Cm).unwrap();
    assert!(
        part.warnings
            .iter()
            .any(|w| w.contains("large") && w.contains("--units")),
        "{:?}",
        part.warnings
    );
    assert!(read(&bytes, Units::Mm).unwrap().warnings.is_empty());
}

// ---------------------------------------------------------------------------------------------
// Loading never panics

#[test]
fn every_prefix_of_a_valid_file_loads_or_is_refused_without_panic() {
    let ascii = ascii_solid("c", &cube([0.0; 3], 10.0)).into_bytes();
    let binary = binary(b"solid c", &cube([0.0; 3], 10.0));
    for bytes in [&ascii, &binary] {
        for len in 0..bytes.len() {
            let _ = read(&bytes[..len], Units::Mm);
        }
    }
}

#[test]
fn corrupted_files_load_or_are_refused_without_panic() {
    let ascii = ascii_solid("c", &cube([0.0; 3], 10.0)).into_bytes();
    let binary = binary(b"solid c", &cube([0.0; 3], 10.0));
    let mut rng = SplitMix(0x5EED);
    for round in 0..2000 {
        let mut bytes = if round % 2 == 0 {
            ascii.clone()
        } else {
            binary.clone()
        };
        for _ in 0..1 + rng.next() % 8 {
            let at = (rng.next() % bytes.len() as u64) as usize;
            bytes[at] = match rng.next() % 4 {
                0 => b' ',
                1 => b'\n',
                2 => b"0123456789.-+eE"[(rng.next() % 15) as usize],
                _ => rng.next() as u8,
            };
        }
        if let Err(e) = read(&bytes, Units::Mm) {
            // Every refusal is a sentence with a place or a reason, never empty.
            assert!(!e.to_string().is_empty());
        }
    }
}

/// A height-field sheet of `n` x `n` cells (2 n^2 facets), enough to take the parallel path.
fn sheet(n: usize) -> Vec<Facet> {
    let z = |i: usize, j: usize| ((i * 7 + j * 13) % 5) as f32 * 0.25;
    let p = |i: usize, j: usize| [i as f32, j as f32, z(i, j)];
    let mut facets = Vec::with_capacity(2 * n * n);
    for i in 0..n {
        for j in 0..n {
            facets.push([p(i, j), p(i + 1, j), p(i + 1, j + 1)]);
            facets.push([p(i, j), p(i + 1, j + 1), p(i, j + 1)]);
        }
    }
    facets
}

fn read_file_reopen(path: &std::path::Path) -> Result<LoadedMesh, LoadError> {
    let len = std::fs::metadata(path).unwrap().len();
    let open = || std::fs::File::open(path).map(std::io::BufReader::new);
    moldgate::mesh::read_stl_reopen(open, len, Units::Mm)
}

#[test]
fn reading_a_large_binary_file_on_several_threads_gives_the_same_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sheet.stl");
    let bytes = binary(b"sheet", &sheet(150)); // 45,000 facets
    std::fs::write(&path, &bytes).unwrap();
    let one = read_mm(&bytes);
    let many = read_file_reopen(&path).unwrap();
    assert_eq!(one.mesh.vertices, many.mesh.vertices);
    assert_eq!(one.mesh.triangles, many.mesh.triangles);
    assert_eq!(one.stats.vertices, 151 * 151);
    assert_eq!(one.stats.open_edges, many.stats.open_edges);
    assert_eq!(one.stats.bodies, 1);
}

#[test]
fn runs_joined_on_many_threads_number_vertices_as_one_reader_does() {
    // Facets shuffled, so that a vertex first met in one run turns up again in any later
    // one, plus a few collapsed facets; read by five runs.
    let mut facets = sheet(150);
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    for i in (1..facets.len()).rev() {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        facets.swap(i, (seed % (i as u64 + 1)) as usize);
    }
    for i in [10, 20_000, 44_999] {
        facets[i][1] = facets[i][0];
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("shuffled.stl");
    let bytes = binary(b"shuffled", &facets);
    std::fs::write(&path, &bytes).unwrap();
    let one = read_mm(&bytes);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(5)
        .build()
        .unwrap();
    let many = pool.install(|| read_file_reopen(&path)).unwrap();
    assert_eq!(one.mesh.vertices, many.mesh.vertices);
    assert_eq!(one.mesh.triangles, many.mesh.triangles);
    assert_eq!(one.stats.collapsed_facets, 3);
    assert_eq!(many.stats.collapsed_facets, 3);
    assert_eq!(many.stats.vertices, 151 * 151);
}

#[test]
fn errors_on_the_parallel_path_name_the_same_place() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sheet.stl");
    let facets = sheet(150);
    let mut bytes = binary(b"sheet", &facets);
    // A NaN late in the file, in the last run of records.
    let at = coordinate_offset(44_000, 2, 1);
    bytes[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    std::fs::write(&path, &bytes).unwrap();
    match read_file_reopen(&path).unwrap_err() {
        LoadError::NonFinite {
            place: Place::Byte(b),
            triangle: 44_000,
            ..
        } => assert_eq!(b, at as u64),
        other => panic!("{other:?}"),
    }
    // Truncated: the size rule fails, so the one-thread reader reports it.
    std::fs::write(&path, &bytes[..bytes.len() - 10]).unwrap();
    assert!(matches!(
        read_file_reopen(&path).unwrap_err(),
        LoadError::Truncated { .. }
    ));
}
