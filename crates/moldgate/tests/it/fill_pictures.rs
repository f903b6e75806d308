//! Pictures of the fill on a coarse mesh: the field is drawn at the resolution of its cells,
//! not blended from the corners of large triangles, and the colour bar spans the field's
//! real range (the one the report quotes), in the PNG and the GLB alike.

use moldgate::math::DVec3;
use moldgate::mesh::{from_generated, LoadedMesh, Mesh};
use moldgate::render::{render, RenderOptions};
use moldgate::study::{study, StudyOptions};

/// A plate `x` by `y` by `z` mm in 12 triangles (two a face), wound outwards.
fn coarse_plate(x: f64, y: f64, z: f64) -> LoadedMesh {
    from_generated(block(DVec3::ZERO, DVec3::new(x, y, z)))
}

/// A box from `lo` to `hi` in 12 triangles (two a face), wound outwards.
fn block(lo: DVec3, hi: DVec3) -> Mesh {
    let vertices = (0..8)
        .map(|i| {
            DVec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            )
        })
        .collect();
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let triangles = quads
        .iter()
        .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
        .collect();
    Mesh {
        vertices,
        triangles,
    }
}

fn options(json: &str) -> StudyOptions {
    serde_json::from_str(json).unwrap()
}

/// The `field` object of a GLB's scene extras.
fn glb_field(glb: &[u8]) -> serde_json::Value {
    let len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let json: serde_json::Value = serde_json::from_slice(&glb[20..20 + len]).unwrap();
    json["asset"]["extras"]["field"].clone()
}

/// The darkest luminance of the pixels within `r` of `(x, y)` (the hatching of the
/// qualifying region is light, so the darkest pixel is the field's colour).
fn darkest(picture: &moldgate::render::Picture, x: f64, y: f64, r: i64) -> f64 {
    let mut best = f64::MAX;
    for dy in -r..=r {
        for dx in -r..=r {
            let (px, py) = ((x as i64 + dx) as u32, (y as i64 + dy) as u32);
            if let Some([red, g, b]) = picture.pixel(px, py) {
                best = best.min(0.2126 * red as f64 + 0.7152 * g as f64 + 0.0722 * b as f64);
            }
        }
    }
    best
}

#[test]
fn flow_length_on_a_coarse_plate_is_drawn_from_the_cells() {
    // Two triangles a face: every corner is some 60 mm of flow from the central gate.
    let part = coarse_plate(100.0, 70.0, 3.0);
    let s = study(
        &part,
        &options(r#"{ "fill": true, "color_by": "flow_length", "demold": "+z" }"#),
    )
    .unwrap();
    let fill = s.fill().unwrap();
    let paper = fill.paper.as_ref().unwrap();
    let gate = s.gates()[0].point;
    assert!((gate.z - 3.0).abs() < 1e-9, "{gate}");

    // The colour bar (and the GLB's range) spans the cells: from about 0 at the gate to
    // the longest flow the report quotes.
    let scene = s.scene(&part, "plate").unwrap();
    let [lo, hi] = scene.field.range().unwrap();
    assert!((lo as f64) < fill.cell_mm, "{lo} mm at the gate");
    assert_eq!(hi, paper.l_max_mm as f32);
    let field = glb_field(&s.glb(&part, "plate").unwrap());
    assert_eq!(field["min"].as_f64().unwrap(), lo as f64);
    assert_eq!(field["max"].as_f64().unwrap(), hi as f64);

    // The drawn surface holds vertices near the gate with values near 0.
    let (surface, values) = scene.surface();
    let near = (0..surface.vertices.len())
        .min_by(|&a, &b| {
            let d = |v: usize| surface.vertices[v].distance(gate);
            d(a).total_cmp(&d(b))
        })
        .unwrap();
    assert!(surface.vertices[near].distance(gate) <= fill.cell_mm);
    assert!(
        (values[near] as f64) < 2.0 * fill.cell_mm,
        "{}",
        values[near]
    );

    // In the picture along D, the top face is dark (short flow) beside the gate and bright
    // (long flow) near a corner.
    let picture = render(&scene, &RenderOptions::default()).unwrap();
    let camera = picture.views[0].camera;
    let beside = camera.to_pixel(gate + DVec3::new(8.0, 0.0, 0.0));
    let corner = camera.to_pixel(DVec3::new(92.0, 62.0, 3.0));
    let (dark, bright) = (
        darkest(&picture, beside.x, beside.y, 4),
        darkest(&picture, corner.x, corner.y, 4),
    );
    assert!(
        dark + 60.0 < bright,
        "beside the gate {dark}, near a corner {bright}"
    );
}

#[test]
fn the_fill_time_bar_ends_at_the_reported_fill_time() {
    let part = coarse_plate(100.0, 70.0, 3.0);
    let s = study(&part, &options(r#"{ "fill": true, "demold": "+z" }"#)).unwrap();
    let fill = s.fill().unwrap();
    let scene = s.scene(&part, "plate").unwrap();
    let [lo, hi] = scene.field.range().unwrap();
    assert_eq!(hi, fill.paper.as_ref().unwrap().fill_time_s as f32);
    assert!(lo < hi / 10.0, "{lo} {hi}");
}

#[test]
fn the_height_along_d_is_drawn_on_the_part_itself() {
    let part = coarse_plate(100.0, 70.0, 3.0);
    let s = study(
        &part,
        &options(r#"{ "fill": true, "color_by": "height", "demold": "+z" }"#),
    )
    .unwrap();
    let scene = s.scene(&part, "plate").unwrap();
    assert!(scene.display.is_none() && scene.field.cells.is_none());
    let (surface, values) = scene.surface();
    assert_eq!(surface.triangles, part.mesh.triangles);
    assert_eq!(values, &scene.field.per_vertex[..]);
}

#[test]
fn the_refined_surface_is_made_once_a_study_and_is_the_one_refine_makes() {
    let part = coarse_plate(100.0, 70.0, 3.0);
    let s = study(
        &part,
        &options(r#"{ "fill": true, "color_by": "flow_length", "demold": "+z" }"#),
    )
    .unwrap();
    let (first, second) = (
        s.scene(&part, "plate").unwrap(),
        s.scene(&part, "plate").unwrap(),
    );
    let (a, b) = (first.display.unwrap(), second.display.unwrap());
    // The PNG, the GLB and the page share one surface...
    assert!(std::sync::Arc::ptr_eq(&a, &b));
    // ... the one a scene refining its own field draws.
    let fresh = moldgate::scene::Scene::new(&part.mesh, s.analysis(), "plate")
        .with_field(s.fill_field().unwrap());
    let d = fresh.display.unwrap();
    assert_eq!(a.mesh.vertices, d.mesh.vertices);
    assert_eq!(a.mesh.triangles, d.mesh.triangles);
    assert_eq!(a.parent, d.parent);
    assert_eq!(
        a.values.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        d.values.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
    );
}

#[test]
fn the_suitability_map_is_drawn_on_the_parts_own_triangles() {
    let part = coarse_plate(100.0, 70.0, 3.0);
    let s = study(
        &part,
        &options(r#"{ "fill": true, "suitability": true, "demold": "+z" }"#),
    )
    .unwrap();
    assert!(s.fill_field().unwrap().cells.is_some());
    let scene = s.scene(&part, "plate").unwrap();
    assert!(scene.node_field.is_some() && scene.display.is_none());
}

/// On a part of two bodies each node is scored by its own body's fill, so the lid's every
/// node scores better than the box's best: the pictures colour each node by its score over
/// its own body's best, so that each body shows its best places; one body keeps its unit.
#[test]
fn the_suitability_map_of_two_bodies_colours_each_against_its_own_best() {
    let part = box_and_lid();
    let s = study(
        &part,
        &options(r#"{ "suitability": true, "demold": "+z" }"#),
    )
    .unwrap();
    let map = s.fill().unwrap().suitability.as_ref().unwrap();
    assert!(map.spans_bodies());
    // Each node's body is the body of the side it lies on (the lid from x = 45 mm).
    let lid = map.nodes.iter().find(|n| n.point[0] > 45.0).unwrap().body;
    for n in &map.nodes {
        assert_eq!(n.body == lid, n.point[0] > 45.0, "{n:?}");
    }
    // Each body's best is its least score, and the lid's beats the box's.
    let least = |on_lid: bool| {
        map.nodes
            .iter()
            .filter(|n| (n.body == lid) == on_lid)
            .map(|n| n.score)
            .fold(f64::INFINITY, f64::min)
    };
    let best_score = |body: u32| map.nodes[map.best_per_body[body as usize].unwrap()].score;
    assert_eq!(best_score(lid), least(true));
    assert_eq!(best_score(1 - lid), least(false));
    assert!(least(true) < least(false));
    let field = s.suitability_field().unwrap();
    assert!(
        field.name.contains("over the best of its body"),
        "{}",
        field.name
    );
    assert_eq!(field.unit, "");
    for n in &map.nodes {
        let want = n.score
            / if n.body == lid {
                least(true)
            } else {
                least(false)
            };
        assert!(
            (f64::from(field.per_node[n.node]) - want).abs() < 1e-6,
            "{n:?}"
        );
    }
    // Each body's best is 1, so each shows in the darkest colour.
    for on_lid in [true, false] {
        let least_ratio = map
            .nodes
            .iter()
            .filter(|n| (n.body == lid) == on_lid)
            .map(|n| field.per_node[n.node])
            .fold(f32::INFINITY, f32::min);
        assert_eq!(least_ratio, 1.0);
    }
    // The page says so, with each body's best.
    let page = s.html(None).unwrap();
    assert!(
        page.contains("<p id=\"suitability-bodies\">The part has several bodies")
            && page.contains(&format!("body {} at ", lid + 1))
            && page.contains(&format!("body {} at ", 2 - lid)),
        "{page}"
    );
    // One body: the scores themselves, in their unit.
    let plate = coarse_plate(100.0, 70.0, 3.0);
    let s = study(
        &plate,
        &options(r#"{ "suitability": true, "demold": "+z" }"#),
    )
    .unwrap();
    let map = s.fill().unwrap().suitability.as_ref().unwrap();
    assert!(!map.spans_bodies());
    let field = s.suitability_field().unwrap();
    assert_eq!(field.unit, "mm");
    for n in &map.nodes {
        assert_eq!(field.per_node[n.node], n.score as f32);
    }
    assert!(!s.html(None).unwrap().contains("suitability-bodies"));
}

/// A box 40 x 20 x 10 mm and a lid 40 x 20 x 2 mm 5 mm beside it, in one file.
fn box_and_lid() -> LoadedMesh {
    let mut two = block(DVec3::ZERO, DVec3::new(40.0, 20.0, 10.0));
    let lid = block(DVec3::new(45.0, 0.0, 0.0), DVec3::new(85.0, 20.0, 2.0));
    let base = two.vertices.len() as u32;
    two.vertices.extend(&lid.vertices);
    two.triangles
        .extend(lid.triangles.iter().map(|t| t.map(|v| v + base)));
    from_generated(two)
}

#[test]
fn a_body_the_gate_does_not_reach_is_drawn_filled_from_its_own_gate() {
    // A box and a lid 5 mm beside it, in one file: the paper gate fills the box only.
    let part = box_and_lid();
    // The answer's gate, or a gate of the designer's on the box: the lid is shown from its
    // own gate either way.
    for (colour, placed) in [
        ("fill_time", ""),
        ("flow_length", ""),
        ("fill_time", r#", "gate_at": ["20,10,10"]"#),
    ] {
        let s = study(
            &part,
            &options(&format!(
                r#"{{ "fill": true, "color_by": "{colour}", "demold": "+z"{placed} }}"#
            )),
        )
        .unwrap();
        let fill = s.fill().unwrap();
        let own = fill.body_gates.iter().find(|b| !b.is_answer_body).unwrap();
        assert!(own.pictured);
        assert!(fill.body_gates.iter().filter(|b| b.pictured).count() == 1);
        let lid_gate = DVec3::from_array(own.gate.unwrap());
        assert!(lid_gate.x > 45.0, "{lid_gate}");
        // The scene draws the lid's own gate beside the answer's, named by its body.
        let scene = s.scene(&part, "two").unwrap();
        let markers: Vec<_> = scene.gates.iter().map(|g| (g.point, g.body)).collect();
        assert_eq!(markers.len(), 2, "{markers:?}");
        assert_eq!(markers[0].1, None);
        assert_eq!(markers[1], (lid_gate, Some(own.body)));
        // Every vertex of both bodies has a value: the lid's from its own gate, up to the
        // value its gate reports over it.
        let (surface, values) = scene.surface();
        assert!(
            values.iter().all(|v| v.is_finite()),
            "a vertex without a value"
        );
        let lid_max = surface
            .vertices
            .iter()
            .zip(values)
            .filter(|(p, _)| p.x > 42.0)
            .map(|(_, &v)| v as f64)
            .fold(0.0, f64::max);
        let reported = match colour {
            "fill_time" => own.fill_time_s.unwrap(),
            _ => own.l_max_mm.unwrap(),
        };
        assert!(
            lid_max <= reported * (1.0 + 1e-6) && lid_max > 0.5 * reported,
            "{colour}: the lid's largest value {lid_max} against its gate's {reported}"
        );
    }
}

#[test]
fn a_body_s_own_gate_reports_the_fill_of_a_gate_placed_there() {
    // The box and the lid beside it: the lid's own gate reports its largest flow length and
    // fill time (marched for the body's gate alone), as the whole fill of a gate the
    // designer places at that point finds them.
    let part = box_and_lid();
    let s = study(&part, &options(r#"{ "fill": true, "demold": "+z" }"#)).unwrap();
    let own = s
        .fill()
        .unwrap()
        .body_gates
        .iter()
        .find(|b| !b.is_answer_body)
        .unwrap()
        .clone();
    let [x, y, z] = own.gate.unwrap();
    let placed = study(
        &part,
        &options(&format!(
            r#"{{ "fill": true, "demold": "+z", "gate_at": ["{x:?},{y:?},{z:?}"] }}"#
        )),
    )
    .unwrap();
    let there = &placed.fill().unwrap().placed.as_ref().unwrap().fill;
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs();
    let (l_max, fill_time) = (own.l_max_mm.unwrap(), own.fill_time_s.unwrap());
    assert!(
        close(l_max, there.l_max_mm),
        "{l_max} against {}",
        there.l_max_mm
    );
    assert!(
        close(fill_time, there.fill_time_s),
        "{fill_time} against {}",
        there.fill_time_s
    );
    // The lid is 40 by 20 mm: its far corners some 22 mm from its middle.
    assert!(l_max > 20.0 && fill_time > 0.0, "{l_max} mm, {fill_time} s");
}
