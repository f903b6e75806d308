// The page: options, the part (dropped, picked or a sample), the worker that studies it, the
// 3D view and the results. A new part cancels a study under way by terminating its worker.

import "./style.css";
import { Viewer } from "./viewer.js";
import { barEnds, inPageWords, pageInPageWords } from "./format.js";
import { showReport } from "./results.js";

const $ = (id) => document.getElementById(id);
const app = $("app");

const STAGES = {
  start: "Reading the part",
  tree: "Building the ray-casting tree",
  demold: "Choosing the demolding direction",
  locate: "Locating the gate",
  wall_thickness: "Measuring the wall thickness",
  fill: "Analysing the fill",
  report: "Writing the report",
  "3d": "Building the 3D view",
};

// ---------------------------------------------------------------- the worker

let worker = null;
let seq = 0;
const pending = new Map();
let info = null;
let listed = []; // the materials listed: the built-in ones, with a materials file's
let materialsFile = null; // the designer's materials file, {name, text}, or null

function startWorker() {
  worker = new Worker(new URL("./worker.js", import.meta.url), { type: "module" });
  worker.onmessage = ({ data }) => {
    if (data.type === "progress") return onProgress(data);
    const p = pending.get(data.id);
    if (!p) return;
    pending.delete(data.id);
    if (data.type === "error") p.reject(Object.assign(new Error(data.message), { trapped: data.trapped, fileError: data.fileError }));
    else p.resolve(data);
  };
  worker.onerror = (e) => {
    e.preventDefault();
    const message = `the analysis could not start: ${e.message || "the worker failed to load"}`;
    for (const p of pending.values()) p.reject(new Error(message));
    pending.clear();
  };
}

function ask(message, transfer = []) {
  const id = ++seq;
  return new Promise((resolve, reject) => {
    pending.set(id, { resolve, reject, id });
    worker.postMessage({ ...message, id }, transfer);
  });
}

/** Stops a study under way: its worker is terminated and a fresh one started. */
function cancelStudy() {
  worker.terminate();
  for (const p of pending.values()) p.reject(Object.assign(new Error("cancelled"), { cancelled: true }));
  pending.clear();
  startWorker();
}

// ---------------------------------------------------------------- the options

const optionIds = ["units", "demold", "strategy", "objective", "color_by", "gates", "thickness_rule", "fit_radius", "parting_line", "fill", "wall_thickness", "suitability", "aesthetic", "keep_out", "cosmetic", "gate_radius", "spacing", "grid_offset", "circle_points", "centre", "nearest", "require_flat", "flat_tol", "max_nodes", "cell"];
const materialFields = ["n", "t_melt", "t_wall", "gamma_opt", "mu_opt", "k", "max_flow_ratio"];

function setDefaults() {
  const d = info.defaults;
  $("units").value = "mm";
  for (const id of optionIds) {
    const e = $(id);
    if (id === "units") continue;
    const v = d[id];
    if (e.type === "checkbox") e.checked = !!v;
    else if (id === "keep_out") e.value = (v || []).join("\n");
    else e.value = v === null || v === undefined ? "" : String(v);
  }
  $("gate_at_text").value = "";
  placed = [];
  $("material").value = typeof d.material === "string" ? d.material : "PP";
  $("cosmetic").value = d.cosmetic ?? "";
  showMaterial();
  $("demold-vector").hidden = true;
  $("cosmetic-vector").hidden = true;
}

/** Fills the material list (then "custom parameters…"), keeping the material chosen when
 * it is still listed. */
function listMaterials(materials) {
  const select = $("material");
  const chosen = select.value;
  // A material the new list replaces (a built-in named by a file's material, or by an
  // alias of it) stays chosen under its new entry, as the command line's --material PE-HD
  // takes a file's [HDPE].
  const key = (n) => n.toLowerCase().replace(/[^a-z0-9]/g, "");
  const names = [chosen, ...(info.materials.find((m) => m.name === chosen)?.aliases ?? [])].map(key);
  const kept =
    materials.find((m) => m.name === chosen) ??
    materials.find((m) => [m.name, ...(m.aliases ?? [])].some((n) => names.includes(key(n))));
  listed = materials;
  select.replaceChildren();
  for (const m of materials) {
    const o = document.createElement("option");
    o.value = m.name;
    o.textContent = `${m.name} (R = ${m.gate_radius_mm.toFixed(3)} mm)${m.origin === "built-in" ? "" : `, from ${m.origin}`}`;
    o.title = m.description;
    select.append(o);
  }
  const custom = document.createElement("option");
  custom.value = "custom";
  custom.textContent = "custom parameters…";
  select.append(custom);
  if (chosen === "custom") select.value = "custom";
  else if (kept) select.value = kept.name;
  showMaterial();
  return chosen === "custom" || kept ? null : chosen;
}

// The largest materials file read, bytes: the library's limit for a TOML file.
const MAX_TOML_BYTES = 16 << 20;

/** Reads the materials file the designer chose: its materials join the list (each
 * replacing a built-in of its name), and the studies take it, as the command line's
 * `--materials-file` does. A file that cannot be read is said beside the control, and the
 * built-in list comes back. */
async function loadMaterialsFile() {
  const f = $("materials_file").files[0];
  const status = $("materials-file-status");
  status.classList.remove("error");
  $("materials-builtin").hidden = true;
  // A material the new list no longer has gives way to the first, and says so.
  const gone = (lost) => (lost ? ` ${lost} is not listed any more: ${$("material").value} is chosen.` : "");
  try {
    if (!f) {
      materialsFile = null;
      const lost = listMaterials(info.materials);
      status.textContent = `The built-in materials.${gone(lost)}`;
      status.hidden = !lost;
      return;
    }
    status.textContent = `Reading ${f.name}…`;
    status.hidden = false;
    if (f.size > MAX_TOML_BYTES) throw new Error(`${f.name}: ${f.size} bytes, over the limit of ${MAX_TOML_BYTES} bytes for a TOML file`);
    const file = { name: f.name, text: await f.text() };
    const r = await ask({ type: "materials", file });
    materialsFile = file;
    const lost = listMaterials(r.materials);
    const own = r.materials.filter((m) => m.origin === f.name).map((m) => m.name);
    const names = own.length <= 8 ? `: ${own.join(", ")}` : `: ${own.slice(0, 8).join(", ")} and ${own.length - 8} more`;
    status.textContent = `${own.length} material${own.length === 1 ? "" : "s"} from ${f.name}${names}.${gone(lost)}`;
    $("materials-builtin").hidden = false;
  } catch (e) {
    materialsFile = null;
    $("materials_file").value = "";
    const lost = listMaterials(info.materials);
    status.textContent = `Not read: ${e.message}.${gone(lost)}`;
    status.classList.add("error");
  } finally {
    markStale();
  }
  status.hidden = false;
}

/** Says beside 'Fill analysis' when other options run it whether ticked or not (the
 * library's rule: the balanced gate, several gates and the suitability map need the fill). */
function showFillImplied() {
  const by = [];
  if ($("strategy").value === "balanced") by.push("the balanced gate");
  if ((Number($("gates").value) || 1) > 1) by.push("several gates");
  if ($("suitability").checked) by.push("the gate-suitability map");
  const note = $("fill-implied");
  note.hidden = by.length === 0 || $("fill").checked;
  note.textContent = by.length ? `The fill analysis runs anyway, for ${by.join(", ")}.` : "";
}

/** Marks the results as those of earlier options when the form differs from the options
 * they were studied with (an edit undone, or a value typed before the study that ran with
 * it, leaves them current). */
function markStale(e) {
  if (["file", "sample"].includes(e?.target?.id)) return;
  if ($("error").dataset.kind === "options") $("error").hidden = true;
  if (!current) return;
  $("stale").hidden = formState() === current.asked;
}

/** Back to the built-in materials alone. */
function builtinMaterials() {
  $("materials_file").value = "";
  loadMaterialsFile();
}

function showMaterial() {
  const name = $("material").value;
  const custom = name === "custom";
  $("material-parameters").hidden = !custom;
  if (!custom) {
    const m = listed.find((x) => x.name === name);
    for (const f of materialFields) $(`m-${f}`).value = m?.[f] ?? "";
  }
}

const number = (id) => {
  const v = $(id).value.trim();
  return v === "" ? null : Number(v);
};

function vectorOf(prefix) {
  return ["x", "y", "z"].map((a) => $(`${prefix}-${a}`).value.trim() || "0").join(",");
}

/** The study's options (StudyOptions JSON: the command line's flags in snake case). */
function studyOptions() {
  const o = {};
  for (const id of ["strategy", "objective", "color_by", "thickness_rule", "centre", "nearest", "parting_line"]) o[id] = $(id).value;
  for (const id of ["fill", "wall_thickness", "suitability", "aesthetic", "require_flat", "fit_radius"]) o[id] = $(id).checked;
  for (const id of ["gate_radius", "spacing", "flat_tol", "cell"]) o[id] = number(id);
  o.grid_offset = number("grid_offset") ?? 0;
  for (const id of ["gates", "circle_points", "max_nodes"]) o[id] = number(id) ?? info.defaults[id];
  o.demold = $("demold").value === "vector" ? vectorOf("demold") : $("demold").value;
  o.cosmetic = $("cosmetic").value === "vector" ? vectorOf("cosmetic") : $("cosmetic").value || null;
  o.keep_out = $("keep_out").value.split("\n").map((s) => s.trim()).filter(Boolean);
  // JavaScript writes a number so that it reads back to the same double.
  // The gates typed in or clicked (as given: the library reads and checks them).
  o.gate_at = ownGates();
  if ($("material").value === "custom") {
    const m = { name: "custom" };
    for (const f of materialFields) m[f] = number(`m-${f}`);
    if (m.max_flow_ratio === null) delete m.max_flow_ratio;
    o.material = m;
  } else {
    o.material = $("material").value;
  }
  return o;
}

/** The form as a study would read it (units and options), to tell whether the results
 * shown are those of the form's options. */
function formState() {
  try {
    return JSON.stringify({ units: $("units").value, options: studyOptions(), materials: materialsFile });
  } catch {
    return null;
  }
}

// ---------------------------------------------------------------- the study

let viewer = null;
let part = null; // {name, bytes} or {sample}
let placed = []; // the lines of the designer's gates placed by shift-click on this part ("x,y,z" mm)
let current = null; // the study shown: {report, name}
let started = 0;

let runs = 0;

/** The app's state for people (the overlays) and for tests: `data-state` (loading, ready,
 * busy, done, error, stopped) and `data-run`, counting the studies started. */
function setState(state) {
  app.dataset.state = state;
}

function startRun() {
  app.dataset.run = String(++runs);
  setState("busy");
}

/** The stage the study under way said last, and the timer that keeps its time going
 * between the stages' reports (a stage may run for many seconds). */
let stageWords = "";
setInterval(() => {
  if (app.dataset.state === "busy" && stageWords) showStage();
}, 500);

function showStage() {
  $("busy-text").textContent = `${stageWords}… ${((performance.now() - started) / 1000).toFixed(1)} s`;
}

function onProgress({ id, stage, fraction }) {
  if (id !== seq) return;
  stageWords = STAGES[stage] ?? stage;
  showStage();
  $("progress").value = fraction;
}

/** Shows moldgate's message; `fileError` when the part's file cannot be read (no option can
 * mend that, so the hint does not offer one). */
function showError(message, fileError = false) {
  const box = $("error");
  box.replaceChildren();
  const p = document.createElement("p");
  p.id = "error-message";
  p.textContent = inPageWords(message);
  const hint = document.createElement("p");
  hint.id = "error-hint";
  hint.textContent = fileError
    ? "This file cannot be studied as it is: open or drop another part."
    : "Open or drop another part, or change the options and analyse again.";
  box.append(p, hint);
  // A message about the options goes once they change (it spoke of the options as they
  // were); one about the file stays until another part is opened.
  box.dataset.kind = fileError ? "file" : "options";
  box.hidden = false;
  bringViewIntoSight();
}

/** In the one-column layout (a narrow window) the view is below the options: brought into
 * sight when a study starts or fails, so that its progress and its message show where the
 * designer looks. */
function bringViewIntoSight() {
  if (window.matchMedia("(max-width: 1000px)").matches) $("view-area").scrollIntoView({ block: "start" });
}

function clearResults(status) {
  current = null;
  $("stale").hidden = true;
  viewer?.clear();
  $("result-body").replaceChildren();
  $("downloads").hidden = true;
  $("colour-bar").hidden = true;
  $("status").textContent = status;
}

/** The library's limit of gates a designer places (`gate_at`). */
const MAX_GATE_AT = 32;

/** The lines of 'Your own gates', typed or clicked, blank ones left out. */
function ownGates() {
  return $("gate_at_text").value.split("\n").map((s) => s.trim()).filter(Boolean);
}

/** A gate placed by shift-click: added to 'Your own gates' (where it can be read, edited
 * or deleted like a typed one) and judged with the others in a new study, the view kept. */
function placeGate(point) {
  if (!part || app.dataset.state === "busy") return;
  const lines = ownGates();
  if (lines.length >= MAX_GATE_AT) {
    $("status").textContent = `At most ${MAX_GATE_AT} gates of your own: clear them to place others.`;
    return;
  }
  // To the micrometre: a line to read and edit (the gate is moved onto the surface).
  const line = point.map((v) => String(Number(v.toFixed(3)))).join(",");
  placed.push(line);
  $("gate_at_text").value = [...lines, line].join("\n");
  analyse({ keepCamera: true, again: true });
}

/** Every gate of the designer's, typed or clicked, goes. */
function clearPlaced() {
  placed = [];
  $("gate_at_text").value = "";
  analyse({ keepCamera: true, again: true });
}

/** A new part: the gates clicked on the last one go from 'Your own gates' (they are points
 * of its frame); the typed ones stay. */
function forgetPlaced() {
  if (placed.length) $("gate_at_text").value = ownGates().filter((l) => !placed.includes(l)).join("\n");
  placed = [];
}

async function analyse({ keepCamera = false, again = false } = {}) {
  if (!part) return;
  const request = { file_name: part.name, units: $("units").value, options: studyOptions() };
  if (part.sample) request.sample = part.sample;
  if (materialsFile) request.materials_file = materialsFile;
  // The same part studied again (Analyse, a gate placed): the results on show stay when an
  // option is refused (a mistyped keep-out region), marked as the earlier options', and the
  // message says what to mend. A new part's study starts afresh.
  if (again && current && app.dataset.state === "done") {
    try {
      await ask({ type: "check", request });
    } catch (e) {
      if (e.cancelled) return;
      markStale();
      showError(e.message);
      return;
    }
  }
  if (app.dataset.state === "busy") cancelStudy();
  // The same part studied again keeps the results on show under the progress until the new
  // ones replace them: a study stopped or failed leaves them, marked as the earlier
  // options' when the form differs. A new part's study starts afresh.
  const keep = again && current !== null;
  startRun();
  started = performance.now();
  $("error").hidden = true;
  $("drop-hint").hidden = true;
  $("busy").hidden = false;
  $("busy-text").textContent = STAGES.start;
  stageWords = "";
  $("progress").value = 0;
  if (keep) $("status").textContent = `Analysing ${part.name}…`;
  else clearResults(`Analysing ${part.name}…`);
  bringViewIntoSight();
  const asked = formState();
  const bytes = part.bytes ? part.bytes.slice(0) : new ArrayBuffer(0);
  const colouring = Number($("colouring").value);
  try {
    const r = await ask({ type: "study", bytes, request, colouring }, [bytes]);
    // The view's colouring when the one chosen needs what this study did not make.
    $("colouring").value = String(r.colouring);
    const report = JSON.parse(r.report);
    const extras = await viewer.show(r.glb, { keepCamera });
    await new Promise(requestAnimationFrame);
    const total = performance.now() - started;
    current = { report, name: part.sample ?? part.name, asked };
    $("stale").hidden = true;
    showReport($("result-body"), report, r.times, request.options);
    $("clear-placed")?.addEventListener("click", clearPlaced);
    showColourBar(barField(extras));
    offerColourings(report, request.options);
    $("downloads").hidden = false;
    $("status").textContent = report.gate
      ? `Gate found for ${part.name} in ${(total / 1000).toFixed(2)} s.`
      : `No gate for ${part.name}: see why below.`;
    $("status").dataset.totalMs = String(total);
    $("busy").hidden = true;
    setState("done");
  } catch (e) {
    if (e.cancelled) return;
    $("busy").hidden = true;
    if (keep && !e.fileError) {
      $("status").textContent = `${part.name} could not be analysed with these options: the results on show are the earlier ones.`;
      markStale();
    } else {
      clearResults(`${part.name} could not be analysed.`);
    }
    showError(e.message, !!e.fileError);
    setState("error");
  }
}

// viridis, low to high, sampled from matplotlib's table (as crates/moldgate/src/colormap.rs)
const VIRIDIS = ["#440154", "#482878", "#3e4989", "#31688e", "#26828e", "#1f9e89", "#35b779", "#6ece58", "#b5de2b", "#fde725"];

/** The field the colour bar names: the suitability map's when the scene has one (its
 * scores read the other way from the fields', so the bar says which end is better), else
 * the part's. */
function barField(extras) {
  const map = extras.suitability;
  return map ? { ...map, name: `${map.name} (lower is better)` } : extras.field;
}

function showColourBar(field) {
  const bar = $("colour-bar");
  if (!field || field.min === null || field.min === undefined) {
    bar.hidden = true;
    return;
  }
  const unit = field.unit ? ` ${field.unit}` : "";
  // A far tail of a few cells (the library stops the colours at the cells' 99th
  // percentile): said beside the name, with the largest value.
  const tail = field.largest === null || field.largest === undefined
    ? ""
    : ` (colours stop at the 99th percentile of the cells: the last 1 % reach up to ${barEnds(field.min, field.largest)[1]}${unit}, in the top colour)`;
  $("colour-bar-name").textContent = `${field.name}${tail}`;
  bar.querySelector(".bar").style.background = `linear-gradient(to right, ${VIRIDIS.join(", ")})`;
  const [min, max] = barEnds(field.min, field.max);
  $("colour-bar-min").textContent = `${min}${unit}`;
  $("colour-bar-max").textContent = `${max}${unit}`;
  bar.dataset.field = field.name;
  bar.hidden = false;
}

/** The colourings this study can show: the wall thickness once measured, the fill order
 * once the fill is analysed; the others are offered disabled, saying what they need. */
function offerColourings(report, options) {
  const needs = {
    2: [report.wall_thickness, "needs 'Measure the wall thickness everywhere'"],
    3: [report.fill, "needs 'Fill analysis'"],
  };
  // The fill's colouring is the field the study was asked to colour by.
  $("colouring").options[3].dataset.name = options.color_by === "flow_length" ? "flow length" : "fill order (fill time)";
  for (const option of $("colouring").options) {
    const need = needs[option.value];
    if (!need) continue;
    option.dataset.name ??= option.textContent;
    option.disabled = !need[0];
    option.textContent = need[0] ? option.dataset.name : `${option.dataset.name} (${need[1]})`;
  }
}

async function recolour() {
  if (!current || app.dataset.state !== "done") return;
  setState("busy");
  try {
    const r = await ask({ type: "glb", colouring: Number($("colouring").value) });
    const extras = await viewer.show(r.glb, { keepCamera: true });
    showColourBar(barField(extras));
    $("error").hidden = true;
  } catch (e) {
    if (e.cancelled) return;
    showError(e.message);
  }
  setState("done");
}

async function download(what) {
  if (!current) return;
  try {
    const r = await ask({ type: "download", what, colouring: Number($("colouring").value) });
    // The page names the controls of this app, not the command line's flags.
    if (what === "html") r.bytes = new TextEncoder().encode(pageInPageWords(new TextDecoder().decode(r.bytes)));
    const type = { report: "application/json", png: "image/png", glb: "model/gltf-binary", html: "text/html" }[what];
    const ext = { report: "json", png: "png", glb: "glb", html: "html" }[what];
    const base = current.name.replace(/\.[^.]*$/, "").replace(/[^\w.-]+/g, "_") || "part";
    const a = document.createElement("a");
    a.href = URL.createObjectURL(new Blob([r.bytes], { type }));
    a.download = `${base}.${ext}`;
    document.body.append(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(a.href), 60_000);
  } catch (e) {
    if (!e.cancelled) showError(e.message);
  }
}

// ---------------------------------------------------------------- choosing a part

async function openFile(file) {
  forgetPlaced();
  if (!file) return;
  if (info && file.size > info.maxFileBytes) {
    if (app.dataset.state === "busy") cancelStudy();
    startRun();
    part = null;
    clearResults(`${file.name} is too large.`);
    showError(`${file.name}: ${file.size} bytes, over the limit of ${info.maxFileBytes} bytes the browser can study`, true);
    setState("error");
    return;
  }
  $("sample").value = "";
  part = { name: file.name, bytes: await file.arrayBuffer() };
  $("analyse").disabled = false;
  analyse();
}

function openSample(name) {
  forgetPlaced();
  if (!name) return;
  part = { name: `${name} (sample)`, sample: name };
  $("analyse").disabled = false;
  analyse();
}

function wire() {
  $("file").addEventListener("change", (e) => {
    openFile(e.target.files[0]);
    e.target.value = "";
  });
  $("sample").addEventListener("change", (e) => openSample(e.target.value));
  const area = $("viewport");
  area.addEventListener("dragover", (e) => {
    e.preventDefault();
    area.classList.add("dragging");
  });
  area.addEventListener("dragleave", () => area.classList.remove("dragging"));
  area.addEventListener("drop", (e) => {
    e.preventDefault();
    area.classList.remove("dragging");
    openFile(e.dataTransfer.files[0]);
  });
  // A file dropped beside the view must not replace the page.
  window.addEventListener("dragover", (e) => e.preventDefault());
  window.addEventListener("drop", (e) => e.preventDefault());

  // The browser refuses a form whose invalid field is in a closed section without a word:
  // the section opens first, so that its message shows at the field (a click on Analyse,
  // or Enter in a field, which clicks it).
  $("analyse").addEventListener("click", () => {
    const details = $("options").querySelector(":invalid")?.closest("details");
    if (details) details.open = true;
  });
  $("options").addEventListener("submit", (e) => {
    e.preventDefault();
    analyse({ again: true });
  });
  // A study stopped by the designer: its worker goes, the part stays open for the next, and
  // the results on show before it (the same part's) stay, marked as the earlier options'
  // when the form differs.
  $("stop").addEventListener("click", () => {
    if (app.dataset.state !== "busy") return;
    cancelStudy();
    $("busy").hidden = true;
    if (current !== null) {
      $("status").textContent = `Stopped: the results on show are those of the study before.`;
      markStale();
    } else {
      clearResults(`Stopped: ${part.name} was not analysed. A long study runs faster with a coarser 'Fill cell size' or fewer gates.`);
    }
    setState("stopped");
  });
  $("defaults").addEventListener("click", () => {
    setDefaults();
    markStale();
    showFillImplied();
  });
  $("material").addEventListener("change", showMaterial);
  $("demold").addEventListener("change", () => ($("demold-vector").hidden = $("demold").value !== "vector"));
  $("cosmetic").addEventListener("change", () => ($("cosmetic-vector").hidden = $("cosmetic").value !== "vector"));
  $("colouring").addEventListener("change", recolour);
  // An option changed after a study: its results stay, marked as those of the earlier
  // options, until the next analysis (choosing a file or a sample starts one by itself).
  $("options").addEventListener("input", markStale);
  $("options").addEventListener("change", markStale);
  $("options").addEventListener("input", showFillImplied);
  $("options").addEventListener("change", showFillImplied);
  $("reset-view").addEventListener("click", () => viewer.reset());
  $("view-d").addEventListener("click", () => viewer.viewAlongD());
  for (const layer of ["gates", "placed", "centre", "parting", "qualifying"]) {
    $(`layer-${layer}`).addEventListener("change", (e) => viewer.setLayer(layer, e.target.checked));
  }
  viewer.onPick = placeGate;
  viewer.canvas.addEventListener("keydown", (e) => {
    if (e.key === "r" || e.key === "R") viewer.reset();
    if (e.key === "d" || e.key === "D") viewer.viewAlongD();
  });
  $("materials_file").addEventListener("change", loadMaterialsFile);
  $("materials-builtin").addEventListener("click", builtinMaterials);
  for (const b of document.querySelectorAll("[data-download]")) {
    b.addEventListener("click", () => download(b.dataset.download));
  }
}

async function main() {
  viewer = new Viewer($("viewport"));
  startWorker();
  wire();
  try {
    info = await ask({ type: "info" });
  } catch (e) {
    showError(e.message);
    setState("error");
    return;
  }
  $("version").textContent = `moldgate ${info.version}`;
  for (const s of info.samples) {
    const o = document.createElement("option");
    o.value = s.name;
    o.textContent = s.name;
    o.title = s.description;
    $("sample").append(o);
  }
  listMaterials(info.materials);
  setDefaults();
  setState("ready");
}

main();
