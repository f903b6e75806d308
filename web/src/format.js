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
  "--gate-at": "shift-click (your gates)",
};

/** A message of the library in the page's words: two options that cannot be used together
 * by the page's labels, and the command line's flags by the controls that set the same
 * options (a flag the page has no control for is named as the command line's). */
export function inPageWords(message) {
  const m = /^(\w+) and (\w+) cannot be used together: /.exec(message);
  if (m && m[1] in OPTION_LABELS && m[2] in OPTION_LABELS) {
    message = `${OPTION_LABELS[m[1]]} and ${OPTION_LABELS[m[2]]} cannot be used together: ${message.slice(m[0].length)}`;
  }
  return message.replace(/--[a-z][a-z-]*[a-z]/g, (flag) => FLAG_LABELS[flag] ?? `the command line's ${flag}`);
}
