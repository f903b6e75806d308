// The results beside the view, from the report JSON (the schema of docs/json-schema.md, the
// same as `moldgate locate --json`). Raw numbers sit in data- attributes so tests can compare
// them with the command line's to the last bit; the text is rounded for people.

import { inPageWords, seconds, threeFigures } from "./format.js";

const el = (tag, attrs = {}, ...children) => {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (v !== undefined && v !== null) e.setAttribute(k, String(v));
  }
  for (const c of children) e.append(c instanceof Node ? c : document.createTextNode(String(c)));
  return e;
};

/** `x` rounded for reading, "-0.00" written "0.00". */
const fixed = (x, digits = 2) => {
  if (x === null || x === undefined) return "unknown";
  const s = x.toFixed(digits);
  return /^-0\.?0*$/.test(s) ? s.slice(1) : s;
};
const mm = (x, digits = 2) => (x === null || x === undefined ? "unknown" : `${fixed(x, digits)} mm`);
const v3 = (p, digits = 2) => `(${p.map((c) => fixed(c, digits)).join(", ")})`;
const xyz = (p) => ({ "data-x": p[0], "data-y": p[1], "data-z": p[2] });

/** A definition list from [term, description] rows (a description may be an element). */
function list(id, rows) {
  const dl = el("dl", { id });
  for (const [term, value, attrs = {}] of rows) {
    dl.append(el("dt", {}, term), el("dd", attrs, value));
  }
  return dl;
}

function section(id, title, ...content) {
  return el("section", { id, class: "result" }, el("h3", {}, title), ...content);
}

function gateSection(r) {
  const g = r.gate;
  const mode = g.strategy === "balanced" ? "balanced" : g.mode;
  const paper = r.paper_gate;
  const several = r.fill?.several;
  const rows = [];
  if (several) {
    // A layout: its gates are listed below; the paper gate's own rows say whose they are.
    const minimised = r.fill.objective === "resistance" ? "fill time" : "longest flow path";
    rows.push(["Gates", `${several.gates.length} gates sharing the part, listed below (gate 1 at ${v3(g.point)} mm)`, { id: "gate-point", ...xyz(g.point) }]);
    rows.push(["Chosen by", `a layout of ${several.gates.length} gates minimising the ${minimised}`, { id: "gate-mode", "data-value": "several" }]);
    if (paper) {
      rows.push(["Paper gate (nearest the centre of mass)", `${v3(paper.point)} mm`, xyz(paper.point)]);
      rows.push(["Wall under the paper gate (along D)", mm(paper.thickness_mm), { id: "gate-wall", "data-value": paper.thickness_mm }]);
      rows.push(["Thinnest wall under its disc (along D)", mm(paper.disc_thickness_mm), { id: "gate-disc-wall", "data-value": paper.disc_thickness_mm }]);
      rows.push(["Paper gate from the centre of mass", mm(paper.distance_3d_mm, 1), { "data-value": paper.distance_3d_mm }]);
    }
  } else {
    rows.push(["Gate point", `${v3(g.point)} mm`, { id: "gate-point", ...xyz(g.point) }]);
    rows.push(["Chosen by", { paper: "the paper's rule: nearest the centre of mass", aesthetic: "the parting line (aesthetic)", balanced: "the balanced fill" }[mode] ?? mode, { id: "gate-mode", "data-value": mode }]);
    if (paper && mode === "paper") {
      rows.push(["Surface normal", v3(paper.normal, 3), { id: "gate-normal", ...xyz(paper.normal) }]);
      rows.push(["Wall under the gate (along D, the paper's rule)", mm(paper.thickness_mm), { id: "gate-wall", "data-value": paper.thickness_mm }]);
      // The node's ray alone can cross a boss or a rib: the disc's thinnest wall beside it.
      rows.push(["Thinnest wall under the gate's disc (along D)", mm(paper.disc_thickness_mm), { id: "gate-disc-wall", "data-value": paper.disc_thickness_mm }]);
      rows.push(["From the centre of mass", mm(paper.distance_3d_mm, 1), { "data-value": paper.distance_3d_mm }]);
    }
  }
  rows.push([
    "Gate radius R",
    `${r.options.gate_radius_mm.toFixed(3)} mm (${{ forced: "given", fitted: "the largest that fits" }[r.options.gate_radius_source] ?? `Eq. 8, ${r.material.name}`})`,
    { id: "gate-radius", "data-value": r.options.gate_radius_mm },
  ]);
  if (r.wall_thickness) {
    rows.push(["Wall of the paper gate's facet (across, every facet measured)", mm(r.wall_thickness.at_gate_mm), { "data-value": r.wall_thickness.at_gate_mm }]);
  }
  const content = [list("gate", rows)];
  if (several) {
    // The layout's values are of its objective: mm of L_max, or s of fill time.
    const worst = (x) => (x.fill_time_s != null ? `fill time ${seconds(x.fill_time_s)} s` : `L_max ${x.l_max_mm.toFixed(1)} mm`);
    const ol = el("ol", { id: "several-gates" });
    // A layout that leaves a body without a gate: its shares are of the volume it reaches.
    const of = several.fill && several.fill.reached_share < 0.9995 ? "of the volume the layout reaches" : "of the volume";
    for (const s of several.gates) {
      ol.append(el("li", xyz(s.point), `${v3(s.point)} mm fills ${(100 * s.volume_share).toFixed(1)} % ${of}, ${worst(s)}`));
    }
    // As the library's MultiGate::against_single_words and balance_words.
    const against = several.bodies > 1
      ? `on ${several.bodies} bodies, each fed by its own gates, where the balanced gate alone feeds one`
      : `${several.improvement_pct.toFixed(1)} % shorter than with the balanced gate`;
    const balance = several.bodies > 1 ? "smallest share / largest of the gates of one body" : "smallest share / largest";
    content.push(el("p", { id: "several-worst" }, `${several.gates.length} gates: ${worst(several)} (${against}), balance ${several.balance.toFixed(2)} (${balance})`), ol);
    // Chosen by its flow length, the layout's fill time is given too, said not minimised.
    if (several.fill_time_s == null && several.layout_fill_time_s != null) {
      content.push(el("p", { id: "layout-fill-time", "data-value": several.layout_fill_time_s }, `These gates together fill ${several.fill && several.fill.reached_share < 0.9995 ? "the bodies they reach" : "the part"} in ${seconds(several.layout_fill_time_s)} s (estimate), a time the layout does not minimise (it minimises the longest flow path).`));
    }
    // The fill with all its gates open: L/t and the Eq. 1 pressure of the layout.
    const g = several.fill;
    if (g) {
      const limit = g.flow_ratio_limit ? (g.exceeds_flow_ratio ? `, over the material's limit of ${g.flow_ratio_limit.toFixed(0)}` : ` (limit ${g.flow_ratio_limit.toFixed(0)})`) : "";
      content.push(el("p", { id: "layout-fill", "data-flow-ratio": g.flow_ratio, "data-pressure": g.pressure_mpa }, `With all ${several.gates.length} gates open: flow length / wall L/t ${g.flow_ratio.toFixed(0)}${limit}, Eq. 1 pressure ${threeFigures(g.pressure_mpa)} MPa (the most any place needs from its gate).`));
    }
  }
  return section("gate-result", "Gate", ...content);
}

function noGateSection(r, gates) {
  const tries = el("ul", { id: "no-gate-tries" });
  // A part whose size suggests other units fails for that reason more often than any.
  if (r.mesh.size_suggests_other_units) tries.append(el("li", { id: "try-units" }, `'Units of the file': the part is read as ${r.mesh.units}, which makes it ${r.mesh.units === "mm" ? "very small or very large" : "an unlikely size"} for a moulded part`));
  const aesthetic = r.options.mode === "aesthetic";
  // The wall rule removed the last nodes: the largest radius that fits is one tick away.
  const wallRule = r.counts.circle_on_part > 0 && r.counts.thicker_than_radius === 0;
  if (wallRule && r.options.gate_radius_source !== "fitted") tries.append(el("li", { id: "try-fit-radius" }, "'When no node passes the wall rule, take the largest gate radius that fits' (Advanced)"));
  tries.append(
    el("li", {}, "a smaller gate radius (Advanced) or a finer grid spacing"),
    el("li", {}, "another demolding direction, or 'auto'"),
    el("li", {}, "'Wall thicker than the gate radius: not required' when the walls are thin"),
  );
  // The parting line's gate, unless it is what failed or several gates were asked (the
  // two cannot be used together); when it failed, the other rule of the parting line.
  if (aesthetic) tries.append(el("li", { id: "try-parting-line" }, "'Parting line: the longest loop between the sides' (Advanced), or the paper's gate (untick 'Aesthetic')"));
  else if (!(gates > 1)) tries.append(el("li", { id: "try-aesthetic" }, "'Aesthetic: gate on the parting line'"));
  if (r.counts.kept_out + r.counts.cosmetic > 0) tries.append(el("li", {}, "smaller keep-out regions, or no cosmetic side"));
  return section("no-gate", "No gate",
    el("p", { id: "no-gate-reason", class: "warning", "data-reason": r.no_gate_reason }, inPageWords(r.no_gate_reason ?? "no node qualifies")),
    el("p", {}, "What to try:"), tries);
}

function gateFill(id, title, f) {
  const limit = f.flow_ratio_limit;
  const ratio = limit === null || limit === undefined
    ? f.flow_ratio.toFixed(0)
    : `${f.flow_ratio.toFixed(0)} ${f.exceeds_flow_ratio ? "EXCEEDS" : "within"} the material's limit of ${limit.toFixed(0)}`;
  const rows = [
    ["Gate at", `${v3(f.gate)} mm`, { class: "gate-at", ...xyz(f.gate) }],
    ["Longest flow path L_max", `${f.l_max_mm.toFixed(1)} mm (mean ${f.l_mean_mm.toFixed(1)})`, { class: "l-max", "data-value": f.l_max_mm }],
    ["Flow-cell wall at the gate (the fill model's sample)", mm(f.wall_across_mm), { "data-value": f.wall_across_mm }],
    ["Flow length / wall L/t", ratio, { class: f.exceeds_flow_ratio ? "flow-ratio warning" : "flow-ratio", "data-value": f.flow_ratio }],
    ["Fill pressure (Eq. 1)", `${threeFigures(f.pressure_mpa)} MPa`, { class: "pressure", "data-value": f.pressure_mpa }],
    ["Fill time (a geometric estimate, not a machine's)", `${seconds(f.fill_time_s)} s`, { class: "fill-time", "data-value": f.fill_time_s }],
    ["99 % of the volume filled by (estimate)", `${seconds(f.fill_time_99_s)} s`, { class: "fill-time-99", "data-value": f.fill_time_99_s }],
    ["Melt reaches", `${(100 * f.reached_share).toFixed(1)} % of the part`, { "data-value": f.reached_share }],
  ];
  const last = el("ol", { class: "last-to-fill" });
  for (const q of f.last_to_fill.slice(0, 3)) last.append(el("li", xyz(q.point), `${v3(q.point, 1)}: ${q.flow_length_mm.toFixed(1)} mm of flow path from the gate, filled at ${seconds(q.fill_time_s)} s`));
  const welds = el("ul", { class: "weld-lines" });
  for (const w of f.weld_lines.slice(0, 3)) welds.append(el("li", xyz(w.point), `near ${v3(w.point, 1)}, ${w.flow_length_mm.toFixed(1)} mm from the gate, fronts at ${w.meeting_angle_deg.toFixed(0)}°`));
  if (!f.weld_lines.length) welds.append(el("li", {}, "none found"));
  return el("div", { id }, el("h4", {}, title), list(null, rows), el("p", {}, "Last to fill:"), last, el("p", {}, `Weld lines (where fronts meet${f.weld_lines.length > 3 ? `; the first 3 of ${f.weld_lines.length}` : ""}):`), welds);
}

/** What a balanced search that stopped unproven leaves open, in the words of the
 * command line's summary: no candidate is below the search's lower bound. */
function unproven(search) {
  const gap = search.value > 0 && Number.isFinite(search.lower_bound)
    ? Math.max(0, 100 * (search.value - Math.max(0, search.lower_bound)) / search.value)
    : null;
  return gap === null
    ? `not proven optimal after ${search.runs} flow fields`
    : `not proven optimal after ${search.runs} flow fields: a candidate could be up to ${gap.toFixed(1)} % lower`;
}

/** The fill section; `mode`: "paper" or "aesthetic", the rule of the gate `f.paper` fills from. */
function fillSection(f, mode) {
  const parts = [el("p", {}, `${f.cells.toLocaleString("en")} cells of ${f.cell_mm.toFixed(3)} mm; nominal wall ${f.nominal_wall_mm.toFixed(2)} mm (${WALL_SOURCE[f.wall_source] ?? f.wall_source})`)];
  if (f.paper) parts.push(gateFill("fill-paper", mode === "aesthetic" ? "From the aesthetic gate" : "From the paper's gate", f.paper));
  if (f.balanced && !f.balanced.is_paper_gate) {
    parts.push(gateFill("fill-balanced", "From the balanced gate", f.balanced.fill));
    parts.push(el("p", { id: "balanced-verdict" }, `The balanced gate shortens ${f.objective === "resistance" ? "the fill time" : "the worst flow"} by ${f.balanced.improvement_pct.toFixed(1)} %${f.balanced.search.proven ? "." : `; ${unproven(f.balanced.search)}.`}`));
  } else if (f.balanced) {
    parts.push(el("p", { id: "balanced-verdict" }, f.balanced.search.proven
      ? "The balanced gate is the paper's gate: no candidate does better by more than a flow cell."
      : `The balanced gate is the paper's gate: no candidate tried did better by more than a flow cell; ${unproven(f.balanced.search)}.`));
  }
  if (f.body_gates?.length) parts.push(bodyGates(f.body_gates));
  if (f.suitability) parts.push(suitabilityPart(f.suitability));
  // The fill's warnings are among the report's, listed once under Warnings.
  return section("fill-result", "Fill", ...parts);
}

/** A gate per body, on a file of several bodies: each body is moulded from its own gate (the
 * 3D view shows the bodies the answer's gate does not reach filled from theirs). */
function bodyGates(bodies) {
  const items = el("ol", { id: "body-gates", start: 0 });
  for (const b of bodies) {
    const share = `${(100 * b.volume_share).toFixed(1)} % of the volume`;
    const own = b.is_answer_body ? ", holds the answer's gate" : "";
    const text = b.gate === null
      ? `Body ${b.body + 1} (${share}${own}): ${b.rule === "parting_line" ? "no parting line" : "no qualifying node"}`
      : `Body ${b.body + 1} (${share}${own}): own gate ${v3(b.gate)} mm (${b.rule === "parting_line" ? "the aesthetic rule on this body alone: the point of its parting line nearest its centre of mass" : "the paper's rule on this body alone"})${b.pictured ? "; the 3D view fills the body from it, marked by a dashed ring" : ""}, longest flow ${mm(b.l_max_mm, 1)}, fill time ${b.fill_time_s === null ? "unknown" : `${seconds(b.fill_time_s)} s`} at its own nominal wall of ${mm(b.nominal_wall_mm)}`;
    items.append(el("li", b.gate === null ? { "data-body": b.body } : { "data-body": b.body, ...xyz(b.gate) }, text));
  }
  return el("div", {}, el("p", {}, `A gate per body (the file holds ${bodies.length} separate bodies; a gate fills only its own):`), items);
}

/** The gate-suitability map in words: the best node, the range, how many scores are exact. */
function suitabilityPart(m) {
  // L_max to 0.1 mm; a fill time to three significant figures, as everywhere.
  const value = (x) => (m.unit === "s" ? seconds(x) : x.toFixed(1));
  const scores = m.nodes.map((n) => n.score);
  const lo = Math.min(...scores);
  const hi = Math.max(...scores);
  const best = m.best === null ? null : m.nodes[m.best];
  const what = m.objective === "resistance" ? "fill time" : "L_max";
  const gap = m.max_gap_pct === null ? "unbounded" : `${m.max_gap_pct.toFixed(1)} %`;
  // A best score the map's runs did not prove is a lower bound, said as such (as the
  // command line's summary and the report page say it).
  const bestText = (n) => n.kind === "lower_bound"
    ? `at least ${value(n.score)} ${m.unit} (a lower bound: the map's runs ended before a march at this node; ${n.upper === null ? "no upper bound" : `at most ${value(n.upper)} ${m.unit}`})`
    : `${value(n.score)} ${m.unit}`;
  return el("div", { id: "suitability-result", "data-nodes": m.nodes.length, "data-exact": m.exact, "data-best": best ? best.score : "" },
    el("p", {}, `Gate suitability: ${m.nodes.length.toLocaleString("en")} qualifying nodes scored by the ${what} of a gate at each, ${value(lo)} to ${value(hi)} ${m.unit} (lower is better; the 3D view colours them, dark blue best).`),
    el("p", {}, best ? `Best node ${v3(best.point)} mm: ${bestText(best)}. ${m.exact} scores exact (to ${value(m.tolerance)} ${m.unit}, the cells' resolution: the balanced gate's own value may differ by as much), the others lower bounds within ${gap} of their upper bounds.` : "No node scored."),
    ...bodiesPart(m, bestText));
}

/** On a part of several bodies, each body's best node: a gate fills only its own body, so
 * the scores compare within a body, and the 3D view colours each node against its body's
 * best. Nothing for one body. */
function bodiesPart(m, scoreText) {
  const bests = (m.best_per_body ?? [])
    .map((i, body) => (i === null ? null : `body ${body + 1} at ${v3(m.nodes[i].point)} mm, ${scoreText(m.nodes[i])}`))
    .filter((t) => t !== null);
  if (bests.length < 2) return [];
  return [el("p", { id: "suitability-bodies" }, `The part has several bodies, and a gate fills only its own: each node is scored by the fill of its body, and the 3D view colours it by its score over its body's best (1: that best). The best of each body: ${bests.join("; ")}.`)];
}

function countsSection(c, fit) {
  const rows = [
    ["grid nodes", c.nodes], ["hit the part", c.centre_hits], ["whole circle on the part", c.circle_on_part],
    ["wall thicker than R", c.thicker_than_radius], ["wall unknown", c.thickness_unknown], ["flat", c.flat],
    ["kept out", c.kept_out], ["on cosmetic faces", c.cosmetic], ["qualify", c.qualifying],
  ];
  // With the fitted radius taken, the counts are the grid's at the refused one.
  const at = fit?.accepted ? ` (at R = ${fit.refused_mm.toFixed(3)} mm, before the fit)` : "";
  const table = el("table", { id: "counts" }, el("caption", {}, `Grid nodes through each rule${at}`));
  for (const [name, n] of rows) table.append(el("tr", { "data-count": name }, el("th", { scope: "row" }, name), el("td", { "data-value": n }, n.toLocaleString("en"))));
  return section("counts-result", "Nodes per rule", table);
}

function partSection(r) {
  const m = r.mesh;
  const format = { stl_binary: "binary STL", stl_ascii: "ASCII STL", obj: "OBJ", ply_ascii: "ASCII PLY", ply_binary_little_endian: "binary PLY", ply_binary_big_endian: "binary PLY (big-endian)", generated: "sample" }[m.format] ?? m.format;
  const size = m.bounds_max.map((hi, i) => hi - m.bounds_min[i]);
  return section("part-result", "Part", list("part", [
    ["File", r.input.path ?? `sample '${r.input.sample}'`],
    ["Read as", `${format}, ${m.units}`],
    ["Triangles", m.triangles.toLocaleString("en"), { "data-value": m.triangles }],
    // A part read in the wrong units (metres as mm) is a fraction of a millimetre: three
    // figures, not "0.0".
    ["Size", `${size.map((s) => (s >= 1 ? s.toFixed(1) : threeFigures(s))).join(" × ")} mm`],
    // Where the part lies in its file's frame, which typed gates are given in.
    ["Extends from", `${v3(m.bounds_min, Math.max(...size) < 10 ? 4 : 2)} to ${v3(m.bounds_max, Math.max(...size) < 10 ? 4 : 2)} mm`, { id: "part-bounds" }],
    ["Mesh", m.open_edges === 0 && m.non_manifold_edges === 0 ? `closed, ${m.bodies} ${m.bodies === 1 ? "body" : "bodies"}` : `${m.open_edges} open and ${m.non_manifold_edges} non-manifold edges, ${m.bodies} ${m.bodies === 1 ? "body" : "bodies"}`],
    ["Demolding direction D", v3(r.options.demold, 3), xyz(r.options.demold)],
    // A part of a few millimetres (often one read in the wrong units) gets four decimals.
    ["Centre of mass", `${v3(r.centre_of_mass.used, Math.max(...size) < 10 ? 4 : 2)} mm`, { id: "centre-of-mass", ...xyz(r.centre_of_mass.used) }],
  ]));
}

function wallSection(w) {
  return section("wall-result", "Wall thickness", list("wall", [
    ["Minimum", mm(w.min_mm)], ["Nominal", mm(w.nominal_mm)], ["Maximum", mm(w.max_mm)],
    ["Unknown", `${(100 * w.unknown_area_share).toFixed(1)} % of the area`],
  ]));
}

function timingsSection(r, page) {
  const t = r.timings;
  const ms = (s) => `${(1000 * s).toFixed(1)} ms`;
  // The stages as the command line's time line gives them: the gate's location is the grid,
  // the rays (the centre of mass and the parting line alongside) and the selection; the ray
  // tree and the fill's cells run beside it (or beside the automatic direction's choice,
  // which holds the gate's location), and the whole is every stage once.
  const rows = [
    [r.input.sample ? "Make the sample" : "Read the file", ms(t.load_s), { id: "time-load", "data-value": t.load_s }],
  ];
  if (t.demold_s != null) rows.push(["Automatic direction", ms(t.demold_s), { id: "time-demold", "data-value": t.demold_s }]);
  const located = t.grid_s + t.projection_s + t.select_s;
  rows.push(["Gate location", ms(located), { id: "time-locate", "data-value": located }]);
  rows.push(["Grid / rays / selection", `${ms(t.grid_s)} / ${ms(t.projection_s)} / ${ms(t.select_s)}`]);
  if (t.tree_s != null) rows.push(["Ray tree", `${ms(t.tree_s)} (beside the ${t.demold_s != null ? "choice of direction" : "gate's location"})`]);
  if (t.wall_s != null) rows.push(["Wall thickness", ms(t.wall_s), { id: "time-wall", "data-value": t.wall_s }]);
  // The fill's cells are made with the ray tree, beside the gate's location where threads
  // allow; the fill's own time is the rest of it.
  const cells = r.fill?.times.cells_beside_s ?? 0;
  if (cells > 0) rows.push(["Fill's cells", `${ms(cells)} (with the ray tree)`]);
  if (t.fill_s != null) rows.push(["Fill analysis", ms(t.fill_s), { id: "time-fill", "data-value": t.fill_s }]);
  rows.push(["Whole analysis", ms(t.total_s), { id: "time-total", "data-value": t.total_s }]);
  if (page) {
    rows.push(["Whole study in the browser", `${page.study_ms.toFixed(0)} ms`, { id: "time-study", "data-value": page.study_ms }]);
    rows.push(["3D file", `${page.glb_ms.toFixed(0)} ms`, { id: "time-glb", "data-value": page.glb_ms }]);
  }
  return section("timings-result", "Time", list("timings", rows));
}

/** The gates the designer placed (shift-click): each one's verdict by the paper's rules and
 * the wall under it, and with the fill their layout beside the paper and balanced gates. */
function placedSection(r) {
  const p = r.placed_gates;
  const ol = el("ol", { id: "placed-list" });
  p.gates.forEach((g, i) => {
    const offFlat = g.qualifies && !g.flat && g.step_mm !== null && g.step_mm !== undefined;
    const verdict = !g.qualifies
      ? `fails: ${g.why}`
      : offFlat
        ? `qualifies, off a flat seat (its disc reaches ${mm(g.step_mm)} off its height along D)`
        : "qualifies";
    ol.append(el("li", {
      class: "placed-gate", "data-qualifies": g.qualifies, "data-failed-rule": g.failed_rule ?? "",
      "data-moved": g.moved_mm, "data-asked": g.asked.join(","), ...xyz(g.point),
    }, `your gate ${i + 1} at ${v3(g.point)} mm (moved ${mm(g.moved_mm)} onto the surface), wall along D ${mm(g.thickness_mm)}: ${verdict}`));
  });
  const content = [ol];
  const f = p.fill;
  if (f) {
    const rows = [[p.gates.length === 1 ? "Your gate" : "Your gates together", f, "placed-fill"]];
    if (r.fill?.paper) rows.push([r.options.mode === "aesthetic" ? "Aesthetic gate" : "Paper gate", r.fill.paper, "placed-paper"]);
    if (r.fill?.balanced) rows.push(["Balanced gate", r.fill.balanced.fill, "placed-balanced"]);
    content.push(list("placed-fill-list", rows.map(([name, g, id]) => [
      name,
      // On a part of several bodies a gate fills its own body only: how much of the part it
      // reaches says whether two rows compare like with like.
      `L_max ${mm(g.l_max_mm, 1)}, L/t ${g.flow_ratio.toFixed(0)}${g.flow_ratio_limit ? ` (limit ${g.flow_ratio_limit.toFixed(0)})` : ""}, ${threeFigures(g.pressure_mpa)} MPa (Eq. 1), fill ${seconds(g.fill_time_s)} s, ${g.weld_lines.length} weld lines${g.reached_share < 0.9995 ? `; reaches ${(100 * g.reached_share).toFixed(1)} % of the part` : ""}`,
      { id, "data-value": g.l_max_mm },
    ])));
  } else if (p.no_fill_reason) {
    content.push(el("p", {}, `No fill of your gates: ${inPageWords(p.no_fill_reason)}.`));
  }
  content.push(el("p", { class: "hint" }, "Shift-click the part to place another gate; gates placed together are one layout."));
  content.push(el("button", { id: "clear-placed", type: "button" }, "Clear your gates"));
  return section("placed-result", "Your gates", ...content);
}

/** The nominal wall's source in words, as the library's `WallSource::words`. */
const WALL_SOURCE = {
  measured: "measured",
  volume_over_area: "2V/A estimate",
  diagonal_share: "a hundredth of the part's diagonal: the mesh encloses no volume",
};

/** Fills `container` with the report's results; `page` holds the page's own timings,
 * `asked` the options the study was asked with (`gates`). */
export function showReport(container, r, page, asked = {}) {
  container.replaceChildren();
  container.append(r.gate ? gateSection(r) : noGateSection(r, asked.gates));
  if (r.fill) container.append(fillSection(r.fill, r.options.mode));
  if (r.placed_gates) container.append(placedSection(r));
  const warnings = el("ul", { id: "warnings" });
  for (const w of r.warnings) warnings.append(el("li", { class: "warning", "data-warning": w }, inPageWords(w)));
  if (r.warnings.length) container.append(section("warnings-result", "Warnings", warnings));
  container.append(partSection(r), countsSection(r.counts, r.radius_fit));
  if (r.wall_thickness) container.append(wallSection(r.wall_thickness));
  if (r.demold_auto) {
    const ul = el("ul", {});
    // The undercut is flattened into each line; a line left at its lower bound says "at least".
    // The label tells a principal axis from the world axis it prints as at three decimals.
    for (const c of r.demold_auto.tried) ul.append(el("li", {}, `${v3(c.direction, 3)} (${c.label}): undercut ${c.evaluated ? "" : "at least "}${c.area_mm2.toFixed(1)} mm²`));
    container.append(section("demold-auto-result", "Demolding directions tried", ul));
  }
  container.append(timingsSection(r, page));
}

