// The analysis runs here, off the page's thread: one Web Worker with the single-threaded
// WebAssembly build (rayon falls back to the calling thread). The page terminates this worker
// to cancel a study and starts a new one.
//
// Messages in:  {type: "info"} | {type: "materials", file} | {type: "check", id, request}
//               | {type: "study", id, bytes, request, colouring}
//               | {type: "glb", id, colouring} | {type: "download", id, what, colouring}
// Messages out: {type: "info", ...} | {type: "materials", materials} | {type: "checked"}
//               | {type: "progress", id, stage, fraction}
//               | {type: "result", id, report, glb, colouring, times} | {type: "glb", id, glb}
//               | {type: "download", id, what, bytes} | {type: "error", id, message, trapped, fileError}

import { Moldgate } from "./moldgate.js";

const wasmUrl = new URL("./wasm/moldgate_web.wasm", import.meta.url);
let current = 0;
let handle = 0;
const ready = Moldgate.load(wasmUrl, (stage, fraction) =>
  postMessage({ type: "progress", id: current, stage, fraction })
);

async function handleMessage(mg, m) {
  switch (m.type) {
    case "info":
      return {
        type: "info",
        version: await mg.version(),
        samples: await mg.samples(),
        materials: await mg.materials(),
        defaults: await mg.defaults(),
        maxFileBytes: mg.maxFileBytes(),
      };
    case "materials":
      return { type: "materials", materials: await mg.materialsWith(m.file) };
    case "check":
      await mg.check(m.request);
      return { type: "checked" };
    case "study": {
      current = m.id;
      if (handle) mg.drop(handle);
      handle = 0;
      const t0 = performance.now();
      handle = await mg.study(new Uint8Array(m.bytes), m.request);
      const t1 = performance.now();
      const report = await mg.report(handle);
      postMessage({ type: "progress", id: m.id, stage: "3d", fraction: 1 });
      // A colouring chosen for an earlier study may need what this one did not make (the
      // fill, the walls): the view then shows the study as studied.
      let colouring = m.colouring;
      let glb;
      try {
        glb = await mg.glb(handle, colouring);
      } catch (e) {
        if (colouring === 0) throw e;
        colouring = 0;
        glb = await mg.glb(handle, colouring);
      }
      const t2 = performance.now();
      return {
        type: "result",
        id: m.id,
        report,
        glb,
        colouring,
        times: { study_ms: t1 - t0, glb_ms: t2 - t1 },
        transfer: [glb.buffer],
      };
    }
    case "glb": {
      const glb = await mg.glb(handle, m.colouring);
      return { type: "glb", id: m.id, glb, transfer: [glb.buffer] };
    }
    case "download": {
      const f = { report: (h) => mg.report(h), png: (h) => mg.png(h, m.colouring), glb: (h) => mg.glb(h, m.colouring), html: (h) => mg.html(h, m.colouring) }[m.what];
      const bytes = await f(handle);
      return { type: "download", id: m.id, what: m.what, bytes };
    }
    default:
      throw new Error(`unknown message ${m.type}`);
  }
}

self.onmessage = async ({ data }) => {
  try {
    const mg = await ready;
    const { transfer = [], ...reply } = await handleMessage(mg, data);
    postMessage({ ...reply, id: data.id }, transfer);
  } catch (e) {
    // A trap replaced the instance: the study under the old handle is gone.
    if (e.trapped) handle = 0;
    postMessage({ type: "error", id: data.id, message: e.message || String(e), trapped: !!e.trapped, fileError: !!e.fileError });
  }
};
