// The JavaScript glue (src/moldgate.js) over the WebAssembly module, in Node without a
// browser: the protocol, the library's errors, recovery after a trap, and the results' number format.
import assert from "node:assert/strict";
import { readFileSync } from "node:fs";
import { join } from "node:path";
import { test } from "node:test";

import { barEnds, inPageWords, pageInPageWords, seconds } from "../src/format.js";
import { Moldgate, MoldgateError } from "../src/moldgate.js";
import { WEB } from "./harness.mjs";

const wasm = readFileSync(join(WEB, "src/wasm/moldgate_web.wasm"));
const enc = new TextEncoder();

test("a sample is studied, with progress, and its outputs are whole", async () => {
  const stages = [];
  const mg = await Moldgate.fromBytes(wasm, (stage, fraction) => stages.push([stage, fraction]));
  const h = await mg.study(new Uint8Array(0), { sample: "cover", options: { fill: true } });
  assert.equal(mg.threads(), 1, "rayon runs on the calling thread");
  const report = JSON.parse(await mg.report(h));
  assert.ok(report.gate);
  assert.ok(report.timings.total_s > 0, "the clock reaches the module");
  assert.deepEqual(stages.at(-1), ["report", 1]);
  assert.ok(stages.some(([s]) => s === "fill"));
  const glb = await mg.glb(h, 3);
  assert.equal(new TextDecoder().decode(glb.subarray(0, 4)), "glTF");
  assert.equal(new DataView(glb.buffer).getUint32(8, true), glb.length);
  const png = await mg.png(h, 0);
  assert.equal(png[1], 0x50);
  mg.drop(h);
  await assert.rejects(mg.report(h), new MoldgateError(`no study ${h}`));
});

test("the library's errors come back as messages, the module stays usable", async () => {
  const mg = await Moldgate.fromBytes(wasm);
  // A file that cannot be read is the file's fault (no option mends it); a bad option is not.
  await assert.rejects(mg.study(enc.encode("v 1 2\n"), { file_name: "a.obj" }), (e) => /a\.obj: line 1/.test(e.message) && e.fileError === true);
  await assert.rejects(mg.study(new Uint8Array(0), { sample: "plate", options: { demold: "up" } }), (e) => /demold/.test(e.message) && e.fileError === false);
  await assert.rejects(mg.study(new Uint8Array(0), { sample: "plate", colour: 1 }), /request: unknown field `colour`/);
  assert.ok((await mg.study(new Uint8Array(0), { sample: "plate" })) > 0);
});

test("a panic traps the call, its message is kept, and a fresh instance carries on", async () => {
  const mg = await Moldgate.fromBytes(wasm);
  const first = mg.instance;
  const message = enc.encode("deliberate");
  const error = await mg.call(() => mg.withBytes(message, (p, l) => mg.x.mg_panic(p, l))).catch((e) => e);
  assert.ok(error instanceof MoldgateError);
  assert.equal(error.trapped, true);
  assert.match(error.message, /internal error: panicked at .*\bdeliberate/s);
  assert.notEqual(mg.instance, first);
  const h = await mg.study(new Uint8Array(0), { sample: "cap", options: { demold: "-z" } });
  assert.ok(JSON.parse(await mg.report(h)).gate);
});

test("times keep three significant figures, as the command line writes them", () => {
  // The same cases as the library's own test of `seconds_text`.
  for (const [t, want] of [
    [0.006123, "0.00612"], [0.01614, "0.0161"], [0.1614, "0.161"], [1.614, "1.61"], [16.14, "16.1"],
    [161.4, "161"], [1614, "1614"], [0.1, "0.100"], [1, "1.00"], [0.0099996, "0.0100"], [9.996, "10.0"],
    [99.96, "100"], [0, "0.000"], [1e-12, "0.000000000"],
  ]) {
    assert.equal(seconds(t), want, String(t));
  }
});

test("the library's messages read in the page's words", () => {
  assert.equal(
    inPageWords("x (try a smaller gate radius or spacing, another demolding direction, or --aesthetic); set its units to in, cm or m (--units)"),
    "x (try a smaller gate radius or spacing, another demolding direction, or 'Aesthetic: gate on the parting line'); set its units to in, cm or m ('Units of the file')"
  );
  assert.equal(inPageWords("the largest that fits (--fit-radius takes it)"), "the largest that fits (set 'Gate radius' to it)");
  assert.equal(inPageWords("x; --material-file y"), "x; the command line's --material-file y");
  // A page: its text in the page's words, its style, its JSON and flags of no control kept.
  assert.equal(
    pageInPageWords("<style>a { color: var(--accent-dark); }</style><p>With <code>--suitability</code>, or <code>moldgate locate --json</code></p><script>{\"w\": \"--require-flat\"}</script>"),
    "<style>a { color: var(--accent-dark); }</style><p>With <code>'Gate-suitability map'</code>, or <code>moldgate locate --json</code></p><script>{\"w\": \"--require-flat\"}</script>",
  );
  // A choice by the words of its menu; the own gates by their box alone.
  assert.equal(
    pageInPageWords("<p>(or with <code>--nearest 2d</code>), <code>--centre volume</code>; Your gates (--gate-at)</p>"),
    "<p>(or with <code>'Nearest the centre: in the plane'</code>), <code>'Centre of mass: volume'</code>; Your gates ('Your own gates')</p>",
  );
  assert.equal(inPageWords("--objective length minimises the longest flow path L_max instead"), "'Balanced and several gates minimise: the longest flow length' minimises the longest flow path L_max instead");
  assert.equal(inPageWords("flow lengths are rough; try --cell 1.000"), "flow lengths are rough; try 'Fill cell size' of 1.000 mm");
  assert.equal(inPageWords("its undercut, 499 mm^2, is"), "its undercut, 499 mm², is");
  // Option errors name the control at fault.
  assert.equal(inPageWords("spacing must be a positive number, got 0"), "'Grid spacing' must be a positive number, got 0");
  // An own gate far from the part, after its file's name as the study says it.
  assert.equal(
    inPageWords("part.stl: gate_at 1 (500.000, 0.000, 0.000) is 450.000 mm from the part's surface"),
    "part.stl: 'Your own gates', gate 1, (500.000, 0.000, 0.000) is 450.000 mm from the part's surface",
  );
  assert.equal(inPageWords("options: material.n: got no value (null), expected a number"), "'Material': 'Power-law index n': got no value (null), expected a number");
  assert.equal(inPageWords("max_nodes must be between 1 and 20000000"), "'Largest grid (nodes)' must be between 1 and 20000000");
  assert.equal(
    inPageWords("gates and aesthetic cannot be used together: why"),
    "'Number of gates' above 1 and 'Aesthetic: gate on the parting line' cannot be used together: why"
  );
  // The library's own names of an option, and a line of the page's own gates.
  assert.equal(inPageWords("circle points must be at most 360, got 100000000"), "'Points on each circle' must be at most 360, got 100000000");
  assert.equal(
    inPageWords("gate_at 1 'middle': expected x,y,z (three numbers in mm), got 1 value"),
    "'Your own gates', gate 1, 'middle': expected x,y,z (three numbers in mm), got 1 value"
  );
  assert.equal(
    inPageWords("gate_at 2 (0.000, 0.000, 5.000) is 3.000 mm from the part's surface"),
    "'Your own gates', gate 2, (0.000, 0.000, 5.000) is 3.000 mm from the part's surface"
  );
  assert.equal(
    inPageWords("cover: a grid of 3844001 nodes with 360 circle points can need 42583 MiB for the ray hits, more than the budget of 3072 MiB; use at most 23 circle points, or a spacing of at least 0.1474 mm (at most 277309 nodes)"),
    "cover: a grid of 3844001 nodes with 360 circle points can need 42583 MiB for the ray hits, more than the budget of 3072 MiB; set 'Points on each circle' to at most 23, or 'Grid spacing' to at least 0.1474 mm (at most 277309 nodes)"
  );
  // Words with dashes that are not flags stay as they are.
  assert.equal(inPageWords("a 2-core run, x - y"), "a 2-core run, x - y");
});

test("the colour bar's ends read to the decimals of the span between them", () => {
  assert.deepEqual(barEnds(2.05e-6, 0.105), ["0", "0.105"]);
  assert.deepEqual(barEnds(0.14, 8.43), ["0.14", "8.43"]);
  assert.deepEqual(barEnds(-205.2, -201.3), ["-205", "-201"]);
  assert.deepEqual(barEnds(0.016, 0.0512), ["0.016", "0.0512"]);
  assert.deepEqual(barEnds(3, 3), ["3", "3"]);
  assert.deepEqual(barEnds(0, 0), ["0", "0"]);
  assert.deepEqual(barEnds(2.99999785, 3.00000596), ["3", "3"]);
  assert.deepEqual(barEnds(0.0003, 0.0287), ["0.0003", "0.0287"]);
});
