// The browser app in a real Chromium: the same gates as the command line, bad input, the 3D
// view, downloads, keyboard, layouts. Run by scripts/test-web.sh (node --test tests/).
import assert from "node:assert/strict";
import { execFileSync } from "node:child_process";
import { existsSync, readFileSync, writeFileSync } from "node:fs";
import { join } from "node:path";
import { after, before, describe, test } from "node:test";

import { seconds } from "../src/format.js";
import { CLI, PARTS, REPO, analyseAgain, cli, openApp, settled, shown, studyFile, studySample, tempDir } from "./harness.mjs";

const TMP = tempDir();

const TOLERANCE_MM = 1e-9;

function assertSameGate(page, expected, what) {
  return shown(page).then((s) => {
    assert.equal(s.error, null, `${what}: the page shows an error`);
    if (expected.gate === null) {
      assert.equal(s.gate, null, `${what}: the page shows a gate, the command line has none`);
      assert.equal(s.noGate, expected.no_gate_reason, `${what}: reason`);
    } else {
      assert.ok(s.gate, `${what}: no gate in the page`);
      for (let i = 0; i < 3; i++) {
        assert.ok(Math.abs(s.gate[i] - expected.gate.point[i]) <= TOLERANCE_MM, `${what}: gate ${s.gate} against ${expected.gate.point}`);
      }
    }
    assert.deepEqual(s.warnings, expected.warnings, `${what}: warnings`);
  });
}

/** The triangles of a binary STL. */
function stlTriangles(bytes) {
  const n = bytes.readUInt32LE(80);
  const tris = [];
  for (let t = 0; t < n; t++) {
    const o = 84 + 50 * t + 12;
    tris.push([0, 1, 2].map((k) => [0, 1, 2].map((a) => bytes.readFloatLE(o + 12 * k + 4 * a))));
  }
  return tris;
}

function writeObj(tris, path) {
  const lines = ["# written by the moldgate browser tests"];
  for (const t of tris) for (const p of t) lines.push(`v ${p.join(" ")}`);
  tris.forEach((_, i) => lines.push(`f ${3 * i + 1} ${3 * i + 2} ${3 * i + 3}`));
  writeFileSync(path, lines.join("\n") + "\n");
}

function writePly(tris, path) {
  const lines = ["ply", "format ascii 1.0", `element vertex ${3 * tris.length}`, "property float x", "property float y", "property float z", `element face ${tris.length}`, "property list uchar int vertex_indices", "end_header"];
  for (const t of tris) for (const p of t) lines.push(p.join(" "));
  tris.forEach((_, i) => lines.push(`3 ${3 * i} ${3 * i + 1} ${3 * i + 2}`));
  writeFileSync(path, lines.join("\n") + "\n");
}

/** Pixel statistics of a PNG screenshot, decoded by the browser. */
function pixelStats(page, png) {
  return page.evaluate(async (b64) => {
    const blob = await (await fetch(`data:image/png;base64,${b64}`)).blob();
    const bitmap = await createImageBitmap(blob);
    const c = new OffscreenCanvas(bitmap.width, bitmap.height);
    const g = c.getContext("2d");
    g.drawImage(bitmap, 0, 0);
    const d = g.getImageData(0, 0, bitmap.width, bitmap.height).data;
    let red = 0, background = 0, coloured = 0;
    const colours = new Set();
    for (let i = 0; i < d.length; i += 4) {
      const [r, gr, b] = [d[i], d[i + 1], d[i + 2]];
      colours.add((r >> 3) * 1024 + (gr >> 3) * 32 + (b >> 3));
      if (r > 170 && gr < 90 && b < 100) red++;
      if (Math.abs(r - 0x2a) < 3 && Math.abs(gr - 0x2f) < 3 && Math.abs(b - 0x38) < 3) background++;
      // viridis: green above red for most of its range, or the purple/yellow ends
      if ((gr > r + 20 && gr > 60) || (b > gr + 40 && r > 40)) coloured++;
    }
    return { pixels: d.length / 4, red, background, coloured, distinct: colours.size };
  }, png.toString("base64"));
}

describe("moldgate in the browser", () => {
  let app;
  let page;

  before(async () => {
    assert.ok(existsSync(CLI), `${CLI} not built: cargo build --release -p moldgate-cli`);
    app = await openApp();
    page = app.page;
  });

  after(async () => {
    await app?.close();
  });

  test("every sample shows the command line's gate and warnings", async () => {
    const names = await page.$$eval("#sample option", (os) => os.map((o) => o.value).filter(Boolean));
    const listed = execFileSync(CLI, ["sample", "--list"], { encoding: "utf8" });
    assert.ok(names.length >= 5, `samples: ${names}`);
    for (const name of names) {
      assert.match(listed, new RegExp(`\\b${name}\\b`));
      assert.equal(await studySample(page, name), "done", name);
      await assertSameGate(page, cli(["locate", "--sample", name]), name);
    }
  });

  test("OBJ and PLY files are read by their extension and give the STL's gate", async () => {
    const stl = join(TMP, "tray.stl");
    execFileSync(CLI, ["sample", "tray", "-o", stl]);
    const tris = stlTriangles(readFileSync(stl));
    writeObj(tris, join(TMP, "tray.obj"));
    writePly(tris, join(TMP, "tray.PLY"));
    for (const f of ["tray.stl", "tray.obj", "tray.PLY"]) {
      const path = join(TMP, f);
      assert.equal(await studyFile(page, path), "done", f);
      await assertSameGate(page, cli(["locate", path]), f);
    }
  });

  const shared = [
    { file: "esp32s3box_bottom_housing_352k.stl", demold: "+y", units: "mm" },
    { file: "trimesh_ADIS16480_meters_ascii.STL", demold: "+y", units: "m" },
  ];
  for (const p of shared) {
    test(`shared part ${p.file} shows the command line's gate`, async (t) => {
      const path = join(PARTS, p.file);
      if (!existsSync(path)) {
        t.skip(`${path} not found (set MOLDGATE_PARTS)`);
        return;
      }
      assert.equal(await studyFile(page, path, p), "done", p.file);
      await assertSameGate(page, cli(["locate", path, "--demold", p.demold, "--units", p.units]), p.file);
    });
  }

  test("a part read in the wrong units says first to set the file's units", async (t) => {
    const path = join(PARTS, "trimesh_ADIS16480_meters_ascii.STL");
    if (!existsSync(path)) {
      t.skip(`${path} not found (set MOLDGATE_PARTS)`);
      return;
    }
    assert.equal(await studyFile(page, path, { demold: "+y", units: "mm" }), "done");
    const expected = cli(["locate", path, "--demold", "+y"]);
    assert.equal(expected.gate, null);
    assert.ok(expected.mesh.size_suggests_other_units);
    const first = await page.$eval("#no-gate-tries li", (e) => [e.id, e.textContent]);
    assert.equal(first[0], "try-units", first[1]);
    assert.ok(first[1].startsWith("'Units of the file'"), first[1]);
    // Its size reads in three figures, not as 0.0.
    const size = await page.$$eval("#part dt", (dts) => dts.find((d) => d.textContent === "Size").nextElementSibling.textContent);
    assert.match(size, /^0\.0\d{3} × 0\.0\d{3} × 0\.0\d{3} mm$/);
  });

  test("a file of two bodies lists a gate per body, as the command line does", async (t) => {
    const path = join(PARTS, "prusa_psu_cover_mk3_ascii.stl");
    if (!existsSync(path)) {
      t.skip(`${path} not found (set MOLDGATE_PARTS)`);
      return;
    }
    await page.check("#fill");
    assert.equal(await studyFile(page, path, { demold: "+z" }), "done");
    const expected = cli(["locate", path, "--demold", "+z", "--fill"]);
    const bodies = await page.$$eval("#body-gates li", (items) => items.map((e) => [Number(e.dataset.body), ["x", "y", "z"].map((a) => Number(e.dataset[a])), e.textContent]));
    assert.equal(bodies.length, expected.fill.body_gates.length);
    assert.equal(bodies.length, 2);
    for (const [i, b] of expected.fill.body_gates.entries()) {
      assert.equal(bodies[i][0], b.body);
      assert.deepEqual(bodies[i][1], b.gate, `body ${b.body}'s gate`);
      assert.ok(bodies[i][2].includes(`${(100 * b.volume_share).toFixed(1)} % of the volume`), bodies[i][2]);
    }
    // The balanced gate, elsewhere than the paper's on this part, is given with its place.
    assert.ok(!expected.fill.balanced.is_paper_gate);
    const balanced = await page.$eval("#fill-balanced .gate-at", (e) => ["x", "y", "z"].map((a) => Number(e.dataset[a])));
    assert.deepEqual(balanced, expected.fill.balanced.fill.gate);
    // Its search stops unproven on this part: the page says so, with the most a candidate
    // could still gain below it (no candidate is below the search's lower bound).
    const search = expected.fill.balanced.search;
    assert.equal(search.proven, false);
    const gap = (100 * (search.value - search.lower_bound)) / search.value;
    const verdict = await page.$eval("#balanced-verdict", (e) => e.textContent);
    assert.ok(verdict.includes(`not proven optimal after ${search.runs} flow fields: a candidate could be up to ${gap.toFixed(1)} % lower`), verdict);
    // The time rows are the stages', each once: the gate's location is not the whole
    // analysis less the reading (here the fill is most of it).
    const time = (id) => page.$eval(`#${id}`, (e) => Number(e.dataset.value));
    const [load, located, fill, total] = [await time("time-load"), await time("time-locate"), await time("time-fill"), await time("time-total")];
    assert.ok(located > 0 && located < fill, `gate location ${located} s, fill ${fill} s`);
    assert.ok(load + located + fill <= total * 1.001 + 1e-6, `${load} + ${located} + ${fill} s over the whole ${total} s`);
    await page.uncheck("#fill");
  });

  test("the 3D view shows the part's colours and the gate's red", async () => {
    await page.selectOption("#demold", "-z");
    assert.equal(await studySample(page, "cover"), "done");
    const png = await page.locator("#viewport").screenshot();
    writeFileSync(join(TMP, "view.png"), png);
    const s = await pixelStats(page, png);
    assert.ok(s.distinct > 200, `only ${s.distinct} colours: blank view?`);
    assert.ok(s.background < 0.9 * s.pixels, `${s.background} of ${s.pixels} pixels are background`);
    assert.ok(s.coloured > 0.03 * s.pixels, `only ${s.coloured} pixels in the colour map`);
    assert.ok(s.red > 50, `only ${s.red} red pixels: no gate marker?`);
    const bar = await page.$eval("#colour-bar", (e) => ({ hidden: e.hidden, field: e.dataset.field }));
    assert.deepEqual(bar, { hidden: false, field: "height along D" });
    // Without the walls measured or the fill analysed, their colourings are offered
    // disabled, saying what they need (not chosen, then refused over the view).
    const offered = await page.$$eval("#colouring option", (os) => os.map((o) => [o.value, o.disabled, o.textContent]));
    assert.deepEqual(offered, [
      ["0", false, "as studied"],
      ["1", false, "height along D"],
      ["2", true, "wall thickness (needs 'Measure the wall thickness everywhere')"],
      ["3", true, "fill order (fill time) (needs 'Fill analysis')"],
    ]);
  });

  test("a gate the part hides from the view's side is ringed faintly", async () => {
    await page.selectOption("#demold", "+z");
    assert.equal(await studySample(page, "cover"), "done");
    const hidden = (n) =>
      page.waitForFunction((n) => document.querySelector("#viewport").dataset.gatesHidden === n, n, { timeout: 20_000 });
    // Along D, from the side the mould opens to, the paper's gate is the surface the node's
    // ray meets first: in sight.
    await page.click("#view-d");
    await hidden("0");
    const png = await page.locator("#viewport").screenshot();
    const seen = (await pixelStats(page, png)).red;
    // Turned over (a drag up by half the view's height turns the camera by half a turn),
    // the cover's top hides it.
    const box = await page.locator("#viewport").boundingBox();
    await page.mouse.move(box.x + box.width / 2, box.y + box.height * 0.75);
    await page.mouse.down();
    await page.mouse.move(box.x + box.width / 2, box.y + box.height * 0.25, { steps: 10 });
    await page.mouse.up();
    await hidden("1");
    const faint = (await pixelStats(page, await page.locator("#viewport").screenshot())).red;
    assert.ok(faint < seen / 2, `${faint} red pixels behind the part, ${seen} in sight`);
    await page.click("#reset-view");
  });

  test("bad files show the library's message and the next file still works", async () => {
    const cases = [
      ["empty.stl", Buffer.alloc(0), /empty\.stl: empty file/],
      ["broken.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", /broken\.obj: line 4/],
      ["short.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\u0001", /short\.ply: byte 169: the file ends/],
      ["part.step", "ISO-10303-21;", /part\.step: this is a STEP file/],
      ["noise.stl", "solid x\n facet normal 0 0 1\n outer loop\n vertex 0 0 zero\n", /noise\.stl: .*line 4/],
    ];
    for (const [name, content, message] of cases) {
      const path = join(TMP, name);
      writeFileSync(path, content);
      assert.equal(await studyFile(page, path), "error", name);
      const s = await shown(page);
      assert.match(s.error ?? "", message, name);
      // No option mends a file that cannot be read: the hint does not offer one.
      assert.equal(await page.$eval("#error-hint", (e) => e.textContent), "This file cannot be studied as it is: open or drop another part.", name);
      assert.equal(s.gate, null);
      assert.equal(await page.$eval("#result-body", (e) => e.children.length), 0, "old results cleared");
    }
    const good = join(TMP, "tray.stl");
    assert.equal(await studyFile(page, good), "done");
    await assertSameGate(page, cli(["locate", good]), "after bad files");
  });

  test("options that cannot go together are named by the page's labels", async () => {
    await page.selectOption("#strategy", "balanced");
    await page.check("#aesthetic");
    assert.equal(await studySample(page, "plate"), "error");
    const s = await shown(page);
    assert.match(s.error ?? "", /^'Gate chosen by: balanced' and 'Aesthetic: gate on the parting line' cannot be used together: the balanced gate/);
    assert.equal(await page.$eval("#error-hint", (e) => e.textContent), "Open or drop another part, or change the options and analyse again.");
    // Its message goes with the options it spoke of.
    await page.click("#defaults");
    assert.ok(await page.$eval("#error", (e) => e.hidden));
  });

  test("a part where no node qualifies says why and what to try", async () => {
    await page.$eval("details", (d) => (d.open = true));
    await page.fill("#gate_radius", "40");
    assert.equal(await studySample(page, "plate"), "done");
    const expected = cli(["locate", "--sample", "plate", "--gate-radius", "40"]);
    assert.equal(expected.gate, null);
    await assertSameGate(page, expected, "plate, R = 40 mm");
    assert.ok((await page.$$("#no-gate-tries li")).length >= 3);
    // The reason names the page's controls, not the command line's flags.
    assert.ok(expected.no_gate_reason.includes("--aesthetic"), expected.no_gate_reason);
    const reason = await page.$eval("#no-gate-reason", (e) => e.textContent);
    assert.ok(reason.includes("'Aesthetic: gate on the parting line'") && !/--[a-z]/.test(reason), reason);
    // The wall rule removed the last nodes (the plate is 3 mm thick): the largest radius
    // that fits is offered; with several gates asked, the aesthetic gate is not (the two
    // cannot be used together).
    await page.fill("#gate_radius", "5");
    assert.equal(await studySample(page, "plate"), "done");
    assert.ok(await page.$("#try-fit-radius"), "the largest radius that fits is offered");
    assert.ok(await page.$("#try-aesthetic"), "the aesthetic gate is offered");
    await page.fill("#gates", "2");
    assert.equal(await studySample(page, "plate"), "done");
    assert.equal(await page.$("#try-aesthetic"), null, "the aesthetic gate is not offered beside two gates");
    await page.fill("#gates", "");
    await page.fill("#gate_radius", "");
  });

  test("a refused option keeps the results on show, marked as the earlier options'", async () => {
    assert.equal(await studySample(page, "plate"), "done");
    const run = await page.$eval("#app", (e) => e.dataset.run);
    await page.fill("#keep_out", "cube:1,2,3");
    await page.click("#analyse");
    await page.waitForFunction(() => !document.getElementById("error").hidden);
    const message = await page.textContent("#error-message");
    assert.match(message, /^'Keep-out regions'/, message);
    // No study ran; the last one's results and view stay, said to be of other options.
    assert.equal(await page.$eval("#app", (e) => e.dataset.run), run);
    assert.equal(await page.$eval("#app", (e) => e.dataset.state), "done");
    assert.ok(await page.$eval("#result-body", (e) => e.children.length > 0));
    assert.ok(!(await page.$eval("#stale", (e) => e.hidden)));
    // Changing the refused option takes its message away; the results stay, still stale.
    await page.fill("#keep_out", "");
    assert.ok(await page.$eval("#error", (e) => e.hidden));
    assert.equal(await analyseAgain(page), "done");
    assert.ok(await page.$eval("#error", (e) => e.hidden));
  });

  test("options that run the fill whether ticked or not say so beside it", async () => {
    assert.ok(await page.$eval("#fill-implied", (e) => e.hidden));
    await page.check("#suitability");
    assert.equal(await page.$eval("#fill-implied", (e) => e.hidden), false);
    assert.equal(await page.textContent("#fill-implied"), "The fill analysis runs anyway, for the gate-suitability map.");
    await page.fill("#gates", "2");
    assert.equal(await page.textContent("#fill-implied"), "The fill analysis runs anyway, for several gates, the gate-suitability map.");
    await page.check("#fill");
    assert.ok(await page.$eval("#fill-implied", (e) => e.hidden));
    await page.click("#defaults");
    assert.ok(await page.$eval("#fill-implied", (e) => e.hidden));
  });

  test("a grid too large for memory is refused before the work", async () => {
    await page.$eval("details", (d) => (d.open = true));
    await page.fill("#spacing", "0.0001");
    assert.equal(await analyseAgain(page), "error");
    assert.match((await shown(page)).error, /600001600001 nodes, more than the limit of 4000000/);
    // The results of the study before stay on show, marked as the earlier options'.
    assert.ok(await page.$eval("#result-body", (e) => e.children.length > 0));
    assert.ok(!(await page.$eval("#stale", (e) => e.hidden)));
    assert.match(await page.$eval("#status", (e) => e.textContent), /the results on show are the earlier ones/);
    // An option mends it: the hint offers that, not another file.
    assert.equal(await page.$eval("#error-hint", (e) => e.textContent), "Open or drop another part, or change the options and analyse again.");
    await page.click("#defaults");
    assert.equal(await analyseAgain(page), "done");
    await assertSameGate(page, cli(["locate", "--sample", "plate"]), "after a refused grid");
  });

  test("Stop and a new part each cancel the study under way", async (t) => {
    const big = join(PARTS, "esp32s3box_bottom_housing_352k.stl");
    if (!existsSync(big)) {
      t.skip(`${big} not found (set MOLDGATE_PARTS)`);
      return;
    }
    await page.selectOption("#demold", "+y");
    await page.check("#fill");
    const before = await page.$eval("#app", (e) => Number(e.dataset.run));
    await page.setInputFiles("#file", big);
    await page.waitForFunction((n) => Number(document.getElementById("app").dataset.run) > n, before);
    await page.waitForFunction(() => !document.getElementById("busy").hidden && document.getElementById("app").dataset.state === "busy");
    // Stop ends it, and says so; the part stays open.
    await page.click("#stop");
    await page.waitForFunction(() => document.getElementById("app").dataset.state === "stopped");
    assert.ok(await page.$eval("#busy", (e) => e.hidden));
    assert.match(await page.$eval("#status", (e) => e.textContent), /^Stopped: esp32s3box_bottom_housing_352k.stl was not analysed/);
    // A new part cancels the study under way.
    await page.click("#analyse");
    await page.waitForFunction(() => !document.getElementById("busy").hidden && document.getElementById("app").dataset.state === "busy");
    assert.equal(await studySample(page, "cap"), "done");
    assert.match(await page.$eval("#status", (e) => e.textContent), /cap/);
    await page.uncheck("#fill");
    await page.selectOption("#demold", "+z");
    assert.equal(await analyseAgain(page), "done");
    await assertSameGate(page, cli(["locate", "--sample", "cap"]), "cap after a cancelled study");
  });

  test("Stop keeps the results of the study before on show", async (t) => {
    const big = join(PARTS, "esp32s3box_bottom_housing_352k.stl");
    if (!existsSync(big)) {
      t.skip(`${big} not found (set MOLDGATE_PARTS)`);
      return;
    }
    assert.equal(await studyFile(page, big, { demold: "+y" }), "done");
    const gate = await page.$eval("#result-body", (e) => e.textContent);
    // A longer study of the same part, stopped: the gate found before stays, said to be
    // of the earlier options.
    await page.check("#fill");
    const before = await page.$eval("#app", (e) => Number(e.dataset.run));
    await page.click("#analyse");
    await page.waitForFunction((n) => Number(document.getElementById("app").dataset.run) > n, before);
    await page.click("#stop");
    await page.waitForFunction(() => document.getElementById("app").dataset.state === "stopped");
    assert.match(await page.$eval("#status", (e) => e.textContent), /^Stopped: the results on show are those of the study before/);
    assert.equal(await page.$eval("#result-body", (e) => e.textContent), gate);
    assert.ok(!(await page.$eval("#stale", (e) => e.hidden)));
    assert.ok(!(await page.$eval("#downloads", (e) => e.hidden)));
    await page.uncheck("#fill");
    await page.selectOption("#demold", "+z");
  });

  test("the fill analysis and the other options reach the library", async () => {
    await page.selectOption("#demold", "-z");
    await page.selectOption("#strategy", "balanced");
    await page.check("#wall_thickness");
    await page.fill("#keep_out", "sphere:0,0,30,5");
    await page.selectOption("#material", "ABS");
    assert.equal(await studySample(page, "cover"), "done");
    const expected = cli(["locate", "--sample", "cover", "--demold", "-z", "--strategy", "balanced", "--wall-thickness", "--keep-out", "sphere:0,0,30,5", "--material", "ABS"]);
    await assertSameGate(page, expected, "cover, balanced");
    // Each gate's place is given beside its fill.
    const paperAt = await page.$eval("#fill-paper .gate-at", (e) => ["x", "y", "z"].map((a) => Number(e.dataset[a])));
    assert.deepEqual(paperAt, expected.fill.paper.gate);
    const lmax = await page.$eval("#fill-result .l-max", (e) => Number(e.dataset.value));
    assert.equal(lmax, expected.fill.paper.l_max_mm);
    // The fill time and the places last to fill read as the command line writes them.
    const time = await page.$eval("#fill-paper .fill-time", (e) => [Number(e.dataset.value), e.textContent]);
    assert.equal(time[0], expected.fill.paper.fill_time_s);
    assert.ok(time[1].endsWith(`${seconds(expected.fill.paper.fill_time_s)} s`), time[1]);
    const last = await page.$$eval("#fill-paper .last-to-fill li", (items) => items.map((e) => e.textContent));
    assert.deepEqual(last.map((t) => t.split(", filled at ")[1]), expected.fill.paper.last_to_fill.slice(0, 3).map((q) => `${seconds(q.fill_time_s)} s`));
    for (const c of ["2", "3", "1"]) {
      await page.selectOption("#colouring", c);
      await page.waitForFunction((name) => document.getElementById("colour-bar").dataset.field?.startsWith(name), { 2: "wall", 3: "fill", 1: "height" }[c]);
    }
    await page.selectOption("#colouring", "0");
    await page.click("#defaults");
  });

  test("the fill can colour the part by its flow length, as the command line's --color-by does", async () => {
    await page.selectOption("#demold", "-z");
    await page.check("#fill");
    await page.selectOption("#color_by", "flow_length");
    assert.equal(await studySample(page, "cover"), "done");
    const expected = cli(["locate", "--sample", "cover", "--demold", "-z", "--fill", "--color-by", "flow-length"]);
    await assertSameGate(page, expected, "cover, coloured by flow length");
    // The study's own colouring is the flow length, in mm, up to about the worst flow length.
    await page.waitForFunction(() => document.getElementById("colour-bar").dataset.field?.startsWith("flow length"));
    const most = await page.$eval("#colour-bar-max", (e) => parseFloat(e.textContent));
    const lmax = expected.fill.paper.l_max_mm;
    assert.ok(most > 0.8 * lmax && most < 1.05 * lmax, `the bar ends at ${most}, L_max ${lmax}`);
    assert.ok((await page.textContent("#colour-bar-max")).endsWith(" mm"));
    // The fill's entry of the view's colourings says which field it is.
    const fill = await page.$eval("#colouring option[value='3']", (o) => o.textContent);
    assert.equal(fill, "flow length");
    // The downloaded picture is coloured as the view is: the study's own colouring and the
    // fill's field give one picture, the height another.
    const downloadPng = async () => {
      const [download] = await Promise.all([page.waitForEvent("download"), page.click("[data-download=png]")]);
      return readFileSync(await download.path());
    };
    const own = await downloadPng();
    await page.selectOption("#colouring", "1");
    await page.waitForFunction(() => document.getElementById("colour-bar").dataset.field?.startsWith("height"));
    const height = await downloadPng();
    writeFileSync(join(TMP, "download-height.png"), height);
    assert.equal((await pixelStats(page, height)).pixels, 1600 * 900);
    assert.ok(!height.equals(own), "the height's picture is the study's own");
    await page.selectOption("#colouring", "3");
    await page.waitForFunction(() => document.getElementById("colour-bar").dataset.field?.startsWith("flow length"));
    assert.ok((await downloadPng()).equals(own), "the fill's field is the study's own colouring");
    await page.selectOption("#colouring", "0");
    await page.click("#defaults");
    assert.equal(await page.inputValue("#color_by"), "fill_order");
  });

  test("a colouring the next study does not make falls back to the study's own", async () => {
    await page.selectOption("#demold", "-z");
    await page.check("#fill");
    assert.equal(await studySample(page, "cover"), "done");
    await page.selectOption("#colouring", "3");
    await page.waitForFunction(() => document.getElementById("colour-bar").dataset.field?.startsWith("fill"));
    // Without the fill, the fill's colouring cannot be shown: the study is still shown, as
    // studied, and the fill's colouring is offered disabled.
    await page.uncheck("#fill");
    assert.equal(await analyseAgain(page), "done");
    assert.equal(await page.inputValue("#colouring"), "0");
    assert.equal(await page.$eval("#colouring option[value='3']", (o) => o.disabled), true);
    await page.waitForFunction(() => document.getElementById("colour-bar").dataset.field?.startsWith("height"));
    await page.click("#defaults");
  });

  test("a materials file gives its materials to the list and the study, as --materials-file does", async () => {
    const toml = join(TMP, "mine.toml");
    writeFileSync(toml, "[MyPP]\nn = 0.3\nt_melt = 230\nt_wall = 50\ngamma_opt = 10000\nmu_opt = 9.88\nk = 0.15\n\n[HDPE]\nn = 0.4\nt_melt = 220\nt_wall = 40\ngamma_opt = 1000\nmu_opt = 300\nk = 0.4\n");
    await page.setInputFiles("#materials_file", toml);
    await page.waitForFunction(() => document.getElementById("materials-file-status").textContent.startsWith("2 materials from mine.toml"));
    // The list is the command line's with the same file: PE-HD replaced by the file's HDPE.
    const listedNames = await page.$$eval("#material option", (os) => os.map((o) => o.value));
    const expected = JSON.parse(execFileSync(CLI, ["materials", "--materials-file", toml, "--json"]).toString());
    assert.deepEqual(listedNames, [...expected.materials.map((m) => m.name), "custom"]);
    await page.selectOption("#material", "MyPP");
    await page.selectOption("#demold", "-z");
    assert.equal(await studySample(page, "cover"), "done");
    const mine = cli(["locate", "--sample", "cover", "--demold", "-z", "--materials-file", toml, "--material", "MyPP"]);
    await assertSameGate(page, mine, "cover, the file's material");
    const radius = await page.$eval("#gate-radius", (e) => Number(e.dataset.value));
    assert.equal(radius, mine.options.gate_radius_mm);
    assert.notEqual(radius, expected.materials[0].gate_radius_mm, "MyPP's radius is not PP's");
    // A file that cannot be read is said beside the control, with its line; the built-in
    // list comes back and the studies go without it.
    const bad = join(TMP, "bad.toml");
    writeFileSync(bad, "[X]\nn = 0.3\nk = hot\n");
    await page.setInputFiles("#materials_file", bad);
    await page.waitForFunction(() => document.getElementById("materials-file-status").classList.contains("error"));
    const said = await page.textContent("#materials-file-status");
    assert.ok(said.startsWith("Not read: bad.toml: line 3: "), said);
    // The material studied is gone: the first is chosen, said so, and the results are marked
    // as those of other options.
    assert.ok(said.endsWith("MyPP is not listed any more: PP is chosen."), said);
    assert.equal(await page.$eval("#stale", (e) => e.hidden), false);
    const builtIn = await page.$$eval("#material option", (os) => os.map((o) => o.value));
    assert.ok(!builtIn.includes("MyPP") && builtIn.includes("PE-HD"), builtIn.join(", "));
    assert.equal(await studySample(page, "cover"), "done");
    await assertSameGate(page, cli(["locate", "--sample", "cover", "--demold", "-z"]), "cover, after the bad file");
    // A built-in chosen stays chosen under the file's material that replaces it, and back.
    await page.selectOption("#material", "PE-HD");
    await page.setInputFiles("#materials_file", toml);
    await page.waitForFunction(() => document.getElementById("materials-file-status").textContent.startsWith("2 materials"));
    assert.equal(await page.inputValue("#material"), "HDPE");
    assert.equal(await page.isVisible("#materials-builtin"), true);
    await page.click("#materials-builtin");
    await page.waitForFunction(() => document.getElementById("materials-builtin").hidden);
    // Hidden on the page, not only marked so.
    assert.equal(await page.isHidden("#materials-builtin"), true);
    assert.equal(await page.inputValue("#material"), "PE-HD");
    assert.equal(await page.$eval("#materials-file-status", (e) => e.hidden), true);
    await page.click("#defaults");
  });

  test("the results' values keep a readable column beside long labels", async () => {
    await page.selectOption("#demold", "-z");
    assert.equal(await studySample(page, "cover"), "done");
    const narrow = await page.$$eval("#results dl", (lists) =>
      lists.flatMap((dl) => {
        const width = dl.getBoundingClientRect().width;
        return [...dl.querySelectorAll("dd")]
          .filter((dd) => dd.getBoundingClientRect().width < 0.4 * width)
          .map((dd) => `${dl.id}: ${dd.textContent} (${dd.getBoundingClientRect().width.toFixed(0)} of ${width.toFixed(0)} px)`);
      }),
    );
    assert.deepEqual(narrow, []);
    // The gate's wall along D beside the thinnest under its disc, as the command line
    // gives both (on the cover the node's ray crosses a boss: 12 mm against 2).
    const expected = cli(["locate", "--sample", "cover", "--demold", "-z"]).paper_gate;
    assert.equal(Number(await page.getAttribute("#gate-wall", "data-value")), expected.thickness_mm);
    assert.equal(Number(await page.getAttribute("#gate-disc-wall", "data-value")), expected.disc_thickness_mm);
    assert.ok(expected.disc_thickness_mm < expected.thickness_mm);
    await page.click("#defaults");
  });

  test("a far tail of slow cells is said beside the colour bar, with its largest value", async (t) => {
    const path = join(PARTS, "esp32s3box_bottom_housing_352k.stl");
    if (!existsSync(path)) {
      t.skip(`${path} not found (set MOLDGATE_PARTS)`);
      return;
    }
    await page.check("#fill");
    assert.equal(await studyFile(page, path, { demold: "+y" }), "done");
    const name = await page.textContent("#colour-bar-name");
    assert.match(name, /^fill time \(estimate\) \(colours stop at the 99th percentile of the cells: the last 1 % reach up to 0\.12\d* s, in the top colour\)$/, name);
    // The bar's top end is the percentile, well below the largest value.
    const top = Number((await page.textContent("#colour-bar-max")).split(" ")[0]);
    assert.ok(top > 0.02 && top < 0.05, String(top));
    await page.click("#defaults");
  });

  test("the automatic demolding direction lists the lines tried with the command line's labels", async () => {
    await page.selectOption("#demold", "auto");
    assert.equal(await studySample(page, "cover"), "done");
    const items = await page.$$eval("#demold-auto-result li", (lis) => lis.map((li) => li.textContent));
    const tried = cli(["locate", "--sample", "cover", "--demold", "auto"]).demold_auto.tried;
    assert.equal(items.length, tried.length);
    tried.forEach((c, i) => assert.ok(items[i].includes(`(${c.label}): undercut `), `${items[i]} / ${c.label}`));
    assert.ok(tried.some((c) => c.kind === "axis" && c.label.endsWith(" axis")));
    await page.click("#defaults");
  });

  test("several gates minimising the fill time are given in seconds", async () => {
    await page.selectOption("#demold", "+z");
    await page.selectOption("#objective", "resistance");
    await page.fill("#gates", "2");
    await page.check("#suitability");
    assert.equal(await studySample(page, "tray"), "done");
    const worst = await page.textContent("#several-worst");
    const expected = cli(["locate", "--sample", "tray", "--demold", "+z", "--objective", "resistance", "--gates", "2", "--suitability"]);
    // The map's scores are fill times too, written as the command line writes them.
    const map = expected.fill.suitability;
    assert.equal(map.unit, "s");
    assert.match(await page.textContent("#suitability-result"), new RegExp(`: ${seconds(map.nodes[map.best].score)} s\\. `));
    assert.match(await page.textContent("#colour-bar-name"), /^gate suitability: fill time from a gate here \(lower is better\)$/);
    const several = expected.fill.several;
    assert.equal(several.l_max_mm, null);
    assert.equal(worst, `2 gates: fill time ${seconds(several.fill_time_s)} s (${several.improvement_pct.toFixed(1)} % shorter than with the balanced gate), balance ${several.balance.toFixed(2)} (smallest share / largest)`);
    // The gate section says it is a layout, and the paper gate's rows are named as such.
    assert.equal(await page.getAttribute("#gate-mode", "data-value"), "several");
    assert.match(await page.textContent("#gate"), /Paper gate \(nearest the centre of mass\)/);
    assert.doesNotMatch(await page.textContent("#gate"), /Chosen by\s*the paper's rule/);
    const first = await page.textContent("#several-gates li");
    assert.match(first, new RegExp(`, fill time ${seconds(several.gates[0].fill_time_s)} s$`));
    await page.uncheck("#suitability");
    await page.click("#defaults");
  });

  test("several gates minimising the flow length give their fill time too, said not minimised", async () => {
    await page.selectOption("#demold", "+z");
    await page.fill("#gates", "2");
    assert.equal(await studySample(page, "tray"), "done");
    const expected = cli(["locate", "--sample", "tray", "--demold", "+z", "--gates", "2"]).fill.several;
    assert.equal(expected.fill_time_s, null);
    assert.ok(expected.layout_fill_time_s > 0);
    assert.equal(await page.getAttribute("#layout-fill-time", "data-value"), String(expected.layout_fill_time_s));
    assert.equal(
      await page.textContent("#layout-fill-time"),
      `These gates together fill the part in ${seconds(expected.layout_fill_time_s)} s (estimate), a time the layout does not minimise (it minimises the longest flow path).`,
    );
    // The layout's own L/t and pressure, all gates open, as the command line gives them.
    assert.equal(await page.getAttribute("#layout-fill", "data-flow-ratio"), String(expected.fill.flow_ratio));
    assert.equal(await page.getAttribute("#layout-fill", "data-pressure"), String(expected.fill.pressure_mpa));
    assert.match(await page.textContent("#layout-fill"), /^With all 2 gates open: flow length \/ wall L\/t \d+ \(limit 250\), Eq. 1 pressure /);
    await page.click("#defaults");
  });

  test("typed gates and the fitted radius are the command line's", async () => {
    // A gate typed in: judged and filled as the command line's --gate-at.
    await page.selectOption("#demold", "+z");
    await page.check("#fill");
    await page.fill("#gate_at_text", "-30,0,5");
    assert.equal(await studySample(page, "plate"), "done");
    const placed = await page.$$eval("#placed-list li", (ls) => ls.map((l) => ({ ...l.dataset })));
    const expected = cli(["locate", "--sample", "plate", "--demold", "+z", "--fill", "--gate-at", "-30,0,5"]);
    assert.equal(placed.length, 1);
    assert.equal(placed[0].qualifies, String(expected.placed_gates.gates[0].qualifies));
    assert.equal(await page.$eval("#placed-fill", (e) => Number(e.dataset.value)), expected.placed_gates.fill.l_max_mm);
    await page.click("#defaults");
    // The plate's 3 mm wall refuses a 4 mm gate; with the fit, the largest radius that fits.
    await page.selectOption("#demold", "+z");
    await page.$eval("details", (d) => (d.open = true));
    await page.fill("#gate_radius", "4");
    await page.check("#fit_radius");
    assert.equal(await studySample(page, "plate"), "done");
    const fitted = cli(["locate", "--sample", "plate", "--demold", "+z", "--gate-radius", "4", "--fit-radius"]);
    assert.equal(fitted.radius_fit.accepted, true);
    const point = await page.$eval("#gate-point", (e) => [e.dataset.x, e.dataset.y, e.dataset.z].map(Number));
    for (const i of [0, 1, 2]) assert.ok(Math.abs(point[i] - fitted.gate.point[i]) <= TOLERANCE_MM, `${point} against ${fitted.gate.point}`);
    assert.match(await page.textContent("#counts"), /at R = 4\.000 mm, before the fit/);
    await page.click("#defaults");
  });

  test("shift-click places a gate of the designer's, judged and filled as the command line does", async () => {
    await page.selectOption("#demold", "+z");
    await page.check("#fill");
    assert.equal(await studySample(page, "plate"), "done");
    await page.click("#view-d");
    const box = await page.$eval("#viewport canvas", (e) => e.getBoundingClientRect().toJSON());
    // The middle of the view is the middle of the plate's top face, 20 mm from the hole.
    const at = { x: box.width * 0.5, y: box.height * 0.5 };
    // A plain click places nothing; a shift-click starts a study with the gate.
    const before = await page.$eval("#app", (e) => e.dataset.run);
    await page.click("#viewport canvas", { position: at });
    assert.equal(await page.$eval("#app", (e) => e.dataset.run), before);
    assert.equal(await settled(page, () => page.click("#viewport canvas", { position: at, modifiers: ["Shift"] })), "done");
    const placed = await page.$$eval("#placed-list li", (ls) => ls.map((l) => ({ ...l.dataset })));
    assert.equal(placed.length, 1);
    // The clicked gate is a line of 'Your own gates', to read, edit or delete.
    assert.equal(await page.$eval("#gate_at_text", (e) => e.value), placed[0].asked);
    const expected = cli(["locate", "--sample", "plate", "--fill", "--gate-at", placed[0].asked]);
    const g = expected.placed_gates.gates[0];
    assert.equal(placed[0].qualifies, String(g.qualifies));
    assert.equal(placed[0].qualifies, "true", `a point of the top face, away from the hole, qualifies: ${JSON.stringify(placed[0])}`);
    // Written to the micrometre, the point moves that little onto the surface.
    assert.ok(Number(placed[0].moved) < 1e-3, `moved ${placed[0].moved}`);
    assert.match(placed[0].asked, /^-?\d+(\.\d{1,3})?,-?\d+(\.\d{1,3})?,-?\d+(\.\d{1,3})?$/);
    for (const [i, a] of ["x", "y", "z"].entries()) {
      assert.ok(Math.abs(Number(placed[0][a]) - g.point[i]) <= TOLERANCE_MM, `${a}: ${placed[0][a]} against ${g.point[i]}`);
    }
    assert.ok(Math.abs(g.point[2] - 3) < 1e-6, `on the top face: ${g.point}`);
    const lmax = await page.$eval("#placed-fill", (e) => Number(e.dataset.value));
    assert.equal(lmax, expected.placed_gates.fill.l_max_mm);
    assert.ok(await page.evaluate(() => document.getElementById("placed-result") !== null));
    // A second shift-click makes a layout of two; clearing them studies the part alone.
    const right = { x: box.width * 0.5, y: box.height * 0.62 };
    assert.equal(await settled(page, () => page.click("#viewport canvas", { position: right, modifiers: ["Shift"] })), "done");
    assert.equal(await page.$$eval("#placed-list li", (ls) => ls.length), 2);
    assert.equal((await page.$eval("#gate_at_text", (e) => e.value)).split("\n").length, 2);
    assert.equal(await settled(page, () => page.click("#clear-placed")), "done");
    assert.equal(await page.$("#placed-result"), null);
    assert.equal(await page.$eval("#gate_at_text", (e) => e.value), "");
    await page.uncheck("#fill");
  });

  test("the gate-suitability map is the command line's and the 3D view shows it", async () => {
    await page.selectOption("#demold", "+z");
    await page.check("#suitability");
    assert.equal(await studySample(page, "cap"), "done");
    const expected = cli(["locate", "--sample", "cap", "--suitability"]);
    const map = expected.fill.suitability;
    const shownMap = await page.$eval("#suitability-result", (e) => ({ nodes: Number(e.dataset.nodes), exact: Number(e.dataset.exact), best: Number(e.dataset.best) }));
    assert.equal(shownMap.nodes, map.nodes.length);
    assert.equal(shownMap.exact, map.exact);
    assert.equal(shownMap.best, map.nodes[map.best].score);
    // The colour bar is the map's, spanning its scores.
    await page.waitForFunction(() => document.getElementById("colour-bar").dataset.field?.startsWith("gate suitability"));
    // Another colouring shows that field alone, under its own name; the study's own
    // colouring brings the map back.
    await page.selectOption("#colouring", "1");
    await page.waitForFunction(() => document.getElementById("colour-bar").dataset.field?.startsWith("height"));
    await page.selectOption("#colouring", "0");
    await page.waitForFunction(() => document.getElementById("colour-bar").dataset.field?.startsWith("gate suitability"));
    // A changed option marks the results as those of the earlier options until the next
    // analysis.
    assert.equal(await page.isHidden("#stale"), true);
    const studied = await page.inputValue("#material");
    await page.selectOption("#material", "ABS");
    assert.equal(await page.isVisible("#stale"), true);
    // Undone, the options are those studied again: the results are current.
    await page.selectOption("#material", studied);
    assert.equal(await page.isHidden("#stale"), true);
    await page.selectOption("#material", "ABS");
    assert.equal(await page.isVisible("#stale"), true);
    assert.equal(await analyseAgain(page), "done");
    assert.equal(await page.isHidden("#stale"), true);
    await page.uncheck("#suitability");
    await page.click("#defaults");
  });

  test("the downloads are the command line's report, a PNG and a valid GLB", async () => {
    await page.selectOption("#demold", "-z");
    assert.equal(await studySample(page, "cover"), "done");
    const files = {};
    for (const what of ["report", "png", "glb", "html"]) {
      const [download] = await Promise.all([page.waitForEvent("download"), page.click(`[data-download=${what}]`)]);
      const path = join(TMP, `download-${download.suggestedFilename()}`);
      await download.saveAs(path);
      files[what] = path;
    }
    const report = JSON.parse(readFileSync(files.report, "utf8"));
    const expected = cli(["locate", "--sample", "cover", "--demold", "-z"]);
    const keys = (o, prefix = "") =>
      Object.entries(o).flatMap(([k, v]) => (v && typeof v === "object" && !Array.isArray(v) ? keys(v, `${prefix}${k}.`) : [`${prefix}${k}`])).sort();
    assert.deepEqual(keys(report).filter((k) => !k.startsWith("timings.")), keys(expected).filter((k) => !k.startsWith("timings.")));
    assert.deepEqual(report.gate, expected.gate);
    const png = readFileSync(files.png);
    assert.equal(png.subarray(1, 4).toString(), "PNG");
    assert.deepEqual([png.readUInt32BE(16), png.readUInt32BE(20)], [1600, 900]);
    const decoded = await pixelStats(page, png);
    assert.equal(decoded.pixels, 1600 * 900);
    const validator = join(REPO, "tools/gltf-validator/validate.js");
    const out = execFileSync("node", [validator, files.glb], { encoding: "utf8" });
    assert.equal(JSON.parse(out).issues.numErrors, 0);
    const html = readFileSync(files.html, "utf8");
    assert.match(html, /^<!DOCTYPE html>|^<!doctype html>/i);
    assert.match(html, /data:image\/png;base64,/);
    // The page names this app's controls, not the command line's flags (which the command
    // line's page for the same study does); its style is the command line's.
    const cliPage = join(TMP, "cli-page.html");
    cli(["locate", "--sample", "cover", "--demold", "-z", "--report", cliPage]);
    const visible = (page) => page.replace(/<style[\s\S]*?<\/style>|<script[\s\S]*?<\/script>/g, "");
    const style = (page) => /<style[\s\S]*?<\/style>/.exec(page)[0];
    const cliHtml = readFileSync(cliPage, "utf8");
    assert.match(visible(cliHtml), /--suitability/);
    assert.doesNotMatch(visible(html), /--(suitability|wall-thickness|aesthetic|require-flat|gates|centre|nearest|objective)\b/);
    assert.match(visible(html), /'Gate-suitability map'/);
    assert.equal(style(html), style(cliHtml));
  });

  test("every control has a label and the keyboard reaches them", async () => {
    const unlabelled = await page.$$eval("input, select, textarea", (es) => es.filter((e) => e.labels.length === 0 && !e.getAttribute("aria-label")).map((e) => e.id));
    assert.deepEqual(unlabelled, []);
    await page.focus("#file");
    const reached = new Set();
    for (let i = 0; i < 60; i++) {
      await page.keyboard.press("Tab");
      reached.add(await page.evaluate(() => document.activeElement?.id || document.activeElement?.dataset.download || document.activeElement?.tagName));
    }
    for (const id of ["sample", "material", "demold", "fill", "analyse", "reset-view", "colouring", "CANVAS"]) {
      assert.ok(reached.has(id), `Tab never reaches ${id}: ${[...reached]}`);
    }
  });

  test("nothing leaves the page's origin and the console stays clean", () => {
    assert.deepEqual(app.problems.foreign, []);
    assert.deepEqual(app.problems.console, []);
  });
});

describe("layouts", () => {
  for (const [width, height] of [[1280, 720], [3840, 2160]]) {
    test(`${width}x${height}: no overflow, results and view on screen`, async () => {
      const app = await openApp({ width, height });
      try {
        await app.page.selectOption("#demold", "-z");
        assert.equal(await studySample(app.page, "cover"), "done");
        const box = (id) => app.page.$eval(id, (e) => e.getBoundingClientRect().toJSON());
        const view = await box("#viewport");
        const gate = await box("#gate-point");
        assert.ok(view.width > width * 0.4 && view.height > height * 0.6, `view ${view.width}x${view.height}`);
        assert.ok(gate.right <= width && gate.bottom <= height, "the gate is on screen");
        // The colourings that say what they need do not widen the toolbar's menu past 13 rem
        // (it widened once another colouring was chosen).
        await app.page.selectOption("#colouring", "1");
        await app.page.waitForFunction(() => document.getElementById("colour-bar").dataset.field?.startsWith("height"));
        const menu = await app.page.$eval("#colouring", (e) => e.getBoundingClientRect().width / parseFloat(getComputedStyle(document.documentElement).fontSize));
        assert.ok(menu <= 13.01, `the colouring menu is ${menu} rem wide`);
        await app.page.selectOption("#colouring", "0");
        const scroll = await app.page.evaluate(() => document.documentElement.scrollWidth);
        assert.ok(scroll <= width, `page ${scroll} px wide`);
        const font = await app.page.$eval("#gate-point", (e) => parseFloat(getComputedStyle(e).fontSize));
        assert.ok(font >= 13 && font >= height / 110, `text ${font} px at ${height} px high`);
        await app.page.screenshot({ path: join(TMP, `layout-${width}x${height}.png`) });
        assert.deepEqual(app.problems.console, []);
      } finally {
        await app.close();
      }
    });
  }
});
