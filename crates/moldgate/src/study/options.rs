//! The options of a study, in two forms: [`StudyOptions`], the raw vocabulary every front
//! end shares (command-line flags, TOML, JSON, query parameters), and [`Settings`], the same
//! options validated once into the library's types.
//!
//! Field names are the command line's flags in snake case (`--gate-radius` is
//! `gate_radius`) and every default is the command line's. `docs/study-options.md` gives
//! the JSON form with an example.

use serde::{Deserialize, Serialize};

use crate::error::OptionsError;
use crate::flow::{ColourBy, FillOptions, FlowOptions, Objective, Strategy};
use crate::gate::{FlatRule, Nearest, Spacing, ThicknessFallback, ThicknessRule};
use crate::material::{self, name};
use crate::math::DVec3;
use crate::mesh::MAX_COORDINATE_MM;
use crate::report::RadiusSource;
use crate::study::StudyError;
use crate::{CentreKind, Direction, GateMode, LocateOptions, Material};

/// The largest grid accepted, in nodes: the gate location's own limit, so that a study and
/// [`crate::locate`] refuse the same values.
pub use crate::gate::MAX_NODES_LIMIT;

/// A material: a name of the built-in library (`"PP"`, `"pa66-gf30"`, an alias such as
/// `"HDPE"`; case and separators ignored), a name of the user materials given to
/// [`StudyOptions::validate_with`] (which win over a built-in of the same name), or every
/// parameter of a material.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum MaterialChoice {
    /// A material by name.
    Name(String),
    /// A material given in full (`n`, `t_melt`, `t_wall`, `gamma_opt`, `mu_opt`, `k`, and
    /// optionally `name` and `max_flow_ratio`).
    Parameters(Material),
}

impl Default for MaterialChoice {
    fn default() -> Self {
        MaterialChoice::Name("PP".into())
    }
}

/// Which centre of mass the gate is placed by (`centre`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CentreChoice {
    /// Area-weighted facet centroids (the paper's Eq. 5).
    #[default]
    Surface,
    /// Centroid of the enclosed volume.
    Volume,
}

/// How nearness to the centre of mass is measured (`nearest`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum NearestChoice {
    /// 3D distance from the node's surface point.
    #[default]
    #[serde(rename = "3d")]
    ThreeD,
    /// Distance in the projection plane.
    #[serde(rename = "2d")]
    TwoD,
}

/// The paper's rule that R_gate be below the wall thickness (`thickness_rule`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ThicknessChoice {
    /// Keep only nodes whose wall is thicker than R_gate (the paper's rule).
    #[default]
    Require,
    /// Measure and report thickness but do not filter on it.
    Ignore,
}

/// Which gate is the answer (`strategy`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum StrategyChoice {
    /// The paper's gate: the qualifying node nearest the centre of mass.
    #[default]
    Paper,
    /// The qualifying node that minimises the fill objective (implies `fill`).
    Balanced,
}

/// What the balanced gate and several gates minimise (`objective`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ObjectiveChoice {
    /// The largest flow length.
    #[default]
    Length,
    /// The largest flow resistance (fill order).
    Resistance,
}

/// What pictures of the fill are coloured by (`color_by`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ColorByChoice {
    /// Flow length from the gate, mm.
    FlowLength,
    /// Estimated fill time from the gate, s (`fill_time` is accepted too).
    #[default]
    #[serde(alias = "fill_time")]
    FillOrder,
    /// Wall thickness the fill analysis used, mm.
    Wall,
    /// Height along the demolding direction.
    Height,
}

/// Every option of a study, as a front end receives it: the command line's `locate` flags
/// in snake case, with the command line's defaults. Unknown fields are refused.
///
/// ```
/// let o: moldgate::StudyOptions =
///     serde_json::from_str(r#"{ "material": "ABS", "fill": true, "gates": 2 }"#).unwrap();
/// assert_eq!(o.gates, 2);
/// assert_eq!(o.demold, "+z");
/// let settings = o.validate().unwrap();
/// assert!(settings.fill.is_some());
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StudyOptions {
    /// Demolding direction: `+x`, `-y`, ... or `x,y,z`; `auto` picks the axis or principal
    /// axis with the least undercut area. Default `+z`.
    pub demold: String,
    /// The material. Default `PP`.
    pub material: MaterialChoice,
    /// Override of the material's power-law index n.
    pub n: Option<f64>,
    /// Override of the melt temperature, degrees C.
    pub t_melt: Option<f64>,
    /// Override of the mould wall temperature, degrees C.
    pub t_wall: Option<f64>,
    /// Override of the optimal shear rate, 1/s.
    pub gamma_opt: Option<f64>,
    /// Override of the viscosity at that shear rate, Pa s.
    pub mu_opt: Option<f64>,
    /// Override of the thermal conductivity, W/(m C).
    pub k: Option<f64>,
    /// The gate radius in mm instead of Eq. 8. Default: Eq. 8 of the material.
    pub gate_radius: Option<f64>,
    /// Grid spacing in mm. Default: min(R_gate, longest projected side / 100).
    pub spacing: Option<f64>,
    /// Grid shift as a fraction of the spacing along both axes. Default 0.
    pub grid_offset: f64,
    /// Points on each node's circle, 3 to [`crate::gate::MAX_CIRCLE_POINTS`]. Default 16.
    pub circle_points: usize,
    /// Which centre of mass the gate is placed by. Default `surface`.
    pub centre: CentreChoice,
    /// How nearness to the centre of mass is measured. Default `3d`.
    pub nearest: NearestChoice,
    /// The paper's rule that R_gate be below the wall thickness. Default `require`.
    pub thickness_rule: ThicknessChoice,
    /// When the thickness rule leaves no node, take the gate of the largest gate radius that
    /// fits (searched below R_gate and reported either way). Default false.
    pub fit_radius: bool,
    /// Keep only nodes whose circle is flat within `flat_tol`. Default false.
    pub require_flat: bool,
    /// Flatness tolerance along the demolding direction, mm. Default 0.1 R_gate.
    pub flat_tol: Option<f64>,
    /// Put the gate on the parting line, nearest the centre of mass. Default false.
    pub aesthetic: bool,
    /// Which edges make the parting line: `outline` (the closed outer rim of each body seen
    /// along D) or `longest` (the longest loop of the edges between the two sides, the
    /// paper's path). Default `outline` (docs/parting-line.md).
    pub parting_line: crate::parting::PartingRule,
    /// Largest grid accepted, in nodes (at most [`MAX_NODES_LIMIT`], and within the ray
    /// memory budget [`crate::gate::RAY_MEMORY_BUDGET_BYTES`] with `circle_points`). Default
    /// 4 000 000.
    pub max_nodes: usize,
    /// Regions no gate may reach into: `box:x0,y0,z0,x1,y1,z1` or `sphere:x,y,z,r` (mm).
    pub keep_out: Vec<String>,
    /// The visible side: no gate on faces turned towards this direction.
    pub cosmetic: Option<String>,
    /// Analyse the fill (flow length, fill order, Eq. 1 pressure, last places to fill,
    /// weld lines, the balanced gate). Default false; implied by `strategy = "balanced"`
    /// and `gates > 1`.
    pub fill: bool,
    /// Which gate is the answer. Default `paper`.
    pub strategy: StrategyChoice,
    /// What the balanced gate and several gates minimise. Default `length`.
    pub objective: ObjectiveChoice,
    /// Number of gates that together minimise the worst flow (1 to
    /// [`FlowOptions::max_gates`], 32 by default). Default 1.
    pub gates: usize,
    /// What pictures of the fill are coloured by. Default `fill_order` (the estimated fill
    /// time, s).
    pub color_by: ColorByChoice,
    /// Side of the flow-analysis cells, mm. Default: half the nominal wall, at most 1/120
    /// of the part's diagonal.
    pub cell: Option<f64>,
    /// Also measure the wall thickness everywhere. Default false.
    pub wall_thickness: bool,
    /// Gates the designer places, each `"x,y,z"` in mm in the part's frame (at most
    /// [`MAX_GATE_AT`]): each is moved to the nearest point of the surface and judged by the
    /// paper's rules; with the fill, they are filled together as one layout
    /// ([`crate::study::judge`]). Default none.
    pub gate_at: Vec<String>,
    /// Score every qualifying node as a gate (the gate-suitability map: the objective of
    /// the balanced gate at each node, exact or bounded). Default false; implies `fill`.
    pub suitability: bool,
}

impl Default for StudyOptions {
    fn default() -> Self {
        StudyOptions {
            demold: "+z".into(),
            material: MaterialChoice::default(),
            n: None,
            t_melt: None,
            t_wall: None,
            gamma_opt: None,
            mu_opt: None,
            k: None,
            gate_radius: None,
            spacing: None,
            grid_offset: 0.0,
            circle_points: 16,
            centre: CentreChoice::Surface,
            nearest: NearestChoice::ThreeD,
            thickness_rule: ThicknessChoice::Require,
            fit_radius: false,
            require_flat: false,
            flat_tol: None,
            aesthetic: false,
            parting_line: crate::parting::PartingRule::Outline,
            max_nodes: 4_000_000,
            keep_out: Vec::new(),
            cosmetic: None,
            fill: false,
            strategy: StrategyChoice::Paper,
            objective: ObjectiveChoice::Length,
            gates: 1,
            color_by: ColorByChoice::FillOrder,
            cell: None,
            wall_thickness: false,
            gate_at: Vec::new(),
            suitability: false,
        }
    }
}

/// The demolding direction of a study: given, or chosen per part.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Demold {
    /// This direction.
    Given(Direction),
    /// The axis or principal axis with the least undercut ([`crate::undercut`]).
    Auto,
}

/// The options of a study validated into the library's types ([`StudyOptions::validate`]):
/// what [`crate::study::study_with`] runs.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// The material, with its overrides.
    pub material: Material,
    /// The options of [`crate::locate`] (its direction is replaced per part under
    /// [`Demold::Auto`]).
    pub locate: LocateOptions,
    /// Whether R_gate comes from the material or was forced.
    pub radius_source: RadiusSource,
    /// The demolding direction.
    pub demold: Demold,
    /// Whether the wall thickness is measured everywhere.
    pub wall_thickness: bool,
    /// The fill analysis, when asked for.
    pub fill: Option<FillOptions>,
    /// The designer's gates as given (`gate_at`), before they are moved onto the surface.
    pub gate_at: Vec<DVec3>,
    /// What the pictures are coloured by: the fill's field (its own `colour_by`), or
    /// without the fill the wall map when it is measured and this asks for it.
    pub color_by: ColorByChoice,
    /// Warnings about the options themselves (an option that changes nothing as given),
    /// added to every part's report.
    pub warnings: Vec<String>,
}

impl Settings {
    /// What would make a study stopped at its time limit quicker, in the command line's
    /// flags and among what was asked, for the stage it stopped in: "a coarser --cell,
    /// fewer --gates or no --suitability" for the fill, "no --wall-thickness" for the wall
    /// stage, "a coarser --spacing" for the gate's grid, a given direction for `--demold
    /// auto`; nothing for the other stages.
    pub fn less_time_words(&self, stage: crate::study::Stage) -> String {
        use crate::study::Stage;
        let mut ways = Vec::new();
        match stage {
            Stage::WallThickness => ways.push("no --wall-thickness"),
            Stage::Fill => {
                if let Some(f) = &self.fill {
                    ways.push("a coarser --cell");
                    if f.gates > 1 {
                        ways.push("fewer --gates");
                    }
                    if f.suitability {
                        ways.push("no --suitability");
                    }
                }
            }
            Stage::Locate => ways.push("a coarser --spacing"),
            Stage::Demold => ways.push("a direction given to --demold (not auto)"),
            Stage::Tree | Stage::Report => {}
        }
        match ways.as_slice() {
            [] => String::new(),
            [one] => format!("{one} takes less time"),
            [rest @ .., last] => format!("{} or {last} take less time", rest.join(", ")),
        }
    }
}

/// The most gates a designer may place (`gate_at`): as many as a several-gate layout
/// may have ([`FlowOptions::max_gates`]'s default).
pub const MAX_GATE_AT: usize = 32;

/// The largest gate radius taken, mm, given or from Eq. 8: a metre, far beyond any gate.
pub const MAX_GATE_RADIUS_MM: f64 = 1000.0;

/// The smallest gate radius taken, mm, given or from Eq. 8: a micrometre, far below any
/// gate (the automatic grid spacing follows the radius, and a radius of 1e-296 mm asked
/// for a grid beyond any limit, said as the part's units' fault).
pub const MIN_GATE_RADIUS_MM: f64 = 0.001;

/// Gate radii of injection moulding, mm: Eq. 8's radius of a material outside them is
/// warned about (the built-in library's span 0.78 to 1.92 mm).
const PLAUSIBLE_RADIUS_MM: (f64, f64) = (0.2, 10.0);

/// How far, in degrees C, a melt or mould-wall temperature given beside a named material may
/// lie from that grade's own before a warning says so: processing windows span about 40 C
/// either side (PC 280-320 C), and one farther off is most often another grade's or a unit's.
const FAR_FROM_THE_GRADE_C: f64 = 50.0;

/// How many names an unknown material is answered with.
const SUGGESTIONS: usize = 3;

/// The material called `query`, case and separators ignored: the user's first, then the
/// built-in library's (names and aliases), where a built-in that a user material replaces
/// (one named like its name or an alias, as `material::library_with` lists them) is that
/// user material under any of its names; an unknown name fails with the [`SUGGESTIONS`]
/// closest known names.
fn lookup(query: &str, user: &[Material]) -> Result<Material, StudyError> {
    if let Some(m) = user.iter().find(|m| name::same(&m.name, query)) {
        return Ok(m.clone());
    }
    // The user material that replaces a built-in, if one does.
    let replacing = |i: &material::MaterialInfo| {
        user.iter().find(|m| {
            std::iter::once(&i.material.name)
                .chain(&i.aliases)
                .any(|n| name::same(n, &m.name))
        })
    };
    if let Some(info) = material::find(query) {
        return Ok(replacing(info).unwrap_or(&info.material).clone());
    }
    // Aliases count for closeness, but the answer is the material's own name; a built-in
    // that a user material replaces is not offered.
    let shadowed = |i: &&material::MaterialInfo| replacing(i).is_some();
    let known = user
        .iter()
        .map(|m| (m.name.as_str(), m.name.as_str()))
        .chain(
            material::library()
                .iter()
                .filter(|i| !shadowed(i))
                .flat_map(|i| {
                    std::iter::once(&i.material.name)
                        .chain(&i.aliases)
                        .map(|spelling| (spelling.as_str(), i.material.name.as_str()))
                }),
        );
    Err(StudyError::UnknownMaterial {
        name: crate::error::excerpt(query.as_bytes()),
        closest: name::closest_of(query, known, SUGGESTIONS)
            .into_iter()
            .map(String::from)
            .collect(),
    })
}

/// A point `"x,y,z"` in mm: three finite numbers within [`MAX_COORDINATE_MM`].
fn read_point(text: &str) -> Result<DVec3, String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!(
            "expected x,y,z (three numbers in mm), got {} value{}",
            parts.len(),
            if parts.len() == 1 { "" } else { "s" }
        ));
    }
    let mut p = [0.0; 3];
    for (axis, (v, part)) in ["x", "y", "z"].iter().zip(p.iter_mut().zip(&parts)) {
        let x: f64 = part
            .parse()
            .map_err(|_| format!("{axis} is not a number"))?;
        if !x.is_finite() {
            return Err(format!("{axis} must be a finite number"));
        }
        if x.abs() > MAX_COORDINATE_MM {
            return Err(format!(
                "{axis} is beyond the coordinate limit of {MAX_COORDINATE_MM:e} mm"
            ));
        }
        *v = x;
    }
    Ok(DVec3::from_array(p))
}

fn invalid(field: &'static str, message: impl Into<String>) -> StudyError {
    StudyError::Invalid {
        field,
        message: message.into(),
    }
}

fn parse_error(field: &'static str, source: OptionsError) -> StudyError {
    StudyError::Parse { field, source }
}

fn positive(field: &'static str, v: f64) -> Result<f64, StudyError> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(invalid(
            field,
            format!("must be a positive number, got {v}"),
        ))
    }
}

/// Study options given as JSON that do not read as [`StudyOptions`] (the service's and the
/// Python package's options).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct JsonOptionsError {
    /// The first option that fails on its own, when one does (a parameter of a material
    /// given as a table is `material.n`, ...).
    pub field: Option<String>,
    /// What is wrong, in plain words (`expected a number`, not `expected f64`).
    pub message: String,
}

impl std::fmt::Display for JsonOptionsError {
    /// `field: message`, or the message alone when no option is at fault by itself.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.field {
            Some(field) => write!(f, "{field}: {}", self.message),
            None => f.write_str(&self.message),
        }
    }
}

/// serde's refusal of an unknown name, ``unknown field `gate`, expected one of `demold`,
/// ...``, with the option nearest it in spelling first when one is near (at most a third
/// of its letters to change, insert or drop): ``unknown field `gate` (did you mean
/// `gates`?), expected one of ...``. Any other message is returned as it is.
fn with_nearest_name(message: &str) -> String {
    let Some(rest) = message.strip_prefix("unknown field `") else {
        return message.to_string();
    };
    let Some((name, list)) = rest.split_once("`, expected one of ") else {
        return message.to_string();
    };
    // The time limit is not an option of the study but of whoever runs it.
    if name == "timeout" {
        return format!(
            "unknown field `timeout` (a study's time limit is set where it runs: the command line's --timeout, the Python functions' timeout argument, or by the service's operator with moldgate serve --timeout), expected one of {list}"
        );
    }
    let names = list.split(", ").map(|n| n.trim_matches('`'));
    let limit = (name.chars().count() / 3).max(1);
    let nearest = names
        .map(|n| (crate::material::name::edit_distance(name, n), n))
        .filter(|&(d, _)| d <= limit)
        .min_by_key(|&(d, _)| d);
    match nearest {
        Some((_, n)) => {
            format!("unknown field `{name}` (did you mean `{n}`?), expected one of {list}")
        }
        None => message.to_string(),
    }
}

/// The first key of `object` whose value, put alone (or over `base`) into a `T`, fails.
fn culprit<T: serde::de::DeserializeOwned>(
    object: &serde_json::Map<String, serde_json::Value>,
    base: &serde_json::Map<String, serde_json::Value>,
) -> Option<String> {
    object
        .iter()
        .find(|(k, v)| {
            let mut one = base.clone();
            one.insert((*k).clone(), (*v).clone());
            serde_json::from_value::<T>(serde_json::Value::Object(one)).is_err()
        })
        .map(|(k, _)| k.clone())
}

impl StudyOptions {
    /// The options of a JSON object (every field optional, as [`StudyOptions::default`]).
    /// An error names the first option that fails on its own; for a material given as a
    /// table of parameters, the parameter (`material.k`).
    pub fn from_json_object(
        object: serde_json::Map<String, serde_json::Value>,
    ) -> Result<StudyOptions, JsonOptionsError> {
        let error =
            match serde_json::from_value::<StudyOptions>(serde_json::Value::Object(object.clone()))
            {
                Ok(o) => return Ok(o),
                Err(e) => e,
            };
        let mut field = culprit::<StudyOptions>(&object, &serde_json::Map::new());
        let mut message = error.to_string();
        // In a material's table, the parameter at fault (each alone over the paper's PP)
        // and the table's own error (the choice of a name or a table hides it).
        if let (Some("material"), Some(serde_json::Value::Object(table))) =
            (field.as_deref(), object.get("material"))
        {
            if let Err(e) =
                serde_json::from_value::<Material>(serde_json::Value::Object(table.clone()))
            {
                message = e.to_string();
            }
            let pp = serde_json::to_value(Material::builtin("PP").expect("PP is built in"))
                .ok()
                .and_then(|v| v.as_object().cloned())
                .unwrap_or_default();
            if let Some(p) = culprit::<Material>(table, &pp) {
                field = Some(format!("material.{p}"));
            }
        }
        // A choice of names given as another type: serde's "expected string or map" as the
        // names the option takes, from the error of a text that is none of them.
        if let (Some(f), true) = (field.as_deref(), message.contains("expected string or map")) {
            let mut named = object.clone();
            named.insert(f.to_string(), serde_json::Value::from("\u{1}"));
            if let Err(e) = serde_json::from_value::<StudyOptions>(serde_json::Value::Object(named))
            {
                let names = e.to_string();
                // "unknown variant `\u{1}`, expected `paper` or `balanced`" (or "one of").
                if let Some(at) = names.find("`, expected ") {
                    let names = names[at + 3..].split(" at line").next().unwrap_or_default();
                    message = message.replace("expected string or map", names);
                }
            }
        }
        let mut message = with_nearest_name(&crate::files::plain_words(&message));
        // Counts are read as any count, 0 included, then refused out of their range
        // (`validate`): a type error names the range the option really takes.
        let range = match field.as_deref() {
            Some("gates") => Some("a whole number of 1 or more".to_string()),
            Some("circle_points") => Some("a whole number of 3 or more".to_string()),
            Some("max_nodes") => Some(format!("a whole number from 1 to {MAX_NODES_LIMIT}")),
            _ => None,
        };
        if let Some(range) = range {
            message = message.replace("a whole number of 0 or more", &range);
        }
        Err(JsonOptionsError { field, message })
    }

    /// Whether `demold` asks for the automatic direction.
    pub fn auto_demold(&self) -> bool {
        self.demold.trim().eq_ignore_ascii_case("auto")
    }

    /// Validates the options once, with the built-in materials only.
    pub fn validate(&self) -> Result<Settings, StudyError> {
        self.validate_with(&[])
    }

    /// Validates the options once; a material name is looked up in `user` (by
    /// [`Material::name`]) before the built-in library (names and aliases), case and
    /// separators ignored, so a user material wins over a built-in of the same name.
    pub fn validate_with(&self, user: &[Material]) -> Result<Settings, StudyError> {
        if self.aesthetic && self.strategy == StrategyChoice::Balanced {
            return Err(StudyError::Conflict {
                first: "strategy",
                second: "aesthetic",
                why: "the balanced gate is a grid node chosen by the fill, the aesthetic gate the point of the parting line nearest the centre of mass; choose one",
            });
        }
        if self.aesthetic && self.gates > 1 {
            return Err(StudyError::Conflict {
                first: "gates",
                second: "aesthetic",
                why: "several gates are grid nodes placed by the fill, the aesthetic gate the one point of the parting line nearest the centre of mass; choose one",
            });
        }
        let gate_at = self.gate_at()?;
        let (material, grade) = self.material(user)?;
        let demold = if self.auto_demold() {
            Demold::Auto
        } else {
            Demold::Given(self.demold.parse().map_err(|e| parse_error("demold", e))?)
        };
        let (gate_radius_mm, radius_source) = match self.gate_radius {
            Some(r) => (positive("gate_radius", r)?, RadiusSource::Forced),
            None => (material.gate_radius_mm(), RadiusSource::Material),
        };
        // A radius no part could hold is refused before any work (and before a message
        // writes it out in hundreds of digits).
        if !(MIN_GATE_RADIUS_MM..=MAX_GATE_RADIUS_MM).contains(&gate_radius_mm) {
            let said = crate::error::figures(gate_radius_mm);
            let beyond = match gate_radius_mm > MAX_GATE_RADIUS_MM {
                true => format!("more than {MAX_GATE_RADIUS_MM} mm"),
                false => format!("less than {MIN_GATE_RADIUS_MM} mm"),
            };
            return Err(match radius_source {
                RadiusSource::Material => invalid(
                    "material",
                    format!(
                        "{}: Eq. 8 gives a gate radius of {said} mm, {beyond}; check its parameters' units (gamma_opt in 1/s, mu_opt in Pa s, k in W/(m C))",
                        match material.name.as_str() {
                            "" => "(given)",
                            name => name,
                        }
                    ),
                ),
                _ => invalid(
                    "gate_radius",
                    format!(
                        "must be from {MIN_GATE_RADIUS_MM} to {MAX_GATE_RADIUS_MM} mm, got {said}"
                    ),
                ),
            });
        }
        let spacing = match self.spacing {
            Some(h) => Spacing::Mm(positive("spacing", h)?),
            None => Spacing::Auto,
        };
        if !(self.grid_offset.is_finite() && self.grid_offset.abs() < 1.0) {
            return Err(invalid(
                "grid_offset",
                format!(
                    "must be a fraction of the spacing, above -1 and below 1, got {}",
                    self.grid_offset
                ),
            ));
        }
        if self.circle_points < 3 {
            return Err(invalid(
                "circle_points",
                format!("must be at least 3, got {}", self.circle_points),
            ));
        }
        if let Some(t) = self.flat_tol {
            if !(t.is_finite() && t >= 0.0) {
                return Err(invalid(
                    "flat_tol",
                    format!("must be zero or positive, got {t}"),
                ));
            }
        }
        if self.max_nodes == 0 || self.max_nodes > MAX_NODES_LIMIT {
            return Err(invalid(
                "max_nodes",
                format!(
                    "must be between 1 and {MAX_NODES_LIMIT}, got {}",
                    self.max_nodes
                ),
            ));
        }
        if self.keep_out.len() > crate::gate::MAX_KEEP_OUT {
            return Err(invalid(
                "keep_out",
                format!(
                    "is given {} regions, over the limit of {}",
                    self.keep_out.len(),
                    crate::gate::MAX_KEEP_OUT
                ),
            ));
        }
        let keep_out = self
            .keep_out
            .iter()
            .map(|k| k.parse())
            .collect::<Result<_, OptionsError>>()
            .map_err(|e| parse_error("keep_out", e))?;
        let cosmetic = self
            .cosmetic
            .as_deref()
            .map(str::parse)
            .transpose()
            .map_err(|e| parse_error("cosmetic", e))?;
        let locate = LocateOptions {
            direction: match demold {
                Demold::Given(d) => d,
                Demold::Auto => Direction::default(),
            },
            gate_radius_mm,
            spacing,
            grid_offset: self.grid_offset,
            circle_points: self.circle_points,
            centre: match self.centre {
                CentreChoice::Surface => CentreKind::Surface,
                CentreChoice::Volume => CentreKind::Volume,
            },
            nearest: match self.nearest {
                NearestChoice::ThreeD => Nearest::Surface3d,
                NearestChoice::TwoD => Nearest::Plane2d,
            },
            thickness_rule: match self.thickness_rule {
                ThicknessChoice::Require => ThicknessRule::Require,
                ThicknessChoice::Ignore => ThicknessRule::Ignore,
            },
            parting: self.parting_line,
            thickness_fallback: if self.fit_radius {
                ThicknessFallback::LargestFitting
            } else {
                ThicknessFallback::Report
            },
            flat_rule: if self.require_flat {
                FlatRule::Require
            } else {
                FlatRule::Report
            },
            flat_tolerance_mm: self.flat_tol,
            mode: if self.aesthetic {
                GateMode::Aesthetic
            } else {
                GateMode::Paper
            },
            max_nodes: self.max_nodes,
            keep_out,
            cosmetic,
        };
        // The gate location's limits (circle points, the ray memory budget), checked here
        // so that every front end refuses the same options before any work.
        locate.validate().map_err(StudyError::Locate)?;
        let fill = self.fill_options()?;
        let mut warnings = Vec::new();
        if fill.is_none() && self.objective != ObjectiveChoice::Length {
            warnings.push(
                "objective resistance changes nothing without the fill analysis: it is what the balanced gate, several gates and the suitability map minimise (ask for one, or for fill)"
                    .to_string(),
            );
        }
        if fill.is_none() && self.cell.is_some() {
            warnings.push(
                "cell changes nothing without the fill analysis: it is the side of the fill's flow cells (ask for fill, a balanced gate, several gates or the suitability map)"
                    .to_string(),
            );
        }
        // The same point twice is one gate: the second reaches first no place of the part.
        for (j, q) in gate_at.iter().enumerate() {
            if let Some(i) = gate_at[..j].iter().position(|p| p == q) {
                warnings.push(format!(
                    "--gate-at gives gate {} at the point of gate {} ({}, {}, {}): one gate there, and the second fills nothing of the part",
                    j + 1,
                    i + 1,
                    q.x,
                    q.y,
                    q.z
                ));
            }
        }
        // A temperature far from the named grade's own: said, not refused (a designer may
        // mean it), since it moves Eq. 8's radius and the fill's numbers.
        if let Some(grade) = &grade {
            for (flag, given, own) in [
                ("--t-melt", self.t_melt, grade.t_melt),
                ("--t-wall", self.t_wall, grade.t_wall),
            ] {
                if let Some(v) = given.filter(|v| (v - own).abs() > FAR_FROM_THE_GRADE_C) {
                    warnings.push(format!(
                        "{flag} {} C is {} C {} {}'s own {} C: a temperature that far from the grade's is most often another grade's or another unit's (degrees C); check it",
                        crate::error::figures(v),
                        crate::error::figures((v - own).abs()),
                        if v < own { "below" } else { "above" },
                        grade.name,
                        crate::error::figures(own),
                    ));
                }
            }
        }
        // Eq. 8's radius far outside moulding practice is most often a parameter in the
        // wrong unit (a shear rate of 1 for 10,000 1/s), a forced one a diameter or inches:
        // said, not refused.
        let implausible =
            !(PLAUSIBLE_RADIUS_MM.0..=PLAUSIBLE_RADIUS_MM.1).contains(&gate_radius_mm);
        if implausible && radius_source == RadiusSource::Material {
            let material_words = match material.name.as_str() {
                "" => "the material given".to_string(),
                name => format!("material {name}"),
            };
            warnings.push(format!(
                "{material_words}: Eq. 8 gives a gate radius of {} mm, far outside the {}-{} mm of injection moulding; check its parameters' units (gamma_opt in 1/s, mu_opt in Pa s, k in W/(m C)), or give the radius with --gate-radius",
                crate::report::three_figures(gate_radius_mm),
                PLAUSIBLE_RADIUS_MM.0,
                PLAUSIBLE_RADIUS_MM.1,
            ));
        } else if implausible && radius_source == RadiusSource::Forced {
            warnings.push(format!(
                "--gate-radius {} mm is far outside the {}-{} mm of injection-moulding gates: check its unit (millimetres, a radius, not a diameter)",
                crate::report::three_figures(gate_radius_mm),
                PLAUSIBLE_RADIUS_MM.0,
                PLAUSIBLE_RADIUS_MM.1,
            ));
        }
        // Without the fill the pictures are coloured by height, or by the wall map when it
        // is measured and asked for.
        match (fill.is_none(), self.color_by, self.wall_thickness) {
            (true, ColorByChoice::FlowLength, _) => warnings.push(
                "--color-by flow-length changes nothing without the fill analysis: the pictures are coloured by the height along D (ask for --fill)"
                    .to_string(),
            ),
            (true, ColorByChoice::Wall, false) => warnings.push(
                "--color-by wall changes nothing without the fill analysis or the wall thickness: the pictures are coloured by the height along D (ask for --fill or --wall-thickness)"
                    .to_string(),
            ),
            _ => {}
        }
        Ok(Settings {
            material,
            locate,
            radius_source,
            demold,
            wall_thickness: self.wall_thickness,
            fill,
            gate_at,
            color_by: self.color_by,
            warnings,
        })
    }

    /// The designer's gates read from `"x,y,z"` (mm), their number checked first.
    fn gate_at(&self) -> Result<Vec<DVec3>, StudyError> {
        if self.gate_at.len() > MAX_GATE_AT {
            return Err(invalid(
                "gate_at",
                format!(
                    "is given {} times, over the limit of {MAX_GATE_AT} gates",
                    self.gate_at.len()
                ),
            ));
        }
        self.gate_at
            .iter()
            .enumerate()
            .map(|(i, text)| {
                read_point(text).map_err(|why| {
                    invalid(
                        "gate_at",
                        format!(
                            "{} '{}': {why}",
                            i + 1,
                            crate::error::excerpt(text.as_bytes())
                        ),
                    )
                })
            })
            .collect()
    }

    /// The material: a user material or a built-in by name, or given in full, then the
    /// single-parameter overrides (which add " (modified)" to the name); and the named
    /// grade before them (`None` for a material given in full).
    fn material(&self, user: &[Material]) -> Result<(Material, Option<Material>), StudyError> {
        let (mut m, grade) = match &self.material {
            MaterialChoice::Parameters(m) => (m.clone(), None),
            MaterialChoice::Name(name) => {
                let grade = lookup(name, user)?;
                (grade.clone(), Some(grade))
            }
        };
        let overrides = [
            (&mut m.n, self.n),
            (&mut m.t_melt, self.t_melt),
            (&mut m.t_wall, self.t_wall),
            (&mut m.gamma_opt, self.gamma_opt),
            (&mut m.mu_opt, self.mu_opt),
            (&mut m.k, self.k),
        ];
        let mut changed = false;
        for (field, value) in overrides {
            if let Some(v) = value {
                *field = v;
                changed = true;
            }
        }
        if changed {
            m.name += " (modified)";
        }
        m.validate().map_err(StudyError::Material)?;
        Ok((m, grade))
    }

    /// The fill analysis's options, or `None` when it was not asked for.
    fn fill_options(&self) -> Result<Option<FillOptions>, StudyError> {
        if self.gates == 0 {
            return Err(invalid("gates", "must be at least 1"));
        }
        let flow = FlowOptions {
            cell_mm: self.cell,
            ..FlowOptions::default()
        };
        if self.gates > flow.max_gates {
            return Err(invalid(
                "gates",
                format!("must be at most {}, got {}", flow.max_gates, self.gates),
            ));
        }
        if let Some(h) = self.cell {
            positive("cell", h)?;
        }
        let wanted = self.fill
            || self.strategy == StrategyChoice::Balanced
            || self.gates > 1
            || self.suitability;
        if !wanted {
            return Ok(None);
        }
        Ok(Some(FillOptions {
            flow,
            strategy: match self.strategy {
                StrategyChoice::Paper => Strategy::Paper,
                StrategyChoice::Balanced => Strategy::Balanced,
            },
            objective: match self.objective {
                ObjectiveChoice::Length => Objective::Length,
                ObjectiveChoice::Resistance => Objective::Resistance,
            },
            gates: self.gates,
            colour_by: match self.color_by {
                ColorByChoice::FlowLength => ColourBy::FlowLength,
                ColorByChoice::FillOrder => ColourBy::FillTime,
                ColorByChoice::Wall => ColourBy::Wall,
                ColorByChoice::Height => ColourBy::Height,
            },
            // Set per part, once the designer's gates are on its surface.
            placed: Vec::new(),
            suitability: self.suitability,
        }))
    }
}

#[cfg(test)]
mod tests {
    /// An unknown name held whole by some grades' names suggests them first: the two
    /// polyethylenes for "polyethylene" (it suggested PET, PS and PEEK).
    #[test]
    fn a_family_name_suggests_its_grades() {
        let o: super::StudyOptions =
            serde_json::from_str(r#"{ "material": "polyethylene" }"#).unwrap();
        let Err(crate::study::StudyError::UnknownMaterial { closest, .. }) = o.validate() else {
            panic!("polyethylene is not one grade");
        };
        assert_eq!(closest[..2], ["PE-LD", "PE-HD"], "{closest:?}");
    }

    /// A melt temperature far from the named grade's is said: PC's 305 C given as 200.
    #[test]
    fn a_temperature_far_from_the_grades_is_said() {
        let warnings = |json: &str| {
            serde_json::from_str::<super::StudyOptions>(json)
                .unwrap()
                .validate()
                .unwrap()
                .warnings
        };
        let w = warnings(r#"{ "material": "PC", "t_melt": 200 }"#);
        assert!(
            w.iter()
                .any(|w| w.starts_with("--t-melt 200 C is 105 C below PC's own 305 C")),
            "{w:?}"
        );
        assert!(warnings(r#"{ "material": "PC", "t_melt": 290 }"#).is_empty());
        let w = warnings(r#"{ "material": "PP", "t_wall": 120 }"#);
        assert!(
            w.iter().any(|w| w.starts_with("--t-wall 120 C is")),
            "{w:?}"
        );
    }

    /// Decimal options read from JSON (the service's query and form, Python's keywords) are
    /// the nearest doubles, as the command line reads them: a radius of 17 digits keeps its
    /// last one, and a grid offset a double above -1 is not rounded to -1 and refused.
    #[test]
    fn decimal_options_in_json_are_read_to_the_last_digit() {
        let o: super::StudyOptions = serde_json::from_str(
            r#"{ "gate_radius": 2.3497464368498266, "grid_offset": -0.9999999999999999 }"#,
        )
        .unwrap();
        assert_eq!(o.gate_radius, Some("2.3497464368498266".parse().unwrap()));
        assert_eq!(o.grid_offset, "-0.9999999999999999".parse::<f64>().unwrap());
        assert!(o.validate().is_ok());
    }

    #[test]
    fn what_takes_less_time_is_said_for_the_stage_stopped_in() {
        use crate::study::Stage;
        let settings = |json: &str| {
            serde_json::from_str::<super::StudyOptions>(json)
                .unwrap()
                .validate()
                .unwrap()
        };
        let heavy = settings(r#"{ "gates": 3, "suitability": true }"#);
        assert_eq!(
            heavy.less_time_words(Stage::Fill),
            "a coarser --cell, fewer --gates or no --suitability take less time"
        );
        // The fill's options do nothing for a study stopped before the fill.
        assert_eq!(
            heavy.less_time_words(Stage::Locate),
            "a coarser --spacing takes less time"
        );
        assert_eq!(
            heavy.less_time_words(Stage::Demold),
            "a direction given to --demold (not auto) takes less time"
        );
        assert_eq!(heavy.less_time_words(Stage::Tree), "");
        assert_eq!(
            settings("{}").less_time_words(Stage::WallThickness),
            "no --wall-thickness takes less time"
        );
        assert_eq!(
            crate::study::keyword_words(&heavy.less_time_words(Stage::Locate), "True"),
            "a coarser spacing takes less time"
        );
    }

    use super::*;

    #[test]
    fn an_unknown_name_is_answered_with_the_nearest_option() {
        let said = |json: &str| {
            let serde_json::Value::Object(o) = serde_json::from_str(json).unwrap() else {
                panic!("not an object")
            };
            StudyOptions::from_json_object(o).unwrap_err().to_string()
        };
        assert!(said(r#"{"gate": 2}"#)
            .contains("unknown field `gate` (did you mean `gates`?), expected one of `demold`"));
        assert!(said(r#"{"gate_raduis": 2}"#).contains("(did you mean `gate_radius`?)"));
        assert!(said(r#"{"timeout": 5}"#).contains(
            "unknown field `timeout` (a study's time limit is set where it runs: the command line's --timeout"
        ));
        assert!(said(r#"{"spacng": 1}"#).contains("(did you mean `spacing`?)"));
        // Nothing near: the list alone.
        let far = said(r#"{"colour": "red"}"#);
        assert!(
            far.contains("unknown field `colour`, expected one of"),
            "{far}"
        );
        // A choice of names given as a number: the names it takes.
        for (json, says) in [
            (
                r#"{"strategy": 1}"#,
                "strategy: got the number 1, expected `paper` or `balanced`",
            ),
            (
                r#"{"parting_line": 3}"#,
                "parting_line: got the number 3, expected ",
            ),
            (
                r#"{"circle_points": true}"#,
                "circle_points: got true, expected a whole number of 3 or more",
            ),
            (
                r#"{"max_nodes": 1e6}"#,
                "max_nodes: got the decimal number 1000000.0, expected a whole number from 1 to ",
            ),
            (
                r#"{"objective": true}"#,
                "objective: got true, expected `length` or `resistance`",
            ),
        ] {
            let s = said(json);
            assert!(s.contains(says), "{s}");
        }
    }

    #[test]
    fn an_empty_object_is_the_defaults() {
        let json: StudyOptions = serde_json::from_str("{}").unwrap();
        let toml: StudyOptions = toml::from_str("").unwrap();
        assert_eq!(json, StudyOptions::default());
        assert_eq!(toml, StudyOptions::default());
        let s = json.validate().unwrap();
        assert_eq!(s.locate, LocateOptions::default());
        assert_eq!(s.material, Material::builtin("PP").unwrap());
        assert_eq!(s.demold, Demold::Given(Direction::PLUS_Z));
        assert_eq!(s.fill, None);
        assert!(!s.wall_thickness);
    }

    #[test]
    fn json_and_toml_give_the_same_options() {
        let json: StudyOptions = serde_json::from_str(
            r#"{ "material": "abs", "demold": "-y", "gate_radius": 1.5, "spacing": 0.5,
                 "centre": "volume", "nearest": "2d", "thickness_rule": "ignore",
                 "keep_out": ["sphere:0,0,0,2"], "cosmetic": "+y", "fill": true,
                 "strategy": "balanced", "objective": "resistance", "gates": 1,
                 "cell": 0.8, "wall_thickness": true, "color_by": "flow_length" }"#,
        )
        .unwrap();
        let toml: StudyOptions = toml::from_str(
            r#"material = "abs"
demold = "-y"
gate_radius = 1.5
spacing = 0.5
centre = "volume"
nearest = "2d"
thickness_rule = "ignore"
keep_out = ["sphere:0,0,0,2"]
cosmetic = "+y"
fill = true
strategy = "balanced"
objective = "resistance"
gates = 1
cell = 0.8
wall_thickness = true
color_by = "flow_length"
"#,
        )
        .unwrap();
        assert_eq!(json, toml);
        let s = json.validate().unwrap();
        assert_eq!(s.material.name, "ABS");
        assert_eq!(s.locate.gate_radius_mm, 1.5);
        assert_eq!(s.radius_source, RadiusSource::Forced);
        assert_eq!(s.locate.spacing, Spacing::Mm(0.5));
        assert_eq!(s.locate.centre, CentreKind::Volume);
        assert_eq!(s.locate.nearest, Nearest::Plane2d);
        assert_eq!(s.locate.thickness_rule, ThicknessRule::Ignore);
        assert_eq!(s.locate.keep_out.len(), 1);
        assert!(s.locate.cosmetic.is_some());
        let fill = s.fill.unwrap();
        assert_eq!(fill.strategy, Strategy::Balanced);
        assert_eq!(fill.objective, Objective::Resistance);
        assert_eq!(fill.flow.cell_mm, Some(0.8));
        assert_eq!(fill.colour_by, ColourBy::FlowLength);
        // The default pictures the fill time; `fill_time` names it too.
        let o: StudyOptions = serde_json::from_str(r#"{ "fill": true }"#).unwrap();
        assert_eq!(
            o.validate().unwrap().fill.unwrap().colour_by,
            ColourBy::FillTime
        );
        let o: StudyOptions = serde_json::from_str(r#"{ "color_by": "fill_time" }"#).unwrap();
        assert_eq!(o.color_by, ColorByChoice::FillOrder);
    }

    #[test]
    fn unknown_fields_are_refused_by_name() {
        let e = serde_json::from_str::<StudyOptions>(r#"{ "gate_radus": 1 }"#).unwrap_err();
        assert!(e.to_string().contains("unknown field `gate_radus`"), "{e}");
        let e = toml::from_str::<StudyOptions>("spacng = 1.0").unwrap_err();
        assert!(e.to_string().contains("unknown field `spacng`"), "{e}");
        let e = serde_json::from_str::<StudyOptions>(r#"{ "nearest": "4d" }"#).unwrap_err();
        assert!(e.to_string().contains("4d"), "{e}");
    }

    #[test]
    fn a_material_is_a_name_or_every_parameter() {
        let o: StudyOptions = serde_json::from_str(
            r#"{ "material": { "name": "mine", "n": 0.3, "t_melt": 220, "t_wall": 40,
                 "gamma_opt": 9000, "mu_opt": 12, "k": 0.2 }, "mu_opt": 15 }"#,
        )
        .unwrap();
        let m = o.validate().unwrap().material;
        assert_eq!(m.name, "mine (modified)");
        assert_eq!(m.mu_opt, 15.0);
        assert_eq!(m.max_flow_ratio, None);
        let user = [Material {
            name: "Mine".into(),
            ..Material::builtin("PC").unwrap()
        }];
        let o: StudyOptions = serde_json::from_str(r#"{ "material": "MINE" }"#).unwrap();
        assert_eq!(o.validate_with(&user).unwrap().material.name, "Mine");
        let e = o.validate().unwrap_err();
        assert!(
            e.to_string()
                .starts_with("unknown material 'MINE'; closest: "),
            "{e}"
        );
        let o: StudyOptions =
            serde_json::from_str(r#"{ "strategy": "balanced", "aesthetic": true }"#).unwrap();
        let e = o.validate().unwrap_err().to_string();
        assert!(
            e.starts_with("strategy and aesthetic cannot be used together"),
            "{e}"
        );
        // Several gates are the fill's grid nodes: the aesthetic gate cannot be one of them.
        let o: StudyOptions = serde_json::from_str(r#"{ "gates": 2, "aesthetic": true }"#).unwrap();
        let e = o.validate().unwrap_err().to_string();
        assert!(
            e.starts_with("gates and aesthetic cannot be used together"),
            "{e}"
        );
    }

    #[test]
    fn options_that_change_nothing_or_look_mistaken_are_warned_about() {
        let warned = |json: &str| {
            let o: StudyOptions = serde_json::from_str(json).unwrap();
            o.validate().unwrap().warnings
        };
        let w = warned(r#"{ "objective": "resistance" }"#);
        assert_eq!(w.len(), 1);
        assert!(
            w[0].starts_with("objective resistance changes nothing"),
            "{w:?}"
        );
        let w = warned(r#"{ "cell": 0.5 }"#);
        assert_eq!(w.len(), 1);
        assert!(w[0].starts_with("cell changes nothing"), "{w:?}");
        // A colouring the pictures cannot have without the fill (the wall map colours them
        // when it is measured).
        let w = warned(r#"{ "color_by": "flow_length", "wall_thickness": true }"#);
        assert_eq!(w.len(), 1);
        assert!(
            w[0].starts_with("--color-by flow-length changes nothing"),
            "{w:?}"
        );
        let w = warned(r#"{ "color_by": "wall" }"#);
        assert_eq!(w.len(), 1);
        assert!(w[0].starts_with("--color-by wall changes nothing"), "{w:?}");
        // A material whose Eq. 8 radius no mould has (a shear rate of 100 1/s): 134 mm.
        let odd = r#"{ "material": { "n": 0.3, "t_melt": 230, "t_wall": 50, "gamma_opt": 100,
                       "mu_opt": 10, "k": 0.15 } }"#;
        let w = warned(odd);
        assert_eq!(w.len(), 1);
        assert!(
            w[0].starts_with(
                "the material given: Eq. 8 gives a gate radius of 134 mm, far outside the 0.2-10 mm"
            ),
            "{w:?}"
        );
        // A forced radius outside moulding practice (a diameter, or inches), said too; one
        // inside is not.
        for (json, warns) in [
            (r#"{ "gate_radius": 12 }"#, true),
            (r#"{ "gate_radius": 0.1 }"#, true),
            (r#"{ "gate_radius": 1.5 }"#, false),
        ] {
            let w = warned(json);
            assert_eq!(
                w.iter()
                    .any(|w| w.contains("far outside the 0.2-10 mm of injection-moulding gates")),
                warns,
                "{json}: {w:?}"
            );
        }
        let w = warned(r#"{ "gate_at": ["1,2,3", "4,5,6", "1.0,2,3e0"] }"#);
        assert_eq!(
            w,
            ["--gate-at gives gate 3 at the point of gate 1 (1, 2, 3): one gate there, and the second fills nothing of the part"]
        );
        // Radii no part holds are refused, in a few digits.
        let refused = |json: &str| {
            let o: StudyOptions = serde_json::from_str(json).unwrap();
            o.validate().unwrap_err().to_string()
        };
        assert_eq!(
            refused(r#"{ "gate_radius": 1e300 }"#),
            "gate_radius must be from 0.001 to 1000 mm, got 1.000e300"
        );
        assert_eq!(
            refused(r#"{ "gate_radius": 1e-6 }"#),
            "gate_radius must be from 0.001 to 1000 mm, got 0.000001"
        );
        let e = refused(
            r#"{ "material": { "name": "Fast", "n": 0.3, "t_melt": 230, "t_wall": 50,
                 "gamma_opt": 1e300, "mu_opt": 10, "k": 0.15 } }"#,
        );
        assert!(
            e.starts_with("material Fast: Eq. 8 gives a gate radius of ")
                && e.contains("mm, less than 0.001 mm; check its parameters' units"),
            "{e}"
        );
        let e = refused(
            r#"{ "material": { "name": "Odd", "n": 0.3, "t_melt": 230, "t_wall": 50,
                 "gamma_opt": 1e-300, "mu_opt": 10, "k": 0.15 } }"#,
        );
        assert!(
            e.starts_with(
                "material Odd: Eq. 8 gives a gate radius of 1.344e304 mm, more than 1000 mm"
            ),
            "{e}"
        );
        let forced = r#"{ "gate_radius": 1.5, "material": { "n": 0.3, "t_melt": 230,
                          "t_wall": 50, "gamma_opt": 1, "mu_opt": 10, "k": 0.15 } }"#;
        assert!(warned(forced).is_empty());
        for m in material::library() {
            let json = format!(r#"{{ "material": "{}" }}"#, m.material.name);
            assert!(warned(&json).is_empty(), "{json}");
        }
        for json in [
            r#"{ "color_by": "wall", "wall_thickness": true }"#,
            r#"{ "color_by": "wall", "fill": true }"#,
            r#"{ "color_by": "flow_length", "gates": 2 }"#,
            r#"{ "color_by": "height" }"#,
            r#"{ "cell": 0.5, "fill": true }"#,
            r#"{ "cell": 0.5, "strategy": "balanced" }"#,
            r#"{ "objective": "resistance", "fill": true }"#,
            r#"{ "objective": "resistance", "gates": 2 }"#,
            r#"{ "objective": "length" }"#,
            "{}",
        ] {
            assert!(warned(json).is_empty(), "{json}");
        }
    }

    fn material_named(name: &str, user: &[Material]) -> Result<Material, StudyError> {
        let o = StudyOptions {
            material: MaterialChoice::Name(name.into()),
            ..StudyOptions::default()
        };
        o.validate_with(user).map(|s| s.material)
    }

    #[test]
    fn built_in_names_ignore_case_and_separators_and_take_aliases() {
        let grade = material::find("PA66-GF30").unwrap();
        for spelling in ["pa66-gf30", "PA66 GF30", "pa66gf30", "PA6.6-GF30"] {
            assert_eq!(
                material_named(spelling, &[]).unwrap(),
                grade.material,
                "{spelling}"
            );
        }
        let hd = material_named("hdpe", &[]).unwrap();
        assert_eq!(hd, material::find("PE-HD").unwrap().material);
        assert_eq!(hd.name, "PE-HD");
    }

    #[test]
    fn a_user_material_wins_over_the_built_in_of_its_name() {
        // The user's "pa-66" is the built-in PA66 once case and separators are ignored.
        let mine = Material {
            name: "pa-66".into(),
            ..Material::builtin("PC").unwrap()
        };
        let user = [mine.clone()];
        assert_eq!(material_named("PA66", &user).unwrap(), mine);
        assert_eq!(material_named("Pa 66", &user).unwrap(), mine);
        // Other names still reach the library.
        assert_eq!(material_named("PA6", &user).unwrap().name, "PA6");
        assert_ne!(material_named("PA66", &[]).unwrap(), mine);
        // The replaced built-in is not offered beside the user's material.
        let e = material_named("PA67", &user).unwrap_err().to_string();
        assert_eq!(e, "unknown material 'PA67'; closest: PA6, pa-66, PA66-GF30");
    }

    #[test]
    fn a_user_material_named_like_an_alias_replaces_that_built_in_under_every_name() {
        // The user's "HDPE" is named like the built-in PE-HD's alias: the listing shows it in
        // PE-HD's place, and the study takes it by either name (it took the built-in PE-HD).
        let mine = Material {
            name: "HDPE".into(),
            ..Material::builtin("PC").unwrap()
        };
        let user = [mine.clone()];
        let listed: Vec<String> = material::library_with(user.to_vec())
            .iter()
            .map(|l| match l {
                material::Listed::BuiltIn(i) => i.material.name.clone(),
                material::Listed::User(m) => m.name.clone(),
            })
            .collect();
        assert!(listed.contains(&"HDPE".to_string()) && !listed.contains(&"PE-HD".to_string()));
        for name in ["PE-HD", "pe hd", "HDPE"] {
            assert_eq!(material_named(name, &user).unwrap(), mine, "{name}");
        }
        assert_eq!(material_named("PE-LD", &user).unwrap().name, "PE-LD");
    }

    #[test]
    fn an_unknown_material_names_the_closest_ones() {
        let e = material_named("PA77", &[]).unwrap_err();
        let StudyError::UnknownMaterial { name, closest } = &e else {
            panic!("{e}")
        };
        assert_eq!(name, "PA77");
        assert_eq!(closest, &["PA6", "PA66", "PA66-GF30"]);
        assert_eq!(
            e.to_string(),
            "unknown material 'PA77'; closest: PA6, PA66, PA66-GF30"
        );
        // The user's materials are among the candidates.
        let user = [Material {
            name: "MyPP".into(),
            ..Material::builtin("PP").unwrap()
        }];
        let e = material_named("MyPX", &user).unwrap_err().to_string();
        assert!(
            e.starts_with("unknown material 'MyPX'; closest: MyPP"),
            "{e}"
        );
    }

    #[test]
    fn bad_values_name_their_field() {
        let cases = [
            (
                r#"{ "gate_radius": 0 }"#,
                "gate_radius must be a positive number, got 0",
            ),
            (
                r#"{ "spacing": -1 }"#,
                "spacing must be a positive number, got -1",
            ),
            (
                r#"{ "circle_points": 2 }"#,
                "circle_points must be at least 3, got 2",
            ),
            (
                r#"{ "flat_tol": -1 }"#,
                "flat_tol must be zero or positive, got -1",
            ),
            (r#"{ "max_nodes": 0 }"#, "max_nodes must be between 1"),
            (r#"{ "gates": 0 }"#, "gates must be at least 1"),
            (r#"{ "gates": 33 }"#, "gates must be at most 32, got 33"),
            (r#"{ "cell": 0 }"#, "cell must be a positive number, got 0"),
            (
                r#"{ "demold": "sideways" }"#,
                "demold: cannot read direction",
            ),
            (
                r#"{ "keep_out": ["cube:1"] }"#,
                "keep_out: cannot read keep-out region",
            ),
            (
                r#"{ "cosmetic": "0,0,0" }"#,
                "cosmetic: a direction must be",
            ),
            (r#"{ "n": -1 }"#, "n must be a positive finite number"),
            (
                r#"{ "gate_at": ["1,2"] }"#,
                "gate_at 1 '1,2': expected x,y,z (three numbers in mm), got 2 values",
            ),
            (
                r#"{ "gate_at": ["0,0,0", "a,b,c"] }"#,
                "gate_at 2 'a,b,c': x is not a number",
            ),
            (
                r#"{ "gate_at": ["1,NaN,0"] }"#,
                "gate_at 1 '1,NaN,0': y must be a finite number",
            ),
            (
                r#"{ "gate_at": ["1,2,inf"] }"#,
                "gate_at 1 '1,2,inf': z must be a finite number",
            ),
            (
                r#"{ "gate_at": ["1,2,3e12"] }"#,
                "gate_at 1 '1,2,3e12': z is beyond the coordinate limit",
            ),
        ];
        for (json, message) in cases {
            let o: StudyOptions = serde_json::from_str(json).unwrap();
            let e = o.validate().unwrap_err().to_string();
            assert!(e.starts_with(message) || e.contains(message), "{json}: {e}");
        }
    }

    #[test]
    fn gates_placed_are_read_and_their_number_is_bounded() {
        let o: StudyOptions =
            serde_json::from_str(r#"{ "gate_at": ["1,2,3", " -4.5 , 0 ,1e1 "] }"#).unwrap();
        let s = o.validate().unwrap();
        assert_eq!(
            s.gate_at,
            vec![DVec3::new(1.0, 2.0, 3.0), DVec3::new(-4.5, 0.0, 10.0)]
        );
        let o = StudyOptions {
            gate_at: vec!["0,0,0".into(); MAX_GATE_AT + 1],
            ..StudyOptions::default()
        };
        let e = o.validate().unwrap_err().to_string();
        assert_eq!(e, "gate_at is given 33 times, over the limit of 32 gates");
        let o = StudyOptions {
            gate_at: vec!["0,0,0".into(); MAX_GATE_AT],
            ..StudyOptions::default()
        };
        assert_eq!(o.validate().unwrap().gate_at.len(), MAX_GATE_AT);
    }

    #[test]
    fn keep_out_regions_are_counted_before_they_are_read() {
        let limit = crate::gate::MAX_KEEP_OUT;
        // Over the limit, the count is refused before any region is read (these are not
        // regions at all).
        let o = StudyOptions {
            keep_out: vec!["not a region".into(); limit + 1],
            ..StudyOptions::default()
        };
        let e = o.validate().unwrap_err().to_string();
        assert_eq!(e, "keep_out is given 65 regions, over the limit of 64");
        let o = StudyOptions {
            keep_out: vec!["sphere:0,0,0,1".into(); limit],
            ..StudyOptions::default()
        };
        assert_eq!(o.validate().unwrap().locate.keep_out.len(), limit);
        // The library's own options hold the same limit.
        let mut locate = o.validate().unwrap().locate;
        locate.keep_out.push(locate.keep_out[0]);
        assert!(locate.validate().is_err());
    }

    #[test]
    fn fill_is_implied_by_balanced_and_several_gates() {
        for json in [
            r#"{ "strategy": "balanced" }"#,
            r#"{ "gates": 3 }"#,
            r#"{ "fill": true }"#,
        ] {
            let o: StudyOptions = serde_json::from_str(json).unwrap();
            assert!(o.validate().unwrap().fill.is_some(), "{json}");
        }
        let o: StudyOptions = serde_json::from_str(r#"{ "demold": " AUTO " }"#).unwrap();
        assert_eq!(o.validate().unwrap().demold, Demold::Auto);
    }
}
