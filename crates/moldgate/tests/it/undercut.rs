//! Undercut areas and the automatic demolding direction against closed forms.

use moldgate::math::DVec3;
use moldgate::raycast::{Bvh, Sampling};
use moldgate::samples::{self, BoxUnion};
use moldgate::undercut::{
    auto_direction, principal_axes, undercut, undercut_by_rays, CandidateKind,
};
use moldgate::Direction;

fn dir(s: &str) -> Direction {
    s.parse().unwrap()
}

#[test]
fn cover_opens_along_z_without_undercut_but_not_along_x() {
    let mesh = samples::sample("cover").unwrap();
    for d in ["+z", "-z"] {
        let u = undercut(&mesh, dir(d), Sampling::Centroid);
        assert_eq!(u.area_mm2, 0.0, "{d}: {u:?}");
    }
    let x = undercut(&mesh, dir("+x"), Sampling::Centroid);
    let minus_x = undercut(&mesh, dir("-x"), Sampling::Centroid);
    assert_eq!(x, minus_x, "D and -D mould alike");
    // Along x the inner faces of the walls at x = +-58 (76 x 28 mm each) face into the part
    // and are blocked, and so are most of the ribs' and bosses' x-facing faces.
    assert!(x.area_mm2 >= 2.0 * 76.0 * 28.0, "{x:?}");
    let auto = auto_direction(&mesh, Sampling::Centroid).unwrap();
    let chosen = auto.candidate();
    // The cover is open to -z: D points to the open side.
    assert_eq!(chosen.direction, [0.0, 0.0, -1.0], "{auto:#?}");
    assert_eq!(chosen.undercut.area_mm2, 0.0);
    assert!(auto.tried.len() >= 3);
    assert!(auto.tried.iter().all(|c| c.kind == CandidateKind::Axis
        || auto.tried[..3].iter().all(|a| {
            DVec3::from_array(a.direction)
                .dot(DVec3::from_array(c.direction))
                .abs()
                < 1.0 - 1e-12
        })));
}

#[test]
fn a_box_with_a_side_pocket_has_exactly_the_pocket_as_undercut_along_z() {
    // A 40 x 40 x 20 block with a side pocket 10 deep (x from 30 to 40), 20 wide (y 10..30),
    // 6 high (z 7..13), open on the +x side. Along z, the pocket's floor (facing +z) and its
    // ceiling (facing -z) are blocked: 2 x 10 x 20 mm^2. Along x it opens freely.
    let mut part = BoxUnion::default();
    part.add([0.0, 0.0, 0.0], [40.0, 40.0, 20.0]);
    part.subtract([30.0, 10.0, 7.0], [40.0, 30.0, 13.0]);
    let mesh = part.mesh();
    let u = undercut(&mesh, dir("+z"), Sampling::Centroid);
    assert!((u.area_mm2 - 400.0).abs() < 1e-9, "{u:?}");
    // Block 6400, less the pocket's mouth (20 x 6), plus its floor, ceiling (10 x 20 each),
    // sides (10 x 6 each) and back (20 x 6).
    let total = 6400.0 - 120.0 + 400.0 + 120.0 + 120.0;
    assert!((u.share - 400.0 / total).abs() < 1e-12, "{u:?}");
    // Along y the pocket's side walls are blocked: 2 x 10 x 6.
    let u = undercut(&mesh, dir("y"), Sampling::Centroid);
    assert!((u.area_mm2 - 120.0).abs() < 1e-9, "{u:?}");
    let u = undercut(&mesh, dir("x"), Sampling::Centroid);
    assert_eq!(u.area_mm2, 0.0);
    let auto = auto_direction(&mesh, Sampling::Centroid).unwrap();
    // The material is at low x (the pocket removes some at high x): D points to +x.
    assert_eq!(auto.candidate().direction, [1.0, 0.0, 0.0], "{auto:#?}");
}

#[test]
fn partly_shadowed_facets_count_by_their_samples() {
    // A 20 x 20 x 2 plate with a 10 x 20 x 2 overhang bridge above its x < 10 half, joined
    // by a post: the plate's top under the bridge is an undercut along z. The plate's top
    // is one big face split in cells at x = 10 by the grid of box planes, so sampling
    // matters only where a facet is partly under the bridge.
    let mut part = BoxUnion::default();
    part.add([0.0, 0.0, 0.0], [20.0, 20.0, 2.0]);
    part.add([0.0, 0.0, 2.0], [2.0, 20.0, 6.0]);
    part.add([0.0, 0.0, 6.0], [10.0, 20.0, 8.0]);
    let mesh = part.mesh();
    let coarse = undercut(&mesh, dir("z"), Sampling::Centroid);
    let fine = undercut(&mesh, dir("z"), Sampling::Spacing(0.5));
    // Plate top under the bridge (x 2..10) and bridge underside (x 2..10): 2 x 8 x 20.
    assert!((coarse.area_mm2 - 320.0).abs() < 1e-9, "{coarse:?}");
    assert!((fine.area_mm2 - 320.0).abs() < 1e-9, "{fine:?}");
}

#[test]
fn plate_opens_along_its_thickness() {
    // Every axis line of the plate has its hole's walls as undercut except z; z also has
    // the smallest extent.
    let mesh = samples::sample("plate").unwrap();
    let auto = auto_direction(&mesh, Sampling::Centroid).unwrap();
    let c = auto.candidate();
    assert_eq!(c.undercut.area_mm2, 0.0);
    assert!(
        DVec3::from_array(c.direction).dot(DVec3::Z).abs() > 1.0 - 1e-12,
        "{auto:#?}"
    );
    let x = &auto.tried[0];
    assert!(x.undercut.area_mm2 > 0.0, "hole walls facing x: {x:?}");
}

#[test]
fn principal_axes_of_a_rotated_slab() {
    // A 40 x 10 x 2 slab rotated by 30 degrees about z: its principal axes are the rotated
    // x (largest spread), the rotated y, then z.
    let mut part = BoxUnion::default();
    part.add([-20.0, -5.0, -1.0], [20.0, 5.0, 1.0]);
    let mut mesh = part.mesh();
    let (s, c) = 30f64.to_radians().sin_cos();
    for v in &mut mesh.vertices {
        *v = DVec3::new(c * v.x - s * v.y, s * v.x + c * v.y, v.z);
    }
    let axes = principal_axes(&mesh);
    assert_eq!(axes.len(), 3);
    assert!(
        (axes[0] - DVec3::new(c, s, 0.0)).length() < 1e-9,
        "{axes:?}"
    );
    assert!(
        axes[1].dot(DVec3::new(-s, c, 0.0)).abs() > 1.0 - 1e-9,
        "{axes:?}"
    );
    assert!((axes[2] - DVec3::Z).length() < 1e-9, "{axes:?}");
    let auto = auto_direction(&mesh, Sampling::Centroid).unwrap();
    // z (an axis) and the third principal axis coincide: tried once.
    assert_eq!(auto.tried.len(), 5, "{auto:#?}");
    assert!(
        DVec3::from_array(auto.candidate().direction)
            .dot(DVec3::Z)
            .abs()
            > 1.0 - 1e-12
    );
}

#[test]
fn nothing_to_evaluate_is_an_error() {
    let mesh = moldgate::Mesh::default();
    assert!(auto_direction(&mesh, Sampling::Centroid).is_err());
}

#[test]
fn the_undercut_sum_is_the_same_on_any_number_of_threads() {
    // The cover's x line has thousands of blocked facets spread over several sum blocks.
    let mesh = samples::sample("cover").unwrap().subdivided().subdivided();
    let runs: Vec<(f64, f64)> = [1, 2, 3, 8]
        .iter()
        .map(|&threads| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let u = pool.install(|| undercut(&mesh, dir("+x"), Sampling::Centroid));
            (u.area_mm2, u.share)
        })
        .collect();
    assert!(runs[0].0 > 0.0);
    for r in &runs {
        assert_eq!(r.0.to_bits(), runs[0].0.to_bits(), "{runs:?}");
        assert_eq!(r.1.to_bits(), runs[0].1.to_bits(), "{runs:?}");
    }
}

#[test]
fn near_ties_go_to_the_shallowest_draw() {
    // A 30 x 30 x 4 plate with a 2 x 2 x 1 notch cut into the middle of its +x side, near the
    // top: along z the notch's floor and ceiling are blocked (8 mm^2), along x nothing. The
    // 8 mm^2 are 0.36 % of the 2224 mm^2 surface: a tie, and the 4 mm draw along z beats the
    // 30 mm one along x.
    let mut part = BoxUnion::default();
    part.add([0.0, 0.0, 0.0], [30.0, 30.0, 4.0]);
    part.subtract([28.0, 14.0, 1.5], [30.0, 16.0, 2.5]);
    let mesh = part.mesh();
    let z = undercut(&mesh, dir("z"), Sampling::Centroid);
    assert!((z.area_mm2 - 8.0).abs() < 1e-9, "{z:?}");
    assert_eq!(undercut(&mesh, dir("x"), Sampling::Centroid).area_mm2, 0.0);
    let auto = auto_direction(&mesh, Sampling::Centroid).unwrap();
    let c = auto.candidate();
    assert!(z.share < moldgate::undercut::TIE_SHARE, "{z:?}");
    assert!(
        DVec3::from_array(c.direction).dot(DVec3::Z).abs() > 1.0 - 1e-12,
        "{auto:#?}"
    );
    assert!((c.undercut.area_mm2 - 8.0).abs() < 1e-9);
}

#[test]
fn lines_tied_in_undercut_and_draw_go_to_one_where_a_gate_qualifies() {
    // A 20 mm cube: every line is free of undercut and 20 mm deep. Without a gate check the
    // first line tried (x) wins; a check that accepts only z picks z, and asks only about the
    // tied lines, in order, until one qualifies.
    let mut part = BoxUnion::default();
    part.add([0.0, 0.0, 0.0], [20.0, 20.0, 20.0]);
    let mesh = part.mesh();
    let plain = auto_direction(&mesh, Sampling::Centroid).unwrap();
    assert_eq!(plain.candidate().direction, [1.0, 0.0, 0.0]);
    let mut asked = Vec::new();
    let checked = moldgate::undercut::auto_direction_checked(&mesh, Sampling::Centroid, |d| {
        asked.push(d.vector().to_array());
        d.vector().z.abs() == 1.0
    })
    .unwrap();
    assert_eq!(
        checked.candidate().direction,
        [0.0, 0.0, 1.0],
        "{checked:#?}"
    );
    assert_eq!(asked, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    assert_eq!(checked.candidate().gate_qualifies, Some(true));
    assert_eq!(checked.tried[0].gate_qualifies, Some(false));
}

#[test]
fn drawn_rays_agree_with_traced_rays_on_every_sample() {
    // The same rule answered two ways: by drawing triangles into the parallel rays
    // (`undercut`) and by tracing each ray through a tree (`undercut_by_rays`). They may
    // differ only at rays that graze an edge or a vertex (the tree counts a graze within its
    // f32 tolerance, the drawing gives an edge to one triangle, and on an outline edge to
    // both or neither), so by a sliver of the area. The tilted lines are chosen not to graze
    // the samples' edges exactly: along 0.3,-0.5,1 a row of the cover's ceiling facets
    // (centroids at thirds of a millimetre) sends its rays exactly through a rib's lower
    // edge, which the tree counts as blocked and the drawing does not (1.6 % of the area).
    let lines = ["+x", "+y", "+z", "0.31,-0.53,1", "1,1.1,1.2"];
    for info in samples::SAMPLES {
        let name = info.name;
        let mesh = samples::sample(name).unwrap();
        let area: f64 = (0..mesh.triangles.len())
            .map(|t| {
                let [a, b, c] = mesh.corners(t);
                0.5 * (b - a).cross(c - a).length()
            })
            .sum();
        let bvh = Bvh::new(&mesh);
        for line in lines {
            for sampling in [Sampling::Centroid, Sampling::Spacing(2.0)] {
                let drawn = undercut(&mesh, dir(line), sampling);
                let traced = undercut_by_rays(&mesh, &bvh, dir(line), sampling);
                assert!(
                    (drawn.area_mm2 - traced.area_mm2).abs() <= 1e-3 * area,
                    "{name} along {line}, {sampling:?}: drawn {drawn:?}, traced {traced:?}"
                );
            }
        }
    }
}

/// `mesh` with every triangle split `times` times into four at its edges' midpoints (the
/// midpoints are not welded: the rays of the undercut rule read triangles, not their
/// neighbours), so that the choice's bounds leave lines out.
fn subdivided(mesh: &moldgate::mesh::Mesh, times: u32) -> moldgate::mesh::Mesh {
    let mut corners: Vec<[DVec3; 3]> = (0..mesh.triangles.len()).map(|t| mesh.corners(t)).collect();
    for _ in 0..times {
        corners = corners
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = ((a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5);
                [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
            })
            .collect();
    }
    moldgate::mesh::Mesh {
        vertices: corners.iter().flatten().copied().collect(),
        triangles: (0..corners.len() as u32)
            .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
            .collect(),
    }
}

#[test]
fn the_work_beside_the_rays_runs_once_and_changes_nothing() {
    // The block with a side pocket, finely split: more facets than the bounds draw, so
    // lines are drawn ray by ray after their bounds, and `beside` runs once, beside the
    // first of them, along the likeliest choice. Its facets are all alike in area, so the
    // bounds are loose: the likeliest choice is the shallow z, whose bound may tie with the
    // free x, and x is chosen.
    let mut part = BoxUnion::default();
    part.add([0.0, 0.0, 0.0], [40.0, 40.0, 20.0]);
    part.subtract([30.0, 10.0, 7.0], [40.0, 30.0, 13.0]);
    let mesh = subdivided(&part.mesh(), 4);
    assert!(mesh.triangles.len() > 8192, "{}", mesh.triangles.len());
    let plain = auto_direction(&mesh, Sampling::Centroid).unwrap();
    assert_eq!(plain.candidate().direction, [1.0, 0.0, 0.0], "{plain:#?}");
    let calls = std::sync::Mutex::new(Vec::new());
    let (auto, early) = moldgate::undercut::auto_direction_beside(
        &mesh,
        Sampling::Centroid,
        |d| {
            calls.lock().unwrap().push(d);
            d.vector().to_array()
        },
        |_, _| true,
    )
    .unwrap();
    assert_eq!(auto, plain);
    let (along, done) = early.unwrap();
    assert_eq!(*calls.lock().unwrap(), [along]);
    assert_eq!(done, along.vector().to_array());
    assert_eq!(along.vector().z.abs(), 1.0, "{along:?}");
}

#[test]
fn a_tie_break_reads_the_work_beside_the_rays_for_its_line_only() {
    // A finely split 40 x 30 x 10 box: every axis free of undercut, so every line is drawn
    // and the shallowest draw (z) wins without a gate check; `beside` ran along z, the
    // likeliest choice, beside the rays of x. A cube asks the check about the axes in order
    // until one qualifies, and only the question about the line `beside` ran along (x, the
    // first of equal draws) comes with its work.
    let mut part = BoxUnion::default();
    part.add([0.0, 0.0, 0.0], [40.0, 30.0, 10.0]);
    let mesh = subdivided(&part.mesh(), 6);
    assert!(mesh.triangles.len() > 8192, "{}", mesh.triangles.len());
    let (auto, early) = moldgate::undercut::auto_direction_beside(
        &mesh,
        Sampling::Centroid,
        |d| d.vector().x,
        |_, _| panic!("the extents break the tie"),
    )
    .unwrap();
    assert_eq!(auto.candidate().direction[2].abs(), 1.0, "{auto:#?}");
    let (along, x) = early.unwrap();
    assert_eq!(along, auto.direction());
    assert_eq!(x, along.vector().x);

    let mut part = BoxUnion::default();
    part.add([0.0, 0.0, 0.0], [20.0, 20.0, 20.0]);
    let mesh = subdivided(&part.mesh(), 6);
    let mut asked = Vec::new();
    let (auto, early) = moldgate::undercut::auto_direction_beside(
        &mesh,
        Sampling::Centroid,
        |d| d.vector().to_array(),
        |d, done| {
            asked.push((d.vector().to_array(), done.copied()));
            d.vector().z.abs() == 1.0
        },
    )
    .unwrap();
    let checked = moldgate::undercut::auto_direction_checked(&mesh, Sampling::Centroid, |d| {
        d.vector().z.abs() == 1.0
    })
    .unwrap();
    assert_eq!(auto, checked);
    assert_eq!(auto.candidate().direction[2].abs(), 1.0, "{auto:#?}");
    let (along, _) = early.unwrap();
    assert_eq!(along.vector().x.abs(), 1.0, "{along:?}");
    assert_eq!(asked.len(), 3, "{asked:?}");
    for (d, done) in &asked {
        let is_along = *d == along.vector().to_array();
        assert_eq!(done.is_some(), is_along, "{d:?}");
        if let Some(done) = done {
            assert_eq!(done, d);
        }
    }
}

#[test]
fn demold_auto_of_a_loaded_part_is_that_of_its_mesh() {
    // The loaded part's centres, summed at load, stand for `Centres::of` its mesh: the
    // same choice, the same bounds and the same work beside, to the bit.
    let mut meshes: Vec<_> = samples::SAMPLES
        .iter()
        .map(|info| samples::sample(info.name).unwrap())
        .collect();
    // Finer than the bounds' least count of facets, so lines stop at a bound.
    meshes.push(samples::sample("cover").unwrap().subdivided().subdivided());
    for mesh in meshes {
        let part = moldgate::mesh::from_generated(mesh);
        let beside = |d: moldgate::Direction| d.vector().to_array();
        let of_mesh = moldgate::undercut::auto_direction_beside(
            &part.mesh,
            Sampling::Centroid,
            beside,
            |_, _| true,
        )
        .unwrap();
        let of_part = moldgate::undercut::auto_direction_beside_loaded(
            &part,
            Sampling::Centroid,
            beside,
            |_, _| true,
        )
        .unwrap();
        assert_eq!(of_part.0, of_mesh.0);
        assert_eq!(
            of_part.1.map(|(d, t)| (d.vector().to_array(), t)),
            of_mesh.1.map(|(d, t)| (d.vector().to_array(), t))
        );
    }
}

/// A stopped study's choice of the direction stops drawing at its next batch of tests and
/// says it was stopped, not that the budget was passed; not stopped, the same part chooses.
#[test]
fn a_stopped_choice_of_the_direction_says_so() {
    let part = moldgate::mesh::from_generated(samples::sample("cover").unwrap());
    let choose = |cancel: Option<&moldgate::cancel::Cancel>| {
        moldgate::undercut::auto_direction_beside_loaded_until(
            &part,
            Sampling::Centroid,
            |_| (),
            |_, _| true,
            cancel,
        )
    };
    assert!(choose(None).is_ok());
    let token = moldgate::cancel::Cancel::new();
    assert!(choose(Some(&token)).is_ok());
    token.cancel();
    assert!(matches!(
        choose(Some(&token)),
        Err(moldgate::undercut::DemoldError::Cancelled)
    ));
}
