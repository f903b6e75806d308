// Numbers and messages as the page writes them, shared by the page and its tests.

/** A time in seconds without its unit: `threeFigures`, so that close times on a part that
 * fills in milliseconds still show their order. */
export const seconds = (t) => threeFigures(t);

/**
 * A positive value to three significant figures (0.00612, 0.0161, 1.61, 16.1, 161, and 1614
 * above 999): the fill's times and pressures; zero, negative and non-finite values with
 * three decimals. The same text as the command line's (`three_figures` in the library's
 * report module).
 */
export function threeFigures(t) {
  if (!Number.isFinite(t) || t <= 0) return t.toFixed(3);
  const decimals = (v) => Math.min(9, Math.max(0, 2 - Math.floor(Math.log10(v))));
  const d = decimals(t);
  const text = t.toFixed(d);
  // Rounding may carry into the next power of ten (0.009996 -> 0.01000): one digit fewer.
  const v = Number(text);
  const carried = v > 0 ? decimals(v) : d;
  return carried < d ? t.toFixed(carried) : text;
}

/** The colour bar's two ends as text, to the same decimals: three significant figures of
 * the span between them (a fill time from 2e-6 s at the gate to 0.105 s reads "0" to
 * "0.105", a wall from 0.14 to 8.43 mm "0.14" to "8.43"), at most four of the larger end,
 * whole numbers from 100 up. */
export function barEnds(min, max) {
  // Three figures of the span, but no more than four of the larger end (a uniform wall of
  // 3 mm with rounding noise reads "3" to "3", not "2.99999785" to "3.00000596").
  const figures = (x) => 2 - Math.floor(Math.log10(x));
  const span = Math.abs(max - min) || Math.abs(max) || 1;
  const larger = Math.max(Math.abs(min), Math.abs(max)) || 1;
  const decimals = Math.min(12, Math.max(0, Math.min(figures(span), figures(larger) + 1)));
  const text = (x) => (Math.abs(x) >= 100 ? x.toFixed(0) : String(Number(x.toFixed(decimals))));
  return [text(min), text(max)];
}

/** The page's names for the options the library's messages name (as the command line
 * names its flags). */
const OPTION_LABELS = {
  strategy: "'Gate chosen by: balanced'",
  gates: "'Number of gates' above 1",
  aesthetic: "'Aesthetic: gate on the parting line'",
};

/** The page's names for the command line's flags that the library's messages name. */
const FLAG_LABELS = {
  "--units": "'Units of the file'",
  "--demold": "'Demolding direction'",
  "--strategy": "'Gate chosen by'",
  "--objective": "'Balanced and several gates minimise'",
  "--gates": "'Number of gates'",
  "--aesthetic": "'Aesthetic: gate on the parting line'",
  "--fill": "'Fill analysis'",
  "--wall-thickness": "'Measure the wall thickness everywhere'",
  "--gate-radius": "'Gate radius'",
  "--spacing": "'Grid spacing'",
  "--require-flat": "'Only flat gate discs'",
  "--max-nodes": "'Largest grid (nodes)'",
  "--cell": "'Fill cell size'",
  "--gate-at": "'Your own gates' (or shift-click on the part)",
  "--fit-radius": "'When no node passes the wall rule, take the largest gate radius that fits'",
  "--parting-line": "'Parting line'",
  "--suitability": "'Gate-suitability map'",
  "--centre": "'Centre of mass'",
  "--nearest": "'Nearest the centre'",
  "--thickness-rule": "'Wall thicker than the gate radius'",
  "--keep-out": "'Keep-out regions'",
  "--cosmetic": "'Visible (cosmetic) side'",
  "--flat-tol": "'Flatness tolerance'",
  "--circle-points": "'Points on each circle'",
  "--grid-offset": "'Grid offset'",
  "--color-by": "'The fill's colours show'",
};

/** The page's names for the options (the library's field names) an option error starts with. */
const FIELD_LABELS = {
  units: "'Units of the file'",
  material: "'Material'",
  demold: "'Demolding direction'",
  strategy: "'Gate chosen by'",
  objective: "'Balanced and several gates minimise'",
  gates: "'Number of gates'",
  thickness_rule: "'Wall thicker than the gate radius'",
  keep_out: "'Keep-out regions'",
  cosmetic: "'Visible (cosmetic) side'",
  gate_radius: "'Gate radius'",
  spacing: "'Grid spacing'",
  grid_offset: "'Grid offset'",
  circle_points: "'Points on each circle'",
  centre: "'Centre of mass'",
  nearest: "'Nearest the centre'",
  flat_tol: "'Flatness tolerance'",
  max_nodes: "'Largest grid (nodes)'",
  cell: "'Fill cell size'",
  gate_at: "'Your own gates'",
  parting_line: "'Parting line'",
};

/** The names the library's range checks give a few options, as the page labels them. */
const LIBRARY_NAMES = {
  "circle points": "'Points on each circle'",
  "the node limit": "'Largest grid (nodes)'",
  "flatness tolerance": "'Flatness tolerance'",
  "gate radius": "'Gate radius'",
  spacing: "'Grid spacing'",
};

/** The material parameters' names in the page's custom material. */
const MATERIAL_LABELS = {
  n: "'Power-law index n'",
  t_melt: "'Melt temperature'",
  t_wall: "'Mould temperature'",
  gamma_opt: "'Optimal shear rate'",
  mu_opt: "'Viscosity at that rate'",
  k: "'Thermal conductivity'",
  max_flow_ratio: "'Flow-length ratio limit L/t'",
};

/** A message of the library in the page's words: an option error by the control at fault,
 * two options that cannot be used together by the page's labels, the command line's flags
 * (with the values they take) by the controls that set the same options (a flag the page
 * has no control for is named as the command line's), and mm^2 as mm². */
export function inPageWords(message) {
  const m = /^(\w+) and (\w+) cannot be used together: /.exec(message);
  if (m && m[1] in OPTION_LABELS && m[2] in OPTION_LABELS) {
    message = `${OPTION_LABELS[m[1]]} and ${OPTION_LABELS[m[2]]} cannot be used together: ${message.slice(m[0].length)}`;
  }
  // "gate_at 2 ...": the second of the own gates (typed ones first, then those placed).
  // A part's error comes after its file's name ("part.stl: gate_at 1 ...").
  message = message.replace(/(^|: )(?:options: )?gate_at (\d+)\b/, (_, before, n) => `${before}'Your own gates', gate ${n},`);
  // The rays' memory: what fits, by the controls that set it.
  message = message.replace(/use at most (\d+) circle points, or a spacing of at least ([\d.e+-]+) mm/, "set 'Points on each circle' to at most $1, or 'Grid spacing' to at least $2 mm");
  // The library's own names of a few options ("circle points must be at most 360").
  message = message.replace(/^(circle points|the node limit|flatness tolerance|gate radius|spacing)(?= must | is )/, (name) => LIBRARY_NAMES[name]);
  // "options: material.n: ..." or "spacing must ...": the field at fault first.
  const f = /^(?:options: )?([a-z_]+)(?:\.([a-z_]+))?(?=:| must | is )/.exec(message);
  if (f && f[1] in FIELD_LABELS) {
    const field = f[1] === "material" && f[2] in MATERIAL_LABELS ? `'Material': ${MATERIAL_LABELS[f[2]]}` : FIELD_LABELS[f[1]];
    message = field + message.slice(f[0].length);
  }
  return flagWords(message, (flag) => `the command line's ${flag}`);
}

/** `text` with the command line's flags named by the page's controls; a flag the page has
 * no control for is `unknown(flag)`. */
function flagWords(text, unknown) {
  return text
    .replace(/--objective (length|resistance)/g, (_, v) => `'Balanced and several gates minimise: ${v === "length" ? "the longest flow length" : "the largest flow resistance"}'`)
    .replace(/--cell (\d+(?:\.\d+)?)/g, "'Fill cell size' of $1 mm")
    .replace(/\(--fit-radius takes it\)/g, "(set 'Gate radius' to it)")
    .replace(/mm\^2/g, "mm²")
    .replace(/mm\^3/g, "mm³")
    .replace(/--[a-z][a-z-]*[a-z]/g, (flag) => FLAG_LABELS[flag] ?? unknown(flag));
}

/** The study's HTML page (the library's, as the command line writes it) in the page's
 * words: its text names the page's controls, not the command line's flags. Its style and
 * its embedded JSON (the command line's report, as the report download is) are left as
 * they are, and so are flags of no control (`moldgate locate --json`). */
export function pageInPageWords(html) {
  const choices = (text) =>
    text
      .replace(/--nearest (2d|3d)/g, (_, v) => `'Nearest the centre: ${v === "2d" ? "in the plane" : "in 3D"}'`)
      .replace(/--centre (volume|surface)/g, (_, v) => `'Centre of mass: ${v}'`)
      .replace(/--gate-at\b/g, "'Your own gates'");
  return html
    .split(/(<style[\s\S]*?<\/style>|<script[\s\S]*?<\/script>)/)
    .map((part, i) => (i % 2 === 1 ? part : flagWords(choices(part), (flag) => flag)))
    .join("");
}
