//! Gates the designer places (`gate_at`) against closed forms: the snap onto a box's top
//! face by the known distance, the rules a corner, a side wall and a thin plate fail, the
//! refusal of a far point, the fill of a placed gate against the half diagonal and the
//! paper gate's own march, and a layout of the K-gate answer's points giving its L_max.

use moldgate::samples::BoxUnion;
use moldgate::study::judge::FailedRule;
use moldgate::study::{study, StudyError, StudyOptions};
use moldgate::LoadedMesh;

fn block(lo: [f64; 3], hi: [f64; 3]) -> LoadedMesh {
    let mut b = BoxUnion::default();
    b.add(lo, hi);
    moldgate::mesh::from_generated(b.mesh())
}

fn options(json: &str) -> StudyOptions {
    serde_json::from_str(json).unwrap()
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

#[test]
fn a_point_above_the_top_face_snaps_straight_down_and_qualifies() {
    // A 40 x 30 x 10 block; a point 3 mm above its top face.
    let part = block([0.0, 0.0, 0.0], [40.0, 30.0, 10.0]);
    let s = study(&part, &options(r#"{ "gate_at": ["20,15,13"] }"#)).unwrap();
    let p = s.report().placed_gates.as_ref().unwrap();
    let g = &p.gates[0];
    assert_eq!(g.asked, [20.0, 15.0, 13.0]);
    assert!(close(g.moved_mm, 3.0, 1e-12), "{}", g.moved_mm);
    assert!(close(g.point[2], 10.0, 1e-12) && g.point[0] == 20.0 && g.point[1] == 15.0);
    assert_eq!(g.normal, [0.0, 0.0, 1.0]);
    assert!(g.seen_along_d && g.qualifies && p.all_qualify, "{g:?}");
    assert_eq!(g.failed_rule, None);
    // The wall along D under it is the block's height, as for a grid node.
    assert!(close(g.thickness_mm.unwrap(), 10.0, 1e-9));
    assert!(close(g.disc_thickness_mm.unwrap(), 10.0, 1e-5));
    // The same verdict as the paper gate of the same place: the paper gate of a block is
    // above its centre, at (20, 15, 10).
    let paper = s.report().paper_gate.as_ref().unwrap();
    assert!(close(paper.point[0], 20.0, 0.5) && close(paper.point[1], 15.0, 0.5));
    assert_eq!(g.thickness_mm.is_some(), paper.thickness_mm.is_some());
    // Without the fill there is no fill, and the report says why.
    assert!(p.fill.is_none());
    assert!(p.no_fill_reason.as_deref().unwrap().contains("--fill"));
    assert_eq!(s.placed_gates().len(), 1);
}

#[test]
fn each_rule_is_named_where_it_fails() {
    let part = block([0.0, 0.0, 0.0], [40.0, 30.0, 10.0]);
    let r = moldgate::Material::builtin("PP").unwrap().gate_radius_mm();
    // Half a radius in from a corner of the top face: the circle leaves the part. A point
    // beside a side wall snaps onto the wall, which the +D mould half cannot reach.
    let corner = format!("{},{},10", 0.5 * r, 0.5 * r);
    let json = format!(r#"{{ "gate_at": ["{corner}", "40.5,15,5", "20,15,-2"] }}"#);
    let s = study(&part, &options(&json)).unwrap();
    let p = s.report().placed_gates.as_ref().unwrap();
    assert!(!p.all_qualify);
    let [corner, side, below] = &p.gates[..] else {
        panic!("{p:?}")
    };
    assert_eq!(
        corner.failed_rule,
        Some(FailedRule::CircleOffPart),
        "{corner:?}"
    );
    assert!(corner.seen_along_d && !corner.qualifies);
    assert!(corner.why.as_deref().unwrap().contains("circle of radius"));
    assert_eq!(
        side.failed_rule,
        Some(FailedRule::NotSeenAlongD),
        "{side:?}"
    );
    assert!(close(side.moved_mm, 0.5, 1e-12));
    assert_eq!(side.point, [40.0, 15.0, 5.0]);
    assert_eq!(side.normal, [1.0, 0.0, 0.0]);
    // Below the part: the bottom face, under the top one along D.
    assert_eq!(
        below.failed_rule,
        Some(FailedRule::NotSeenAlongD),
        "{below:?}"
    );
    assert!(
        below.why.as_deref().unwrap().contains("10.000 mm above it"),
        "{below:?}"
    );
    assert!(close(below.moved_mm, 2.0, 1e-12));

    // A plate 3 mm thick under a gate of radius 4: the wall rule, with the numbers.
    let plate = block([0.0, 0.0, 0.0], [60.0, 40.0, 3.0]);
    let s = study(
        &plate,
        &options(r#"{ "gate_at": ["30,20,3"], "gate_radius": 4 }"#),
    )
    .unwrap();
    let g = &s.report().placed_gates.as_ref().unwrap().gates[0];
    assert_eq!(g.failed_rule, Some(FailedRule::ThinWall), "{g:?}");
    assert!(g.why.as_deref().unwrap().contains("3.000 mm"), "{g:?}");
    // With the rule ignored it qualifies; a keep-out over it names the keep-out.
    let s = study(
        &plate,
        &options(
            r#"{ "gate_at": ["30,20,3"], "gate_radius": 4, "thickness_rule": "ignore",
                 "keep_out": ["sphere:33,20,3,1"] }"#,
        ),
    )
    .unwrap();
    let g = &s.report().placed_gates.as_ref().unwrap().gates[0];
    assert_eq!(g.failed_rule, Some(FailedRule::KeptOut), "{g:?}");
}

#[test]
fn a_point_far_from_the_part_is_refused_with_the_distance_and_the_limit() {
    let part = block([0.0, 0.0, 0.0], [40.0, 30.0, 10.0]);
    // The diagonal is sqrt(40^2 + 30^2 + 10^2) = 50.99 mm: the limit is 5.099 mm.
    let e = study(
        &part,
        &options(r#"{ "gate_at": ["20,15,10", "20,15,20"] }"#),
    )
    .unwrap_err();
    let StudyError::Invalid { field, message } = &e else {
        panic!("{e}")
    };
    assert_eq!(*field, "gate_at");
    assert!(
        message.starts_with(
            "2 (20.000, 15.000, 20.000) is 10.000 mm from the part's surface, over the limit of 5.099 mm"
        ),
        "{message}"
    );
    // Just inside the limit is taken.
    assert!(study(&part, &options(r#"{ "gate_at": ["20,15,15"] }"#)).is_ok());
}

#[test]
fn a_placed_gate_fills_as_the_march_says() {
    // A plate 100 x 60 x 3 gated at the centre of its top: the farthest point is a bottom
    // corner in a straight line, the half diagonal.
    let plate = block([-50.0, -30.0, 0.0], [50.0, 30.0, 3.0]);
    let exact = (50.0f64 * 50.0 + 30.0 * 30.0 + 3.0 * 3.0).sqrt();
    let s = study(
        &plate,
        &options(r#"{ "gate_at": ["0,0,3"], "fill": true, "cell": 0.5 }"#),
    )
    .unwrap();
    let p = s.report().placed_gates.as_ref().unwrap();
    let f = p.fill.as_ref().unwrap();
    println!("L_max {:.3} (exact {exact:.3})", f.l_max_mm);
    // First-order marching on cells of 0.5 mm (the error shrinks with the cell, see the
    // fill's own test of the plate).
    assert!((f.l_max_mm - exact).abs() / exact < 0.015, "{}", f.l_max_mm);
    assert!(close(p.gates[0].volume_share.unwrap(), 1.0, 1e-12));
    assert!(close(p.gates[0].l_max_mm.unwrap(), f.l_max_mm, 1e-12));
    // Eq. 1 on the uniform plate: the pressure factor times the path.
    let fill = s.report().fill.as_ref().unwrap();
    let eq1 = fill.pressure_mpa_per_mm * f.l_max_mm;
    assert!(
        (f.pressure_mpa - eq1).abs() / eq1 < 0.02,
        "{} vs {eq1}",
        f.pressure_mpa
    );
    assert!(close(
        f.flow_ratio,
        f.l_max_mm / fill.nominal_wall_mm,
        1e-12
    ));
    // Placed at the paper gate's own point, the fill is the paper gate's: the same march.
    let paper = fill.paper.as_ref().unwrap();
    let at = paper.gate;
    let json = format!(
        r#"{{ "gate_at": ["{},{},{}"], "fill": true, "cell": 0.5 }}"#,
        at[0], at[1], at[2]
    );
    let s = study(&plate, &options(&json)).unwrap();
    let p = s.report().placed_gates.as_ref().unwrap();
    let f = p.fill.as_ref().unwrap();
    assert!(p.gates[0].moved_mm < 1e-9);
    assert_eq!(f.l_max_mm, paper.l_max_mm);
    assert_eq!(f.pressure_mpa, paper.pressure_mpa);
    assert_eq!(f.fill_time_s, paper.fill_time_s);
    assert_eq!(f.last_to_fill.len(), paper.last_to_fill.len());
}

#[test]
fn a_layout_of_the_k_gate_answer_s_points_gives_its_l_max() {
    for (name, k) in [("plate", 2), ("tray", 3)] {
        let part = moldgate::mesh::from_generated(moldgate::samples::sample(name).unwrap());
        let json = format!(r#"{{ "gates": {k} }}"#);
        let s = study(&part, &options(&json)).unwrap();
        let several = s.report().fill.as_ref().unwrap().several.clone().unwrap();
        let l_max = several.l_max_mm.unwrap();
        let points: Vec<String> = several
            .gates
            .iter()
            .map(|g| format!("\"{},{},{}\"", g.point[0], g.point[1], g.point[2]))
            .collect();
        let json = format!(r#"{{ "fill": true, "gate_at": [{}] }}"#, points.join(","));
        let s = study(&part, &options(&json)).unwrap();
        let p = s.report().placed_gates.as_ref().unwrap();
        let f = p.fill.as_ref().unwrap();
        println!(
            "{name}: K = {k}, K-gate L_max {:.4}, layout {:.4}",
            l_max, f.l_max_mm
        );
        assert!(
            close(f.l_max_mm, l_max, 1e-9 * l_max),
            "{name}: {} vs {}",
            f.l_max_mm,
            l_max
        );
        for (g, share) in p.gates.iter().zip(&several.gates) {
            assert!(
                close(g.volume_share.unwrap(), share.volume_share, 1e-9),
                "{name}"
            );
        }
        // The pictures show the designer's layout.
        assert_eq!(s.placed_gates().len(), k);
    }
}

#[test]
fn two_gates_at_the_quarter_points_of_a_bar_halve_its_flow_length() {
    // A bar 200 x 20 x 4: one gate at the middle reaches the ends at about 100 mm; gates at
    // the quarter points reach about 50 mm, each filling half.
    let bar = block([0.0, 0.0, 0.0], [200.0, 20.0, 4.0]);
    let one = study(
        &bar,
        &options(r#"{ "gate_at": ["100,10,4"], "fill": true }"#),
    )
    .unwrap();
    let two = study(
        &bar,
        &options(r#"{ "gate_at": ["50,10,4", "150,10,4"], "fill": true }"#),
    )
    .unwrap();
    let l1 = one
        .report()
        .placed_gates
        .as_ref()
        .unwrap()
        .fill
        .as_ref()
        .unwrap()
        .l_max_mm;
    let p2 = two.report().placed_gates.as_ref().unwrap();
    let l2 = p2.fill.as_ref().unwrap().l_max_mm;
    let corner = |dx: f64| (dx * dx + 10.0f64.powi(2) + 4.0f64.powi(2)).sqrt();
    println!(
        "one gate {l1:.3} (straight {:.3}), two {l2:.3} ({:.3})",
        corner(100.0),
        corner(50.0)
    );
    assert!((l1 - corner(100.0)).abs() / corner(100.0) < 0.02, "{l1}");
    assert!((l2 - corner(50.0)).abs() / corner(50.0) < 0.02, "{l2}");
    for g in &p2.gates {
        assert!(close(g.volume_share.unwrap(), 0.5, 0.02), "{g:?}");
    }
    // Where the two fronts meet, at x = 100, is a weld line.
    let welds = &p2.fill.as_ref().unwrap().weld_lines;
    assert!(
        welds.iter().any(|w| (w.point[0] - 100.0).abs() < 3.0),
        "{welds:?}"
    );
}
