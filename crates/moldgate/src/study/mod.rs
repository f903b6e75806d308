//! The whole study of a part, in one call: the demolding direction (given or automatic),
//! the gate ([`crate::locate`]), the wall thickness, the fill analysis, and from them the
//! report, the scene, the picture, the GLB file and the HTML page. Every front end (the
//! command line, the Python package, the HTTP service, the browser app) runs this, so they
//! all give the same answers from the same options.
//!
//! ```
//! use moldgate::study::{study, StudyOptions};
//!
//! let part = moldgate::mesh::from_generated(moldgate::samples::sample("plate").unwrap());
//! let options: StudyOptions = serde_json::from_str(r#"{ "material": "ABS" }"#).unwrap();
//! let s = study(&part, &options).unwrap();
//! assert!(s.report().gate.is_some());
//! let json = s.report_json().unwrap();
//! assert!(json.contains("\"schema_version\""));
//! ```
//!
//! Options come in two forms ([`options`]): [`StudyOptions`], raw and shared by every front
//! end (serde, the command line's flags in snake case and its defaults), and [`Settings`],
//! validated once. [`study_with`] runs validated settings with [`Hooks`]: a progress
//! observer and a cancellation token, checked between stages and inside the fill's marches.

pub mod judge;
mod options;
mod run;
mod words;

pub use options::{
    CentreChoice, ColorByChoice, Demold, JsonOptionsError, MaterialChoice, NearestChoice,
    ObjectiveChoice, Settings, StrategyChoice, StudyOptions, ThicknessChoice, MAX_GATE_AT,
    MAX_GATE_RADIUS_MM, MAX_NODES_LIMIT, MIN_GATE_RADIUS_MM,
};
pub use run::{GateMarker, Study};
pub use words::keyword_words;

pub use crate::cancel::Cancel;
use crate::error::OptionsError;
use crate::flow::FillError;
use crate::gltf::GlbError;
use crate::mesh::LoadedMesh;
use crate::render::RenderError;
use crate::undercut::DemoldError;

/// A stage of a study, as the progress observer sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Stage {
    /// Building the ray-casting tree (automatic direction, wall thickness, fill).
    Tree,
    /// Choosing the demolding direction (`demold = "auto"`).
    Demold,
    /// The paper's gate location: grid, rays, rules, parting line.
    Locate,
    /// Measuring the wall thickness everywhere.
    WallThickness,
    /// The fill analysis.
    Fill,
    /// Assembling the report.
    Report,
}

impl Stage {
    /// The stage's name in snake case (`"wall_thickness"`), for progress lines and logs.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Tree => "tree",
            Stage::Demold => "demold",
            Stage::Locate => "locate",
            Stage::WallThickness => "wall_thickness",
            Stage::Fill => "fill",
            Stage::Report => "report",
        }
    }
}

impl std::fmt::Display for Stage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Where a study is: the stage that starts (or is under way) and the fraction of the whole
/// study done so far, 0 to 1 (a rough guide: stages are weighted by their usual cost).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Progress {
    /// The stage.
    pub stage: Stage,
    /// Fraction of the study done, 0 to 1.
    pub fraction: f64,
}

/// What a front end hooks into a study: both optional, no threads of their own.
///
/// The observer is called on the calling thread between stages (never inside a parallel
/// loop), so it may take a lock or write to a terminal. The cancellation token is read
/// between stages, in the fill stage (whose several-gate search and suitability map may
/// run for minutes on a large part) between the steps of its cells, before each facet's
/// rays of its walls and every few thousand cells of each march, in the wall stage
/// before each facet's rays, and in the locate stage before each block of triangles its
/// rays draw (and each run of the search for the radius that fits); once set, the study
/// returns [`StudyError::Cancelled`] naming the stage it stopped at. The other steps run to
/// their end (each is bounded by the part's size and the options' limits).
#[derive(Clone, Copy, Default)]
pub struct Hooks<'a> {
    /// Called with each stage as it starts, and with [`Stage::Report`] at 1.0 at the end.
    pub progress: Option<&'a (dyn Fn(Progress) + Sync)>,
    /// Set it (from another thread, a signal handler or a timer) to stop the study.
    pub cancel: Option<&'a Cancel>,
}

impl std::fmt::Debug for Hooks<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Hooks")
            .field("progress", &self.progress.is_some())
            .field("cancel", &self.cancel)
            .finish()
    }
}

impl StudyError {
    /// What a front end adds to its message of a study stopped after its gate was
    /// located (see [`StudyError::Cancelled`]): "; the method's gate, found before the
    /// stop: (x, y, z) mm", or nothing.
    pub fn gate_before_stop(&self) -> String {
        match self {
            StudyError::Cancelled {
                located: Some(r), ..
            } => r
                .gate
                .as_ref()
                .map(|g| {
                    let [x, y, z] = g.point;
                    format!(
                        "; the method's gate, found before the stop: ({x:.3}, {y:.3}, {z:.3}) mm"
                    )
                })
                .unwrap_or_default(),
            _ => String::new(),
        }
    }
}

impl Hooks<'_> {
    /// Reports `stage` at `fraction`, then fails if the study was cancelled.
    pub(crate) fn enter(&self, stage: Stage, fraction: f64) -> Result<(), StudyError> {
        if crate::cancel::is_set(self.cancel) {
            return Err(StudyError::Cancelled {
                stage,
                located: None,
            });
        }
        if let Some(p) = self.progress {
            p(Progress { stage, fraction });
        }
        Ok(())
    }
}

/// Why a study could not be made.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// An option out of range; `field` is the [`StudyOptions`] field.
    #[error("{field} {message}")]
    Invalid {
        /// The field of [`StudyOptions`] (`gate_radius`).
        field: &'static str,
        /// What is wrong ("must be a positive number, got 0").
        message: String,
    },
    /// An option that cannot be read (a direction, a keep-out region).
    #[error("{field}: {source}")]
    Parse {
        /// The field of [`StudyOptions`].
        field: &'static str,
        /// Why.
        source: OptionsError,
    },
    /// Two options that cannot be used together.
    #[error("{first} and {second} cannot be used together: {why}")]
    Conflict {
        /// One field.
        first: &'static str,
        /// The other.
        second: &'static str,
        /// Why.
        why: &'static str,
    },
    /// A material name that is neither a user material nor a built-in one (nor an alias of
    /// one), case and separators ignored.
    #[error("unknown material '{name}'; closest: {}", closest.join(", "))]
    UnknownMaterial {
        /// The name asked for.
        name: String,
        /// The closest known names, closest first ([`crate::material::name::closest_of`]):
        /// the user's materials and the library's, aliases ranking their material.
        closest: Vec<String>,
    },
    /// A material parameter out of range.
    #[error("{0}")]
    Material(OptionsError),
    /// What the gate location refuses: an option above its limit or over the ray memory
    /// budget ([`crate::LocateOptions::validate`], at validation), or the part itself at the
    /// locate stage (a grid too large for `max_nodes`, [`OptionsError::PartTooLarge`],
    /// [`OptionsError::OverlappingSurface`]).
    #[error("{0}")]
    Locate(OptionsError),
    /// The automatic demolding direction could not be chosen.
    #[error("demold auto: {0}")]
    Demold(DemoldError),
    /// The fill analysis failed ([`FillError::TooFewCandidates`]: no gate layout exists).
    #[error("{0}")]
    Fill(FillError),
    /// The study was cancelled: before `stage` started, or inside it (the fill and wall
    /// stages).
    #[error("cancelled at the {stage} stage")]
    Cancelled {
        /// The stage that did not start, or that stopped part way.
        stage: Stage,
        /// What the stages before the stop found, when it came after the gate was located
        /// (in the wall map or the fill stage) and the study's answer is the method's gate
        /// (no balanced gate nor layout asked for): the report of the located part without
        /// what was stopped (the gate, the automatic direction, the wall map when made),
        /// with a warning that says so. `None` otherwise.
        located: Option<Box<crate::report::Report>>,
    },
    /// The picture could not be drawn.
    #[error("cannot draw the part: {0}")]
    Render(RenderError),
    /// The GLB file could not be made.
    #[error("cannot write the GLB: {0}")]
    Glb(GlbError),
    /// A mesh other than the one studied was given for a picture or file.
    #[error("this is not the part that was studied ({vertices} vertices and {triangles} triangles expected)")]
    OtherPart {
        /// Vertices of the studied part.
        vertices: usize,
        /// Triangles of the studied part.
        triangles: usize,
    },
    /// The report could not be encoded.
    #[error("cannot encode the report: {0}")]
    Encode(String),
}

/// The longest time limit of a study, seconds (a day): every front end's (the command
/// line's `--timeout`, the service's limits, the Python package's `timeout`).
pub const MAX_TIMEOUT_S: f64 = 86_400.0;

/// The shortest time limit of a study, seconds (a millisecond): a shorter one stops every
/// study before its first stage, and its messages would read 0 s.
pub const MIN_TIMEOUT_S: f64 = 0.001;

/// A time limit of `seconds` as a duration: a number from [`MIN_TIMEOUT_S`] to
/// [`MAX_TIMEOUT_S`]; else the message, which names the limit as `name`.
pub fn time_limit(name: &str, seconds: f64) -> Result<std::time::Duration, String> {
    if seconds.is_finite() && (MIN_TIMEOUT_S..=MAX_TIMEOUT_S).contains(&seconds) {
        Ok(std::time::Duration::from_secs_f64(seconds))
    } else {
        Err(format!(
            "{name} must be a number of seconds from {MIN_TIMEOUT_S} to {MAX_TIMEOUT_S} (a day), got {}",
            crate::error::figures(seconds)
        ))
    }
}

/// Validates `options` and studies `part` with them, without hooks.
pub fn study(part: &LoadedMesh, options: &StudyOptions) -> Result<Study, StudyError> {
    study_with(part, &options.validate()?, &Hooks::default())
}

/// Studies `part` with validated settings, reporting progress and honouring cancellation
/// through `hooks`.
///
/// A part without a gate is a [`Study`] whose report says why (`gate` is `None`,
/// `no_gate_reason` is set); an error is a study that could not be made at all.
pub fn study_with(
    part: &LoadedMesh,
    settings: &Settings,
    hooks: &Hooks,
) -> Result<Study, StudyError> {
    run::run(part, settings, hooks)
}
