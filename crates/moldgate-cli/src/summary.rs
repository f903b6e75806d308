//! The short human summary printed on stdout.

use std::fmt::Write;

use moldgate::report::Report;

fn v3(p: [f64; 3]) -> String {
    format!("({:.3}, {:.3}, {:.3})", p[0], p[1], p[2])
}

fn mm(x: Option<f64>) -> String {
    x.map(|v| format!("{v:.2} mm"))
        .unwrap_or_else(|| "unknown (open mesh)".into())
}

/// Renders the report as a few lines of text.
pub fn render(r: &Report) -> String {
    let mut s = String::new();
    let name = r
        .input
        .path
        .clone()
        .or(r.input.sample.as_ref().map(|n| format!("sample '{n}'")))
        .unwrap_or_default();
    let m = &r.mesh;
    let _ = writeln!(
        s,
        "{name}: {} in {}, {} triangles, {} vertices, {} {}, {}",
        match m.format {
            moldgate::mesh::Format::StlBinary => "binary STL",
            moldgate::mesh::Format::StlAscii => "ASCII STL",
            moldgate::mesh::Format::Generated => "generated",
        },
        m.units,
        m.triangles,
        m.vertices,
        m.bodies,
        if m.bodies == 1 { "body" } else { "bodies" },
        if m.open_edges == 0 && m.non_manifold_edges == 0 {
            "closed".to_string()
        } else {
            format!(
                "{} open and {} non-manifold edges",
                m.open_edges, m.non_manifold_edges
            )
        }
    );
    let o = &r.options;
    let _ = writeln!(
        s,
        "material {}: R_gate = {:.4} mm{}",
        r.material.material.name,
        o.gate_radius_mm,
        match o.gate_radius_source {
            moldgate::report::RadiusSource::Material => " (Eq. 8)",
            moldgate::report::RadiusSource::Forced => " (forced)",
        }
    );
    let _ = writeln!(
        s,
        "demold {}, grid {} x {} nodes at {:.3} mm ({})",
        v3(o.demold),
        r.grid.n_u,
        r.grid.n_w,
        o.spacing_mm,
        o.spacing_rule
    );
    let _ = writeln!(
        s,
        "centre of mass ({}): {}",
        match r.centre_of_mass.kind {
            moldgate::CentreKind::Surface => "surface, Eq. 5",
            moldgate::CentreKind::Volume => "volume",
        },
        v3(r.centre_of_mass.used)
    );
    let c = &r.counts;
    let _ = writeln!(
        s,
        "nodes: {} -> {} hit -> {} with the whole circle on the part -> {} thicker than R ({} unknown); {} flat; {} qualify",
        c.nodes, c.centre_hits, c.circle_on_part, c.thicker_than_radius, c.thickness_unknown, c.flat, c.qualifying
    );
    if let Some(g) = &r.paper_gate {
        let _ = writeln!(
            s,
            "paper gate: {} mm, normal {}, wall {} (disc min {}), {:.3} mm from the centre of mass",
            v3(g.point),
            v3(g.normal),
            mm(g.thickness_mm),
            mm(g.disc_thickness_mm),
            g.distance_3d_mm
        );
    }
    if let Some(g) = &r.aesthetic_gate {
        let _ = writeln!(
            s,
            "aesthetic gate (parting line, {:.1} mm long): {} mm, {:.3} mm from the centre of mass",
            r.parting_line.length_mm,
            v3(g.point),
            g.distance_3d_mm
        );
    }
    match &r.gate {
        Some(g) => {
            let mode = match g.mode {
                moldgate::GateMode::Paper => "paper",
                moldgate::GateMode::Aesthetic => "aesthetic",
            };
            let _ = writeln!(s, "GATE ({mode}): {} mm", v3(g.point));
        }
        None => {
            let _ = writeln!(
                s,
                "no gate: {}",
                r.no_gate_reason.clone().unwrap_or_default()
            );
        }
    }
    if let Some(auto) = &r.demold_auto {
        let tried: Vec<String> = auto
            .tried
            .iter()
            .map(|c| format!("{} {:.1} mm^2", v3(c.direction), c.undercut.area_mm2))
            .collect();
        let _ = writeln!(
            s,
            "demold auto: undercut of each direction tried: {}",
            tried.join(", ")
        );
    }
    if let Some(w) = &r.wall_thickness {
        let _ = writeln!(
            s,
            "wall thickness: min {}, nominal {}, max {}, at the gate {} ({:.1} % of the area unknown)",
            mm(w.min_mm),
            mm(w.nominal_mm),
            mm(w.max_mm),
            mm(w.at_gate_mm),
            100.0 * w.unknown_area_share
        );
    }
    for w in &r.warnings {
        let _ = writeln!(s, "warning: {w}");
    }
    let t = &r.timings;
    let ms = |x: f64| x * 1e3;
    let _ = writeln!(
        s,
        "time: {:.1} ms (load {:.1}, centre {:.1}, grid {:.1}, rays {:.1}, select {:.1}, parting line {:.1})",
        ms(t.total_s),
        ms(t.load_s),
        ms(t.centre_s),
        ms(t.grid_s),
        ms(t.projection_s),
        ms(t.select_s),
        ms(t.parting_s)
    );
    s
}
