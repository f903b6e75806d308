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
        println!("h {h}: L_max {:.3} (exact {exact:.3}), error {err:.3}", fill.l_max_mm);
        errors.push(err);
    }
    assert!(errors[2] < errors[0], "{errors:?}");
    assert!(errors[2] / exact < 0.01, "{errors:?}");
}
