//! Studies: options from JSON (the library's `StudyOptions`), user materials, the study
//! and what it gives (report, gates, pictures, per-vertex fields), batch rows.

use std::path::{Path, PathBuf};
use std::time::Instant;

use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList};

use moldgate::batch_row::{BatchRow, Status};
use moldgate::flow::FillError;
use moldgate::render::RenderError;
use moldgate::report::Input;
use moldgate::study::{Hooks, MaterialChoice, Settings, StudyError, StudyOptions};
use moldgate::Material;

use crate::part::{units, Part};
use crate::{detached, guarded, OptionsError, PyErrBox};

/// A JSON text as Python objects.
pub(crate) fn json_to_py<'py>(py: Python<'py>, json: &str) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (json,))
}

/// serde_json's message without the place in the JSON text, which the user did not write.
fn serde_message(e: &serde_json::Error) -> String {
    let s = e.to_string();
    match s.rfind(" at line ") {
        Some(i) => s[..i].to_string(),
        None => s,
    }
}

/// Reads a TOML file of user materials, each named by its table (the command line's
/// `--materials-file`): a regular file of at most `MAX_MATERIALS_BYTES`.
fn read_materials(path: &Path) -> Result<Vec<Material>, String> {
    let fail = |e: String| format!("{}: {e}", moldgate::files::shown(&path));
    let text = moldgate::files::read_toml_text(path, moldgate::files::MAX_MATERIALS_BYTES)
        .map_err(|e| fail(e.to_string()))?;
    moldgate::material::materials_from_toml(&text).map_err(fail)
}

/// The options from their JSON form: an error names the option at fault (a parameter of a
/// material given as a table as `material.n`).
fn options(json: &str) -> Result<StudyOptions, String> {
    let value: serde_json::Value = serde_json::from_str(json).map_err(|e| serde_message(&e))?;
    let serde_json::Value::Object(object) = value else {
        return Err("the options must be a table of names and values".into());
    };
    // A value given is named as Python writes it (True, None), not as JSON.
    let mut o = StudyOptions::from_json_object(object).map_err(|e| {
        e.to_string()
            .replace(": got true,", ": got True,")
            .replace(": got false,", ": got False,")
            .replace("got no value (null)", "got None")
    })?;
    if let MaterialChoice::Parameters(m) = &mut o.material {
        if m.name.is_empty() {
            m.name = "user material".into();
        }
    }
    Ok(o)
}

/// Options and user materials validated into the library's settings.
fn settings(json: &str, materials_file: Option<&Path>) -> Result<Settings, String> {
    let o = options(json)?;
    let user = match materials_file {
        Some(p) => read_materials(p)?,
        None => Vec::new(),
    };
    o.validate_with(&user).map_err(|e| python_message(&e))
}

/// A study's error in this package's words: options named as its arguments, not the
/// command line's flags, and an option over its limit led by its keyword
/// (`circle_points: circle points must be at most 360, ...`).
fn python_message(e: &StudyError) -> String {
    let m = moldgate::study::keyword_words(&e.to_string(), "True");
    match e {
        StudyError::Locate(l) => match l.field() {
            Some(field) if !m.starts_with(field) => format!("{field}: {m}"),
            _ => m,
        },
        _ => m,
    }
}

/// The exception of a study that could not be made, and the batch status it stands for
/// (the command line's exit codes for the same errors).
fn study_error(e: &StudyError) -> (Status, PyErrBox) {
    let m = python_message(e);
    match e {
        // The part's fault, not an option's (as the command line's exit code 3).
        StudyError::Locate(l) if l.is_the_parts() => (Status::InputError, PyErrBox::Load(m)),
        StudyError::Invalid { .. }
        | StudyError::Parse { .. }
        | StudyError::Conflict { .. }
        | StudyError::UnknownMaterial { .. }
        | StudyError::Material(_)
        | StudyError::Locate(_) => (Status::OptionError, PyErrBox::Options(m)),
        StudyError::Fill(FillError::TooFewCandidates { .. }) => {
            (Status::NoGate, PyErrBox::NoGate(m))
        }
        StudyError::Fill(FillError::GateOffPart(..)) => (Status::InputError, PyErrBox::Load(m)),
        StudyError::Fill(_) => (Status::OptionError, PyErrBox::Options(m)),
        StudyError::Demold(_) | StudyError::Render(RenderError::EmptyMesh) => {
            (Status::InputError, PyErrBox::Load(m))
        }
        StudyError::Glb(_) => (Status::OutputError, PyErrBox::Internal(m)),
        StudyError::Cancelled { .. }
        | StudyError::Render(_)
        | StudyError::OtherPart { .. }
        | StudyError::Encode(_) => (Status::InternalError, PyErrBox::Internal(m)),
    }
}

/// study(part, options_json, materials_file=None)
/// --
///
/// Studies a part with options given as the JSON form of `StudyOptions`. Use
/// `moldgate.study`, which takes the options as keyword arguments.
///
/// The study runs on a thread of its own while this one waits without the GIL, looking
/// every 50 ms for a signal (Ctrl-C: `KeyboardInterrupt`) and for the time limit `timeout`
/// (seconds: the built-in `TimeoutError`); either stops the study (its cancellation token)
/// within a step of it (a march of the fill, a facet of a wall map, a block of triangles of
/// the gate's rays; the load runs to its end) before the exception is raised. A study that
/// ends before the look that finds its limit passed is returned.
#[pyfunction]
#[pyo3(signature = (part, options_json, materials_file = None, timeout = None))]
pub fn study(
    py: Python<'_>,
    part: Py<Part>,
    options_json: &str,
    materials_file: Option<PathBuf>,
    timeout: Option<f64>,
) -> PyResult<Study> {
    let settings = guarded(|| {
        settings(options_json, materials_file.as_deref()).map_err(OptionsError::new_err)
    })?;
    let limit = time_limit(timeout)?;
    let p = part.get();
    let mesh = p.mesh.clone();
    let (input, load_s) = (p.input.clone(), p.load_s);
    let cancel = moldgate::study::Cancel::new();
    let started = Instant::now();
    let (done, result) = std::sync::mpsc::channel();
    // Waited on without the GIL, which needs it shareable.
    let result = std::sync::Mutex::new(result);
    std::thread::scope(|scope| {
        scope.spawn(|| {
            let hooks = Hooks {
                cancel: Some(&cancel),
                ..Hooks::default()
            };
            let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                moldgate::study_with(&mesh, &settings, &hooks)
            }));
            // The receiver waits until this is sent (or has stopped waiting).
            let _ = done.send(outcome);
        });
        // Why the study was stopped, if it was: a signal's exception, or the time limit.
        let mut stopped: Option<Stop> = None;
        let outcome = loop {
            let waited = py.detach(|| {
                result
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .recv_timeout(std::time::Duration::from_millis(50))
            });
            match waited {
                Ok(outcome) => break outcome,
                Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                    return Err(crate::InternalError::new_err(
                        "internal error in moldgate, please report it: the study's thread ended without an answer",
                    ))
                }
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
            }
            if stopped.is_some() {
                continue;
            }
            if let Err(signal) = py.check_signals() {
                stopped = Some(Stop::Signal(signal));
                cancel.cancel();
            } else if limit.is_some_and(|l| started.elapsed() >= l) {
                stopped = Some(Stop::Time);
                cancel.cancel();
            }
        };
        match stopped {
            Some(Stop::Signal(e)) => return Err(e),
            // The stage it stopped in, what takes less time there, and the gate found
            // before the stop, as the command line says them.
            Some(Stop::Time) => {
                let said = match &outcome {
                    Ok(Err(e @ StudyError::Cancelled { stage, .. })) => {
                        let hint = less_time_keywords(&settings, *stage);
                        format!(
                            " in the {stage} stage{}{}",
                            if hint.is_empty() {
                                String::new()
                            } else {
                                format!(" ({hint})")
                            },
                            e.gate_before_stop()
                        )
                    }
                    _ => String::new(),
                };
                return Err(pyo3::exceptions::PyTimeoutError::new_err(format!(
                    "the study took longer than its timeout of {} s and was stopped{said}",
                    timeout.unwrap_or_default()
                )));
            }
            None => {}
        }
        let mut s = match outcome {
            Ok(Ok(s)) => s,
            // No layout of the gates asked for: named by its part, as every other no-gate
            // error is.
            Ok(Err(e)) => {
                return Err(match study_error(&e).1 {
                    PyErrBox::NoGate(m) => PyErrBox::NoGate(format!(
                        "{}: {m}",
                        input.path.as_deref().unwrap_or("part")
                    )),
                    other => other,
                }
                .into_py_err())
            }
            Err(panic) => return Err(crate::panicked(&*panic)),
        };
        s.set_input(input, load_s);
        Ok(Study { study: s, part })
    })
}

/// Why a study was stopped before its end.
enum Stop {
    /// A signal (Ctrl-C), with its exception.
    Signal(PyErr),
    /// The time limit.
    Time,
}

/// What takes less time in a study stopped at `stage`, in the package's keywords (the
/// command line's words, `a coarser --cell`, as `a coarser cell`).
fn less_time_keywords(settings: &Settings, stage: moldgate::study::Stage) -> String {
    let hint = settings
        .less_time_words(stage)
        .replace("no --suitability", "no suitability map")
        .replace("no --wall-thickness", "no wall map");
    moldgate::study::keyword_words(&hint, "True")
}

/// A time limit in seconds as a duration: from a millisecond to a day (the library's
/// [`moldgate::study::MAX_TIMEOUT_S`]).
fn time_limit(timeout: Option<f64>) -> PyResult<Option<std::time::Duration>> {
    timeout
        .map(|t| moldgate::study::time_limit("timeout", t))
        .transpose()
        .map_err(OptionsError::new_err)
}

/// batch_row(path, options_json, materials_file=None, units="mm", demold=None, timeout=None)
/// --
///
/// Loads and studies one file and gives its batch summary row as one line of JSON, the
/// row of `moldgate locate DIR --summary x.jsonl`. A part that fails is a failed row;
/// options that are refused raise `OptionsError` (they would fail every part). A study
/// past `timeout` seconds is stopped, and its row says so (status `timeout`, exit code 6,
/// as the command line's batch gives for `--timeout`).
#[pyfunction]
#[pyo3(signature = (path, options_json, materials_file = None, units = "mm", demold = None, timeout = None))]
pub fn batch_row(
    py: Python<'_>,
    path: PathBuf,
    options_json: &str,
    materials_file: Option<PathBuf>,
    units: &str,
    demold: Option<String>,
    timeout: Option<f64>,
) -> PyResult<String> {
    let limit = time_limit(timeout)?;
    let cancel = moldgate::study::Cancel::new();
    let u = self::units(units)?;
    let settings = guarded(|| {
        settings(options_json, materials_file.as_deref()).map_err(OptionsError::new_err)
    })?;
    let demold = match demold {
        Some(d) => d,
        None => options(options_json)
            .map(|o| o.demold)
            .map_err(OptionsError::new_err)?,
    };
    let file = moldgate::files::shown(&path);
    let t = Instant::now();
    let row = py.detach(|| {
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let (mesh, input) = match crate::part::read_file(&path, u) {
                Ok((mesh, bytes)) => (
                    mesh,
                    Input {
                        path: Some(file.clone()),
                        sample: None,
                        bytes,
                    },
                ),
                Err(m) => return Err((Status::InputError, m, None)),
            };
            let load_s = t.elapsed().as_secs_f64();
            // A timer that stops the study at the limit, woken early when the study ends.
            let (finished, wait) = std::sync::mpsc::channel::<()>();
            let hooks = Hooks {
                cancel: Some(&cancel),
                ..Hooks::default()
            };
            let studied = std::thread::scope(|scope| {
                if let Some(limit) = limit {
                    let cancel = &cancel;
                    scope.spawn(move || {
                        if let Err(std::sync::mpsc::RecvTimeoutError::Timeout) =
                            wait.recv_timeout(limit)
                        {
                            cancel.cancel();
                        }
                    });
                }
                let studied = moldgate::study_with(&mesh, &settings, &hooks);
                drop(finished);
                studied
            });
            // The messages of the command line's batch for the same errors.
            let mut s =
                studied.map_err(|e| {
                    let (status, _) = study_error(&e);
                    let gate = e.gate_before_stop();
                    match e {
                        // Stopped in the fill stage: the row keeps the gate found before.
                        StudyError::Cancelled { stage, located } => {
                            let stage = &stage;
                            let hint = less_time_keywords(&settings, *stage);
                            let located = located.map(|mut r| {
                                r.set_input(input.clone(), load_s);
                                r
                            });
                            (
                                Status::Timeout,
                                format!(
                                "{file}: stopped at its timeout of {} s, in the {stage} stage{}{gate}",
                                timeout.unwrap_or_default(),
                                if hint.is_empty() { String::new() } else { format!(" ({hint})") }
                            ),
                                located,
                            )
                        }
                        StudyError::Demold(d) => {
                            (status, format!("{file}: demold=\"auto\": {d}"), None)
                        }
                        StudyError::Fill(f @ FillError::GateOffPart(..)) => {
                            (status, format!("{file}: {f}"), None)
                        }
                        e => (status, e.to_string(), None),
                    }
                })?;
            s.set_input(input, load_s);
            Ok(s.into_report())
        }))
        .unwrap_or_else(|_| {
            Err((
                Status::InternalError,
                "internal error, please report it (see the panic message above)".into(),
                None,
            ))
        })
    });
    let time_s = t.elapsed().as_secs_f64();
    let row = match &row {
        Ok(report) => BatchRow::studied(&file, u, &demold, report, time_s),
        Err((status, m, located)) => BatchRow::new(
            &file,
            u,
            &demold,
            located.as_deref(),
            Some((*status, m)),
            time_s,
        ),
    };
    Ok(row.to_json())
}

/// materials(materials_file=None)
/// --
///
/// The built-in library (the paper's Table 1, then typical grades), each replaced by a
/// material of `materials_file` of the same name or alias, then the file's others: each a
/// dict of its parameters, aliases, description, family, the source of every value, its
/// origin, and the melt velocity of Eq. 7 and the gate radius of Eq. 8 (the entries of
/// `moldgate materials --json`).
#[pyfunction]
#[pyo3(signature = (materials_file = None))]
pub fn materials<'py>(
    py: Python<'py>,
    materials_file: Option<PathBuf>,
) -> PyResult<Bound<'py, PyList>> {
    let user = match &materials_file {
        Some(p) => read_materials(p).map_err(OptionsError::new_err)?,
        None => Vec::new(),
    };
    let origin = materials_file
        .as_deref()
        .map(|p| moldgate::files::shown(&p))
        .unwrap_or_default();
    let listing = moldgate::material::Listing::new(user, &origin);
    let list = PyList::empty(py);
    for m in &listing.materials {
        let d = json_to_py(py, &serde_json::to_string(m).unwrap_or_default())?;
        list.append(d.cast_into::<PyDict>()?)?;
    }
    Ok(list)
}

/// check_options(options_json, materials_file=None, timeout=None)
/// --
///
/// Validates options (and a time limit) as a study would, raising `OptionsError`; no part
/// is needed.
#[pyfunction]
#[pyo3(signature = (options_json, materials_file = None, timeout = None))]
pub fn check_options(
    options_json: &str,
    materials_file: Option<PathBuf>,
    timeout: Option<f64>,
) -> PyResult<()> {
    time_limit(timeout)?;
    guarded(|| {
        settings(options_json, materials_file.as_deref())
            .map(|_| ())
            .map_err(OptionsError::new_err)
    })
}

/// The JSON form of the default options (the command line's defaults).
#[pyfunction]
pub fn default_options() -> String {
    serde_json::to_string(&StudyOptions::default()).unwrap_or_default()
}

/// Panics inside the library's boundary: the test that a panic becomes an exception.
#[pyfunction]
pub fn panic_for_test(py: Python<'_>) -> PyResult<()> {
    detached(py, || -> Result<(), PyErrBox> { panic!("a test panic") })
}

/// One gate of the answer.
#[pyclass(frozen, get_all, module = "moldgate")]
pub struct Gate {
    /// Gate point on the surface, mm (numpy, 3).
    point: Py<PyArray1<f64>>,
    /// Outward unit normal there (numpy, 3); zero when no triangle is near.
    normal: Py<PyArray1<f64>>,
    /// Gate radius R_gate, mm.
    radius_mm: f64,
    /// 3D distance to the centre of mass, mm (None for the extra gates of a layout).
    distance_mm: Option<f64>,
    /// Wall thickness along the demolding direction at the gate, mm: known at the paper's
    /// grid gate, None at any other gate (a layout's, the parting line's, a balanced gate
    /// that moved) and where unknown.
    wall_mm: Option<f64>,
    /// `paper` or `aesthetic`.
    mode: String,
    /// `paper` or `balanced`.
    strategy: String,
}

#[pymethods]
impl Gate {
    fn __repr__(&self, py: Python<'_>) -> String {
        let p: Vec<f64> = self.point.bind(py).to_vec().unwrap_or_default();
        // Which gate it is: the paper's, the aesthetic one, or the balanced one.
        let which = match (self.mode.as_str(), self.strategy.as_str()) {
            (_, "balanced") => "balanced",
            (mode, _) => mode,
        };
        format!(
            "<moldgate.Gate ({:.3}, {:.3}, {:.3}) mm, R = {:.3} mm, {which}>",
            p[0], p[1], p[2], self.radius_mm
        )
    }
}

/// The gate-suitability map of a study (`suitability=True`): per qualifying node on the
/// voxelised part, its point and its score (the objective of a gate there, lower is
/// better), exact or a lower bound with its upper bound.
#[pyclass(frozen, get_all, module = "moldgate")]
pub struct Suitability {
    /// Surface points of the scored nodes, (k, 3) float64, mm.
    points: Py<PyArray2<f64>>,
    /// Their scores, (k,) float64, in `unit`.
    scores: Py<PyArray1<f64>>,
    /// Upper bounds of the scores, (k,) float64 (equal to the score where exact; NaN where
    /// unbounded).
    upper: Py<PyArray1<f64>>,
    /// Whether each score is exact (else it is a lower bound), (k,) bool.
    exact: Py<PyArray1<bool>>,
    /// Index of each node in `Study.qualifying_points`, (k,) int64.
    nodes: Py<PyArray1<i64>>,
    /// Body of each node, from 0, (k,) int64: each node is scored by the fill of its own
    /// body, so scores compare only within one body.
    bodies: Py<PyArray1<i64>>,
    /// `mm` (L_max) or `s` (fill time).
    unit: String,
    /// `length` or `resistance`.
    objective: String,
    /// Row of the best node (least score), or None.
    best: Option<usize>,
    /// Row of the best node of each body, by body (None for a body without a node).
    best_per_body: Vec<Option<usize>>,
}

#[pymethods]
impl Suitability {
    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "<moldgate.Suitability of {} nodes, {}>",
            self.scores.bind(py).len().unwrap_or(0),
            self.unit
        )
    }
}

/// A finished study of one part.
#[pyclass(frozen, module = "moldgate")]
pub struct Study {
    study: moldgate::Study,
    part: Py<Part>,
}

impl Study {
    /// The part's name in titles: its file's name, a sample's name as the command line
    /// gives it (`sample 'cover'`), or `part` for one built from arrays.
    fn title(&self) -> String {
        let input = &self.part.get().input;
        match (&input.path, &input.sample) {
            (Some(p), _) => Path::new(p)
                .file_name()
                .map(moldgate::files::shown)
                .unwrap_or_else(|| p.clone()),
            (None, Some(name)) => format!("sample '{name}'"),
            (None, None) => "part".into(),
        }
    }

    fn gate_objects<'py>(&self, py: Python<'py>) -> PyResult<Vec<Gate>> {
        let r = self.study.report();
        let radius = r.options.gate_radius_mm;
        let (mode, strategy, distance) = match &r.gate {
            Some(g) => (
                serde_json::to_value(g.mode).ok(),
                serde_json::to_value(g.strategy).ok(),
                Some(g.distance_3d_mm),
            ),
            None => return Ok(Vec::new()),
        };
        let name = |v: Option<serde_json::Value>| {
            v.and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default()
        };
        let (mode, strategy) = (name(mode), name(strategy));
        // The wall along D is known at the paper's grid gate only: a gate elsewhere (the
        // parting line's, a balanced one that moved, a layout's) has none of its own.
        let paper = r.paper_gate.as_ref().map(|g| (g.point, g.thickness_mm));
        self.study
            .gates()
            .iter()
            .enumerate()
            .map(|(i, g)| {
                Ok(Gate {
                    point: PyArray1::from_slice(py, &g.point.to_array()).unbind(),
                    normal: PyArray1::from_slice(py, &g.normal.to_array()).unbind(),
                    radius_mm: radius,
                    distance_mm: if i == 0 { distance } else { None },
                    wall_mm: paper
                        .filter(|(at, _)| *at == g.point.to_array())
                        .and_then(|(_, wall)| wall),
                    mode: mode.clone(),
                    strategy: strategy.clone(),
                })
            })
            .collect()
    }
}

#[pymethods]
impl Study {
    /// The gate of the answer (the first of several), or None when no position qualifies
    /// (then `report["no_gate_reason"]` says why).
    #[getter]
    fn gate(&self, py: Python<'_>) -> PyResult<Option<Gate>> {
        Ok(self.gate_objects(py)?.into_iter().next())
    }

    /// Every gate of the answer: one, or the K gates of `gates=K`; empty without a gate.
    #[getter]
    fn gates(&self, py: Python<'_>) -> PyResult<Vec<Gate>> {
        self.gate_objects(py)
    }

    /// The report as a dict: the JSON of `moldgate locate --json` (docs/json-schema.md),
    /// its sentences (warnings, reasons) naming this package's keywords
    /// (`require_flat=True`, not `--require-flat`).
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &self.to_json()?)
    }

    /// The report as pretty JSON with a final newline, as `moldgate locate --json` prints it
    /// but for its sentences, which name this package's keywords.
    fn to_json(&self) -> PyResult<String> {
        self.study
            .report_json_in_keywords("True")
            .map_err(|e| study_error(&e).1.into_py_err())
    }

    /// The part that was studied.
    #[getter]
    fn part(&self, py: Python<'_>) -> Py<Part> {
        self.part.clone_ref(py)
    }

    /// png(title=None)
    /// --
    ///
    /// The 1600x900 PNG picture (view along the demolding direction and an isometric
    /// view) as bytes; `title` defaults to the file's name.
    #[pyo3(signature = (title = None))]
    fn png<'py>(&self, py: Python<'py>, title: Option<String>) -> PyResult<Bound<'py, PyBytes>> {
        let title = title.unwrap_or_else(|| self.title());
        let mesh = self.part.get().mesh.clone();
        let bytes = detached(py, || {
            self.study.png(&mesh, title).map_err(|e| study_error(&e).1)
        })?;
        Ok(PyBytes::new(py, &bytes))
    }

    /// glb(title=None)
    /// --
    ///
    /// The study as binary glTF 2.0 (a .glb file's bytes).
    #[pyo3(signature = (title = None))]
    fn glb<'py>(&self, py: Python<'py>, title: Option<String>) -> PyResult<Bound<'py, PyBytes>> {
        let title = title.unwrap_or_else(|| self.title());
        let mesh = self.part.get().mesh.clone();
        let bytes = detached(py, || {
            self.study.glb(&mesh, title).map_err(|e| study_error(&e).1)
        })?;
        Ok(PyBytes::new(py, &bytes))
    }

    /// html(picture=True)
    /// --
    ///
    /// The self-contained HTML report (no scripts, no fetches), with the PNG picture in it
    /// unless `picture=False`; its sentences name this package's keywords, as `report`'s do.
    #[pyo3(signature = (picture = true))]
    fn html(&self, py: Python<'_>, picture: bool) -> PyResult<String> {
        let title = self.title();
        let mesh = self.part.get().mesh.clone();
        detached(py, || {
            let png = if picture {
                Some(
                    self.study
                        .png(&mesh, title)
                        .map_err(|e| study_error(&e).1)?,
                )
            } else {
                None
            };
            self.study
                .html_in_keywords(png.as_deref(), "True")
                .map_err(|e| study_error(&e).1)
        })
    }

    /// Fill order per vertex of `part.vertices`: the estimated fill time divided by its
    /// largest value (0 at the gate, 1 last, NaN where the melt does not reach), float32;
    /// None unless the fill ran with `color_by="fill_order"` (the default).
    #[getter]
    fn fill_order<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f32>>> {
        let t = self.study.fill_time_per_vertex()?;
        let max = t
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .fold(0.0f32, f32::max);
        let order = t
            .iter()
            .map(|&v| if max > 0.0 { v / max } else { v })
            .collect();
        Some(PyArray1::from_vec(py, order))
    }

    /// Estimated fill time per vertex of `part.vertices`, s (NaN where the melt does not
    /// reach), float32; None unless the fill ran with `color_by="fill_order"`.
    #[getter]
    fn fill_time<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f32>>> {
        self.study
            .fill_time_per_vertex()
            .map(|f| PyArray1::from_slice(py, f))
    }

    /// Flow length from the gate per vertex of `part.vertices`, mm (NaN where the melt does
    /// not reach; with several gates, from all of them), float32; None unless the fill ran
    /// with `color_by="flow_length"` (the fill makes the per-vertex field it pictures).
    #[getter]
    fn flow_length<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f32>>> {
        self.study
            .flow_length_per_vertex()
            .map(|f| PyArray1::from_slice(py, f))
    }

    /// Wall thickness per vertex of `part.vertices`, mm (NaN where unknown), float32; None
    /// unless `wall_thickness=True`.
    #[getter]
    fn wall_thickness<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f32>>> {
        self.study
            .wall_thickness_per_vertex()
            .map(|f| PyArray1::from_slice(py, f))
    }

    /// The gate-suitability map, when the study ran with `suitability=True` (else None).
    #[getter]
    fn suitability(&self, py: Python<'_>) -> PyResult<Option<Suitability>> {
        let Some(map) = self.study.fill().and_then(|f| f.suitability.as_ref()) else {
            return Ok(None);
        };
        let n = &map.nodes;
        let points = if n.is_empty() {
            numpy::PyArray2::zeros(py, (0, 3), false)
        } else {
            let rows: Vec<Vec<f64>> = n.iter().map(|x| x.point.to_vec()).collect();
            PyArray2::from_vec2(py, &rows)
                .map_err(|e| crate::InternalError::new_err(e.to_string()))?
        };
        let column = |f: &dyn Fn(&moldgate::flow::NodeScore) -> f64| {
            PyArray1::from_vec(py, n.iter().map(f).collect()).unbind()
        };
        Ok(Some(Suitability {
            points: points.unbind(),
            scores: column(&|x| x.score),
            upper: column(&|x| x.upper.unwrap_or(f64::NAN)),
            exact: PyArray1::from_vec(
                py,
                n.iter()
                    .map(|x| x.kind == moldgate::flow::ScoreKind::Exact)
                    .collect(),
            )
            .unbind(),
            nodes: PyArray1::from_vec(py, n.iter().map(|x| x.node as i64).collect()).unbind(),
            bodies: PyArray1::from_vec(py, n.iter().map(|x| i64::from(x.body)).collect()).unbind(),
            unit: map.unit.to_string(),
            objective: match map.objective {
                moldgate::flow::Objective::Length => "length",
                moldgate::flow::Objective::Resistance => "resistance",
            }
            .to_string(),
            best: map.best,
            best_per_body: map.best_per_body.clone(),
        }))
    }

    /// Surface points of every node that qualifies as a gate position, (k, 3) float64, mm.
    #[getter]
    fn qualifying_points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let rows: Vec<Vec<f64>> = self
            .study
            .qualifying_points()
            .iter()
            .map(|p| p.to_array().to_vec())
            .collect();
        if rows.is_empty() {
            return Ok(numpy::PyArray2::zeros(py, (0, 3), false));
        }
        PyArray2::from_vec2(py, &rows).map_err(|e| crate::InternalError::new_err(e.to_string()))
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        Ok(match self.gate(py)? {
            Some(g) => format!(
                "<moldgate.Study of {}: gate {}>",
                self.title(),
                g.__repr__(py)
            ),
            None => format!("<moldgate.Study of {}: no gate>", self.title()),
        })
    }
}
