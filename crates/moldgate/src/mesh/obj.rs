//! Wavefront OBJ reader: vertex positions and polygonal faces.
//!
//! Read: `v x y z [w]` (extra numbers such as vertex colours are ignored) and `f` with
//! corners `i`, `i/j`, `i/j/k` or `i//k`, where `i` is 1-based or negative (relative to the
//! vertices defined so far); the texture coordinate `j` and normal `k` are not used, but
//! must exist (`vt` and `vn` lines before the face), as a malformed file is refused. Polygons are fanned into triangles from their first corner.
//! Comments (`#`), and the statements that do not change the surface (`vt`, `vn`, `vp`, `o`,
//! `g`, `s`, `usemtl`, `mtllib`, lines, points and the free-form statements) are skipped.
//! Every error names its 1-based line.
//!
//! The triangles go through the same [`Welder`] as an STL's facets, so a part saved as OBJ
//! and as STL gives the same mesh, vertex numbers and counts.

use std::io::BufRead;

use super::text::Lines;
use super::{sniff, Format, RawMesh, Units, Welder, MAX_COORDINATE_MM, MAX_POLYGON_CORNERS};
use crate::error::{excerpt, LoadError, Place};
use crate::math::DVec3;

/// Statements that do not change the triangle surface.
const SKIPPED: &[&[u8]] = &[
    b"vt",
    b"vn",
    b"vp",
    b"o",
    b"g",
    b"s",
    b"usemtl",
    b"mtllib",
    b"l",
    b"p",
    b"mg",
    b"cstype",
    b"deg",
    b"bmat",
    b"step",
    b"curv",
    b"curv2",
    b"surf",
    b"parm",
    b"trim",
    b"hole",
    b"scrv",
    b"sp",
    b"end",
    b"con",
    b"bevel",
    b"c_interp",
    b"d_interp",
    b"lod",
    b"maplib",
    b"usemap",
    b"shadow_obj",
    b"trace_obj",
    b"ctech",
    b"stech",
    b"call",
    b"csh",
];

/// Reads an OBJ written in `units` from `reader` into a welded mesh in file units.
pub fn read(mut reader: impl BufRead, units: Units) -> Result<RawMesh, LoadError> {
    let head = reader.fill_buf()?;
    if head.is_empty() {
        return Err(LoadError::Empty);
    }
    let head = &head[..head.len().min(1024)];
    if let Some(e) = sniff::not_a_mesh(head, false).or_else(|| sniff::stl_by_another_name(head)) {
        return Err(e);
    }
    let limit = MAX_COORDINATE_MM / units.mm_per_unit();
    let mut lines = Lines::new(reader);
    let mut welder = Welder::with_capacity(1024);
    let mut positions: Vec<DVec3> = Vec::new();
    let mut corners: Vec<usize> = Vec::new();
    let mut facets = 0u64;
    let mut next_memory_check = super::TRIANGLES_PER_MEMORY_CHECK as u64;
    // Texture coordinates and normals defined so far: a face's references to them are
    // checked as its vertices are, though neither is used.
    let mut defined = Defined::default();
    let mut line = Vec::new();
    let syntax = |line: u64, message: String| LoadError::Syntax {
        place: Place::Line(line),
        message,
    };
    while lines.next_into(&mut line)? {
        let line_no = lines.line_no;
        let content = match line.iter().position(|&b| b == b'#') {
            Some(hash) => &line[..hash],
            None => &line[..],
        };
        let mut tokens = content
            .split(|b| b.is_ascii_whitespace())
            .filter(|t| !t.is_empty());
        let Some(keyword) = tokens.next() else {
            continue;
        };
        match keyword {
            b"v" => {
                let mut xyz = [0.0f64; 3];
                for (axis, value) in xyz.iter_mut().enumerate() {
                    let tok = tokens.next().ok_or_else(|| {
                        syntax(
                            line_no,
                            format!("vertex has {axis} coordinates, expected x y z"),
                        )
                    })?;
                    *value = number(tok, line_no)?;
                    if value.abs() > limit {
                        return Err(LoadError::OutOfRange {
                            place: Place::Line(line_no),
                            value: *value,
                            mm: *value * units.mm_per_unit(),
                            limit_mm: MAX_COORDINATE_MM,
                        });
                    }
                }
                // An optional w, or per-vertex colours: numbers we do not use.
                for tok in tokens {
                    number(tok, line_no)?;
                }
                positions.push(DVec3::from_array(xyz));
            }
            b"f" => {
                corners.clear();
                for tok in tokens {
                    if corners.len() == MAX_POLYGON_CORNERS {
                        return Err(syntax(
                            line_no,
                            format!(
                                "face has more than {MAX_POLYGON_CORNERS} corners, the limit of a polygon"
                            ),
                        ));
                    }
                    defined.vertices = positions.len();
                    corners.push(corner(tok, &defined, line_no)?);
                }
                if corners.len() < 3 {
                    return Err(syntax(
                        line_no,
                        format!(
                            "face has {} corners, a face needs at least 3",
                            corners.len()
                        ),
                    ));
                }
                // A fan from the first corner: (0, k, k + 1).
                for k in 1..corners.len() - 1 {
                    welder.push([
                        positions[corners[0]],
                        positions[corners[k]],
                        positions[corners[k + 1]],
                    ]);
                    facets += 1;
                }
                if facets >= next_memory_check {
                    super::check_triangle_memory(facets as usize, Place::Line(line_no))?;
                    next_memory_check += super::TRIANGLES_PER_MEMORY_CHECK as u64;
                }
            }
            b"vt" => defined.textures += 1,
            b"vn" => defined.normals += 1,
            other if SKIPPED.contains(&other) => {}
            other => {
                return Err(syntax(
                    line_no,
                    format!("unknown OBJ statement '{}'", excerpt(other)),
                ));
            }
        }
    }
    let (mesh, collapsed_facets) = welder.finish();
    Ok(RawMesh {
        format: Format::Obj,
        solids: 1,
        facets_read: facets,
        corners_read: 3 * facets,
        collapsed_facets,
        mesh,
        warnings: Vec::new(),
    })
}

/// A finite coordinate.
fn number(tok: &[u8], line: u64) -> Result<f64, LoadError> {
    let shown = || excerpt(tok);
    let value = std::str::from_utf8(tok)
        .ok()
        .and_then(|s| s.parse::<f64>().ok())
        .ok_or_else(|| LoadError::Syntax {
            place: Place::Line(line),
            message: format!("expected a number, found '{}'", shown()),
        })?;
    if !value.is_finite() {
        return Err(LoadError::Syntax {
            place: Place::Line(line),
            message: format!("coordinate '{}' is not finite", shown()),
        });
    }
    Ok(value)
}

/// What a face corner may refer to: the vertices, texture coordinates and normals defined
/// before its line.
#[derive(Debug, Default)]
struct Defined {
    vertices: usize,
    textures: usize,
    normals: usize,
}

/// The 0-based vertex of a face corner `i`, `i/j`, `i/j/k` or `i//k`; the texture
/// coordinate `j` and normal `k`, when given, must exist too (they are not used).
fn corner(tok: &[u8], defined: &Defined, line: u64) -> Result<usize, LoadError> {
    let syntax = |message: String| LoadError::Syntax {
        place: Place::Line(line),
        message,
    };
    let shown = || excerpt(tok);
    let mut parts = tok.split(|&b| b == b'/');
    let index = |part: &[u8], what: &str, plural: &str, count: usize| {
        let i: i64 = std::str::from_utf8(part)
            .ok()
            .and_then(|s| s.parse().ok())
            .ok_or_else(|| syntax(format!("expected a {what} index, found '{}'", shown())))?;
        let resolved = match i {
            0 => return Err(syntax(format!("{what} index 0 (indices start at 1)"))),
            i if i > 0 => i - 1,
            i => count as i64 + i,
        };
        if resolved < 0 || resolved >= count as i64 {
            let (noun, verb) = match count {
                1 => (what, "is"),
                _ => (plural, "are"),
            };
            return Err(syntax(format!(
                "{what} index {i} is out of range: {count} {noun} {verb} defined before this line"
            )));
        }
        Ok(resolved as usize)
    };
    let vertex = index(
        parts.next().unwrap_or_default(),
        "vertex",
        "vertices",
        defined.vertices,
    )?;
    let others = [
        (
            "texture coordinate",
            "texture coordinates",
            defined.textures,
        ),
        ("normal", "normals", defined.normals),
    ];
    for ((what, plural, count), part) in others.into_iter().zip(parts.by_ref()) {
        if !part.is_empty() {
            index(part, what, plural, count)?;
        }
    }
    if parts.next().is_some() {
        return Err(syntax(format!(
            "expected a corner i, i/j, i/j/k or i//k, found '{}'",
            shown()
        )));
    }
    Ok(vertex)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read_str(text: &str) -> Result<RawMesh, LoadError> {
        read(text.as_bytes(), Units::Mm)
    }

    fn line_of(err: LoadError) -> u64 {
        match err {
            LoadError::Syntax {
                place: Place::Line(n),
                ..
            } => n,
            other => panic!("expected a syntax error with a line, got {other:?}"),
        }
    }

    #[test]
    fn an_empty_file_is_said_empty_as_an_empty_stl_is() {
        let e = read(&b""[..], Units::Mm).unwrap_err();
        assert_eq!(e.to_string(), "empty file");
    }

    #[test]
    fn quad_with_every_corner_form_is_two_triangles() {
        let raw = read_str(
            "# a square\nmtllib a.mtl\no sq\nv 0 0 0\nv 1 0 0 1.0\nv 1 1 0\nv 0 1 0\n\
             vt 0 0\nvn 0 0 1\ng top\nusemtl red\ns off\nf 1 2/1 3/1/1 4//1\n",
        )
        .unwrap();
        assert_eq!(raw.facets_read, 2);
        assert_eq!(raw.mesh.vertices.len(), 4);
        assert_eq!(raw.mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn negative_indices_count_back_from_the_last_vertex() {
        let raw = read_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n").unwrap();
        assert_eq!(raw.mesh.triangles, vec![[0, 1, 2]]);
        assert_eq!(raw.mesh.vertices[1], DVec3::X);
    }

    #[test]
    fn errors_name_their_line() {
        let base = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
        for (bad, line) in [
            ("v 1 x 0\n", 4),
            ("v 1 2\n", 4),
            ("v nan 0 0\n", 4),
            ("f 1 2 4\n", 4),
            ("f 0 1 2\n", 4),
            ("f -4 1 2\n", 4),
            ("f 1 2\n", 4),
            ("\n\nf 1 a 2\n", 6),
            ("bogus 1\n", 4),
        ] {
            let err = read_str(&format!("{base}{bad}")).unwrap_err();
            assert_eq!(line_of(err), line, "{bad:?}");
        }
    }

    /// A face's texture and normal references are checked as its vertices are: against what
    /// is defined before its line.
    #[test]
    fn texture_and_normal_references_must_exist() {
        let base = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvn 0 0 1\n";
        for good in [
            "f 1/1 2/2 3/-1\n",
            "f 1//1 2//1 3//-1\n",
            "f 1/2/1 2/1/1 3/1/1\n",
        ] {
            assert!(read_str(&format!("{base}{good}")).is_ok(), "{good:?}");
        }
        for (bad, message) in [
            (
                "f 1/3 2/1 3/1\n",
                "texture coordinate index 3 is out of range: 2 texture coordinates",
            ),
            (
                "f 1/-3 2/1 3/1\n",
                "texture coordinate index -3 is out of range",
            ),
            (
                "f 1//2 2//1 3//1\n",
                "normal index 2 is out of range: 1 normal is defined",
            ),
            ("f 1/0 2/1 3/1\n", "texture coordinate index 0"),
            (
                "f 1/x 2/1 3/1\n",
                "expected a texture coordinate index, found '1/x'",
            ),
            (
                "f 1/1/1/1 2/1 3/1\n",
                "expected a corner i, i/j, i/j/k or i//k, found '1/1/1/1'",
            ),
        ] {
            let err = read_str(&format!("{base}{bad}")).unwrap_err();
            assert!(err.to_string().contains(message), "{bad:?}: {err}");
            assert_eq!(line_of(err), 7, "{bad:?}");
        }
        // Defined after the face: not yet there.
        let later = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\nvt 0 0\n";
        assert_eq!(line_of(read_str(later).unwrap_err()), 4);
    }
}
