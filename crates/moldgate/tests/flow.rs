//! The fill analysis against closed forms: a plate's flow length is its half diagonal, the
//! melt goes around a hole, an open box fills over its walls, the balanced gate equals the
//! brute-force best candidate, and several gates share the part.

use moldgate::flow::{self, balanced_gate, march, several_gates, Domain, Objective, Source};
use moldgate::math::DVec3;
use moldgate::samples::BoxUnion;
use moldgate::{Material, Mesh};

fn boxes(list: &[([f64; 3], [f64; 3], bool)]) -> Mesh {
    let mut part = BoxUnion::default();
    for &(lo, hi, add) in list {
        if add {
            part.add(lo, hi);
        } else {
            part.subtract(lo, hi);
        }
    }
    part.mesh()
}

fn pp() -> Material {
    Material::builtin("PP").unwrap()
}

#[test]
fn plate_gated_at_its_centre_reaches_its_corners_at_the_half_diagonal() {
    let plate = boxes(&[([-50.0, -30.0, 0.0], [50.0, 30.0, 3.0], true)]);
    let gate = DVec3::new(0.0, 0.0, 3.0);
    // The farthest point of the solid is a bottom corner, reached in a straight line.
    let exact = (50.0f64 * 50.0 + 30.0 * 30.0 + 3.0 * 3.0).sqrt();
    let mut errors = Vec::new();
    for h in [1.0, 0.5, 0.25] {
        let domain = Domain::new(&plate, h, None, 3.0, &pp());
        let (fill, _) = flow::fill_from(&domain, gate, &pp()).unwrap();
        let err = (fill.l_max_mm - exact).abs();
        println!(
            "h {h}: L_max {:.3} (exact {exact:.3}), error {err:.3}",
            fill.l_max_mm
        );
        errors.push(err);
    }
    assert!(errors[2] < errors[0], "{errors:?}");
    assert!(errors[2] / exact < 0.01, "{errors:?}");
}

/// Flow length at the cell nearest `p`.
fn length_at(domain: &Domain, field: &flow::Field, p: DVec3) -> f64 {
    field.t[domain.voxels.cell_near(p).unwrap() as usize]
}

#[test]
fn melt_goes_around_a_hole_and_its_fronts_meet_behind_it() {
    // The plate sample: 100 x 60 x 3 with a hole of radius 8 at (20, 0).
    let plate = moldgate::samples::sample("plate").unwrap();
    let gate = DVec3::new(4.0, 0.0, 3.0);
    let behind = DVec3::new(36.0, 0.0, 3.0);
    // In the plane: two tangents of sqrt(16^2 - 8^2) and an arc of 60 degrees.
    let around = 2.0 * (16.0f64 * 16.0 - 64.0).sqrt() + 8.0 * std::f64::consts::PI / 3.0;
    let domain = Domain::new(&plate, 0.5, None, 3.0, &pp());
    let (fill, fields) = flow::fill_from(&domain, gate, &pp()).unwrap();
    let l = length_at(&domain, &fields.length, behind);
    println!("behind the hole: {l:.3} mm, around it {around:.3}, straight 32");
    assert!((l - around).abs() / around < 0.03, "{l} vs {around}");
    // A weld line where the two fronts meet, behind the hole on its axis.
    let weld = fill
        .weld_lines
        .iter()
        .find(|w| w.point[0] > 28.0 && w.point[1].abs() < 2.0);
    assert!(weld.is_some(), "{:?}", fill.weld_lines);
    assert!(weld.unwrap().meeting_angle_deg > 120.0);
}

#[test]
fn open_box_gated_at_the_top_fills_its_rim_over_the_walls() {
    // 100 x 60 x 30 outside, walls and top 2 mm, open at z = 0.
    let cover = boxes(&[
        ([-50.0, -30.0, 0.0], [50.0, 30.0, 30.0], true),
        ([-48.0, -28.0, 0.0], [48.0, 28.0, 28.0], false),
    ]);
    let domain = Domain::new(&cover, 0.5, None, 2.0, &pp());
    let (_, fields) = flow::fill_from(&domain, DVec3::new(0.0, 0.0, 30.0), &pp()).unwrap();
    let rim = DVec3::new(49.0, 0.0, 0.0);
    // Shortest path in the section: to the inner corner (48, 28), then down to the rim.
    let exact = (48.0f64 * 48.0 + 2.0 * 2.0).sqrt() + (1.0f64 + 28.0 * 28.0).sqrt();
    let l = length_at(&domain, &fields.length, rim);
    println!(
        "rim: {l:.3} mm, exact {exact:.3}, through the air {:.3}",
        (49.0f64 * 49.0 + 900.0).sqrt()
    );
    assert!((l - exact).abs() / exact < 0.03, "{l} vs {exact}");
}

/// The worst arrival value of every candidate, each by its own run (seeded at its cell's
/// centre, as the search does).
fn brute_force(domain: &Domain, candidates: &[Source], objective: Objective) -> Vec<f64> {
    candidates
        .iter()
        .map(|c| {
            let centred = Source {
                point: domain.voxels.centre(c.cell),
                cell: c.cell,
            };
            flow::argmax(&march(&domain.voxels, &[centred], domain.cost(objective)).t).1
        })
        .collect()
}

/// The located part's qualifying points as sources, on a coarse grid.
fn candidates(mesh: &Mesh, domain: &Domain, demold: &str, spacing: f64) -> (Vec<Source>, Source) {
    let part = moldgate::mesh::from_generated(mesh.clone());
    let options = moldgate::LocateOptions {
        direction: demold.parse().unwrap(),
        spacing: moldgate::gate::Spacing::Mm(spacing),
        ..Default::default()
    };
    let analysis = moldgate::locate(&part, &options).unwrap();
    let sources: Vec<Source> = analysis
        .qualifying_points
        .iter()
        .filter_map(|&p| domain.source(p))
        .collect();
    let first = domain.source(analysis.gate().unwrap().point()).unwrap();
    (sources, first)
}

#[test]
fn balanced_gate_equals_brute_force_on_the_samples() {
    for (name, demold) in [
        ("plate", "+z"),
        ("bracket", "+z"),
        ("cover", "+z"),
        ("tray", "+z"),
        ("cap", "+z"),
    ] {
        let mesh = moldgate::samples::sample(name).unwrap();
        let h = 1.5;
        let domain = Domain::new(&mesh, h, None, 2.0, &pp());
        let (cands, first) = candidates(&mesh, &domain, demold, 6.0);
        for objective in [Objective::Length, Objective::Resistance] {
            let fast = balanced_gate(&domain, &cands, objective, first, 0.5 * h).unwrap();
            let all = brute_force(&domain, &cands, objective);
            let best = all.iter().copied().fold(f64::INFINITY, f64::min);
            println!(
                "{name} {objective:?}: balanced {:.3} in {} runs, brute force {best:.3} over {} candidates",
                fast.value,
                fast.runs,
                cands.len()
            );
            assert!(fast.proven);
            // The chosen candidate is the best to within half a cell (the march is symmetric
            // only to that tolerance).
            assert!(
                all[fast.candidate] <= best + 0.5 * h,
                "{name}: {} vs {best}",
                all[fast.candidate]
            );
            assert!(fast.runs < cands.len());
        }
    }
}

/// A bar 200 x 10 x 3 along x, made of two boxes so no face crosses x = 0.
fn bar() -> Mesh {
    boxes(&[
        ([-100.0, -5.0, 0.0], [0.0, 5.0, 3.0], true),
        ([0.0, -5.0, 0.0], [100.0, 5.0, 3.0], true),
    ])
}

#[test]
fn resistance_moves_the_balanced_gate_towards_the_thin_half_as_in_one_dimension() {
    let bar = bar();
    // The half x > 0 is a wall half as thick; a Newtonian melt (n = 1) pays (3 / 1.5)^2 = 4
    // per mm there. In one dimension the worst values from a gate at x in the thin half are
    // 100 + 4 x (to the left end) and 4 (100 - x) (to the right end): equal at x = 37.5,
    // with value 250.
    let walls: Vec<f32> = (0..bar.triangles.len())
        .map(|t| {
            let [a, b, c] = bar.corners(t);
            if (a.x + b.x + c.x) / 3.0 > 0.0 {
                1.5
            } else {
                3.0
            }
        })
        .collect();
    let newtonian = Material { n: 1.0, ..pp() };
    let h = 0.75;
    let domain = Domain::new(&bar, h, Some(&walls), 3.0, &newtonian);
    let (cands, first) = candidates(&bar, &domain, "+z", 1.0);
    let by_length = balanced_gate(&domain, &cands, Objective::Length, first, 0.5 * h).unwrap();
    let by_resistance =
        balanced_gate(&domain, &cands, Objective::Resistance, first, 0.5 * h).unwrap();
    let xl = cands[by_length.candidate].point.x;
    let xr = cands[by_resistance.candidate].point.x;
    println!(
        "length gate x {xl:.2} ({:.2}), resistance gate x {xr:.2} ({:.2})",
        by_length.value, by_resistance.value
    );
    assert!(xl.abs() < 2.0, "{xl}");
    assert!((xr - 37.5).abs() < 2.0, "{xr}");
    assert!(
        (by_resistance.value - 250.0).abs() / 250.0 < 0.03,
        "{}",
        by_resistance.value
    );
}

#[test]
fn pressure_is_eq_1_along_the_worst_path_of_a_uniform_plate() {
    let plate = boxes(&[([-50.0, -30.0, 0.0], [50.0, 30.0, 3.0], true)]);
    let domain = Domain::new(&plate, 0.5, None, 3.0, &pp());
    let (fill, _) = flow::fill_from(&domain, DVec3::new(0.0, 0.0, 3.0), &pp()).unwrap();
    // Table 1, PP: mu 9.88 Pa s; Eq. 7: v = sqrt(5 (230 - 50) 0.15 / (3 9.88)) m/s.
    let v = (5.0f64 * 180.0 * 0.15 / (3.0 * 9.88)).sqrt();
    let expected = 12.0 * 9.88 * (fill.l_max_mm * 1e-3) * v / (3e-3f64).powi(2) / 1e6;
    println!(
        "pressure {:.4} MPa, by hand {expected:.4}",
        fill.pressure_mpa
    );
    assert!((fill.pressure_mpa - expected).abs() / expected < 1e-3);
    // L/t against PP's 250.
    assert!((fill.flow_ratio - fill.l_max_mm / 3.0).abs() < 1e-9);
    assert_eq!(fill.flow_ratio_limit, Some(250.0));
    assert!(!fill.exceeds_flow_ratio);
}

#[test]
fn two_gates_on_a_bar_sit_near_its_quarter_points_and_share_it_evenly() {
    let bar = bar();
    let h = 0.75;
    let domain = Domain::new(&bar, h, None, 3.0, &pp());
    let (cands, first) = candidates(&bar, &domain, "+z", 2.0);
    let start = balanced_gate(&domain, &cands, Objective::Length, first, 0.5 * h).unwrap();
    let two = several_gates(&domain, &cands, Objective::Length, start.candidate, 2).unwrap();
    let mut xs: Vec<f64> = two.gates.iter().map(|g| g.point[0]).collect();
    xs.sort_by(f64::total_cmp);
    println!(
        "gates at x {xs:?}, L_max {:.2}, balance {:.3}",
        two.l_max_mm, two.balance
    );
    assert!(
        (xs[0] + 50.0).abs() < 4.0 && (xs[1] - 50.0).abs() < 4.0,
        "{xs:?}"
    );
    // Half of a 100 x 10 x 3 piece from the middle of its top: about sqrt(50^2 + 5^2 + 3^2).
    assert!(two.l_max_mm < 55.0, "{}", two.l_max_mm);
    assert!(two.balance > 0.9, "{}", two.balance);
    // More gates than candidates is refused.
    assert!(several_gates(&domain, &cands[..3], Objective::Length, 0, 4).is_none());
}

#[test]
fn a_gate_fills_only_its_own_body_and_says_so() {
    // Two plates 10 mm apart: separate bodies.
    let two = boxes(&[
        ([0.0, 0.0, 0.0], [40.0, 20.0, 3.0], true),
        ([50.0, 0.0, 0.0], [90.0, 20.0, 3.0], true),
    ]);
    let domain = Domain::new(&two, 0.5, None, 3.0, &pp());
    assert_eq!(domain.bodies, 2);
    let (fill, fields) = flow::fill_from(&domain, DVec3::new(20.0, 10.0, 3.0), &pp()).unwrap();
    // Half the cells, none of the other plate.
    assert!(
        (fill.reached_share - 0.5).abs() < 0.02,
        "{}",
        fill.reached_share
    );
    assert!(length_at(&domain, &fields.length, DVec3::new(70.0, 10.0, 1.5)).is_infinite());
    // The farthest point is a corner of the gate's own plate.
    assert!(fill.farthest[0] < 41.0, "{:?}", fill.farthest);
    // The whole analysis warns and names the body.
    let part = moldgate::mesh::from_generated(two.clone());
    let analysis = moldgate::locate(&part, &moldgate::LocateOptions::default()).unwrap();
    let f = flow::analyse(
        &two,
        &analysis,
        &pp(),
        flow::Walls::Estimate,
        &flow::FillOptions::default(),
    )
    .unwrap();
    assert_eq!(f.bodies, 2);
    assert!(
        f.warnings.iter().any(|w| w.contains("2 separate bodies")),
        "{:?}",
        f.warnings
    );
    assert!(
        f.warnings.iter().any(|w| w.contains("feeds body")),
        "{:?}",
        f.warnings
    );
}
