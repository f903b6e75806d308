// The browser app's speed beside the native command line, on the same machine, runs
// interleaved so both see the same load:
//   browser: from the file's bytes in the page to the result on screen (the study in the
//            worker, the report, the GLB, three.js drawing it), as the page measures it;
//   native:  the whole command `moldgate locate FILE --demold +y` (with `--fill` when the
//            page's fill analysis is on), process start to exit.
// Also the first load's transferred size (gzip, as the test server sends it).
//
//   node web/tests/speed.mjs [FILE] [--demold +y] [--fill] [--runs 7]
// (after scripts/build-web.sh and cargo build --release -p moldgate-cli)
import { execFileSync } from "node:child_process";
import { existsSync } from "node:fs";
import { join } from "node:path";

import { CLI, PARTS, openApp, settled } from "./harness.mjs";

const args = process.argv.slice(2);
const option = (name, fallback) => {
  const i = args.indexOf(name);
  return i >= 0 ? args.splice(i, 2)[1] : fallback;
};
const demold = option("--demold", "+y");
const runs = Number(option("--runs", "7"));
const flag = (name) => {
  const i = args.indexOf(name);
  return i >= 0 && args.splice(i, 1).length === 1;
};
// --fill: the fill analysis on, in the page and in the native command alike.
const fill = flag("--fill");
const file = args[0] ?? join(PARTS, "esp32s3box_bottom_housing_352k.stl");
if (!existsSync(file)) {
  console.log(`speed: ${file} not found (give a file or set MOLDGATE_PARTS); nothing measured`);
  process.exit(0);
}
if (!existsSync(CLI)) throw new Error(`${CLI} not built: cargo build --release -p moldgate-cli`);

const median = (xs) => [...xs].sort((a, b) => a - b)[Math.floor(xs.length / 2)];

const app = await openApp();
const { page, server } = app;
const firstLoad = server.served.filter((s) => /\.(wasm|js|css|html)$|\/$/.test(s.path));
const kib = (b) => (b / 1024).toFixed(1);
console.log("first load, gzip:");
for (const s of firstLoad) console.log(`  ${s.path.padEnd(44)} ${kib(s.bytes).padStart(8)} KiB`);
const total = firstLoad.reduce((a, s) => a + s.bytes, 0);
console.log(`  ${"total".padEnd(44)} ${kib(total).padStart(8)} KiB (${(total / 1e6).toFixed(2)} MB)`);

await page.selectOption("#demold", demold);
if (fill) await page.check("#fill");
const nativeArgs = ["locate", file, "--demold", demold, ...(fill ? ["--fill"] : [])];
const browser = [];
const study = [];
const glb = [];
const native = [];
// One run of each first, not counted: the browser compiles the module's hot code, the
// system caches the file.
for (let i = -1; i < runs; i++) {
  const state = await settled(page, () => page.setInputFiles("#file", file));
  if (state !== "done") throw new Error(`the page says: ${await page.$eval("#error", (e) => e.textContent)}`);
  const t = await page.evaluate(() => ({
    total: Number(document.getElementById("status").dataset.totalMs),
    study: Number(document.getElementById("time-study").dataset.value),
    glb: Number(document.getElementById("time-glb").dataset.value),
  }));
  const start = process.hrtime.bigint();
  execFileSync(CLI, nativeArgs, { stdio: "ignore" });
  const nativeMs = Number(process.hrtime.bigint() - start) / 1e6;
  const name = i < 0 ? "warm-up run (not counted)" : `run ${i + 1}`;
  console.log(`${name}: browser ${t.total.toFixed(0)} ms (study ${t.study.toFixed(0)}, GLB ${t.glb.toFixed(0)}), native ${nativeMs.toFixed(0)} ms`);
  if (i < 0) continue;
  browser.push(t.total);
  study.push(t.study);
  glb.push(t.glb);
  native.push(nativeMs);
}
const b = median(browser);
const n = median(native);
console.log(`${file}, demold ${demold}${fill ? ", fill analysis" : ""}, medians of ${runs}:`);
console.log(`  browser, bytes to result on screen: ${b.toFixed(0)} ms (study in the worker ${median(study).toFixed(0)} ms, GLB ${median(glb).toFixed(0)} ms)`);
console.log(`  native command:                      ${n.toFixed(0)} ms`);
console.log(`  browser / native:                    ${(b / n).toFixed(2)}`);
await app.close();
