// Numbers as the results write them, shared by the page and its tests.

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
