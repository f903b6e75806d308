// What the browser tests share: the built page served on loopback, Chromium, the command
// line for the reference answers, and the shared parts.
import { execFileSync } from "node:child_process";
import { existsSync, mkdtempSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { dirname, join, resolve } from "node:path";
import { fileURLToPath } from "node:url";

import { launch } from "./browser.mjs";
import { serve } from "./server.mjs";

export const WEB = resolve(dirname(fileURLToPath(import.meta.url)), "..");
export const REPO = resolve(WEB, "..");
export const DIST = join(WEB, "dist");
/** The shared real parts: $MOLDGATE_PARTS, else <repository>/../shared/data/parts. */
export const PARTS = process.env.MOLDGATE_PARTS ?? resolve(REPO, "../shared/data/parts");
/** A folder for the files a test writes: removed at exit unless MOLDGATE_WEB_KEEP is set. */
export function tempDir() {
  const dir = mkdtempSync(join(tmpdir(), "moldgate-web-"));
  if (process.env.MOLDGATE_WEB_KEEP) console.log(`# test files kept in ${dir}`);
  else process.on("exit", () => rmSync(dir, { recursive: true, force: true }));
  return dir;
}

/** The native command line, built by scripts/test-web.sh. */
export const CLI =
  process.env.MOLDGATE_BIN ?? join(process.env.CARGO_TARGET_DIR ?? join(REPO, "target"), "release", "moldgate");

/** `moldgate ARGS --json` as an object (a part without a gate exits 4 and still prints it). */
export function cli(args) {
  try {
    return JSON.parse(execFileSync(CLI, [...args, "--json"], { encoding: "utf8", maxBuffer: 1 << 28 }));
  } catch (e) {
    if (e.stdout) return JSON.parse(e.stdout);
    throw e;
  }
}

/** The page, served and opened in Chromium, with every console error and foreign request kept. */
export async function openApp({ width = 1280, height = 720 } = {}) {
  if (!existsSync(join(DIST, "index.html"))) throw new Error(`${DIST} is not built: run scripts/build-web.sh`);
  const server = await serve(DIST);
  const browser = await launch();
  const context = await browser.newContext({ viewport: { width, height }, acceptDownloads: true });
  const page = await context.newPage();
  const origin = new URL(server.url).origin;
  const problems = { console: [], foreign: [] };
  page.on("console", (m) => {
    if (m.type() === "error") problems.console.push(m.text());
  });
  page.on("pageerror", (e) => problems.console.push(`page error: ${e.message}`));
  context.on("request", (r) => {
    const url = r.url();
    if (!url.startsWith("blob:") && !url.startsWith("data:") && new URL(url).origin !== origin) problems.foreign.push(url);
  });
  await page.goto(server.url);
  await page.waitForFunction(() => document.getElementById("app").dataset.state !== "loading", null, { timeout: 120_000 });
  return {
    page,
    server,
    problems,
    async close() {
      await browser.close();
      await server.close();
    },
  };
}

/** The number of studies the page has started. */
export function runs(page) {
  return page.$eval("#app", (e) => Number(e.dataset.run ?? 0));
}

/** Does `action`, then waits for the study it starts to end; returns the app's state
 * ("done" or "error"). */
export async function settled(page, action, timeout = 180_000) {
  const before = await runs(page);
  await action();
  await page.waitForFunction(
    (n) => {
      const app = document.getElementById("app");
      return Number(app.dataset.run ?? 0) > n && ["done", "error"].includes(app.dataset.state);
    },
    before,
    { timeout }
  );
  return page.$eval("#app", (e) => e.dataset.state);
}

/** Studies a file: its options set first, then the file given to the file input. */
export async function studyFile(page, file, { demold = "+z", units = "mm" } = {}) {
  await page.selectOption("#units", units);
  await page.selectOption("#demold", demold);
  return settled(page, () => page.setInputFiles("#file", file));
}

/** Studies a sample with the options set. */
export async function studySample(page, name) {
  await page.selectOption("#sample", "");
  return settled(page, () => page.selectOption("#sample", name));
}

/** Studies the part again with the options set. */
export function analyseAgain(page) {
  return settled(page, () => page.click("#analyse"));
}

/** The gate and warnings the page shows, from its data- attributes. */
export function shown(page) {
  return page.evaluate(() => {
    const g = document.getElementById("gate-point");
    return {
      gate: g ? ["x", "y", "z"].map((a) => Number(g.dataset[a])) : null,
      warnings: [...document.querySelectorAll("#warnings li")].map((li) => li.dataset.warning),
      // The library's own words (the text shown names the page's controls for its flags).
      noGate: document.getElementById("no-gate-reason")?.dataset.reason ?? null,
      error: document.getElementById("error").hidden ? null : document.getElementById("error-message")?.textContent,
    };
  });
}
