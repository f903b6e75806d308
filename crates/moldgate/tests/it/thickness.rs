//! Wall thickness against closed forms on built-in and hand-made parts, and plausibility on
//! the shared real parts (skipped with a printed reason when they are absent).

use std::path::PathBuf;

use moldgate::math::DVec3;
use moldgate::mesh::{self, Mesh, Units};
use moldgate::raycast::{Bvh, Ray};
use moldgate::samples::{self, BoxUnion};
use moldgate::thickness::{wall_thickness, CrossCheck, Sampling, ThicknessOptions, WallThickness};

fn thickness(mesh: &Mesh) -> WallThickness {
    wall_thickness(mesh, &ThicknessOptions::default())
}

/// Asserts `|got - want| <= tol` with a readable message.
macro_rules! assert_close {
    ($got:expr, $want:expr, $tol:expr, $($what:tt)*) => {{
        let (g, w): (f64, f64) = ($got, $want);
        assert!((g - w).abs() <= $tol, "{}: got {g}, want {w} ± {}", format!($($what)*), $tol);
    }};
}

#[test]
fn plate_is_3_mm_everywhere_including_its_edge_faces() {
    let mesh = samples::sample("plate").unwrap();
    let w = thickness(&mesh);
    for t in 0..mesh.triangles.len() {
        let v = w.at_triangle(t).expect("closed plate: every facet known");
        assert_close!(v, 3.0, 1e-3, "triangle {t}, normal {}", mesh.normal(t));
    }
    assert_close!(w.nominal_mm.unwrap(), 3.0, 1e-3, "nominal");
    assert_eq!(w.unknown_area_share, 0.0);
}

#[test]
fn without_the_cross_check_the_edge_faces_measure_the_plate_length() {
    // What rule 5 is for: along the 100 x 60 plate, the ray from an edge face runs to the
    // opposite edge face (or the hole).
    let mesh = samples::sample("plate").unwrap();
    let raw = wall_thickness(
        &mesh,
        &ThicknessOptions {
            cross_check: CrossCheck::Off,
            ..ThicknessOptions::default()
        },
    );
    assert_close!(raw.max_mm.unwrap(), 100.0, 1e-3, "longest chord");
    assert_close!(raw.nominal_mm.unwrap(), 3.0, 1e-3, "nominal, big faces");
}

#[test]
fn cap_wall_is_1_6_mm() {
    // Lathe of 96 segments: the radial wall between two parallel facets is 1.6 cos(pi/96),
    // the top 1.6 exactly; the rim's chord runs up the wall and is cut to the wall's width.
    let mesh = samples::sample("cap").unwrap();
    let w = thickness(&mesh);
    let radial = 1.6 * (std::f64::consts::PI / 96.0).cos();
    for t in 0..mesh.triangles.len() {
        let v = w.at_triangle(t).expect("closed cap");
        assert!(
            (v - 1.6).abs() < 1e-3 || (v - radial).abs() < 1e-3,
            "triangle {t}: {v} mm, normal {}",
            mesh.normal(t)
        );
    }
    assert!(w.min_mm.unwrap() > radial - 1e-3 && w.max_mm.unwrap() < 1.6 + 1e-3);
}

#[test]
fn cover_walls_ribs_and_bosses() {
    // Walls and top 2 mm, ribs 2 mm, bosses 8 mm square with 3 mm holes: 2.5 mm each side.
    let mesh = samples::sample("cover").unwrap();
    let w = thickness(&mesh);
    assert_close!(w.nominal_mm.unwrap(), 2.0, 1e-3, "nominal");
    assert_eq!(w.unknown_area_share, 0.0);
    let bvh = Bvh::new(&mesh);
    // The facet under point p, seen from outside along its normal n.
    let at = |p: DVec3, n: DVec3| {
        let hit = bvh
            .first_hit(&Ray::new(p + n, -n))
            .unwrap_or_else(|| panic!("no facet at {p}"));
        assert!(mesh.normal(hit.triangle as usize).dot(n) > 0.999);
        w.at_triangle(hit.triangle as usize).unwrap()
    };
    assert_close!(
        at(DVec3::new(-30.0, -20.0, 30.0), DVec3::Z),
        2.0,
        1e-3,
        "top"
    );
    assert_close!(
        at(DVec3::new(60.0, 10.0, 15.0), DVec3::X),
        2.0,
        1e-3,
        "side wall"
    );
    assert_close!(
        at(DVec3::new(-44.0, 22.0, 15.0), -DVec3::X),
        2.5,
        1e-3,
        "boss wall"
    );
}

#[test]
fn open_mesh_gives_unknown_not_garbage() {
    // The plate with its top face removed: every ray either leaves through the missing top
    // or measures across a chord whose cross rays do.
    let mut mesh = samples::sample("plate").unwrap();
    let keep: Vec<[u32; 3]> = (0..mesh.triangles.len())
        .filter(|&t| mesh.normal(t).z < 0.5)
        .map(|t| mesh.triangles[t])
        .collect();
    assert!(keep.len() < mesh.triangles.len());
    mesh.triangles = keep;
    let w = thickness(&mesh);
    for (t, v) in w.per_triangle.iter().enumerate() {
        assert!(v.is_nan(), "triangle {t}: {v}, normal {}", mesh.normal(t));
    }
    assert_eq!((w.min_mm, w.nominal_mm, w.max_mm), (None, None, None));
    assert_eq!(w.unknown_area_share, 1.0);

    // One triangle removed from the cover: only the facets that look through the hole are
    // unknown, and everything known is still a wall of the part.
    let mut mesh = samples::sample("cover").unwrap();
    let top = (0..mesh.triangles.len())
        .find(|&t| mesh.normal(t).z > 0.999 && mesh.corners(t)[0].z == 30.0)
        .unwrap();
    mesh.triangles.remove(top);
    let w = thickness(&mesh);
    assert!(w.unknown_area_share > 0.0 && w.unknown_area_share < 0.5);
    assert_close!(
        w.nominal_mm.unwrap(),
        2.0,
        1e-3,
        "nominal of the holed cover"
    );
    // The largest is a chord up a corner column of the walls (an L in section, wide along
    // both axes): at most the cover's height, never a length through the hole.
    assert!(w.max_mm.unwrap() <= 30.0 + 1e-3, "max {:?}", w.max_mm);
}

/// A 10 x 10 x 3 slab whose top is a fan around a point 1e-6 mm from the edge y = 0: the
/// triangle along that edge is a sliver of height 1e-6 mm.
fn slab_with_sliver() -> (Mesh, usize) {
    let v = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
    let vertices = vec![
        v(0.0, 0.0, 0.0),
        v(10.0, 0.0, 0.0),
        v(10.0, 10.0, 0.0),
        v(0.0, 10.0, 0.0),
        v(0.0, 0.0, 3.0),
        v(10.0, 0.0, 3.0),
        v(10.0, 10.0, 3.0),
        v(0.0, 10.0, 3.0),
        v(5.0, 1e-6, 3.0),
    ];
    let triangles = vec![
        // Bottom (facing -z).
        [0, 2, 1],
        [0, 3, 2],
        // Top: the sliver first, then the rest of the fan around vertex 8.
        [4, 5, 8],
        [5, 6, 8],
        [6, 7, 8],
        [7, 4, 8],
        // Sides.
        [0, 1, 5],
        [0, 5, 4],
        [1, 2, 6],
        [1, 6, 5],
        [2, 3, 7],
        [2, 7, 6],
        [3, 0, 4],
        [3, 4, 7],
    ];
    (
        Mesh {
            vertices,
            triangles,
        },
        2,
    )
}

#[test]
fn a_sliver_is_not_zero() {
    let (mesh, sliver) = slab_with_sliver();
    let part = mesh::from_generated(mesh.clone());
    assert_eq!(part.stats.open_edges, 0, "the test part is closed");
    let w = thickness(&mesh);
    assert_close!(w.at_triangle(sliver).unwrap(), 3.0, 1e-3, "sliver");
    assert_close!(w.min_mm.unwrap(), 3.0, 1e-3, "min");
}

#[test]
fn zero_area_facets_are_unknown_and_weigh_nothing() {
    let (mut mesh, _) = slab_with_sliver();
    // A degenerate facet along an edge of the top (three collinear points).
    mesh.vertices.push(DVec3::new(2.0, 0.0, 3.0));
    let extra = (mesh.vertices.len() - 1) as u32;
    mesh.triangles.push([4, extra, 5]);
    let w = thickness(&mesh);
    assert!(w.per_triangle.last().unwrap().is_nan());
    assert_eq!(w.unknown_area_share, 0.0);
    assert_close!(w.nominal_mm.unwrap(), 3.0, 1e-3, "nominal");
}

#[test]
fn an_inverted_facet_is_measured_the_other_way() {
    let (mut mesh, sliver) = slab_with_sliver();
    let flipped = sliver + 1; // a big top facet
    mesh.triangles[flipped].swap(0, 1);
    let w = thickness(&mesh);
    assert_close!(w.at_triangle(flipped).unwrap(), 3.0, 1e-3, "flipped facet");
    for t in 0..mesh.triangles.len() {
        if let Some(v) = w.at_triangle(t) {
            assert_close!(v, 3.0, 1e-3, "triangle {t}");
        }
    }
}

#[test]
fn sampling_finer_than_the_facets_agrees_on_a_box_union() {
    // The bracket: base 5 mm, upright 5 mm. With a 2 mm sampling every facet has many rays.
    let mesh = samples::sample("bracket").unwrap();
    let coarse = thickness(&mesh);
    let fine = wall_thickness(
        &mesh,
        &ThicknessOptions {
            sampling: Sampling::Spacing(2.0),
            ..ThicknessOptions::default()
        },
    );
    assert_close!(coarse.nominal_mm.unwrap(), 5.0, 1e-3, "coarse nominal");
    assert_close!(fine.nominal_mm.unwrap(), 5.0, 1e-3, "fine nominal");
    // Samples near the bracket's inner corner run up the junction of base and upright.
    assert!(
        fine.max_mm.unwrap() <= 50.0 + 1e-3,
        "fine max {:?}",
        fine.max_mm
    );
}

#[test]
fn per_vertex_is_the_area_weighted_mean() {
    let mesh = samples::sample("cover").unwrap();
    let w = thickness(&mesh);
    let pv = w.per_vertex(&mesh);
    assert_eq!(pv.len(), mesh.vertices.len());
    let (lo, hi) = (w.min_mm.unwrap() as f32, w.max_mm.unwrap() as f32);
    for v in pv {
        assert!(v >= lo - 1e-4 && v <= hi + 1e-4, "{v} outside [{lo}, {hi}]");
    }
}

fn parts_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("MOLDGATE_PARTS")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/parts")
        });
    dir.is_dir().then_some(dir)
}

#[test]
fn shared_parts_have_plausible_thickness() {
    let Some(dir) = parts_dir() else {
        let why = "shared parts not found (set MOLDGATE_PARTS)";
        eprintln!("shared_parts_have_plausible_thickness: skipped: {why}");
        println!("shared_parts_have_plausible_thickness: skipped: {why}");
        return;
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("stl")))
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no STL in {}", dir.display());
    println!(
        "{:<40} {:>8} {:>8} {:>8} {:>8} {:>8} {:>9}",
        "part", "tris", "min", "nominal", "max", "unknown", "diagonal"
    );
    let mut faults = Vec::new();
    for path in files {
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        let units = if name.contains("meters") {
            Units::M
        } else if name.contains("inches") {
            Units::In
        } else {
            Units::Mm
        };
        let bytes = std::fs::read(&path).unwrap();
        let part = mesh::read_stl(&bytes[..], bytes.len() as u64, units).unwrap();
        if cfg!(debug_assertions) && part.mesh.triangles.len() > 100_000 {
            println!("{name}: skipped in a debug build (too slow); run with --release");
            continue;
        }
        let w = thickness(&part.mesh);
        let diagonal = part.mesh.bounds().diagonal();
        println!(
            "{:<40} {:>8} {:>8.3} {:>8.3} {:>8.3} {:>7.2}% {:>9.1}",
            name,
            part.mesh.triangles.len(),
            w.min_mm.unwrap_or(f64::NAN),
            w.nominal_mm.unwrap_or(f64::NAN),
            w.max_mm.unwrap_or(f64::NAN),
            100.0 * w.unknown_area_share,
            diagonal
        );
        let finite_ok = w
            .per_triangle
            .iter()
            .all(|&v| v.is_nan() || (v > 0.0 && (v as f64) <= diagonal * 1.001));
        let nominal_ok = w.nominal_mm.is_some_and(|n| n > 0.05 && n < 0.5 * diagonal);
        if !finite_ok || !nominal_ok {
            faults.push(format!(
                "{name}: {w:?}",
                w = (w.min_mm, w.nominal_mm, w.max_mm)
            ));
        }
        // A closed single-body part has (almost) every facet known.
        if part.stats.is_closed() && part.stats.bodies == 1 && w.unknown_area_share > 0.01 {
            faults.push(format!(
                "{name}: closed but {:.2}% unknown",
                100.0 * w.unknown_area_share
            ));
        }
    }
    assert!(faults.is_empty(), "{faults:#?}");
}

#[test]
fn bracket_box_union_is_a_closed_form_too() {
    // A step: a 20 x 20 x 2 plate with a 10 x 20 x 6 block on half of it.
    let mut part = BoxUnion::default();
    part.add([0.0, 0.0, 0.0], [20.0, 20.0, 2.0]);
    part.add([0.0, 0.0, 0.0], [10.0, 20.0, 6.0]);
    let mesh = part.mesh();
    let w = thickness(&mesh);
    // Top of the thin half: 2 mm; top of the block: 6 mm.
    for t in 0..mesh.triangles.len() {
        let [a, b, c] = mesh.corners(t);
        let centroid = (a + b + c) / 3.0;
        if mesh.normal(t).z > 0.999 {
            let want = if centroid.x > 10.0 { 2.0 } else { 6.0 };
            assert_close!(w.at_triangle(t).unwrap(), want, 1e-3, "top at {centroid}");
        }
    }
}

/// The rule of the module before the cross rays were cut at the width found so far: every
/// cross ray runs to where it leaves the solid, and the ball of each point is half the chord.
/// The oracle of `cut_cross_rays_give_the_same_walls` (public API only).
mod unlimited {
    use moldgate::math::DVec3;
    use moldgate::mesh::Mesh;
    use moldgate::raycast::{Bvh, Ray};

    pub struct Probe<'a> {
        pub bvh: &'a Bvh,
        pub mesh: &'a Mesh,
        pub min_hit: f64,
    }

    impl Probe<'_> {
        pub fn facet(&self, t: usize) -> Option<f64> {
            let [a, b, c] = self.mesh.corners(t);
            let n = self.mesh.normal(t);
            self.sample(t as u32, (a + b + c) / 3.0, n)
        }

        fn sample(&self, t: u32, p: DVec3, n: DVec3) -> Option<f64> {
            let (dir, chord) = [-n, n]
                .into_iter()
                .find_map(|dir| self.exit(p, dir, Some(t)).map(|len| (dir, len)))?;
            let mut width = chord;
            for (k, at) in [0.5, 0.25, 0.75].into_iter().enumerate() {
                let m = p + dir * (at * chord);
                let reach = chord * at.min(1.0 - at) * (1.0 - 1e-3);
                let near = match self.bvh.nearest_within(m, reach) {
                    Some(near) if near.distance > self.min_hit => near,
                    _ if k == 0 => return Some(chord),
                    _ => continue,
                };
                let [a, b, c] = self.mesh.corners(near.triangle as usize);
                let q = nearest_on_triangle([a, b, c], m);
                let e = q - m;
                let e = (e - dir * e.dot(dir)).normalize_or_zero();
                if e == DVec3::ZERO {
                    continue;
                }
                for e in [e, dir.cross(e)] {
                    width = width.min(self.exit(m, e, None)? + self.exit(m, -e, None)?);
                }
            }
            Some(width)
        }

        fn exit(&self, p: DVec3, dir: DVec3, skip: Option<u32>) -> Option<f64> {
            let mut ray = Ray::new(p, dir).within(self.min_hit, f64::INFINITY);
            ray.skip = skip;
            let hit = self.bvh.first_hit(&ray)?;
            let leaves = |t: u32| self.mesh.normal(t as usize).dot(dir) > 0.0;
            if leaves(hit.triangle) {
                return Some(hit.distance);
            }
            let tie = self.min_hit.max(1e-6 * hit.distance);
            let mut found = false;
            self.bvh
                .for_each_hit(&ray.within(hit.distance - tie, hit.distance + tie), |h| {
                    found = leaves(h.triangle);
                    !found
                });
            found.then_some(hit.distance)
        }
    }

    fn nearest_on_triangle([a, b, c]: [DVec3; 3], p: DVec3) -> DVec3 {
        let n = (b - a).cross(c - a);
        let len2 = n.length_squared();
        if len2 > 0.0 {
            let q = p - n * ((p - a).dot(n) / len2);
            if [(a, b), (b, c), (c, a)]
                .iter()
                .all(|&(u, v)| (v - u).cross(q - u).dot(n) >= 0.0)
            {
                return q;
            }
        }
        [(a, b), (b, c), (c, a)]
            .into_iter()
            .map(|(u, v)| moldgate::math::nearest_on_segment(u, v, p))
            .min_by(|x, y| x.distance_squared(p).total_cmp(&y.distance_squared(p)))
            .unwrap_or(a)
    }
}

#[test]
fn cut_cross_rays_give_the_same_walls() {
    // Every facet the unlimited rule knows has the same wall (to f32 rounding); a facet it
    // leaves unknown because a cross ray left through a hole farther than the wall found may
    // now be known. On the samples, and the shared parts of under 60k facets when present.
    let mut parts: Vec<(String, Mesh)> = ["cover", "cap", "plate", "bracket", "tray"]
        .into_iter()
        .map(|n| (n.to_string(), samples::sample(n).unwrap()))
        .collect();
    if let Some(dir) = parts_dir() {
        let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("stl")))
            .collect();
        files.sort();
        for path in files {
            let name = path.file_stem().unwrap().to_string_lossy().to_string();
            let units = if name.contains("meters") {
                Units::M
            } else if name.contains("inches") {
                Units::In
            } else {
                Units::Mm
            };
            let bytes = std::fs::read(&path).unwrap();
            let part = mesh::read_stl(&bytes[..], bytes.len() as u64, units).unwrap();
            if part.mesh.triangles.len() < 60_000 {
                parts.push((name, part.mesh));
            }
        }
    } else {
        println!("cut_cross_rays_give_the_same_walls: shared parts not found: samples only");
    }
    for (name, mesh) in &parts {
        // The centroid of each facet, as the oracle samples it: a spacing no facet reaches
        // (one sample, and the large facets' second look of rule 7 left out).
        let w = wall_thickness(
            mesh,
            &ThicknessOptions {
                sampling: moldgate::thickness::Sampling::Spacing(1e12),
                ..ThicknessOptions::default()
            },
        );
        let bvh = Bvh::new(mesh);
        let oracle = unlimited::Probe {
            bvh: &bvh,
            mesh,
            min_hit: 1e-6 * mesh.bounds().diagonal(),
        };
        let min_area = 1e-12 * mesh.bounds().diagonal().powi(2);
        let (mut same, mut now_known) = (0, 0);
        for t in 0..mesh.triangles.len() {
            // Facets without area are unknown by rule 1, before any ray.
            let [a, b, c] = mesh.corners(t);
            let cross = (b - a).cross(c - a);
            if !(0.5 * cross.length() > min_area && cross.is_finite()) {
                continue;
            }
            let got = w.at_triangle(t);
            match (oracle.facet(t), got) {
                (Some(want), Some(got)) => {
                    assert_close!(got, want, 1e-6 * want.max(1.0), "{name}, triangle {t}");
                    same += 1;
                }
                (None, Some(_)) => now_known += 1,
                (None, None) => same += 1,
                (Some(want), None) => panic!("{name}, triangle {t}: {want} mm now unknown"),
            }
        }
        println!("{name}: {same} facets as before, {now_known} known now");
    }
}

#[test]
fn listed_facets_are_measured_once_each_whatever_the_list() {
    // The fill lists the facet of each surface cell, so a facet that owns several cells
    // comes several times, in the cells' order: the walls are those of the whole part at
    // the listed facets (NaN elsewhere), and an index past the mesh is ignored.
    use moldgate::thickness::wall_thickness_of;
    let mesh = samples::sample("cover").unwrap();
    let o = ThicknessOptions::default();
    let bvh = Bvh::new_morton(&mesh);
    let whole = moldgate::thickness::wall_thickness_with(&mesh, &bvh, &o).per_triangle;
    let n = mesh.triangles.len() as u32;
    let mut listed: Vec<u32> = (0..n).rev().step_by(3).collect();
    listed.extend((0..n).step_by(7));
    listed.extend([n, n + 5, u32::MAX]);
    listed.extend((0..n).rev().step_by(3));
    let got = wall_thickness_of(&mesh, &bvh, &o, &listed);
    assert_eq!(got.len(), mesh.triangles.len());
    for t in 0..n {
        let wanted = t % 7 == 0 || (n - 1 - t) % 3 == 0;
        let (g, w) = (got[t as usize], whole[t as usize]);
        if wanted {
            assert_eq!(
                g.to_bits(),
                w.to_bits(),
                "facet {t}: {g} listed, {w} in the whole part"
            );
        } else {
            assert!(g.is_nan(), "facet {t} was not listed but measures {g}");
        }
    }
}
