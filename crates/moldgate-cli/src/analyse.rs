//! One part, loaded and studied: the arguments validated once into [`Settings`], the mesh
//! read from its file (or made from a sample), [`moldgate::study_with`] run on it, and the
//! library's errors mapped to exit codes.

use std::path::Path;
use std::time::{Duration, Instant};

use moldgate::flow::FillError;
use moldgate::mesh::{self, LoadedMesh, Units};
use moldgate::render::RenderError;
use moldgate::report::Input;
use moldgate::study::{self, Hooks, Study, StudyError};

use crate::args::LocateArgs;
use crate::Failure;

/// The validated options of `locate`, the same for every part of a run.
#[derive(Debug, Clone)]
pub struct Settings {
    /// The study's options, validated.
    pub study: study::Settings,
    /// The unit of the files.
    pub units: Units,
    /// Time limit of each study (`--timeout`), or none.
    pub timeout: Option<Duration>,
}

/// Validates the raw arguments of `locate` once into [`Settings`].
pub fn settings(a: &LocateArgs) -> Result<Settings, Failure> {
    let user = match &a.materials_file {
        Some(p) => crate::materials::read_materials(p)?,
        None => Vec::new(),
    };
    let mut study = a
        .study_options()
        .validate_with(&user)
        .map_err(|e| failure(&e, ""))?;
    // Nothing drawn (no picture, report page or 3D scene; a batch draws none): the fill's
    // pictured field, its cells and its value at every vertex (and, for several gates, a
    // march from all of them at once), is not made. The report does not hold it.
    if a.png.is_none() && a.report.is_none() && a.glb.is_none() {
        if let Some(fill) = study.fill.as_mut() {
            fill.colour_by = moldgate::flow::ColourBy::Height;
        }
    }
    let units: Units = a
        .units
        .parse()
        .map_err(|e: String| Failure::usage(format!("--units: {e}")))?;
    let timeout = a
        .batch
        .timeout
        .map(|t| moldgate::study::time_limit("--timeout", t))
        .transpose()
        .map_err(Failure::usage)?;
    Ok(Settings {
        study,
        units,
        timeout,
    })
}

/// The command line's flag of a field of [`moldgate::StudyOptions`].
fn flag(field: &str) -> String {
    format!("--{}", field.replace('_', "-"))
}

/// The failure (message and exit code) of a library error; `part` names the part for the
/// errors that belong to it.
pub fn failure(e: &StudyError, part: &str) -> Failure {
    match e {
        StudyError::Invalid { field, message } => {
            Failure::usage(format!("{} {message}", flag(field)))
        }
        StudyError::Parse { field, source } => Failure::usage(format!("{}: {source}", flag(field))),
        StudyError::Conflict { first, second, why } => Failure::usage(format!(
            "{} and {} cannot be used together: {why}",
            flag(first),
            flag(second)
        )),
        StudyError::UnknownMaterial { .. } => Failure::usage(format!(
            "--material: {e} (`moldgate materials` lists them all)"
        )),
        // The part's fault, not an option's: an input error that names the file.
        StudyError::Locate(l) if l.is_the_parts() => Failure::input(format!("{part}: {l}")),
        // An option over its limit named as its flag, when the message does not name it.
        StudyError::Locate(l) => match l.field().map(flag) {
            Some(f) if !e.to_string().starts_with(&f) => Failure::usage(format!("{f}: {e}")),
            _ => Failure::usage(e.to_string()),
        },
        StudyError::Material(_) => Failure::usage(e.to_string()),
        StudyError::Demold(e) => Failure::input(format!("{part}: --demold auto: {e}")),
        StudyError::Fill(f @ FillError::TooFewCandidates { .. }) => {
            Failure::no_gate(if part.is_empty() {
                f.to_string()
            } else {
                format!("{part}: {f}")
            })
        }
        // The part's fault: its surface encloses no solid at the gate.
        StudyError::Fill(f @ FillError::GateOffPart(..)) => Failure::input(format!("{part}: {f}")),
        StudyError::Fill(f) => Failure::usage(f.to_string()),
        StudyError::Render(RenderError::EmptyMesh) => Failure::input(e.to_string()),
        StudyError::Glb(g) => Failure::output(format!("{part}: {g}")),
        StudyError::Cancelled { .. }
        | StudyError::Render(_)
        | StudyError::OtherPart { .. }
        | StudyError::Encode(_) => Failure::new(1, e.to_string()),
    }
}

/// Where a part comes from.
#[derive(Debug, Clone, Copy)]
pub enum Source<'a> {
    /// A mesh file.
    File(&'a Path),
    /// A built-in sample, by name.
    Sample(&'a str),
}

impl Source<'_> {
    /// The title of a picture or 3D file: the file's name, or the sample's.
    pub fn title(self) -> String {
        match self {
            Source::File(f) => moldgate::files::shown(f.file_name().unwrap_or(f.as_os_str())),
            Source::Sample(s) => format!("sample '{s}'"),
        }
    }
}

/// Reads a mesh file and gives its size in bytes; every failure names the file.
pub fn load_file(path: &Path, units: Units) -> Result<(LoadedMesh, u64), Failure> {
    crate::output::register_input(path);
    moldgate::files::read_mesh_file(path, units)
        .map_err(|e| Failure::input(format!("{}: {e}", moldgate::files::shown(&path))))
}

/// One studied part: the mesh, and its study.
pub struct Analysed {
    /// The part.
    pub part: LoadedMesh,
    /// Its study (the report's `input` says where it came from).
    pub study: Study,
}

/// Loads and studies one part. A part without a gate is a study whose report says why; the
/// error is for a part that could not be studied at all.
pub fn analyse(source: Source, s: &Settings, hooks: &Hooks) -> Result<Analysed, Failure> {
    let t = Instant::now();
    let (part, input) = match source {
        Source::File(path) => {
            let (part, bytes) = load_file(path, s.units)?;
            let input = Input {
                path: Some(moldgate::files::shown(&path)),
                sample: None,
                bytes,
            };
            (part, input)
        }
        Source::Sample(name) => {
            let m = moldgate::samples::sample(name)
                .ok_or_else(|| crate::sample::unknown_sample(name))?;
            let input = Input {
                path: None,
                sample: Some(name.to_string()),
                bytes: 0,
            };
            (mesh::from_generated(m), input)
        }
    };
    let load_s = t.elapsed().as_secs_f64();
    let name = input
        .path
        .clone()
        .or(input.sample.clone())
        .unwrap_or_default();
    // With a time limit, the study reads the deadline's token (no caller gives one of its
    // own: the command line cancels only at its --timeout).
    let deadline = s.timeout.map(crate::deadline::Deadline::start);
    let hooks = Hooks {
        cancel: deadline.as_ref().map(|d| d.token()).or(hooks.cancel),
        ..*hooks
    };
    let mut study = moldgate::study_with(&part, &s.study, &hooks).map_err(|e| {
        let gate = e.gate_before_stop();
        match e {
            StudyError::Cancelled { stage, located } if deadline.is_some() => {
                let hint = s.study.less_time_words(stage);
                Failure {
                    located: located.map(|mut r| {
                        r.set_input(input.clone(), load_s);
                        r
                    }),
                    ..Failure::timeout(format!(
                        "{name}: stopped at --timeout {} s, in the {} stage{}{gate}",
                        s.timeout.unwrap_or_default().as_secs_f64(),
                        stage.to_string().replace('_', " "),
                        if hint.is_empty() {
                            String::new()
                        } else {
                            format!(" ({hint})")
                        }
                    ))
                }
            }
            e => failure(&e, &name),
        }
    })?;
    drop(deadline);
    study.set_input(input, load_s);
    Ok(Analysed { part, study })
}
