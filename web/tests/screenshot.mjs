// The README's picture of the page: a shared part (or the cover sample when the shared parts
// are absent) with the fill analysis, coloured by fill order.
//   node web/tests/screenshot.mjs docs/images/web-app.png
import { existsSync } from "node:fs";
import { join } from "node:path";

import { PARTS, openApp, settled } from "./harness.mjs";

const out = process.argv[2] ?? "web-app.png";
const part = join(PARTS, "esp32s3box_bottom_housing_352k.stl");
const app = await openApp({ width: 1440, height: 810 });
const { page } = app;
await page.check("#fill");
let state;
if (existsSync(part)) {
  await page.selectOption("#demold", "+y");
  state = await settled(page, () => page.setInputFiles("#file", part));
} else {
  console.log(`${part} not found: the cover sample instead`);
  await page.selectOption("#demold", "-z");
  state = await settled(page, () => page.selectOption("#sample", "cover"));
}
if (state !== "done") throw new Error(await page.$eval("#error", (e) => e.textContent));
await page.screenshot({ path: out });
console.log(`wrote ${out}`);
await app.close();
