//! A mesh from arrays a program already holds: vertex positions and triangles as vertex
//! indices (what numpy and trimesh give), welded like the file readers' facets so the same
//! part gives the same mesh, stats and warnings whichever way it arrives.

use crate::error::LoadError;
use crate::math::DVec3;
use crate::mesh::{finish, Format, LoadedMesh, RawMesh, Units, Welder};

/// The most vertices an array mesh may have: vertex numbers are 32-bit.
pub const MAX_VERTICES: usize = u32::MAX as usize - 1;

/// The most triangles an array mesh may have (the readers' limit of 32-bit numbers too).
pub const MAX_TRIANGLES: usize = u32::MAX as usize - 1;

/// Builds a [`LoadedMesh`] from vertex positions (in `units`) and triangles given as three
/// indices into `vertices` each.
///
/// Every coordinate must be finite and every index in `0..vertices.len()`; the first
/// that is not is a [`LoadError`] naming the vertex or the triangle. The corners of every
/// triangle are then welded by exact position, like a file's facets (vertices numbered by
/// first use, so vertices no triangle uses are left out, and two array entries at the same
/// position become one vertex); triangles whose corners weld to fewer than three vertices
/// are dropped and counted.
///
/// ```
/// use moldgate::mesh::{from_arrays, Units};
///
/// let v = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
/// let t = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
/// let part = from_arrays(&v, &t, Units::Cm).unwrap();
/// assert_eq!(part.stats.triangles, 4);
/// assert_eq!(part.stats.bounds_max, [10.0, 10.0, 10.0]); // read in cm
/// assert!(from_arrays(&v, &[[0, 1, 4]], Units::Mm).is_err());
/// ```
pub fn from_arrays(
    vertices: &[[f64; 3]],
    triangles: &[[i64; 3]],
    units: Units,
) -> Result<LoadedMesh, LoadError> {
    if vertices.len() > MAX_VERTICES {
        return Err(LoadError::TooLarge {
            what: "vertices",
            count: vertices.len() as u64,
            limit: MAX_VERTICES as u64,
        });
    }
    if triangles.len() > MAX_TRIANGLES {
        return Err(LoadError::TooLarge {
            what: "triangles",
            count: triangles.len() as u64,
            limit: MAX_TRIANGLES as u64,
        });
    }
    if let Some((vertex, value)) = vertices.iter().enumerate().find_map(|(i, p)| {
        p.iter()
            .find(|c| !c.is_finite())
            .map(|&value| (i as u64, value))
    }) {
        return Err(LoadError::NonFiniteVertex { vertex, value });
    }
    // The files' limit on coordinates, in millimetres (so every sum and square stays finite).
    let limit = super::MAX_COORDINATE_MM / units.mm_per_unit();
    if let Some((vertex, value)) = vertices.iter().enumerate().find_map(|(i, p)| {
        p.iter()
            .find(|c| c.abs() > limit)
            .map(|&value| (i as u64, value))
    }) {
        return Err(LoadError::VertexOutOfRange {
            vertex,
            value,
            mm: value * units.mm_per_unit(),
            limit_mm: super::MAX_COORDINATE_MM,
        });
    }
    let n = vertices.len() as i64;
    if let Some((triangle, index)) = triangles.iter().enumerate().find_map(|(t, tri)| {
        tri.iter()
            .find(|&&i| !(0..n).contains(&i))
            .map(|&index| (t as u64, index))
    }) {
        return Err(LoadError::IndexOutOfRange {
            triangle,
            index,
            vertices: n as u64,
        });
    }
    let mut welder = Welder::with_capacity(triangles.len());
    for tri in triangles {
        welder.push(tri.map(|i| DVec3::from_array(vertices[i as usize])));
    }
    let (mesh, collapsed_facets) = welder.finish();
    let facets = triangles.len() as u64;
    let raw = RawMesh {
        format: Format::Arrays,
        solids: 1,
        facets_read: facets,
        corners_read: 3 * facets,
        collapsed_facets,
        mesh,
        warnings: Vec::new(),
    };
    finish(raw, units)
}

/// For each of the `vertices` given to [`from_arrays`] (in `units`), the number of the
/// vertex of `mesh` (the part it made) at its position, or -1 when no triangle of the part
/// uses it: welding numbers the part's vertices by their first use and merges repeated
/// positions, so a field per vertex of the part reads, for the caller's vertex `i`, at
/// `map[i]`.
pub fn vertex_map(vertices: &[[f64; 3]], mesh: &super::Mesh, units: Units) -> Vec<i64> {
    let key = |p: DVec3| p.to_array().map(f64::to_bits);
    let at: std::collections::HashMap<[u64; 3], i64> = mesh
        .vertices
        .iter()
        .enumerate()
        .map(|(i, &p)| (key(p), i as i64))
        .collect();
    // The position as welding stored it, then scaled to mm as the part was.
    let factor = units.mm_per_unit();
    vertices
        .iter()
        .map(|&p| {
            let welded = super::weld_position(DVec3::from_array(p)) * factor;
            at.get(&key(welded)).copied().unwrap_or(-1)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::samples::sample;

    /// The sample as arrays with every triangle's corners listed separately (no sharing).
    fn unshared(name: &str) -> (Vec<[f64; 3]>, Vec<[i64; 3]>) {
        let m = sample(name).unwrap();
        let mut v = Vec::new();
        let mut t = Vec::new();
        for i in 0..m.triangles.len() {
            let base = v.len() as i64;
            v.extend(m.corners(i).map(|p| p.to_array()));
            t.push([base, base + 1, base + 2]);
        }
        (v, t)
    }

    #[test]
    fn the_vertex_map_finds_each_given_vertex_in_the_part() {
        // A tetrahedron given backwards, with a repeated position (3 and 5) and a vertex no
        // triangle uses (4), in inches.
        let v = vec![
            [0.0, 0.0, 1.0],
            [0.0, 1.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 0.0, 0.0],
            [7.0, 7.0, 7.0],
            [0.0, 0.0, -0.0],
        ];
        let t = vec![[3, 1, 2], [3, 2, 0], [5, 0, 1], [1, 0, 2]];
        let part = from_arrays(&v, &t, Units::In).unwrap();
        let map = vertex_map(&v, &part.mesh, Units::In);
        assert_eq!(map[4], -1);
        assert_eq!(map[3], map[5]);
        for (i, &m) in map.iter().enumerate().filter(|&(_, &m)| m >= 0) {
            let expected = DVec3::from_array(v[i]) * 25.4;
            assert_eq!(
                part.mesh.vertices[m as usize],
                expected + DVec3::ZERO,
                "vertex {i}"
            );
        }
        // Every vertex of the part is some given vertex's.
        let mut seen: Vec<i64> = map.iter().copied().filter(|&m| m >= 0).collect();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(
            seen,
            (0..part.mesh.vertices.len() as i64).collect::<Vec<_>>()
        );
    }

    #[test]
    fn arrays_weld_like_an_stl_file() {
        let m = sample("cover").unwrap();
        let mut stl = Vec::new();
        m.write_stl(&mut stl).unwrap();
        let from_file =
            crate::mesh::read_stl(std::io::Cursor::new(&stl), stl.len() as u64, Units::Mm).unwrap();
        let (v, t) = unshared("cover");
        let from_arrays = from_arrays(&v, &t, Units::Mm).unwrap();
        assert_eq!(from_arrays.mesh.vertices, from_file.mesh.vertices);
        assert_eq!(from_arrays.mesh.triangles, from_file.mesh.triangles);
        assert_eq!(from_arrays.warnings, from_file.warnings);
        let (a, f) = (&from_arrays.stats, &from_file.stats);
        assert_eq!(a.format, Format::Arrays);
        assert_eq!(
            (
                a.vertices,
                a.triangles,
                a.corners_read,
                a.open_edges,
                a.bodies
            ),
            (
                f.vertices,
                f.triangles,
                f.corners_read,
                f.open_edges,
                f.bodies
            )
        );
        assert_eq!(a.area_mm2, f.area_mm2);
    }

    #[test]
    fn bad_values_name_their_place() {
        let v = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, f64::NAN, 0.0]];
        match from_arrays(&v, &[[0, 1, 2]], Units::Mm) {
            Err(LoadError::NonFiniteVertex { vertex: 2, value }) => assert!(value.is_nan()),
            other => panic!("{other:?}"),
        }
        let v = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        for (bad, t) in [(-1, 1u64), (3, 1)] {
            let e = from_arrays(&v, &[[0, 1, 2], [0, bad, 2]], Units::Mm).unwrap_err();
            assert!(
                matches!(e, LoadError::IndexOutOfRange { triangle, index, vertices: 3 }
                    if triangle == t && index == bad),
                "{e:?}"
            );
            assert!(e.to_string().contains("triangle 1"), "{e}");
        }
        assert!(matches!(
            from_arrays(&v, &[], Units::Mm),
            Err(LoadError::NoArea { facets: 0 })
        ));
        assert!(matches!(
            from_arrays(&v, &[[0, 0, 1]], Units::Mm),
            Err(LoadError::NoArea { facets: 1 })
        ));
    }

    #[test]
    fn duplicate_positions_weld_and_collapsed_facets_are_counted() {
        let v = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [-0.0, 0.0, 0.0],
        ];
        // Vertex 3 welds onto vertex 0: the second facet collapses, and the third becomes a
        // repeat of the first (dropped and counted, as when reading a file).
        let part = from_arrays(&v, &[[0, 1, 2], [3, 1, 0], [3, 2, 1]], Units::Mm).unwrap();
        assert_eq!(part.stats.vertices, 3);
        assert_eq!(part.stats.triangles, 1);
        assert_eq!(part.stats.duplicate_triangles, 1);
        assert_eq!(part.stats.collapsed_facets, 1);
        assert!(part.warnings.iter().any(|w| w.contains("1 degenerate")));
    }

    #[test]
    fn coordinates_beyond_the_files_limit_are_refused_in_the_arrays_units() {
        let tri = [[0, 1, 2]];
        let v = |x: f64| vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, x, 0.0]];
        // 1e9 mm is the limit; 1e8 m is beyond it, 1e8 mm within.
        assert!(from_arrays(&v(1e9), &tri, Units::Mm).is_ok());
        assert!(from_arrays(&v(1e8), &tri, Units::Mm).is_ok());
        for (x, units) in [(1.1e9, Units::Mm), (1e8, Units::M), (1e307, Units::Mm)] {
            match from_arrays(&v(x), &tri, units) {
                Err(LoadError::VertexOutOfRange {
                    vertex: 2, value, ..
                }) => assert_eq!(value, x),
                other => panic!("{x} {units:?}: {other:?}"),
            }
        }
        let e = from_arrays(&v(1e307), &tri, Units::Mm)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("vertex 2: a coordinate of 1.0000e307"), "{e}");
    }
}
