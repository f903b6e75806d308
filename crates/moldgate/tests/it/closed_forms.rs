//! The method against answers known in closed form: centroids of boxes and cylinders, the
//! wall thickness of a slab, the candidate count of a box face, and gates that must move
//! out of a hole or fail the thickness rule.

use moldgate::gate::quadrature::Spacing;
use moldgate::gate::ThicknessRule;
use moldgate::math::{DVec2, DVec3};
use moldgate::mesh::{from_generated, LoadedMesh};
use moldgate::samples::BoxUnion;
use moldgate::{locate, Centres, LocateOptions, Mesh};

fn solid(boxes: &[([f64; 3], [f64; 3], bool)]) -> LoadedMesh {
    let mut part = BoxUnion::default();
    for &(lo, hi, add) in boxes {
        if add {
            part.add(lo, hi);
        } else {
            part.subtract(lo, hi);
        }
    }
    from_generated(part.mesh())
}

/// A closed cylinder about the z axis with `n` sides: fans on both ends.
fn cylinder(radius: f64, z0: f64, z1: f64, n: usize) -> Mesh {
    let mut vertices = vec![DVec3::new(0.0, 0.0, z0), DVec3::new(0.0, 0.0, z1)];
    for i in 0..n {
        let a = std::f64::consts::TAU * i as f64 / n as f64;
        let (x, y) = (radius * a.cos(), radius * a.sin());
        vertices.push(DVec3::new(x, y, z0));
        vertices.push(DVec3::new(x, y, z1));
    }
    let mut triangles = Vec::new();
    for i in 0..n as u32 {
        let j = (i + 1) % n as u32;
        let (b0, t0, b1, t1) = (2 + 2 * i, 3 + 2 * i, 2 + 2 * j, 3 + 2 * j);
        triangles.push([0, b1, b0]);
        triangles.push([1, t0, t1]);
        triangles.push([b0, b1, t1]);
        triangles.push([b0, t1, t0]);
    }
    Mesh {
        vertices,
        triangles,
    }
}

fn close(a: DVec3, b: DVec3, tol: f64) -> bool {
    (a - b).abs().max_element() <= tol
}

#[test]
fn box_centroids_are_its_centre() {
    let part = solid(&[([10.0, -5.0, 0.0], [110.0, 55.0, 20.0], true)]);
    let c = Centres::of(&part.mesh);
    let centre = DVec3::new(60.0, 25.0, 10.0);
    assert!(close(c.surface, centre, 1e-9), "{:?}", c.surface);
    assert!(close(c.volume.unwrap(), centre, 1e-9));
    assert!((c.volume_mm3 - 100.0 * 60.0 * 20.0).abs() < 1e-6);
    assert!((c.area_mm2 - 2.0 * (100.0 * 60.0 + 100.0 * 20.0 + 60.0 * 20.0)).abs() < 1e-6);
}

#[test]
fn cylinder_centroids_are_on_its_axis_at_mid_height() {
    let n = 64;
    let c = Centres::of(&cylinder(30.0, 2.0, 12.0, n));
    assert!(
        close(c.surface, DVec3::new(0.0, 0.0, 7.0), 1e-9),
        "{:?}",
        c.surface
    );
    assert!(close(c.volume.unwrap(), DVec3::new(0.0, 0.0, 7.0), 1e-9));
    let polygon = 0.5 * n as f64 * 900.0 * (std::f64::consts::TAU / n as f64).sin();
    assert!((c.volume_mm3 - polygon * 10.0).abs() < 1e-6);
}

#[test]
fn surface_and_volume_centres_differ_on_an_l_block_as_computed_by_hand() {
    // Base 60 x 40 x 10 plus a block 30 x 40 x 20 on its left half (a step).
    let part = solid(&[
        ([0.0, 0.0, 0.0], [60.0, 40.0, 10.0], true),
        ([0.0, 0.0, 10.0], [30.0, 40.0, 30.0], true),
    ]);
    let c = Centres::of(&part.mesh);
    // Volume: boxes of 24000 mm^3 at x = 30 and 24000 mm^3 at x = 15.
    let volume = c.volume.unwrap();
    assert!((volume.x - 22.5).abs() < 1e-9 && (volume.z - 12.5).abs() < 1e-9);
    // Surface, face by face (area, centroid x, centroid z):
    let faces = [
        (60.0 * 40.0, 30.0, 0.0),        // bottom
        (30.0 * 40.0, 45.0, 10.0),       // lower top, right half
        (30.0 * 40.0, 15.0, 30.0),       // upper top
        (30.0 * 40.0, 0.0, 15.0),        // left wall, 30 high
        (10.0 * 40.0, 60.0, 5.0),        // right wall of the base
        (20.0 * 40.0, 30.0, 20.0),       // step wall
        (2.0 * 60.0 * 10.0, 30.0, 5.0),  // front and back of the base
        (2.0 * 30.0 * 20.0, 15.0, 20.0), // front and back of the block
    ];
    let area: f64 = faces.iter().map(|f| f.0).sum();
    let x = faces.iter().map(|f| f.0 * f.1).sum::<f64>() / area;
    let z = faces.iter().map(|f| f.0 * f.2).sum::<f64>() / area;
    assert!((c.surface.x - x).abs() < 1e-9, "{} vs {x}", c.surface.x);
    assert!((c.surface.z - z).abs() < 1e-9, "{} vs {z}", c.surface.z);
    assert!((c.surface.y - 20.0).abs() < 1e-9);
}

#[test]
fn box_face_of_100_by_60_gives_97_by_57_candidates() {
    // PP's R = 1.4254 mm and a 1 mm grid: |x| <= 50 - R and |y| <= 30 - R on integers.
    let part = solid(&[([-50.0, -30.0, 0.0], [50.0, 30.0, 20.0], true)]);
    let options = LocateOptions {
        spacing: Spacing::Mm(1.0),
        ..LocateOptions::default()
    };
    let analysis = locate(&part, &options).unwrap();
    assert_eq!((analysis.grid.n_u, analysis.grid.n_w), (101, 61));
    assert_eq!(analysis.counts.circle_on_part, 97 * 57);
    assert_eq!(analysis.counts.qualifying, 97 * 57);
    let gate = analysis.grid_gate.unwrap();
    assert!(close(gate.point, DVec3::new(0.0, 0.0, 20.0), 1e-12));
    assert!(close(gate.normal, DVec3::Z, 1e-12));
    assert_eq!(gate.thickness_mm, Some(20.0));
    assert!((gate.distance_3d - 10.0).abs() < 1e-12);
}

#[test]
fn slab_thickness_along_a_tilted_direction_is_t_over_cos() {
    let part = solid(&[([-50.0, -30.0, 0.0], [50.0, 30.0, 3.0], true)]);
    for d in [
        DVec3::Z,
        DVec3::new(0.0, 0.3, 1.0),
        DVec3::new(0.2, -0.1, 1.0),
    ] {
        let options = LocateOptions {
            direction: moldgate::Direction::new(d).unwrap(),
            ..LocateOptions::default()
        };
        let analysis = locate(&part, &options).unwrap();
        let gate = analysis.grid_gate.unwrap();
        let expected = 3.0 * d.length() / d.z;
        let thickness = gate.thickness_mm.unwrap();
        assert!(
            (thickness - expected).abs() < 1e-9,
            "{d}: {thickness} vs {expected}"
        );
        // The circle points' hits are kept in f32 (relative to a vertex's height): on a part
        // 3 mm deep that is good to a few 1e-7 mm.
        let disc = gate.disc_thickness_mm.unwrap();
        assert!(
            (disc - expected).abs() < 1e-6,
            "{d}: disc {disc} vs {expected}"
        );
        assert!((gate.point.z - 3.0).abs() < 1e-9, "gate on the top face");
    }
}

#[test]
fn the_thickness_rule_refuses_walls_thinner_than_the_gate_radius() {
    // A 1 mm plate is thinner than PP's 1.4254 mm gate radius.
    let part = solid(&[([-20.0, -20.0, 0.0], [20.0, 20.0, 1.0], true)]);
    let strict = locate(&part, &LocateOptions::default()).unwrap();
    assert!(strict.counts.circle_on_part > 0);
    assert_eq!(strict.counts.thicker_than_radius, 0);
    assert!(strict.grid_gate.is_none());
    let err = strict.gate().unwrap_err().to_string();
    assert!(err.contains("thicker than"), "{err}");
    let relaxed = locate(
        &part,
        &LocateOptions {
            thickness_rule: ThicknessRule::Ignore,
            ..LocateOptions::default()
        },
    )
    .unwrap();
    assert!(relaxed.grid_gate.is_some());
}

#[test]
fn the_gate_leaves_a_hole_at_the_centre_by_at_least_its_radius() {
    // Plate 80 x 50 x 10 with a 20 x 20 through hole at its centre, where the centre of
    // mass lies.
    let part = solid(&[
        ([-40.0, -25.0, 0.0], [40.0, 25.0, 10.0], true),
        ([-10.0, -10.0, 0.0], [10.0, 10.0, 10.0], false),
    ]);
    let options = LocateOptions::default();
    let r = options.gate_radius_mm;
    let analysis = locate(&part, &options).unwrap();
    let on_part = |p: DVec2| {
        p.x.abs() <= 40.0 && p.y.abs() <= 25.0 && (p.x.abs() >= 10.0 || p.y.abs() >= 10.0)
    };
    // The expected gate, found analytically: the node nearest the centre whose circle
    // points all lie on the plate (none exactly on an edge for this grid).
    let mut best: Option<(f64, usize)> = None;
    for i in 0..analysis.grid.len() {
        let q = analysis.grid.node(i);
        let all_on = on_part(q)
            && (0..16).all(|k| {
                let a = std::f64::consts::TAU * k as f64 / 16.0;
                on_part(q + r * DVec2::new(a.cos(), a.sin()))
            });
        if all_on {
            let d = DVec3::new(q.x, q.y, 10.0).distance(analysis.centre);
            if best.is_none_or(|(bd, _)| d < bd - 1e-9) {
                best = Some((d, i));
            }
        }
    }
    let (distance, node) = best.unwrap();
    let gate = analysis.grid_gate.unwrap();
    assert_eq!(gate.node, node);
    assert!((gate.distance_3d - distance).abs() < 1e-9);
    let uw = gate.node_uw;
    assert!(uw.x.abs() >= 10.0 + r || uw.y.abs() >= 10.0 + r, "{uw}");
}

#[test]
fn a_part_smaller_than_the_gate_has_no_candidate_and_says_why() {
    let part = solid(&[([0.0, 0.0, 0.0], [2.0, 2.0, 2.0], true)]);
    let analysis = locate(&part, &LocateOptions::default()).unwrap();
    assert_eq!(analysis.counts.circle_on_part, 0);
    assert!(analysis.counts.centre_hits > 0);
    let err = analysis.gate().unwrap_err().to_string();
    assert!(err.contains("whole circle"), "{err}");
}
