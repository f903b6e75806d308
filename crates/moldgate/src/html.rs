//! The HTML report: one self-contained page (no scripts, no fetches) with the answer, a
//! summary table, the picture as a data URI, the warnings, a glossary and the full JSON.

use std::fmt::Write;

use crate::report::{seconds_text, three_figures, RadiusSource, Report};

/// Escapes text for HTML element content and attribute values.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            _ => out.push(c),
        }
    }
    out
}

/// Standard base64 (RFC 4648, with padding).
pub fn base64(bytes: &[u8]) -> String {
    const TABLE: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(TABLE[(n >> (18 - 6 * i) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

fn v3(p: [f64; 3]) -> String {
    format!("({:.3}, {:.3}, {:.3})", p[0], p[1], p[2])
}

/// The name of the part as the report shows it.
pub fn part_name(r: &Report) -> String {
    r.input
        .path
        .clone()
        .or(r.input.sample.as_ref().map(|n| format!("sample '{n}'")))
        // A part given as bytes or arrays (the service's upload, Python's own mesh).
        .unwrap_or_else(|| "an unnamed part".to_string())
}

const STYLE: &str = "
body { font-family: 'DejaVu Sans', 'Segoe UI', Helvetica, Arial, sans-serif; margin: 24px auto;
       max-width: 1650px; padding: 0 16px; color: #1a1a20; line-height: 1.4; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; }
h2 { font-size: 1.2em; margin-top: 1.6em; border-bottom: 1px solid #ccd; }
.answer { font-size: 1.2em; padding: 10px 14px; background: #f3f5f9; border-left: 5px solid #e6192d; }
.nogate { border-left-color: #888; }
img { max-width: 100%; height: auto; border: 1px solid #ccd; }
table { border-collapse: collapse; }
td, th { text-align: left; padding: 3px 12px 3px 0; vertical-align: top; }
th { font-weight: 600; }
tr:first-child th { white-space: nowrap; }
td.n { text-align: right; font-variant-numeric: tabular-nums; }
tr + tr td, tr + tr th { border-top: 1px solid #eef; }
dt { font-weight: 600; margin-top: 0.5em; }
dd { margin-left: 1.5em; }
pre { background: #f6f7f9; padding: 12px; overflow: auto; font-size: 0.85em; }
.warn li { color: #8a4b00; }
.muted { color: #667; }
";

/// The page. `png` is the picture (omitted when `None`); `json` is the full JSON report.
pub fn page(r: &Report, json: &str, png: Option<&[u8]>) -> String {
    let name = part_name(r);
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <title>moldgate: {}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n",
        escape(&name)
    );
    let _ = writeln!(h, "<h1>Injection gate of {}</h1>", escape(&name));
    let _ = writeln!(
        h,
        "<p class=\"muted\">moldgate {}, report schema {}; method of Mercado-Colmenero, \
         Torres-Alba and Martin-Doñate (gate nearest the centre of mass among the grid nodes \
         whose gate disc lies whole on the part).</p>",
        escape(r.moldgate_version),
        r.schema_version
    );
    match &r.gate {
        Some(g) if g.gates.is_some() => {
            let gates = g.gates.as_deref().unwrap_or_default();
            let points: Vec<String> = gates
                .iter()
                .map(|g| format!("{} mm", v3(g.point)))
                .collect();
            let _ = writeln!(
                h,
                "<p class=\"answer\" id=\"answer\">{} gates at <b id=\"gate\">{}</b>, radius \
                 R = {:.3} mm (see the fill analysis for each one's share).</p>",
                gates.len(),
                points.join(", "),
                r.options.gate_radius_mm
            );
        }
        Some(g) => {
            let _ = writeln!(
                h,
                "<p class=\"answer\" id=\"answer\">Gate at <b id=\"gate\">{} mm</b>, radius \
                 R = {:.3} mm, {:.3} mm from the centre of mass ({}).</p>",
                v3(g.point),
                r.options.gate_radius_mm,
                g.distance_3d_mm,
                match (g.strategy, g.mode) {
                    (crate::flow::Strategy::Balanced, _) => "the balanced gate",
                    (_, crate::GateMode::Paper) =>
                        "the paper's gate: the qualifying node nearest the centre of mass",
                    (_, crate::GateMode::Aesthetic) =>
                        "the aesthetic gate: the point of the parting line nearest the centre of mass",
                }
            );
        }
        None => {
            let _ = writeln!(
                h,
                "<p class=\"answer nogate\" id=\"answer\">No gate: {}</p>",
                escape(r.no_gate_reason.as_deref().unwrap_or("no node qualifies"))
            );
        }
    }
    if let Some(png) = png {
        let _ = writeln!(
            h,
            "<p><img alt=\"The part seen along the demolding direction and in an isometric \
             view, coloured by the field named on the colour bar, with the gate, the centre of \
             mass, the parting line and the qualifying region\" \
             src=\"data:image/png;base64,{}\"></p>",
            base64(png)
        );
    }

    summary_table(&mut h, r);
    fill_table(&mut h, r);
    placed_table(&mut h, r);
    counts_table(&mut h, r);
    demold_table(&mut h, r);

    let _ = writeln!(h, "<h2>Warnings</h2>");
    if r.warnings.is_empty() {
        let _ = writeln!(h, "<p>None.</p>");
    } else {
        let _ = writeln!(h, "<ul class=\"warn\">");
        for w in &r.warnings {
            let _ = writeln!(h, "<li>{}</li>", escape(w));
        }
        let _ = writeln!(h, "</ul>");
    }

    timings_table(&mut h, r);
    let _ = writeln!(h, "{GLOSSARY}");
    let _ = writeln!(
        h,
        "<h2>Full JSON report</h2>\n<details><summary>Show the JSON (the same as \
         <code>moldgate locate --json</code>; fields in docs/json-schema.md)</summary>\n\
         <pre>{}</pre></details>",
        escape(json)
    );
    h.push_str("</body>\n</html>\n");
    crate::report::without_negative_zeros(&h, false)
}

fn row(h: &mut String, key: &str, value: &str) {
    let _ = writeln!(h, "<tr><th>{}</th><td>{}</td></tr>", escape(key), value);
}

fn summary_table(h: &mut String, r: &Report) {
    let _ = writeln!(h, "<h2>Summary</h2>\n<table>");
    let m = &r.mesh;
    let o = &r.options;
    row(
        h,
        "Part",
        &format!(
            "{}: {} triangles, {} vertices, {} {}, {}",
            escape(&part_name(r)),
            m.triangles,
            m.vertices,
            m.bodies,
            if m.bodies == 1 { "body" } else { "bodies" },
            if m.is_closed() {
                "closed".to_string()
            } else {
                format!(
                    "{} open and {} non-manifold edges",
                    m.open_edges, m.non_manifold_edges
                )
            }
        ),
    );
    row(
        h,
        "Size",
        &format!(
            "{} to {} mm (read in {})",
            v3(m.bounds_min),
            v3(m.bounds_max),
            m.units
        ),
    );
    match &r.demold_auto {
        Some(auto) => row(
            h,
            "Demolding direction D",
            &format!(
                "{} (chosen automatically: the {} of least undercut, {:.1} mm<sup>2</sup>; every line tried is listed below)",
                v3(o.demold),
                escape(&auto.candidate().label()),
                auto.candidate().undercut.area_mm2
            ),
        ),
        None => row(h, "Demolding direction D", &v3(o.demold)),
    }
    row(
        h,
        "Material",
        &format!(
            "{}: melt velocity {:.4} m/s (Eq. 7){}",
            escape(&r.material.material.name),
            r.material.melt_velocity_m_s,
            // The summary's note: family values are a starting point, not a grade's data.
            crate::material::typical_note(&r.material.material)
                .map(|note| format!(", {}", escape(&note)))
                .unwrap_or_default()
        ),
    );
    row(
        h,
        "Gate radius R",
        &format!(
            "{:.4} mm ({})",
            o.gate_radius_mm,
            match o.gate_radius_source {
                RadiusSource::Material => "Eq. 8 from the material",
                RadiusSource::Forced => "forced with --gate-radius",
                RadiusSource::Fitted =>
                    "the largest that fits below the refused one (--fit-radius)",
            }
        ),
    );
    let c = &r.centre_of_mass;
    row(
        h,
        "Centre of mass",
        &format!(
            "{} mm ({})",
            v3(c.used),
            match c.kind {
                crate::CentreKind::Surface => "surface, Eq. 5",
                crate::CentreKind::Volume => "enclosed volume",
            }
        ),
    );
    match &r.gate {
        // A layout of several gates: every gate, as the headline gives them.
        Some(g) if g.gates.as_ref().is_some_and(|gates| gates.len() > 1) => {
            let gates = g.gates.as_deref().unwrap_or_default();
            let points: Vec<String> = gates
                .iter()
                .map(|g| format!("{} mm", v3(g.point)))
                .collect();
            row(
                h,
                "Gates",
                &format!(
                    "{} gates: {} (their shares in the fill analysis)",
                    gates.len(),
                    points.join(", ")
                ),
            )
        }
        Some(g) => row(
            h,
            "Gate",
            &format!(
                "{} mm, {:.3} mm from the centre of mass",
                v3(g.point),
                g.distance_3d_mm
            ),
        ),
        None => row(
            h,
            "Gate",
            &format!(
                "none: {}",
                escape(r.no_gate_reason.as_deref().unwrap_or_default())
            ),
        ),
    }
    if let Some(g) = &r.paper_gate {
        let wall = |x: Option<f64>| {
            x.map(|v| format!("{v:.3} mm"))
                .unwrap_or_else(|| "unknown (open mesh)".into())
        };
        row(
            h,
            "Paper gate",
            &format!(
                "{} mm, normal {}, wall along D {} (the paper's rule: the node's ray; thinnest under the disc {}), {}",
                v3(g.point),
                v3(g.normal),
                wall(g.thickness_mm),
                wall(g.disc_thickness_mm),
                if g.flat { "flat" } else { "not flat" }
            ),
        );
    }
    if let Some(w) = &r.wall_thickness {
        let mm = |x: Option<f64>| x.map_or("unknown".to_string(), |v| format!("{v:.3} mm"));
        let slivers = match w.sliver_min_mm {
            Some(m) => format!(
                "; {} sliver facets (thinner than 5 % of the nominal, down to {m:.4} mm) left \
                 out of the min",
                w.slivers
            ),
            None => String::new(),
        };
        row(
            h,
            "Wall thickness of every facet",
            &format!(
                "min {}, nominal {}, max {} (each facet across, along its inverted normal), \
                 at the paper gate's facet {}{slivers}",
                mm(w.min_mm),
                mm(w.nominal_mm),
                mm(w.max_mm),
                mm(w.at_gate_mm)
            ),
        );
    }
    if let Some(g) = &r.aesthetic_gate {
        row(
            h,
            "Parting-line gate",
            &format!(
                "{} mm, {:.3} mm from the centre of mass (an edge gate in the parting plane: \
                 the paper's rules for a gate seen along D, its disc on the part and the wall \
                 along D, do not apply to it; check the wall where it enters)",
                v3(g.point),
                g.distance_3d_mm
            ),
        );
    }
    row(
        h,
        "Grid",
        &format!(
            "{} x {} nodes, spacing {:.4} mm ({})",
            r.grid.n_u, r.grid.n_w, o.spacing_mm, o.spacing_rule
        ),
    );
    let p = &r.parting_line;
    row(
        h,
        "Parting line",
        &format!(
            "{:.1} mm, {} edges, {} ({})",
            p.length_mm,
            p.edges,
            if p.closed { "closed" } else { "open" },
            match r.options.parting_line {
                crate::parting::PartingRule::Outline => format!(
                    "the outer rim: {} piece{} of rim edges joined into {} cycle{}, one a body",
                    p.loops,
                    if p.loops == 1 { "" } else { "s" },
                    p.rims.len(),
                    if p.rims.len() == 1 { "" } else { "s" }
                ),
                crate::parting::PartingRule::Longest => format!(
                    "the longest of {} loop{} of edges between the sides",
                    p.loops,
                    if p.loops == 1 { "" } else { "s" }
                ),
            }
        ),
    );
    let _ = writeln!(h, "</table>");
}

fn counts_table(h: &mut String, r: &Report) {
    let c = &r.counts;
    // With the fitted radius taken, the counts are the grid's at the refused one.
    let at_radius = match &r.radius_fit {
        Some(f) if f.accepted => format!(" (at R = {:.3} mm, before the fit)", f.refused_mm),
        _ => String::new(),
    };
    let _ = writeln!(
        h,
        "<h2>Grid nodes through the rules{at_radius}</h2>\n<table>\n<tr><th>Rule</th><th>Nodes</th></tr>"
    );
    let rows = [
        ("Nodes of the grid", c.nodes),
        ("Ray of the node hits the part", c.centre_hits),
        ("Whole gate circle on the part", c.circle_on_part),
        ("... and wall thicker than R", c.thicker_than_radius),
        ("... of which wall thickness unknown", c.thickness_unknown),
        // Not a step after the wall: counted among the whole circles, and a rule only
        // with --require-flat.
        (
            "Whole gate circle on the part and flat (a rule only with --require-flat)",
            c.flat,
        ),
        ("Qualifying (every rule in force)", c.qualifying),
    ];
    // The designer's own regions, when given: the nodes that passed the paper's rules and
    // that they took.
    let kept_out = (!r.options.keep_out.is_empty()).then_some((
        "... of the nodes passing the rules, kept out by the keep-out regions",
        c.kept_out,
    ));
    let cosmetic = r.options.cosmetic.map(|_| {
        (
            "... of the nodes passing the rules, on a cosmetic face",
            c.cosmetic,
        )
    });
    let last = rows.len() - 1;
    for (name, n) in rows[..last]
        .iter()
        .copied()
        .chain(kept_out)
        .chain(cosmetic)
        .chain(std::iter::once(rows[last]))
    {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td class=\"n\">{n}</td></tr>",
            escape(name)
        );
    }
    let _ = writeln!(h, "</table>");
    if !r.options.keep_out.is_empty() {
        let regions: Vec<String> = r
            .options
            .keep_out
            .iter()
            .enumerate()
            .map(|(i, k)| format!("{}. {}", i + 1, k.describe()))
            .collect();
        let _ = writeln!(
            h,
            "<p id=\"keep-out\">Keep-out regions (dashed on the pictures): {}. A node is kept out \
             when its gate disc reaches into one; so is a point of the parting line for the \
             aesthetic gate.</p>",
            escape(&regions.join("; "))
        );
    }
    if let Some([x, y, z]) = r.options.cosmetic {
        let _ = writeln!(
            h,
            "<p id=\"cosmetic\">Cosmetic side ({x:.3}, {y:.3}, {z:.3}): no gate on a face turned \
             towards it.</p>"
        );
    }
}

/// With the automatic direction, every line tried: its undercut (or the bound that ruled
/// it out), the part's extent along it and whether a gate qualifies on it when a tie asked,
/// so a designer can check the choice.
fn demold_table(h: &mut String, r: &Report) {
    let Some(auto) = &r.demold_auto else {
        return;
    };
    let _ = writeln!(
        h,
        "<h2>The demolding direction, chosen automatically</h2>\n<p>Each line is tried both \
         ways; the least undercut area wins, areas within {:.1} mm<sup>2</sup> ({} % of the \
         surface) being a tie broken by the shallower draw, then by a line on which a gate \
         qualifies. \"At least\": a line ruled out by a bound, not drawn ray by ray.</p>\n\
         <table id=\"demold-auto\">\n<tr><th>line</th><th>direction</th><th>undercut</th>\
         <th>share of the surface</th><th>extent along it</th><th>gate qualifies</th></tr>",
        auto.tie_mm2,
        100.0 * crate::undercut::TIE_SHARE
    );
    for (i, c) in auto.tried.iter().enumerate() {
        let chosen = if i == auto.chosen { " (chosen)" } else { "" };
        let at_least = if c.evaluated { "" } else { "at least " };
        let _ = writeln!(
            h,
            "<tr><th>{}{chosen}</th><td>{}</td><td class=\"n\">{at_least}{:.1} mm<sup>2</sup></td>\
             <td class=\"n\">{at_least}{:.2} %</td><td class=\"n\">{:.1} mm</td><td>{}</td></tr>",
            escape(&c.label()),
            v3(c.direction),
            c.undercut.area_mm2,
            100.0 * c.undercut.share,
            c.extent_mm,
            match c.gate_qualifies {
                Some(true) => "yes",
                Some(false) => "no",
                None => "not asked",
            }
        );
    }
    let _ = writeln!(h, "</table>");
}

/// The designer's gates (`gate_at`): each one's verdict by the paper's rules and the wall
/// under it, then the fill of their layout beside the paper gate's and the balanced gate's.
fn placed_table(h: &mut String, r: &Report) {
    let Some(p) = &r.placed_gates else { return };
    let _ = writeln!(
        h,
        "<h2 id=\"placed-gates\">Your gates</h2>\n<p>{} gate{} placed with <code>--gate-at</code>, \
         each moved to the nearest point of the surface and judged by the paper's rules with a \
         disc of R = {:.3} mm; {}.</p>",
        p.gates.len(),
        if p.gates.len() == 1 { "" } else { "s" },
        r.options.gate_radius_mm,
        if p.all_qualify {
            "every one qualifies"
        } else {
            "<b class=\"warn\">some fail a rule</b>"
        }
    );
    let _ = writeln!(
        h,
        "<table>\n<tr><th>Gate</th><th>Given (mm)</th><th>On the surface (mm)</th><th>Moved</th>\
         <th>Wall along D</th><th>Smallest under the disc</th><th>Verdict</th></tr>"
    );
    let mm = |x: Option<f64>| x.map_or("unknown".to_string(), |v| format!("{v:.2} mm"));
    for (i, g) in p.gates.iter().enumerate() {
        let verdict = match &g.why {
            None => off_flat_marked(&crate::study::judge::qualifies_words(g.off_flat_mm())),
            Some(why) => format!("<b class=\"warn\">fails</b>: {}", escape(why)),
        };
        let _ = writeln!(
            h,
            "<tr class=\"placed\" data-qualifies=\"{}\"><th>your gate {}</th><td>{}</td><td>{}</td>\
             <td class=\"n\">{:.2} mm</td><td class=\"n\">{}</td><td class=\"n\">{}</td><td>{verdict}</td></tr>",
            g.qualifies,
            i + 1,
            v3(g.asked),
            v3(g.point),
            g.moved_mm,
            mm(g.thickness_mm),
            mm(g.disc_thickness_mm),
        );
    }
    for g in crate::study::judge::beside_placed(r) {
        let wall = |x: Option<f64>| match (g.thickness_mm, g.disc_thickness_mm) {
            (None, None) => String::new(),
            _ => mm(x),
        };
        // The verdict in the placed gates' words, the reach off a flat seat marked alike.
        let verdict = off_flat_marked(&g.verdict);
        let _ = writeln!(
            h,
            "<tr class=\"beside\"><th>{}</th><td></td><td>{}</td><td></td><td class=\"n\">{}</td>\
             <td class=\"n\">{}</td><td>{verdict}</td></tr>",
            escape(&g.name),
            v3(g.point),
            wall(g.thickness_mm),
            wall(g.disc_thickness_mm),
        );
    }
    let _ = writeln!(h, "</table>");
    let Some(fill) = &p.fill else {
        if let Some(why) = &p.no_fill_reason {
            let _ = writeln!(h, "<p>No fill of your gates: {}.</p>", escape(why));
        }
        return;
    };
    let _ = writeln!(
        h,
        "<table>\n<tr><th>Fill from</th><th>Gate (mm)</th><th>longest flow path<br>L_max</th><th>flow length / wall<br>L/t</th><th>Pressure (Eq. 1)</th>\
         <th>Fill time</th><th>Flow-cell wall<br>at the gate</th><th>Last to fill</th><th>Weld lines</th></tr>"
    );
    let line = |h: &mut String, label: &str, g: &crate::flow::GateFill| {
        let last = g
            .last_to_fill
            .first()
            .map_or("none".to_string(), |q| format!("{} mm", v3(q.point)));
        let _ = writeln!(
            h,
            "<tr><th>{}</th>{}<td>{last}</td><td class=\"n\">{}</td></tr>",
            escape(label),
            fill_cells(g),
            g.weld_lines.len()
        );
    };
    line(
        h,
        if p.gates.len() == 1 {
            "your gate"
        } else {
            "your gates together (first shown)"
        },
        fill,
    );
    if let Some(f) = &r.fill {
        if let Some(paper) = &f.paper {
            line(h, &answer_gate_name(r), paper);
        }
        if let Some(b) = &f.balanced {
            line(h, r.balanced_row_name(), &b.fill);
        }
    }
    let _ = writeln!(h, "</table>");
    if p.gates.len() > 1 {
        let _ = writeln!(h, "<ul>");
        for words in (0..p.gates.len()).filter_map(|i| p.share_words(i)) {
            let _ = writeln!(h, "<li>{}</li>", escape(&words));
        }
        let _ = writeln!(h, "</ul>");
    }
    let whose = if p.gates.len() == 1 {
        "your gate"
    } else {
        "your gates together"
    };
    weld_list(h, whose, fill);
}

/// A verdict in words (of [`crate::study::judge::qualifies_words`]), escaped, with its
/// "off a flat seat" marked as a warning.
fn off_flat_marked(verdict: &str) -> String {
    escape(verdict).replacen(
        "off a flat seat",
        "<b class=\"warn\">off a flat seat</b>",
        1,
    )
}

/// The name of the gate the fill's first row is of: the paper gate, or the aesthetic gate
/// in aesthetic mode.
fn answer_gate_name(r: &Report) -> String {
    format!("{} gate", r.options.mode.name())
}

/// One gate's fill as table cells: L_max, L/t against the material's limit, Eq. 1 pressure,
/// the estimated fill time and the flow-cell wall at the gate.
fn fill_cells(g: &crate::flow::GateFill) -> String {
    let limit = match (g.flow_ratio_limit, g.exceeds_flow_ratio) {
        (Some(m), true) => format!(" <b class=\"warn\">exceeds the material's {m:.0}</b>"),
        (Some(m), false) => format!(" (material's limit {m:.0})"),
        (None, _) => " (no limit known for this material)".to_string(),
    };
    format!(
        "<td>{} mm</td><td class=\"n\">{:.1} mm</td><td class=\"n\">{:.0}{limit}</td><td class=\"n\">{} MPa</td><td class=\"n\">{} s (99 % by {} s)</td><td class=\"n\">{:.2} mm</td>",
        v3(g.gate),
        g.l_max_mm,
        g.flow_ratio,
        three_figures(g.pressure_mpa),
        seconds_text(g.fill_time_s),
        seconds_text(g.fill_time_99_s),
        g.wall_across_mm
    )
}

/// The fill analysis in words and a table: each gate's flow length, L/t and pressure, the
/// balanced or several gates, the last places to fill and the weld lines.
fn fill_table(h: &mut String, r: &Report) {
    let Some(f) = &r.fill else { return };
    let _ = writeln!(
        h,
        "<h2 id=\"fill\">Fill analysis</h2>\n<p>{} cells of {:.3} mm, nominal wall {:.2} mm \
         ({}), {} {}{}; Eq. 1 pressure {:.4} MPa per mm of path through the nominal wall (each \
         cell's own wall sets its share: a gate's pressure below sums them along its path).</p>",
        f.cells,
        f.cell_mm,
        f.nominal_wall_mm,
        f.wall_source.words(),
        f.bodies,
        if f.bodies == 1 { "body" } else { "bodies" },
        if f.stray_bodies > 0 {
            format!(
                " ({} stray {} left out: below 0.1 % of the area)",
                f.stray_bodies,
                if f.stray_bodies == 1 {
                    "body"
                } else {
                    "bodies"
                }
            )
        } else {
            String::new()
        },
        f.pressure_mpa_per_mm
    );
    if let Some(w) = &f.wall {
        let mm = |x: Option<f64>| x.map_or("unknown".to_string(), |v| format!("{v:.2} mm"));
        let _ = writeln!(
            h,
            "<p>Flow-cell walls (the fill model's: one facet sampled per surface cell, across \
             it) at {} cells: min {} ({} slivers thinner than 5 % of the median left out), median \
             {}, max {}. (<i>Wall thickness of every facet</i>, with \
             <code>--wall-thickness</code>, measures each facet instead.)</p>",
            w.samples,
            mm(w.min_mm),
            w.slivers,
            mm(w.nominal_mm),
            mm(w.max_mm)
        );
    }
    let _ = writeln!(
        h,
        "<table id=\"fill-gates\">\n<tr><th>gate</th><th>point</th><th>longest flow path<br>L_max</th>\
         <th>flow length / wall<br>L/t</th><th>pressure<br>(Eq. 1)</th><th>fill time<br>(estimate)</th>\
         <th>flow-cell wall<br>at the gate</th></tr>"
    );
    if let Some(p) = &f.paper {
        // The fill of the answer's gate: the aesthetic gate in aesthetic mode (named as the
        // summary and the placed gates' table name it).
        let _ = writeln!(
            h,
            "<tr><th>{}</th>{}</tr>",
            answer_gate_name(r),
            fill_cells(p)
        );
    }
    if let Some(b) = &f.balanced {
        // Beside the aesthetic gate, the paper's grid gate may be the balanced gate.
        let paper = if r.balanced_is_paper_gate_beside_another() {
            "the paper gate; "
        } else {
            ""
        };
        let label = match (b.is_paper_gate, b.search.proven) {
            (true, true) => {
                "balanced gate (the paper gate: no candidate better by more than a flow cell)"
                    .to_string()
            }
            (true, false) => format!(
                "balanced gate (the paper gate: no candidate tried better by more than a flow cell; {})",
                b.search.unproven_words()
            ),
            // Lower in the objective the search minimised, not in every column.
            (false, true) => format!(
                "balanced gate ({paper}{:.1} % lower {})",
                b.improvement_pct,
                f.objective.value_words().0
            ),
            (false, false) => format!(
                "balanced gate ({paper}{:.1} % lower {}; {})",
                b.improvement_pct,
                f.objective.value_words().0,
                b.search.unproven_words()
            ),
        };
        let _ = writeln!(
            h,
            "<tr><th>{}</th>{}</tr>",
            escape(&label),
            fill_cells(&b.fill)
        );
    }
    let _ = writeln!(h, "</table>");
    suitability_text(h, f);
    if let Some(m) = &f.several {
        // With the resistance objective the several-gate values are fill times.
        let (what, unit) = f.objective.value_words();
        let field = f.objective.field_words();
        let _ = writeln!(
            h,
            "<p id=\"several\">{} gates together: {what} {} {unit} ({}), balance {:.2} \
             ({}).</p>\n\
             <table>\n<tr><th>gate</th><th>point</th>\
             <th>share of {} (reached first by {field})</th><th>{what} in its share</th></tr>",
            m.gates.len(),
            f.objective.value_text(m.value()),
            m.against_single_words(),
            m.balance,
            m.balance_words(),
            // A layout that leaves a body without a gate: its shares are of the volume it
            // reaches.
            if m.leaves_a_body() {
                "the volume the layout reaches"
            } else {
                "the part's volume"
            }
        );
        for (i, g) in m.gates.iter().enumerate() {
            let _ = writeln!(
                h,
                "<tr><th>{}</th><td>{} mm</td><td class=\"n\">{:.1} %</td><td class=\"n\">{} {unit}</td></tr>",
                i + 1,
                v3(g.point),
                100.0 * g.volume_share,
                f.objective.value_text(g.value())
            );
        }
        let _ = writeln!(h, "</table>");
        // Chosen by its longest flow path, the layout's fill time is still what a designer
        // asks of it (and what the pictures colour, unless the designer's gates take them
        // over): given, and said not to be what the layout was chosen for, so that a colour
        // bar ending above a single gate's fill time does not read as a fault.
        if let Some(g) = &m.fill {
            let limit = match g.flow_ratio_limit {
                Some(l) if g.exceeds_flow_ratio => {
                    format!(", <b class=\"warn\">over the material's limit of {l:.0}</b>")
                }
                Some(l) => format!(" (limit {l:.0})"),
                None => String::new(),
            };
            let _ = writeln!(
                h,
                "<p id=\"layout-fill\">With all {} gates open: flow length / wall L/t {:.0}{limit}, \
                 Eq. 1 pressure {} MPa (the most any place needs from its gate).</p>",
                m.gates.len(),
                g.flow_ratio,
                crate::report::three_figures(g.pressure_mpa)
            );
        }
        if let (crate::flow::Objective::Length, Some(t)) = (f.objective, m.layout_fill_time_s) {
            // The suitability map takes the pictures' place when it was made.
            let pictured = r.placed_gates.as_ref().is_none_or(|p| p.fill.is_none())
                && f.suitability.is_none()
                && !f.per_vertex.fill_time_s.is_empty();
            let _ = writeln!(
                h,
                "<p id=\"layout-fill-time\">These gates together fill {} in {} s \
                 (estimate), a time the layout does not minimise (it minimises the longest flow \
                 path): it may end later than a single gate's fill.{}</p>",
                // A layout that leaves a body without a gate: the time is of the bodies it
                // reaches.
                if m.leaves_a_body() {
                    "the bodies they reach"
                } else {
                    "the part"
                },
                crate::report::seconds_text(t),
                match (pictured, m.leaves_a_body()) {
                    (false, _) => "",
                    (true, false) => " The pictures colour this fill time.",
                    (true, true) => {
                        " The pictures colour this fill time on the bodies they reach, and each \
                         other body by the fill from its own gate (listed below), which may end \
                         later."
                    }
                }
            );
        }
    }
    if !f.body_gates.is_empty() {
        let _ = writeln!(
            h,
            "<p id=\"bodies\">A gate per body ({}, which for the body fed by the \
             answer's gate is not that gate; each body's fill time is taken against its own \
             nominal wall; where the gates a picture shows do not reach a body, the picture fills \
             that body from its own gate, listed here):</p>\n<table>\n<tr><th>body</th><th>share of the volume</th>\
             <th>nominal wall</th><th>gate</th><th>longest flow path<br>L_max</th><th>fill time (estimate)</th></tr>",
            f.body_gates[0].rule.words()
        );
        for b in &f.body_gates {
            let cells = match (b.gate, b.l_max_mm, b.fill_time_s) {
                (Some(g), Some(l), Some(t)) => format!(
                    "<td>{} mm</td><td class=\"n\">{l:.1} mm</td><td class=\"n\">{} s</td>",
                    v3(g),
                    seconds_text(t)
                ),
                _ => format!("<td colspan=\"3\">{}</td>", b.rule.no_gate_words()),
            };
            let _ = writeln!(
                h,
                "<tr><th>{}{}</th><td class=\"n\">{:.1} %</td><td class=\"n\">{:.2} mm</td>{cells}</tr>",
                crate::flow::body_name(b.body),
                match (b.is_answer_body, b.pictured) {
                    (true, true) => " (holds the answer's gate; pictured from its own)",
                    (true, false) => " (holds the answer's gate)",
                    (false, true) => " (pictured from its own gate)",
                    (false, false) => "",
                },
                100.0 * b.volume_share,
                b.nominal_wall_mm
            );
        }
        let _ = writeln!(h, "</table>");
    }
    // The fill whose last places are listed, and its gate's name.
    let (answer, gate) = match (&f.strategy, &f.balanced) {
        (crate::flow::Strategy::Balanced, Some(b)) => (Some(&b.fill), "balanced"),
        _ => (f.paper.as_ref(), "paper"),
    };
    // With several gates the answer is a layout: its own last places, all gates open
    // (flow paths from the nearest gate).
    let (answer, whose, layout_note) = match &f.several {
        None => (answer, "the answer's gate".to_string(), ""),
        Some(m) => match &m.fill {
            Some(layout) => (
                Some(layout),
                format!("the {} gates together", m.gates.len()),
                "; flow paths from the nearest gate",
            ),
            None => (
                answer,
                format!("the {gate} gate alone"),
                "; for the layout's own, give its gates with --gate-at",
            ),
        },
    };
    if let Some(g) = answer {
        let last: Vec<String> = g
            .last_to_fill
            .iter()
            .map(|p| {
                format!(
                    "{} ({:.1} mm of flow path from the gate, filled at {} s)",
                    v3(p.point),
                    p.flow_length_mm,
                    seconds_text(p.fill_time_s)
                )
            })
            .collect();
        let _ = writeln!(
            h,
            "<p>Last to fill from {whose} (where the fill ends and air may be trapped: \
             places reached in the last 20 % of the fill time{layout_note}): {}.</p>",
            if last.is_empty() {
                "none".to_string()
            } else {
                last.join(", ")
            }
        );
        weld_list(h, &whose, g);
    }
}

/// The weld lines of the fill from `whose` ("the answer's gate", "your gates", ...).
fn weld_list(h: &mut String, whose: &str, g: &crate::flow::GateFill) {
    if g.weld_lines.is_empty() {
        let _ = writeln!(h, "<p>Weld lines from {whose}: none found.</p>");
        return;
    }
    let _ = writeln!(h, "<p>Weld lines from {whose}:</p>\n<ul>");
    for w in &g.weld_lines {
        let _ = writeln!(
            h,
            "<li>at {} mm, {:.1} mm long, {:.1} mm of flow path from its gate, fronts meeting at {:.0}°</li>",
            v3(w.point),
            w.extent_mm,
            w.flow_length_mm,
            w.meeting_angle_deg
        );
    }
    let _ = writeln!(h, "</ul>");
}

/// The gate-suitability map in words: what is scored, its range, how many scores are exact
/// and how wide the bounds of the others are.
fn suitability_text(h: &mut String, f: &crate::flow::FillAnalysis) {
    let Some(m) = &f.suitability else { return };
    let (what, _) = m.objective.value_words();
    let unit = m.unit;
    let value = |x: f64| m.objective.value_text(x);
    let (lo, hi) = m
        .nodes
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), n| {
            (a.min(n.score), b.max(n.score))
        });
    let best = m.best.map_or("none".to_string(), |b| {
        let n = &m.nodes[b];
        format!(
            "{} mm, {}",
            v3(n.point),
            m.best_value_text().unwrap_or_default()
        )
    });
    let gap = |g: Option<f64>| g.map_or("unbounded".to_string(), |g| format!("{g:.1} %"));
    let _ = writeln!(
        h,
        "<p id=\"suitability\">Gate suitability: {} qualifying nodes scored by the {what} of a \
         gate at each (lower is better; the picture's colours), from {} to {} {unit}. {} scores \
         are exact (to {} {unit}), the others lower bounds whose upper bounds are at most {} \
         above them (median {}). Best node: {best}. {} marches.</p>",
        m.nodes.len(),
        value(lo),
        value(hi),
        m.exact,
        value(m.tolerance),
        gap(m.max_gap_pct),
        gap(m.median_gap_pct),
        m.runs
    );
    if m.spans_bodies() {
        let bests: Vec<String> = m
            .body_bests()
            .map(|(body, n)| format!("{body} at {} mm, {}", v3(n.point), m.score_text(n)))
            .collect();
        let _ = writeln!(
            h,
            "<p id=\"suitability-bodies\">The part has several bodies, and a gate fills only its \
             own: each node is scored by the fill of its body, and the picture colours it by its \
             score over its body's best (1: that best). The best of each body: {}.</p>",
            bests.join("; ")
        );
    }
}

fn timings_table(h: &mut String, r: &Report) {
    let t = &r.timings;
    let _ = writeln!(h, "<h2>Timings</h2>\n<table>");
    let mut rows = vec![("Reading the mesh", Some(t.load_s))];
    rows.push((
        "Ray-casting tree (beside the gate search or the choice of direction, only its time past them added)",
        t.tree_s,
    ));
    rows.push(("Automatic demolding direction", t.demold_s));
    rows.extend([
        (
            "Centre of mass (alongside the rays, not added)",
            Some(t.centre_s),
        ),
        ("Grid", Some(t.grid_s)),
        ("Rays", Some(t.projection_s)),
        ("Rules and choice", Some(t.select_s)),
        (
            "Parting line (alongside the rays, not added)",
            Some(t.parting_s),
        ),
        ("Wall thickness everywhere", t.wall_s),
        ("Fill analysis", t.fill_s),
        (
            "Total (every stage that ran, the overlapping ones once)",
            Some(t.total_s),
        ),
    ]);
    for (name, s) in rows {
        if let Some(s) = s {
            let _ = writeln!(
                h,
                "<tr><td>{name}</td><td class=\"n\">{:.1} ms</td></tr>",
                s * 1e3
            );
        }
    }
    let _ = writeln!(h, "</table>");
}

const GLOSSARY: &str = "<h2>What the numbers mean</h2>
<dl>
<dt>Demolding direction D</dt><dd>The direction the mould opens along. Rays are cast from its
+ side along -D; the gate goes on the +D side. The picture's first view looks along -D.</dd>
<dt>Centre of mass</dt><dd>The surface centre of mass (Eq. 3-5: facet centroids weighted by
area), or the centroid of the enclosed volume with <code>--centre volume</code>. The gate is
placed as near to it as the rules allow, so the melt has about the same way to go in every
direction.</dd>
<dt>Gate radius R</dt><dd>Radius of the gate from the material (Eq. 7 gives the melt velocity,
Eq. 8 the radius that gives the optimal shear rate), or forced by the user. All lengths are
millimetres.</dd>
<dt>Grid, spacing</dt><dd>Nodes laid over the part as seen along D; each node is a candidate
gate. The spacing is the distance between neighbouring nodes.</dd>
<dt>Whole gate circle on the part</dt><dd>The node's ray and the rays of points on a circle of
radius R around it all hit the part, so a gate of that size fits there.</dd>
<dt>Wall thicker than R</dt><dd>The wall thickness along D under the disc exceeds R (the paper's
rule that the gate not be larger than the wall). Unknown on open meshes, where the ray never
leaves the part; such nodes pass.</dd>
<dt>Flat</dt><dd>The circle's points lie within the flatness tolerance along D.</dd>
<dt>Qualifying nodes</dt><dd>Nodes that pass every rule in force; the hatched region of the
picture. The gate is the qualifying node nearest the centre of mass.</dd>
<dt>Distance from the centre of mass</dt><dd>3D distance from the gate point to the centre of
mass (or in the plane across D with <code>--nearest 2d</code>).</dd>
<dt>Parting line</dt><dd>Where the part's faces turn from facing +D to facing -D: the line
where the mould halves meet. Aesthetic parts (<code>--aesthetic</code>) take the gate on it.</dd>
<dt>Colour of the part</dt><dd>The field named on the colour bar, in the unit shown there
(height along D until a flow or thickness analysis provides another field).</dd>
<dt>Fill analysis</dt><dd>A geometric model of the melt's way through the part: the part as
cubic cells, and the shortest way from the gate to every cell through the solid.</dd>
<dt>L_max (longest flow path)</dt><dd>The longest flow length: the way through the solid from
the gate to the place farthest from it along that way, in mm. The place the fill time
estimate reaches last may be another, nearer one behind thin walls.</dd>
<dt>L/t (flow length / wall)</dt><dd>L_max over the nominal wall thickness. Each material fills reliably only up to
a ratio (its limit, from design guides); above it the part may not fill.</dd>
<dt>Pressure (Eq. 1)</dt><dd>The pressure drop of the melt along that way at the optimal
shear rate, 12 &mu; v L / H&sup2; summed along the path, in MPa.</dd>
<dt>Fill time (estimate)</dt><dd>When the melt front reaches a place, in seconds: the way
from the gate, each mm weighted by the wall's resistance relative to its body's nominal
wall H_ref ((H_ref/H)^((n+1)/n): thin walls slow the front), over the front speed of
Eq. 7. Comparable between gates on one part, not between parts (a part of thin walls does
not read slower than one of thick walls: compare L_max, L/t and the pressure); a geometric
estimate, not a simulation nor a machine's fill time. The part's fill time is its last
place's; the time &ldquo;99 % by&rdquo; is when 99 % of the volume is filled: far below the
fill time, a few thin places fill last and set the fill time of nearly any gate (compare
gates by L_max and the pressure first).</dd>
<dt>Wall along D, flow-cell wall, facet wall</dt><dd>Three measures of a wall.
<b>Wall along D</b> (the paper's rule): the node's ray along the demolding direction D,
from the gate through the part; \"thinnest under the disc\" is the least over the gate's
circle. <b>Flow-cell wall</b> (the fill): the wall of the fill's cell at a point, measured
across one facet that passes through the cell (along its inverted normal), as the flow
resistance sees it; the fill's min and max are over one such sample per surface cell. Near
a rib or step that facet may be the rib's side rather than the gate's own facet.
<b>Facet wall</b> (<code>--wall-thickness</code>): every facet measured across, along its
inverted normal; \"at the paper gate's facet\" is the facet the paper gate lies on (a balanced
or placed gate's own wall is its flow-cell wall). The three agree on a
flat wall and differ where the gate sits on a rib, boss or step.</dd>
<dt>Slivers</dt><dd>Facets thinner than 5 % of the nominal wall (films such as a 0.01 mm
step): not mouldable walls, counted apart from the minimum.</dd>
<dt>Bodies</dt><dd>The mesh's separate pieces. Melt never flows from one body to another: a
part of several bodies needs a gate per body; tiny stray bodies (loose facets) are left
out.</dd>
<dt>Balanced gate</dt><dd>The qualifying node whose farthest flow is the shortest (or lowest
resistance with <code>--objective resistance</code>); the report compares it with the paper
gate.</dd>
<dt>Gate suitability</dt><dd>With <code>--suitability</code>, every qualifying node scored by
the balanced gate's objective: L_max of a gate there in mm (or the fill time with
<code>--objective resistance</code>), lower is better. The picture colours the qualifying
region by it (dark blue best, yellow worst; the colour bar spans the scores) and leaves the
rest of the part grey. A score is exact (a march from the node, to one flow cell) or a lower
bound from the marches of far points, with an upper bound beside it in the JSON; the best
node is exact when the balanced search proved its gate.</dd>
<dt>Several gates</dt><dd>With <code>--gates K</code>, K gates that together make the longest
flow as short as possible (or the fill time with <code>--objective resistance</code>); each
fills its share of the volume.</dd>
<dt>Last to fill</dt><dd>Places the melt reaches last, with their flow length and fill time:
where air is trapped and vents go.</dd>
<dt>Weld lines</dt><dd>Where two melt fronts meet after flowing around an obstacle: a weaker,
sometimes visible line.</dd>
<dt>Your gates (<code>--gate-at</code>)</dt><dd>Gates you place yourself. Each point is moved to
the nearest point of the part's surface (\"moved\" says how far; a point farther than a tenth of
the part's diagonal is refused) and judged like a grid node: the same rays and the same rules, the
first rule it fails named. Several are one layout: with the fill analysis they are opened together,
each filling the places it reaches first.</dd>
<dt>Seen along D</dt><dd>Whether the ray along D meets the part first at the gate: a gate on a face
turned away from D, or under another face, cannot be carried by the mould half on the +D side.</dd>
</dl>";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc_4648_vectors() {
        for (plain, coded) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(plain.as_bytes()), coded);
        }
        assert_eq!(base64(&[0xff, 0xfe, 0xfd]), "//79");
    }

    #[test]
    fn escaping_leaves_no_markup() {
        assert_eq!(
            escape("<a href=\"x\">R & 'b'</a>"),
            "&lt;a href=&quot;x&quot;&gt;R &amp; &#39;b&#39;&lt;/a&gt;"
        );
    }
}
