//! The short human summary printed on stdout.

use std::fmt::Write;

use moldgate::report::{seconds_text, three_figures, Report};

fn v3(p: [f64; 3]) -> String {
    format!("({:.3}, {:.3}, {:.3})", p[0], p[1], p[2])
}

/// A thickness in mm, or why it is unknown: on an open mesh the ray may leave through a
/// hole; on a closed one it did not come out (a facet seen edge-on, a sliver).
fn mm(x: Option<f64>, open: bool) -> String {
    match x {
        Some(v) => format!("{v:.2} mm"),
        None if open => "unknown (open mesh)".into(),
        None => "unknown".into(),
    }
}

/// A fill's L/t against the material's limit, after the ratio: " (limit 250)", or
/// " EXCEEDS the material's 10"; nothing when the limit is unknown.
fn limit_words(g: &moldgate::flow::GateFill) -> String {
    match g.flow_ratio_limit {
        Some(m) if g.exceeds_flow_ratio => format!(" EXCEEDS the material's {m:.0}"),
        Some(m) => format!(" (limit {m:.0})"),
        None => String::new(),
    }
}

/// One line of a gate's fill.
fn fill_line(s: &mut String, label: &str, g: &moldgate::flow::GateFill) {
    let limit = limit_words(g);
    let _ = writeln!(
        s,
        "  {label} {}: flow-cell wall {:.2} mm, longest flow L_max {:.1} mm (mean {:.1}), flow length / wall L/t {:.0}{limit}, pressure {} MPa, fill time {} s (estimate; 99 % of the volume by {} s)",
        v3(g.gate),
        g.wall_across_mm,
        g.l_max_mm,
        g.l_mean_mm,
        g.flow_ratio,
        three_figures(g.pressure_mpa),
        seconds_text(g.fill_time_s),
        seconds_text(g.fill_time_99_s)
    );
}

/// The first three of a fill's last places to fill and of its weld lines, their flow paths
/// measured from `from` (`the gate`, `the nearest gate`).
fn fill_places(s: &mut String, g: &moldgate::flow::GateFill, from: &str) {
    for (i, q) in g.last_to_fill.iter().enumerate().take(3) {
        let _ = writeln!(
            s,
            "    last to fill #{} (in the last 20 % of the fill): {}, {:.1} mm of flow path from {from}, filled at {} s",
            i + 1,
            v3(q.point),
            q.flow_length_mm,
            seconds_text(q.fill_time_s)
        );
    }
    more(
        s,
        g.last_to_fill.len(),
        ("last place to fill", "last places to fill"),
    );
    for w in g.weld_lines.iter().take(3) {
        let _ = writeln!(
            s,
            "    fronts meet ({:.0} deg) near {}, {:.1} mm from {from}",
            w.meeting_angle_deg,
            v3(w.point),
            w.flow_length_mm
        );
    }
    more(
        s,
        g.weld_lines.len(),
        ("place where fronts meet", "places where fronts meet"),
    );
}

/// The fill analysis in a few lines; `balanced_is_paper_gate` when the balanced gate is the
/// paper's grid gate beside another answer ([`Report::balanced_is_paper_gate_beside_another`]).
fn fill(
    s: &mut String,
    f: &moldgate::flow::FillAnalysis,
    label: &str,
    balanced_is_paper_gate: bool,
) {
    let _ = writeln!(
        s,
        "fill: {} cells of {:.3} mm, nominal wall {:.2} mm ({}), {} {}",
        f.cells,
        f.cell_mm,
        f.nominal_wall_mm,
        f.wall_source.words(),
        f.bodies,
        if f.bodies == 1 { "body" } else { "bodies" }
    );
    let _ = writeln!(
        s,
        "  (flow-cell wall: the wall of the fill's cell at a point, measured across one facet through the cell, which near a rib or step may not be the gate's own facet; the paper's wall along D is the node's ray; --wall-thickness measures every facet)"
    );
    let _ = writeln!(
        s,
        "  (fill time: the way from the gate over the front speed of Eq. 7, each mm weighted by its wall against its body's nominal wall; an estimate for comparing gates on one part, not between parts (a part of thin walls does not read slower than one of thick walls: compare L_max, L/t and the pressure), and not the fill time of a moulding machine, which sets its own injection rate; the 99 % time is when 99 % of the volume is filled: far below the fill time, a few thin places fill last and set the fill time of nearly any gate)"
    );
    if let Some(w) = &f.wall {
        let mm = |x: Option<f64>| x.map_or("unknown".to_string(), |v| format!("{v:.2}"));
        let _ = writeln!(
            s,
            "  flow-cell walls (the fill model's: one facet sampled per surface cell, {} cells, {} {} left out): min {}, 5 % {}, median {}, 95 % {}, max {} mm",
            w.samples,
            w.slivers,
            if w.slivers == 1 { "sliver" } else { "slivers" },
            mm(w.min_mm),
            mm(w.p05_mm),
            mm(w.nominal_mm),
            mm(w.p95_mm),
            mm(w.max_mm)
        );
    }
    if let Some(p) = &f.paper {
        fill_line(s, label, p);
        fill_places(s, p, "the gate");
    }
    match &f.balanced {
        Some(b) if b.is_paper_gate => {
            let _ = writeln!(
                s,
                "  balanced gate: the paper gate ({})",
                if b.search.proven {
                    format!(
                        "no candidate does better by more than a flow cell, {} flow fields",
                        b.search.runs
                    )
                } else {
                    format!(
                        "no candidate tried did better by more than a flow cell; {}",
                        b.search.unproven_words()
                    )
                }
            );
        }
        Some(b) => {
            let is_grid_gate = balanced_is_paper_gate;
            let name = if is_grid_gate {
                "balanced gate (the paper gate)"
            } else {
                "balanced gate"
            };
            fill_line(s, name, &b.fill);
            let _ = writeln!(
                s,
                "    shortens {} by {:.1} % against the {} ({})",
                match f.objective {
                    moldgate::flow::Objective::Length => "the longest flow",
                    moldgate::flow::Objective::Resistance => "the fill time",
                },
                b.improvement_pct,
                label.trim(),
                match (b.search.proven, is_grid_gate) {
                    (true, false) => format!("{} flow fields, optimal", b.search.runs),
                    (true, true) => format!(
                        "no candidate does better than the paper gate by more than a flow cell, {} flow fields",
                        b.search.runs
                    ),
                    (false, _) => b.search.unproven_words(),
                }
            );
        }
        None => {
            let _ = writeln!(
                s,
                "  balanced gate: none, no qualifying grid node lies on the gate's body"
            );
        }
    }
    if let Some(m) = &f.suitability {
        let what = match m.objective {
            moldgate::flow::Objective::Length => "longest flow",
            moldgate::flow::Objective::Resistance => "fill time",
        };
        let value = |x: f64| m.objective.value_text(x);
        let (lo, hi) = m
            .nodes
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), n| {
                (a.min(n.score), b.max(n.score))
            });
        if let Some(best) = m.best.map(|b| &m.nodes[b]) {
            let _ = writeln!(
                s,
                "  gate suitability: {} nodes scored by the {what} of a gate there, {} to {} {} (lower is better); best {}: {}",
                m.nodes.len(),
                value(lo),
                value(hi),
                m.unit,
                v3(best.point),
                m.best_value_text().unwrap_or_default()
            );
            if m.spans_bodies() {
                let bests: Vec<String> = m
                    .body_bests()
                    .map(|(body, n)| format!("{body} {}: {}", v3(n.point), m.score_text(n)))
                    .collect();
                let _ = writeln!(
                    s,
                    "    each node is scored by the fill of its own body; the best of each: {} (the pictures colour each node against its own body's best)",
                    bests.join(", ")
                );
            }
            let _ = writeln!(
                s,
                "    {} exact (to {} {}, the cells' resolution: the balanced gate's own value may differ by as much), the others lower bounds within {} of their upper bounds ({} marches)",
                m.exact,
                value(m.tolerance),
                m.unit,
                m.max_gap_pct
                    .map_or("unbounded".to_string(), |g| format!("{g:.1} %")),
                m.runs
            );
        }
    }
    if let Some(m) = &f.several {
        // The layout's values are of its objective: mm of flow length, or s of fill time.
        let (what, unit) = f.objective.value_words();
        let worst = |x: f64| format!("{what} {} {unit}", f.objective.value_text(x));
        let _ = writeln!(
            s,
            "  {} gates: {} ({}), balance {:.2} ({})",
            m.gates.len(),
            worst(m.value()),
            m.against_single_words(),
            m.balance,
            m.balance_words()
        );
        // Chosen by its flow length, the layout's fill time is given too, said not minimised.
        if let (moldgate::flow::Objective::Length, Some(t)) = (f.objective, m.layout_fill_time_s) {
            let _ = writeln!(
                s,
                "  their fill time (estimate){}: {} s, which the layout does not minimise (it minimises L_max)",
                // A layout that leaves a body without a gate: the time is of the bodies it
                // reaches.
                if m.leaves_a_body() { " over the bodies they reach" } else { "" },
                moldgate::report::seconds_text(t)
            );
        }
        if let Some(g) = &m.fill {
            let limit = limit_words(g);
            let _ = writeln!(
                s,
                "  all {} gates open: flow length / wall L/t {:.0}{limit}, pressure {} MPa (Eq. 1: the most any place needs from its gate)",
                m.gates.len(),
                g.flow_ratio,
                three_figures(g.pressure_mpa)
            );
            fill_places(s, g, "the nearest gate");
        }
        // A layout that leaves a body without a gate: its shares are of the volume it
        // reaches.
        let of = if m.leaves_a_body() {
            "of the volume the layout reaches"
        } else {
            "of the volume"
        };
        for (i, g) in m.gates.iter().enumerate() {
            let _ = writeln!(
                s,
                "    gate {}: {} fills {:.1} % {of} (the share it reaches first by {}), {}",
                i + 1,
                v3(g.point),
                100.0 * g.volume_share,
                f.objective.field_words(),
                worst(g.value())
            );
        }
    }
    for b in &f.body_gates {
        let gate = match (b.gate, b.l_max_mm, b.fill_time_s) {
            (Some(g), Some(l), Some(t)) => {
                format!("own gate {} ({}){}, longest flow {l:.1} mm, fill time {} s at its own nominal wall of {:.2} mm", v3(g), b.rule.words(), if b.pictured { format!("; the pictures fill the body from it, drawn as 'gate of {}'", moldgate::flow::body_name(b.body)) } else { String::new() }, seconds_text(t), b.nominal_wall_mm)
            }
            _ => b.rule.no_gate_words().into(),
        };
        let _ = writeln!(
            s,
            "  {} ({:.1} % of the volume{}): {gate}",
            moldgate::flow::body_name(b.body),
            100.0 * b.volume_share,
            if b.is_answer_body {
                ", holds the answer's gate"
            } else {
                ""
            }
        );
    }
}

/// The name of the gate the fill starts from (its `paper` fill): the paper's or the
/// aesthetic gate.
fn gate_name(mode: moldgate::GateMode) -> String {
    format!("{} gate", mode.name())
}

/// Renders the report as a few lines of text.
pub fn render(r: &Report) -> String {
    let mut s = String::new();
    let open = r.mesh.open_edges > 0;
    let name = r
        .input
        .path
        .clone()
        .or(r.input.sample.as_ref().map(|n| format!("sample '{n}'")))
        .unwrap_or_default();
    let name = crate::printable(&name);
    let m = &r.mesh;
    let _ = writeln!(
        s,
        "{name}: {} in {}, {} triangles, {} vertices, {} {}, {}",
        match m.format {
            moldgate::mesh::Format::StlBinary => "binary STL",
            moldgate::mesh::Format::StlAscii => "ASCII STL",
            moldgate::mesh::Format::Obj => "OBJ",
            moldgate::mesh::Format::PlyAscii => "ASCII PLY",
            moldgate::mesh::Format::PlyBinaryLittleEndian => "binary PLY (little-endian)",
            moldgate::mesh::Format::PlyBinaryBigEndian => "binary PLY (big-endian)",
            moldgate::mesh::Format::Generated => "generated",
            moldgate::mesh::Format::Arrays => "arrays",
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
    // Where the part lies in its file's frame (the frame of --gate-at and --keep-out). A
    // side to 0.1 mm, or three figures below a millimetre (a part read in other units).
    let side = |x: f64| {
        if x >= 1.0 {
            format!("{x:.1}")
        } else {
            three_figures(x)
        }
    };
    let size = std::array::from_fn::<f64, 3, _>(|i| m.bounds_max[i] - m.bounds_min[i]);
    if size.iter().all(|s| s.is_finite()) {
        let _ = writeln!(
            s,
            "part box: {} to {} mm, size {} x {} x {} mm",
            v3(m.bounds_min),
            v3(m.bounds_max),
            side(size[0]),
            side(size[1]),
            side(size[2])
        );
    }
    let o = &r.options;
    let _ = writeln!(
        s,
        "material {}: gate radius {:.4} mm{}{}",
        r.material.material.name,
        o.gate_radius_mm,
        match o.gate_radius_source {
            moldgate::report::RadiusSource::Material => " (from the material)",
            moldgate::report::RadiusSource::Forced => " (forced)",
            moldgate::report::RadiusSource::Fitted =>
                " (the largest that fits, taken with --fit-radius: see below)",
        },
        // Family values are a starting point, not a grade's data: say so where they are used.
        moldgate::material::typical_note(&r.material.material)
            .map(|note| format!(" {note}"))
            .unwrap_or_default()
    );
    let _ = writeln!(
        s,
        "demold {}, grid {} x {} nodes at {} mm ({})",
        v3(o.demold),
        r.grid.n_u,
        r.grid.n_w,
        three_figures(o.spacing_mm),
        o.spacing_rule
    );
    let _ = writeln!(
        s,
        "centre of mass ({}): {}",
        match r.centre_of_mass.kind {
            moldgate::CentreKind::Surface => "of the surface",
            moldgate::CentreKind::Volume => "of the volume",
        },
        v3(r.centre_of_mass.used)
    );
    let c = &r.counts;
    // The counts are the grid's at the material's radius: with the fitted radius taken,
    // the gate below comes from another radius, which the line must not hide.
    let at_radius = match &r.radius_fit {
        Some(f) if f.accepted => format!(" (at R_gate = {:.3} mm, before the fit)", f.refused_mm),
        _ => String::new(),
    };
    let _ = writeln!(
        s,
        "nodes{at_radius}: {} on the grid -> {} on the part -> {} with the whole gate disc on the part -> {} with a wall thicker than the radius ({} unknown); {} flat; {} qualify",
        c.nodes, c.centre_hits, c.circle_on_part, c.thicker_than_radius, c.thickness_unknown, c.flat, c.qualifying
    );
    if c.kept_out + c.cosmetic > 0 {
        let _ = writeln!(
            s,
            "keep-out: {} nodes removed by the regions, {} on cosmetic faces",
            c.kept_out, c.cosmetic
        );
    }
    if let Some(g) = &r.paper_gate {
        let _ = writeln!(
            s,
            "paper gate: {} mm, normal {}, wall along D {} (the paper's rule: the node's ray; thinnest under the disc {}), {:.3} mm from the centre of mass",
            v3(g.point),
            v3(g.normal),
            mm(g.thickness_mm, open),
            mm(g.disc_thickness_mm, open),
            g.distance_3d_mm
        );
    }
    if let Some(g) = &r.aesthetic_gate {
        let _ = writeln!(
            s,
            "aesthetic gate (parting line, {:.1} mm long): {} mm, {:.3} mm from the centre of mass (an edge gate in the parting plane: the paper's rules for a gate seen along D, its disc on the part and the wall along D, do not apply to it; check the wall where it enters)",
            r.parting_line.length_mm,
            v3(g.point),
            g.distance_3d_mm
        );
    }
    if let Some(f) = &r.fill {
        fill(
            &mut s,
            f,
            &format!("{:<13}", gate_name(r.options.mode)),
            r.balanced_is_paper_gate_beside_another(),
        );
    }
    if let Some(p) = &r.placed_gates {
        placed_gates(&mut s, r, p, open);
    }
    if let Some(f) = &r.radius_fit {
        // Why R_gate was refused: every disc wholly on the part sits on a wall no thicker
        // than it; where the part is thicker, it is too narrow for the disc.
        let why = match f.thickest_wall_mm {
            Some(th) => format!(
                "at R_gate = {:.3} mm every disc wholly on the part sits on a wall of at most {th:.3} mm, and any thicker wall is too narrow for the disc",
                f.refused_mm
            ),
            None => format!(
                "at R_gate = {:.3} mm no disc wholly on the part has a wall thicker than the radius",
                f.refused_mm
            ),
        };
        let _ = match (f.radius_mm, &f.gate) {
            (Some(radius), Some(g)) => writeln!(
                s,
                "largest gate radius that fits: {radius:.3} mm ({why}), gate {} mm, {:.3} mm from the centre of mass{}",
                v3(g.point),
                g.distance_3d_mm,
                if f.accepted { ", taken (--fit-radius)" } else { "; --fit-radius takes it" }
            ),
            _ => writeln!(
                s,
                "largest gate radius that fits: none down to {:.3} mm ({why})",
                f.floor_mm
            ),
        };
    }
    match &r.gate {
        Some(g) => {
            let mode = match (g.strategy, g.mode) {
                (moldgate::flow::Strategy::Balanced, _) => "balanced",
                (_, moldgate::GateMode::Paper) => "paper",
                (_, moldgate::GateMode::Aesthetic) => "aesthetic",
            };
            match &g.gates {
                Some(gates) => {
                    // The layout is the better of two searches (from the best single gate,
                    // and from the place it reaches last): no one gate seeds it.
                    let points: Vec<String> = gates.iter().map(|g| v3(g.point)).collect();
                    let _ = writeln!(
                        s,
                        "GATES ({} gates, one layout): {} mm",
                        gates.len(),
                        points.join(", ")
                    );
                }
                None => {
                    let _ = writeln!(s, "GATE ({mode}): {} mm", v3(g.point));
                }
            }
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
            .map(|c| {
                let at_least = if c.evaluated { "" } else { "at least " };
                format!(
                    "{} {}: {at_least}{:.1} mm^2",
                    c.label(),
                    v3(c.direction),
                    c.undercut.area_mm2
                )
            })
            .collect();
        let _ = writeln!(
            s,
            "demold auto: undercut of each direction tried: {}",
            tried.join("; ")
        );
    }
    if let Some(w) = &r.wall_thickness {
        let _ = writeln!(
            s,
            "wall thickness of every facet (across, along its inverted normal): min {}, nominal {}, max {}, at the paper gate's facet {} ({:.1} % of the area unknown)",
            mm(w.min_mm, open),
            mm(w.nominal_mm, open),
            mm(w.max_mm, open),
            match (&r.paper_gate, w.at_gate_mm) {
                (None, _) => "none (no gate)".to_string(),
                (Some(_), x) => mm(x, open),
            },
            100.0 * w.unknown_area_share
        );
        if let Some(m) = w.sliver_min_mm {
            let _ = writeln!(
                s,
                "  {} sliver facets (thinner than 5 % of the nominal, down to {m:.4} mm) left out of the min",
                w.slivers
            );
        }
    }
    for w in &r.warnings {
        let _ = writeln!(s, "warning: {w}");
    }
    let t = &r.timings;
    let ms = |x: f64| x * 1e3;
    let mut stages = vec![format!("load {:.1}", ms(t.load_s))];
    if let Some(x) = t.tree_s {
        // The tree is built alongside the gate search, or alongside the choice of the
        // automatic direction (which holds the gate search).
        let alongside = if r.demold_auto.is_none() {
            " alongside the gate search"
        } else {
            " alongside the choice of direction"
        };
        stages.push(format!("ray tree {:.1}{alongside}", ms(x)));
    }
    if let Some(x) = t.demold_s {
        stages.push(format!("demold auto {:.1}", ms(x)));
    }
    stages.push(format!(
        "grid {:.1}, rays {:.1} with the centre of mass {:.1} and the parting line {:.1} alongside, select {:.1}",
        ms(t.grid_s),
        ms(t.projection_s),
        ms(t.centre_s),
        ms(t.parting_s),
        ms(t.select_s)
    ));
    if let Some(x) = t.wall_s {
        stages.push(format!("wall thickness {:.1}", ms(x)));
    }
    if let (Some(x), Some(f)) = (t.fill_s, &r.fill) {
        let ft = &f.times;
        // Cells made beside the gate search (or the choice of direction) are in the tree's
        // join, not in the fill's time.
        let beside = match (ft.cells_beside_s > 0.0, r.demold_auto.is_none()) {
            (true, true) => format!(
                " ({:.1} of them beside the gate search)",
                ms(ft.cells_beside_s)
            ),
            (true, false) => format!(
                " ({:.1} of them beside the choice of direction)",
                ms(ft.cells_beside_s)
            ),
            (false, _) => String::new(),
        };
        // The walls are measured beside the paper gate's flow length and, when it is the
        // objective, the balanced search: those count what they took beyond the walls.
        let alongside = match f.objective {
            // Read from the wall of every facet, the samples took no time of their own.
            _ if t.wall_s.is_some() => "",
            moldgate::flow::Objective::Length => {
                " with the paper gate's flow length and the balanced search alongside"
            }
            moldgate::flow::Objective::Resistance => " with the paper gate's flow length alongside",
        };
        stages.push(format!(
            "fill {:.1}: wall samples {:.1}{alongside}, cells {:.1}{beside}, paper gate {:.1}, balanced search {:.1}, several gates {:.1}",
            ms(x),
            ms(ft.wall_s),
            ms(ft.voxels_s),
            ms(ft.paper_s),
            ms(ft.balanced_s),
            ms(ft.several_s)
        ));
        if r.placed_gates.is_some() {
            stages.push(format!("your gates' fill {:.1}", ms(ft.placed_s)));
        }
        if let Some(x) = ft.suitability_s {
            if let Some(last) = stages.last_mut() {
                last.push_str(&format!(", suitability map {:.1}", ms(x)));
            }
        }
    }
    let _ = writeln!(s, "time: {:.1} ms ({})", ms(t.total_s), stages.join(", "));
    moldgate::report::without_negative_zeros(&s, false)
}

/// The wall along D at a gate and the smallest under its disc.
fn wall(at: Option<f64>, disc: Option<f64>, open: bool) -> String {
    match (at, disc) {
        (Some(a), Some(d)) => format!("{a:.2} mm ({d:.2} mm)"),
        _ => mm(at, open),
    }
}

/// A rule the designer's gate fails, in a designer's words.
fn rule_words(rule: moldgate::study::judge::FailedRule) -> &'static str {
    use moldgate::study::judge::FailedRule as F;
    match rule {
        F::NotSeenAlongD => "not reachable from the +D mould half",
        F::CircleOffPart => "the gate disc runs off the part",
        F::ThinWall => "the wall under it is thinner than the gate radius",
        F::NotFlat => "not flat under the disc",
        F::KeptOut => "in a keep-out region",
        F::Cosmetic => "on the cosmetic side",
    }
}

/// The designer's gates: each one's verdict, then the fill of their layout beside the
/// paper gate's and the balanced gate's (the fill always searches the balanced gate).
fn placed_gates(s: &mut String, r: &Report, p: &moldgate::study::judge::PlacedGates, open: bool) {
    let n = p.gates.len();
    let _ = writeln!(
        s,
        "your gates (--gate-at, moved to the nearest surface point; farther than {:.1} mm is refused):",
        p.snap_limit_mm
    );
    let _ = writeln!(
        s,
        "  {:<14} {:<28} {:>8}  {:<22} the paper's rules (disc of the gate radius)",
        "gate", "on the surface (mm)", "moved", "wall along D (disc)",
    );
    for (i, g) in p.gates.iter().enumerate() {
        let verdict = match (g.failed_rule, &g.why) {
            (None, _) => moldgate::study::judge::qualifies_words(g.off_flat_mm()),
            (Some(rule), Some(why)) => format!("FAILS: {} ({why})", rule_words(rule)),
            (Some(rule), None) => format!("FAILS: {}", rule_words(rule)),
        };
        let _ = writeln!(
            s,
            "  {:<14} {:<28} {:>5.2} mm  {:<22} {verdict}",
            format!("your gate {}", i + 1),
            v3(g.point),
            g.moved_mm,
            if g.seen_along_d {
                wall(g.thickness_mm, g.disc_thickness_mm, open)
            } else {
                "-".into()
            },
        );
    }
    for g in moldgate::study::judge::beside_placed(r) {
        let _ = writeln!(
            s,
            "  {:<14} {:<28} {:>8}  {:<22} {}",
            g.name,
            v3(g.point),
            "",
            if g.thickness_mm.is_some() || g.disc_thickness_mm.is_some() {
                wall(g.thickness_mm, g.disc_thickness_mm, open)
            } else {
                "-".into()
            },
            g.verdict
        );
    }
    let Some(fill) = &p.fill else {
        if let Some(why) = &p.no_fill_reason {
            let _ = writeln!(s, "  no fill of your gates: {why}");
        }
        return;
    };
    let _ = writeln!(
        s,
        "  {:<30} {:>9} {:>10} {:>16} {:>10} {:>10} {:>6}  last to fill",
        if n == 1 {
            "fill (even where a rule fails)"
        } else {
            "fill, one layout"
        },
        "longest",
        "pressure",
        "flow/wall (limit)",
        "fill time",
        "99 % by",
        "welds"
    );
    let row = |s: &mut String, label: &str, g: &moldgate::flow::GateFill| {
        let ratio = match g.flow_ratio_limit {
            Some(m) if g.exceeds_flow_ratio => format!("{:.0} OVER {m:.0}", g.flow_ratio),
            Some(m) => format!("{:.0} ({m:.0})", g.flow_ratio),
            None => format!("{:.0}", g.flow_ratio),
        };
        let last = g
            .last_to_fill
            .first()
            .map_or("-".to_string(), |q| v3(q.point));
        // On a part of several bodies a gate fills its own body only: how much of the part
        // it reaches says whether two rows compare like with like.
        let reach = if g.reached_share < 0.9995 {
            format!("  (reaches {:.1} % of the part)", 100.0 * g.reached_share)
        } else {
            String::new()
        };
        let _ = writeln!(
            s,
            "  {label:<30} {:>6.1} mm {:>6} MPa {ratio:>16} {:>8} s {:>8} s {:>6}  {last}{reach}",
            g.l_max_mm,
            three_figures(g.pressure_mpa),
            seconds_text(g.fill_time_s),
            seconds_text(g.fill_time_99_s),
            g.weld_lines.len()
        );
    };
    row(
        s,
        if n == 1 {
            "your gate"
        } else {
            "your gates together"
        },
        fill,
    );
    if let Some(f) = &r.fill {
        if let Some(paper) = &f.paper {
            row(s, &gate_name(r.options.mode), paper);
        }
        match &f.balanced {
            Some(b) if b.is_paper_gate => {
                let _ = writeln!(
                    s,
                    "  {:<30} the paper gate (no candidate {} better by more than a cell)",
                    "balanced gate",
                    if b.search.proven { "is" } else { "tried was" }
                );
            }
            Some(b) => row(s, r.balanced_row_name(), &b.fill),
            None => {}
        }
    }
    if n > 1 {
        for words in (0..n).filter_map(|i| p.share_words(i)) {
            let _ = writeln!(s, "    {words}");
        }
    }
}

/// The summary lists the first three of a gate's last places to fill and of its weld
/// lines: when there are more, a line says how many and where they all are.
fn more(s: &mut String, count: usize, (one, many): (&str, &str)) {
    if count > 3 {
        let left = count - 3;
        let _ = writeln!(
            s,
            "    ... {left} more {} in the JSON and the report page ({count} in all)",
            if left == 1 { one } else { many }
        );
    }
}
