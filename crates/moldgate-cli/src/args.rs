//! Command-line arguments, validated once into library options, and the commands.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::{Args, Parser, Subcommand, ValueEnum};

use moldgate::flow;
use moldgate::gate::{FlatRule, Nearest, Spacing, ThicknessFallback, ThicknessRule};
use moldgate::mesh::{self, LoadedMesh, Units};
use moldgate::raycast::{Bvh, Sampling};
use moldgate::report::{Input, RadiusSource, Report};
use moldgate::scene::{Field, Marker, Scene};
use moldgate::thickness::{wall_thickness_with, ThicknessOptions};
use moldgate::undercut::auto_direction_checked;
use moldgate::{locate, CentreKind, Direction, GateMode, LocateOptions, Material};

use crate::formats::MeshKind;
use crate::output::{print_stdout, refuse_input, write_atomic};
use crate::summary;
use crate::Failure;

/// Where to put the injection gate of a plastic part, from its triangle mesh.
#[derive(Debug, Parser)]
#[command(name = "moldgate", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Locate the gate of a part (an STL, OBJ or PLY file, or a built-in sample).
    Locate(Box<LocateArgs>),
    /// Write a built-in sample part as a binary STL.
    Sample(SampleArgs),
    /// List the built-in materials and their gate radii (Eq. 7-8, Table 1).
    Materials(MaterialsArgs),
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum CentreArg {
    /// Area-weighted facet centroids (the paper's Eq. 5).
    Surface,
    /// Centroid of the enclosed volume.
    Volume,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum NearestArg {
    /// 3D distance from the node's surface point.
    #[value(name = "3d")]
    ThreeD,
    /// Distance in the projection plane.
    #[value(name = "2d")]
    TwoD,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ThicknessArg {
    /// Keep only nodes whose wall is thicker than R_gate (the paper's rule).
    Require,
    /// Measure and report thickness but do not filter on it.
    Ignore,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum StrategyArg {
    /// The paper's gate: the qualifying node nearest the centre of mass.
    Paper,
    /// The qualifying node that minimises the fill objective.
    Balanced,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ObjectiveArg {
    /// The largest flow length.
    Length,
    /// The largest flow resistance (fill order).
    Resistance,
}

#[derive(Debug, Args)]
pub struct LocateArgs {
    /// The part: an STL (binary or ASCII), OBJ or PLY file, read by its extension (.stl,
    /// .obj, .ply in any case; STL for any other). Several files or folders run them all (see
    /// --out-dir, --summary).
    #[arg(
        required_unless_present_any = ["sample", "manifest"],
        conflicts_with = "sample",
        value_name = "FILE|FOLDER"
    )]
    pub files: Vec<PathBuf>,
    /// Use a built-in sample part instead of a file (see `moldgate sample --list`).
    #[arg(long, value_name = "NAME")]
    pub sample: Option<String>,
    /// Length unit of the file.
    #[arg(long, default_value = "mm", value_name = "mm|cm|m|in")]
    pub units: String,
    /// Demolding direction: +x, -y, ... or x,y,z. Rays come from its + side. `auto` picks
    /// the axis or principal axis with the least undercut area.
    #[arg(
        long,
        default_value = "+z",
        allow_hyphen_values = true,
        value_name = "DIR"
    )]
    pub demold: String,
    /// Material: PP, ABS, PC (the paper's Table 1) or one from --materials-file.
    #[arg(long, default_value = "PP")]
    pub material: String,
    /// TOML file of user materials: one table per material with n, t_melt, t_wall,
    /// gamma_opt, mu_opt, k.
    #[arg(long, value_name = "FILE")]
    pub materials_file: Option<PathBuf>,
    /// Override the material's power-law index n.
    #[arg(long, allow_hyphen_values = true)]
    pub n: Option<f64>,
    /// Override the melt temperature, degrees C.
    #[arg(long, allow_hyphen_values = true)]
    pub t_melt: Option<f64>,
    /// Override the mould wall temperature, degrees C.
    #[arg(long, allow_hyphen_values = true)]
    pub t_wall: Option<f64>,
    /// Override the optimal shear rate, 1/s.
    #[arg(long, allow_hyphen_values = true)]
    pub gamma_opt: Option<f64>,
    /// Override the viscosity at that shear rate, Pa s.
    #[arg(long, allow_hyphen_values = true)]
    pub mu_opt: Option<f64>,
    /// Override the thermal conductivity, W/(m C).
    #[arg(long, allow_hyphen_values = true)]
    pub k: Option<f64>,
    /// Force the gate radius in mm instead of Eq. 8.
    #[arg(long, value_name = "MM", allow_hyphen_values = true)]
    pub gate_radius: Option<f64>,
    /// Grid spacing in mm [default: min(R_gate, longest projected side / 100)].
    #[arg(long, value_name = "MM", allow_hyphen_values = true)]
    pub spacing: Option<f64>,
    /// Shift the grid by this fraction of the spacing along both axes.
    #[arg(
        long,
        default_value_t = 0.0,
        value_name = "F",
        allow_hyphen_values = true
    )]
    pub grid_offset: f64,
    /// Points on each node's circle.
    #[arg(long, default_value_t = 16)]
    pub circle_points: usize,
    /// Which centre of mass the gate is placed by.
    #[arg(long, value_enum, default_value = "surface")]
    pub centre: CentreArg,
    /// How nearness to the centre of mass is measured.
    #[arg(long, value_enum, default_value = "3d")]
    pub nearest: NearestArg,
    /// The paper's rule that R_gate be below the wall thickness.
    #[arg(long, value_enum, default_value = "require")]
    pub thickness_rule: ThicknessArg,
    /// When the thickness rule leaves no node, take the gate of the largest gate radius that
    /// fits (searched below R_gate and reported either way).
    #[arg(long)]
    pub fit_radius: bool,
    /// Keep only nodes whose circle is flat within --flat-tol.
    #[arg(long)]
    pub require_flat: bool,
    /// Flatness tolerance along the demolding direction, mm [default: 0.1 R_gate].
    #[arg(long, value_name = "MM", allow_hyphen_values = true)]
    pub flat_tol: Option<f64>,
    /// Put the gate on the parting line, nearest the centre of mass (aesthetic parts).
    #[arg(long)]
    pub aesthetic: bool,
    /// Largest grid accepted, in nodes.
    #[arg(long, default_value_t = 4_000_000)]
    pub max_nodes: usize,
    /// A region no gate may reach into: box:x0,y0,z0,x1,y1,z1 or sphere:x,y,z,r (mm);
    /// repeat for several.
    #[arg(long, value_name = "REGION", allow_hyphen_values = true)]
    pub keep_out: Vec<String>,
    /// The visible side: no gate on faces turned towards this direction (+x, -y, x,y,z).
    #[arg(long, value_name = "DIR", allow_hyphen_values = true)]
    pub cosmetic: Option<String>,
    /// Analyse the fill: flow length, fill order, Eq. 1 pressure, last places to fill, weld
    /// lines, and the balanced gate for comparison.
    #[arg(long)]
    pub fill: bool,
    /// Which gate is the answer: the paper's, or the candidate that minimises the fill
    /// objective (implies --fill).
    #[arg(long, value_enum, default_value = "paper")]
    pub strategy: StrategyArg,
    /// What the balanced gate and several gates minimise.
    #[arg(long, value_enum, default_value = "length")]
    pub objective: ObjectiveArg,
    /// Number of gates that together minimise the worst flow (implies --fill).
    #[arg(long, default_value_t = 1, value_name = "K")]
    pub gates: usize,
    /// Side of the flow-analysis cells, mm [default: half the nominal wall, at most 1/120
    /// of the part's diagonal].
    #[arg(long, value_name = "MM", allow_hyphen_values = true)]
    pub cell: Option<f64>,
    /// Also measure the wall thickness everywhere (rays along the inverted normals) and
    /// report min / nominal / max and the value at the gate.
    #[arg(long)]
    pub wall_thickness: bool,
    /// Print the JSON report on stdout instead of the summary.
    #[arg(long)]
    pub json: bool,
    /// Write the JSON report to this file (written whole or not at all).
    #[arg(short, long, value_name = "FILE.json")]
    pub output: Option<PathBuf>,
    /// Several parts at once.
    #[command(flatten)]
    pub batch: crate::batch::BatchArgs,
    /// Write the part, gate, centre of mass and parting line as binary glTF (written whole
    /// or not at all; millimetres scaled to metres, demolding direction up).
    #[arg(long, value_name = "FILE.glb")]
    pub glb: Option<PathBuf>,
    /// Write a picture of the analysis to this PNG file (1600x900: the view along D and an
    /// isometric view, coloured, with the gate, centre of mass, parting line and qualifying
    /// region).
    #[arg(long, value_name = "FILE.png")]
    pub png: Option<PathBuf>,
    /// Write a self-contained HTML report (summary, picture, warnings, glossary, full JSON)
    /// to this file.
    #[arg(long, value_name = "FILE.html")]
    pub report: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct SampleArgs {
    /// Sample name.
    #[arg(required_unless_present = "list")]
    pub name: Option<String>,
    /// Output STL file.
    #[arg(short, long, required_unless_present = "list", value_name = "FILE.stl")]
    pub output: Option<PathBuf>,
    /// List the samples.
    #[arg(long)]
    pub list: bool,
}

#[derive(Debug, Args)]
pub struct MaterialsArgs {
    /// Also list the materials of this TOML file.
    #[arg(long, value_name = "FILE")]
    pub materials_file: Option<PathBuf>,
}

/// Reads and parses a TOML file: an unreadable file is an input error (exit 3), a syntax
/// error or a bad value an error of the command line (exit 2) naming the line.
pub fn read_toml<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, Failure> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Failure::input(format!("{}: cannot read: {e}", path.display())))?;
    toml::from_str(&text).map_err(|e| {
        let place = e
            .span()
            .map(|s| format!("line {}: ", 1 + text[..s.start].matches('\n').count()))
            .unwrap_or_default();
        Failure::usage(format!(
            "{}: {place}{}",
            path.display(),
            e.message().trim_end_matches('.')
        ))
    })
}

/// Reads a TOML file of user materials.
fn read_materials(path: &Path) -> Result<BTreeMap<String, Material>, Failure> {
    let mut table: BTreeMap<String, Material> = read_toml(path)?;
    for (name, m) in table.iter_mut() {
        m.name = name.clone();
        m.validate()
            .map_err(|e| Failure::usage(format!("{}: {e}", path.display())))?;
    }
    Ok(table)
}

/// The material: user file first, then the built-ins, then single-parameter overrides.
fn material(a: &LocateArgs) -> Result<Material, Failure> {
    let user = match &a.materials_file {
        Some(p) => read_materials(p)?,
        None => BTreeMap::new(),
    };
    let mut m = user
        .iter()
        .find(|(k, _)| k.eq_ignore_ascii_case(&a.material))
        .map(|(_, m)| m.clone())
        .or_else(|| Material::builtin(&a.material))
        .ok_or_else(|| {
            let mut known: Vec<String> = moldgate::material::BUILTIN
                .iter()
                .map(|s| s.to_string())
                .collect();
            known.extend(user.keys().cloned());
            Failure::usage(format!(
                "unknown material '{}' (known: {})",
                a.material,
                known.join(", ")
            ))
        })?;
    let overrides = [
        (&mut m.n, a.n),
        (&mut m.t_melt, a.t_melt),
        (&mut m.t_wall, a.t_wall),
        (&mut m.gamma_opt, a.gamma_opt),
        (&mut m.mu_opt, a.mu_opt),
        (&mut m.k, a.k),
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
    m.validate().map_err(|e| Failure::usage(e.to_string()))?;
    Ok(m)
}

/// Validates the raw arguments into library options, once.
fn options(a: &LocateArgs, material: &Material) -> Result<(LocateOptions, RadiusSource), Failure> {
    // `auto` needs the mesh: resolved in `run_locate` once it is loaded.
    let direction: Direction = if is_auto(&a.demold) {
        Direction::default()
    } else {
        a.demold
            .parse()
            .map_err(|e: moldgate::OptionsError| Failure::usage(format!("--demold: {e}")))?
    };
    let positive = |name: &str, v: f64| {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(Failure::usage(format!(
                "{name} must be a positive number, got {v}"
            )))
        }
    };
    let (gate_radius_mm, source) = match a.gate_radius {
        Some(r) => (positive("--gate-radius", r)?, RadiusSource::Forced),
        None => (material.gate_radius_mm(), RadiusSource::Material),
    };
    let spacing = match a.spacing {
        Some(h) => Spacing::Mm(positive("--spacing", h)?),
        None => Spacing::Auto,
    };
    if !a.grid_offset.is_finite() {
        return Err(Failure::usage("--grid-offset must be a finite number"));
    }
    if a.circle_points < 3 {
        return Err(Failure::usage(format!(
            "--circle-points must be at least 3, got {}",
            a.circle_points
        )));
    }
    if let Some(t) = a.flat_tol {
        if !(t.is_finite() && t >= 0.0) {
            return Err(Failure::usage(format!(
                "--flat-tol must be zero or positive, got {t}"
            )));
        }
    }
    if a.max_nodes == 0 || a.max_nodes > MAX_NODES_LIMIT {
        return Err(Failure::usage(format!(
            "--max-nodes must be between 1 and {MAX_NODES_LIMIT}, got {}",
            a.max_nodes
        )));
    }
    let options = LocateOptions {
        direction,
        gate_radius_mm,
        spacing,
        grid_offset: a.grid_offset,
        circle_points: a.circle_points,
        centre: match a.centre {
            CentreArg::Surface => CentreKind::Surface,
            CentreArg::Volume => CentreKind::Volume,
        },
        nearest: match a.nearest {
            NearestArg::ThreeD => Nearest::Surface3d,
            NearestArg::TwoD => Nearest::Plane2d,
        },
        thickness_rule: match a.thickness_rule {
            ThicknessArg::Require => ThicknessRule::Require,
            ThicknessArg::Ignore => ThicknessRule::Ignore,
        },
        thickness_fallback: if a.fit_radius {
            ThicknessFallback::LargestFitting
        } else {
            ThicknessFallback::Report
        },
        flat_rule: if a.require_flat {
            FlatRule::Require
        } else {
            FlatRule::Report
        },
        flat_tolerance_mm: a.flat_tol,
        mode: if a.aesthetic {
            GateMode::Aesthetic
        } else {
            GateMode::Paper
        },
        max_nodes: a.max_nodes,
        keep_out: a
            .keep_out
            .iter()
            .map(|k| k.parse())
            .collect::<Result<_, moldgate::OptionsError>>()
            .map_err(|e| Failure::usage(format!("--keep-out: {e}")))?,
        cosmetic: a
            .cosmetic
            .as_deref()
            .map(str::parse)
            .transpose()
            .map_err(|e: moldgate::OptionsError| Failure::usage(format!("--cosmetic: {e}")))?,
    };
    Ok((options, source))
}

/// Reads a mesh file and gives its size in bytes; every failure names the file.
pub fn load_file(path: &Path, units: Units) -> Result<(LoadedMesh, u64), Failure> {
    let fail = |e: &dyn std::fmt::Display| Failure::input(format!("{}: {e}", path.display()));
    if path.is_dir() {
        return Err(fail(&"is a folder, not a mesh file"));
    }
    let file = File::open(path).map_err(|e| fail(&format_args!("cannot open: {e}")))?;
    let len = file
        .metadata()
        .map_err(|e| fail(&format_args!("cannot read: {e}")))?
        .len();
    drop(file);
    // Opened once per reading thread for large binary files.
    let open = || File::open(path).map(|f| BufReader::with_capacity(1 << 16, f));
    let part = match crate::formats::mesh_kind(path) {
        MeshKind::Stl => mesh::read_stl_reopen(open, len, units),
        MeshKind::Obj => open()
            .map_err(Into::into)
            .and_then(|r| mesh::read_obj(r, units)),
        MeshKind::Ply => open()
            .map_err(Into::into)
            .and_then(|r| mesh::read_ply(r, units)),
    }
    .map_err(|e| fail(&e))?;
    Ok((part, len))
}

/// The largest grid the command line accepts. With 16 circle points a node costs 17 rays of
/// 24 bytes, so this is about 8 GB: far beyond a useful grid (the default limit is 4 million
/// nodes), and a bound that keeps an absurd `--max-nodes` from reaching the allocator.
const MAX_NODES_LIMIT: usize = 20_000_000;

/// The fill analysis's options, or `None` when it was not asked for.
fn fill_options(a: &LocateArgs) -> Result<Option<flow::FillOptions>, Failure> {
    if a.gates == 0 {
        return Err(Failure::usage("--gates must be at least 1"));
    }
    if let Some(h) = a.cell {
        if !(h.is_finite() && h > 0.0) {
            return Err(Failure::usage(format!(
                "--cell must be a positive number, got {h}"
            )));
        }
    }
    let wanted = a.fill || a.strategy == StrategyArg::Balanced || a.gates > 1;
    if !wanted {
        return Ok(None);
    }
    Ok(Some(flow::FillOptions {
        flow: flow::FlowOptions {
            cell_mm: a.cell,
            ..flow::FlowOptions::default()
        },
        strategy: match a.strategy {
            StrategyArg::Paper => flow::Strategy::Paper,
            StrategyArg::Balanced => flow::Strategy::Balanced,
        },
        objective: match a.objective {
            ObjectiveArg::Length => flow::Objective::Length,
            ObjectiveArg::Resistance => flow::Objective::Resistance,
        },
        gates: a.gates,
    }))
}

/// The validated options of `locate`, the same for every part of a run.
#[derive(Debug, Clone)]
pub struct Settings {
    /// The material (Table 1, a user file, overrides).
    pub material: Material,
    /// The library's options.
    pub options: LocateOptions,
    /// Whether R comes from the material or `--gate-radius`.
    pub radius_source: RadiusSource,
    /// The fill analysis, when asked for.
    pub fill: Option<flow::FillOptions>,
    /// The unit of the files.
    pub units: Units,
    /// `--demold auto`: the direction is chosen per part once it is loaded.
    pub auto_demold: bool,
    /// `--wall-thickness`: measure and report the wall everywhere.
    pub wall_thickness: bool,
}

fn is_auto(demold: &str) -> bool {
    demold.trim().eq_ignore_ascii_case("auto")
}

/// Validates the raw arguments of `locate` once into [`Settings`].
pub fn settings(a: &LocateArgs) -> Result<Settings, Failure> {
    let material = material(a)?;
    let (options, radius_source) = options(a, &material)?;
    let fill = fill_options(a)?;
    let units: Units = a
        .units
        .parse()
        .map_err(|e: String| Failure::usage(format!("--units: {e}")))?;
    Ok(Settings {
        material,
        options,
        radius_source,
        fill,
        units,
        auto_demold: is_auto(&a.demold),
        wall_thickness: a.wall_thickness,
    })
}

/// Where a part comes from.
#[derive(Debug, Clone, Copy)]
pub enum Source<'a> {
    /// A mesh file.
    File(&'a Path),
    /// A built-in sample, by name.
    Sample(&'a str),
}

pub fn run_locate(a: LocateArgs) -> Result<(), Failure> {
    if crate::batch::wanted(&a) {
        return crate::batch::run(a);
    }
    crate::batch::with_jobs(a.batch.jobs, || locate_one(a))
}

/// `locate` on one file or sample.
fn locate_one(a: LocateArgs) -> Result<(), Failure> {
    let settings = settings(&a)?;
    let file = a.files.first();
    if let Some(out) = &a.output {
        refuse_input(out, file.map(PathBuf::as_path))?;
    }
    if let Some(glb) = &a.glb {
        crate::glb::check_path(glb, file.map(PathBuf::as_path), a.output.as_deref())?;
    }
    crate::pictures::check_outputs(&a)?;
    let source = match (file, &a.sample) {
        (Some(path), _) => Source::File(path),
        (None, Some(name)) => Source::Sample(name),
        (None, None) => return Err(Failure::usage("give a mesh file or --sample NAME")),
    };
    let Analysed {
        report,
        part,
        analysis,
        fill_order,
    } = analyse(source, &settings)?;
    let json = serde_json::to_string_pretty(&report).map_err(|e| Failure {
        code: 1,
        message: format!("cannot encode the report: {e}"),
    })? + "\n";
    if let Some(out) = &a.output {
        write_atomic(out, json.as_bytes())?;
    }
    if let Some(path) = &a.glb {
        let title = title_of(source);
        let scene = scene_of(&part, &analysis, &report, fill_order.clone(), title);
        crate::glb::write(path, &scene)?;
    }
    if a.png.is_some() || a.report.is_some() {
        let scene = scene_of(&part, &analysis, &report, fill_order, title_of(source));
        crate::pictures::write(&a, scene, &report, &json, &settings.material)?;
    }
    if a.json {
        print_stdout(&json)?;
    } else {
        print_stdout(&summary::render(&report))?;
    }
    match (&report.gate, &report.no_gate_reason) {
        (None, Some(reason)) => Err(Failure::no_gate(format!(
            "{}: {reason}",
            report
                .input
                .path
                .clone()
                .or(report.input.sample.clone())
                .unwrap_or_default()
        ))),
        _ => Ok(()),
    }
}

/// The title of a picture or 3D file: the file's name, or the sample's.
fn title_of(source: Source) -> String {
    match source {
        Source::File(f) => f
            .file_name()
            .unwrap_or(f.as_os_str())
            .to_string_lossy()
            .into_owned(),
        Source::Sample(s) => format!("sample '{s}'"),
    }
}

/// The scene pictures and 3D files show: coloured by the fill order when the fill was
/// analysed, with the report's answer (the balanced gate under `--strategy balanced`) and
/// every gate of a several-gate layout.
fn scene_of<'a>(
    part: &'a LoadedMesh,
    analysis: &moldgate::Analysis,
    report: &Report,
    fill_order: Option<Field>,
    title: String,
) -> Scene<'a> {
    let mut scene = Scene::new(&part.mesh, analysis, title);
    if let Some(f) = fill_order {
        scene = scene.with_field(f);
    }
    let r = analysis.options.gate_radius_mm;
    if let (Some(g), Some(first)) = (&report.gate, scene.gates.first_mut()) {
        if g.strategy == flow::Strategy::Balanced {
            *first = Marker {
                point: moldgate::math::DVec3::from_array(g.point),
                normal: moldgate::math::DVec3::ZERO,
                radius_mm: r,
            };
            scene.subtitle = format!(
                "balanced gate ({:.2}, {:.2}, {:.2}) mm, R = {r:.2} mm",
                g.point[0], g.point[1], g.point[2]
            );
        }
    }
    if let Some(several) = report.fill.as_ref().and_then(|f| f.several.as_ref()) {
        scene.gates = several
            .gates
            .iter()
            .map(|g| Marker {
                point: moldgate::math::DVec3::from_array(g.point),
                normal: moldgate::math::DVec3::ZERO,
                radius_mm: r,
            })
            .collect();
    }
    scene
}

/// One analysed part: its report, and what pictures and 3D files are drawn from.
pub struct Analysed {
    /// The report.
    pub report: Report,
    /// The part.
    pub part: LoadedMesh,
    /// The gate analysis.
    pub analysis: moldgate::Analysis,
    /// The fill order of the answer's gate per vertex, when the fill was analysed.
    pub fill_order: Option<Field>,
}

/// Loads and analyses one part. A part without a gate is a report (its `gate` is `None` and
/// `no_gate_reason` says why); the error is for a part that could not be analysed at all.
pub fn analyse(source: Source, s: &Settings) -> Result<Analysed, Failure> {
    let Settings {
        material,
        options,
        radius_source,
        fill: fill_options,
        units,
        auto_demold,
        wall_thickness,
    } = s;
    let radius_source = *radius_source;
    let t = Instant::now();
    let (part, input) = match source {
        Source::File(path) => {
            let (part, bytes) = load_file(path, *units)?;
            let input = Input {
                path: Some(path.display().to_string()),
                sample: None,
                bytes,
            };
            (part, input)
        }
        Source::Sample(name) => {
            let m = moldgate::samples::sample(name).ok_or_else(|| unknown_sample(name))?;
            let input = Input {
                path: None,
                sample: Some(name.to_string()),
                bytes: 0,
            };
            (mesh::from_generated(m), input)
        }
    };
    let load_s = t.elapsed().as_secs_f64();
    // One ray-casting tree serves the automatic direction and the wall thickness (which the
    // fill analysis uses for its flow resistance).
    let wants_wall = *wall_thickness || fill_options.is_some();
    let t = Instant::now();
    let bvh = (*auto_demold || wants_wall).then(|| Bvh::new(&part.mesh));
    let tree_s = t.elapsed().as_secs_f64();
    let mut options = options.clone();
    let auto = match &bvh {
        Some(bvh) if *auto_demold => {
            // Lines still tied after the shallowest draw go to one on which a gate qualifies.
            let gate_qualifies = |d| {
                let o = moldgate::LocateOptions {
                    direction: d,
                    ..options.clone()
                };
                locate(&part, &o).is_ok_and(|a| a.gate().is_ok())
            };
            let auto = auto_direction_checked(&part.mesh, bvh, Sampling::Centroid, gate_qualifies)
                .map_err(|e| {
                    Failure::input(format!("{}: --demold auto: {e}", input_name(&input)))
                })?;
            options.direction = auto.direction();
            Some(auto)
        }
        _ => None,
    };
    let analysis = locate(&part, &options).map_err(|e| Failure::usage(e.to_string()))?;
    // The full wall map only when asked for; the fill analysis measures its own samples.
    let wall = match (&bvh, *wall_thickness) {
        (Some(bvh), true) => {
            let t = Instant::now();
            let w = wall_thickness_with(&part.mesh, bvh, &ThicknessOptions::default());
            Some((w, t.elapsed().as_secs_f64()))
        }
        _ => None,
    };
    let fill = fill_options
        .as_ref()
        .map(|o| {
            if analysis.gate().is_err() {
                return Ok(None);
            }
            let walls = match (&wall, &bvh) {
                (Some((w, _)), _) if w.nominal_mm.is_some() => {
                    flow::Walls::Given(&w.per_triangle, w.nominal_mm.unwrap_or_default())
                }
                (_, Some(bvh)) => flow::Walls::Measure(bvh),
                _ => flow::Walls::Estimate,
            };
            flow::analyse(&part.mesh, &analysis, material, walls, o)
                .map(|mut f| {
                    f.times.tree_s = tree_s;
                    Some(f)
                })
                .map_err(|e| match e {
                    flow::FillError::TooFewCandidates { .. } => Failure::no_gate(e.to_string()),
                    _ => Failure::usage(e.to_string()),
                })
        })
        .transpose()?
        .flatten();
    let mut report = Report::new(
        input,
        &part.stats,
        &part.warnings,
        material,
        radius_source,
        &analysis,
        load_s,
    );
    if let Some(auto) = auto {
        report = report.with_demold_auto(auto);
    }
    if let Some((w, time_s)) = &wall {
        report = report.with_wall_thickness(w, *time_s);
    }
    let mut fill_order = None;
    if let Some(mut fill) = fill {
        fill_order = Some(Field {
            name: "fill order (0 gate, 1 last)".into(),
            unit: String::new(),
            per_vertex: std::mem::take(&mut fill.fill_order_per_vertex),
        });
        report = report.with_fill(fill, analysis.centre);
    }
    Ok(Analysed {
        report,
        part,
        analysis,
        fill_order,
    })
}

fn input_name(input: &Input) -> String {
    input
        .path
        .clone()
        .or(input.sample.clone())
        .unwrap_or_default()
}

fn unknown_sample(name: &str) -> Failure {
    let names: Vec<&str> = moldgate::samples::SAMPLES.iter().map(|s| s.name).collect();
    Failure::usage(format!(
        "unknown sample '{name}' (known: {})",
        names.join(", ")
    ))
}

pub fn run_sample(a: SampleArgs) -> Result<(), Failure> {
    if a.list {
        let mut out = String::new();
        for s in moldgate::samples::SAMPLES {
            out += &format!("{:10} {}\n", s.name, s.description);
        }
        return print_stdout(&out);
    }
    let (Some(name), Some(path)) = (a.name, a.output) else {
        return Err(Failure::usage("give a sample name and -o FILE.stl"));
    };
    let mesh = moldgate::samples::sample(&name).ok_or_else(|| unknown_sample(&name))?;
    let mut bytes = Vec::new();
    mesh.write_stl(&mut bytes)
        .map_err(|e| Failure::output(format!("cannot encode STL: {e}")))?;
    write_atomic(&path, &bytes)?;
    eprintln!(
        "wrote {} ({} triangles, mm)",
        path.display(),
        mesh.triangles.len()
    );
    Ok(())
}

pub fn run_materials(a: MaterialsArgs) -> Result<(), Failure> {
    let mut all: Vec<Material> = moldgate::material::BUILTIN
        .iter()
        .filter_map(|n| Material::builtin(n))
        .collect();
    if let Some(p) = &a.materials_file {
        all.extend(read_materials(p)?.into_values());
    }
    let mut out = format!(
        "{:<10} {:>7} {:>7} {:>7} {:>9} {:>8} {:>6} {:>10} {:>10}\n",
        "material", "n", "Tmelt_C", "Twall_C", "gamma_1/s", "mu_Pa.s", "k", "v_m/s", "R_gate_mm"
    );
    for m in all {
        out += &format!(
            "{:<10} {:>7} {:>7} {:>7} {:>9} {:>8} {:>6} {:>10.5} {:>10.4}\n",
            m.name,
            m.n,
            m.t_melt,
            m.t_wall,
            m.gamma_opt,
            m.mu_opt,
            m.k,
            m.melt_velocity_m_s(),
            m.gate_radius_mm()
        );
    }
    print_stdout(&out)
}
