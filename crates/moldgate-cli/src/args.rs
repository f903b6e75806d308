//! The command line's arguments (clap), and their translation into the library's
//! [`StudyOptions`] (field for field: the options' names are the flags in snake case).
//! Nothing here validates or runs: [`StudyOptions::validate`] does the one, the command
//! modules the other.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

use moldgate::study::{
    CentreChoice, ColorByChoice, MaterialChoice, NearestChoice, ObjectiveChoice, StrategyChoice,
    StudyOptions, ThicknessChoice,
};

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
    /// List the built-in materials (the paper's Table 1 and typical grades): gate radius
    /// (Eq. 7-8), L/t limit, and with --json every value's source.
    Materials(MaterialsArgs),
    /// Serve studies over HTTP (POST /v1/study; the API is at /v1/openapi.json).
    Serve(ServeArgs),
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
pub enum PartingLineArg {
    /// The closed outer rim of each body seen along D (the default).
    Outline,
    /// The longest loop of the edges between the two sides (the paper's path; may run over
    /// holes or threads, and may be open).
    Longest,
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

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ColorByArg {
    /// Flow length from the gate, mm.
    FlowLength,
    /// Estimated fill time from the gate, s (`fill-time` names it too).
    #[value(alias = "fill-time")]
    FillOrder,
    /// Wall thickness, mm.
    Wall,
    /// Height along the demolding direction.
    Height,
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
    /// Material: PP, ABS, PC (the paper's Table 1), a built-in grade such as PA66-GF30
    /// (`moldgate materials` lists them; case and separators are ignored) or one from
    /// --materials-file, which wins over a built-in of the same name.
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
    /// Shift the grid by this fraction of the spacing along both axes (above -1, below 1).
    #[arg(
        long,
        default_value_t = 0.0,
        value_name = "F",
        allow_hyphen_values = true
    )]
    pub grid_offset: f64,
    /// Points on each node's circle.
    #[arg(long, default_value_t = 16, allow_negative_numbers = true)]
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
    /// Which edges make the parting line (and so where --aesthetic puts the gate).
    #[arg(long, value_enum, default_value = "outline")]
    pub parting_line: PartingLineArg,
    /// Largest grid accepted, in nodes.
    #[arg(long, default_value_t = 4_000_000, allow_negative_numbers = true)]
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
    /// What pictures of the fill are coloured by.
    #[arg(long = "color-by", value_enum, default_value = "fill-order")]
    pub color_by: ColorByArg,
    /// Number of gates that together minimise the worst flow (implies --fill).
    #[arg(
        long,
        default_value_t = 1,
        value_name = "K",
        allow_negative_numbers = true
    )]
    pub gates: usize,
    /// Side of the flow-analysis cells, mm [default: half the nominal wall, at most 1/120
    /// of the part's diagonal].
    #[arg(long, value_name = "MM", allow_hyphen_values = true)]
    pub cell: Option<f64>,
    /// Also measure the wall thickness everywhere (rays along the inverted normals) and
    /// report min / nominal / max and the value at the gate.
    #[arg(long)]
    pub wall_thickness: bool,
    /// A gate you place, x,y,z in mm in the part's frame: moved to the nearest surface
    /// point and judged by the paper's rules (with --fill, its fill beside the paper and
    /// balanced gates); repeat for a layout of several gates filled together (at most 32).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub gate_at: Vec<String>,
    /// Also score every qualifying node as a gate (the gate-suitability map: L_max, or the
    /// chosen objective, of a gate at each node, exact or bounded; implies --fill). The
    /// pictures then show the map.
    #[arg(long)]
    pub suitability: bool,
    /// Print the JSON report on stdout instead of the summary.
    #[arg(long)]
    pub json: bool,
    /// Write the JSON report to this file (written whole or not at all).
    #[arg(short, long, value_name = "FILE.json")]
    pub output: Option<PathBuf>,
    /// Several parts at once.
    #[command(flatten)]
    pub batch: BatchArgs,
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
    /// Also list the materials of this TOML file (one of the same name as a built-in
    /// replaces it).
    #[arg(long, value_name = "FILE")]
    pub materials_file: Option<PathBuf>,
    /// Print every parameter with its source as JSON instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// Options of `serve`; every limit has a default and is checked before the work.
#[derive(Debug, Args)]
pub struct ServeArgs {
    /// Address to listen on (port 0: any free port, printed on stderr).
    #[arg(long, default_value = "127.0.0.1:8080", value_name = "ADDR")]
    pub bind: std::net::SocketAddr,
    /// Largest request body, in MiB.
    #[arg(
        long,
        default_value_t = 100,
        value_name = "MIB",
        allow_negative_numbers = true
    )]
    pub max_upload: u64,
    /// Studies that run at once (default: the number of cores).
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub analyses: Option<usize>,
    /// Studies admitted beyond those, waiting; more are refused with 503.
    #[arg(
        long,
        default_value_t = 16,
        value_name = "N",
        allow_negative_numbers = true
    )]
    pub queue: usize,
    /// Time limit of a study, seconds (504 past it).
    #[arg(
        long,
        default_value_t = 60.0,
        value_name = "S",
        allow_hyphen_values = true
    )]
    pub timeout: f64,
    /// Time limit for receiving a request body, seconds (408 past it).
    #[arg(
        long,
        default_value_t = 60.0,
        value_name = "S",
        allow_hyphen_values = true
    )]
    pub read_timeout: f64,
    /// Largest grid a request may ask for, in nodes.
    #[arg(
        long,
        default_value_t = 4_000_000,
        value_name = "N",
        allow_negative_numbers = true
    )]
    pub max_nodes: usize,
    /// Time limit for receiving a request's line and headers, seconds, from the accept (or
    /// the previous answer on a kept-alive connection); past it the connection is closed
    /// without an answer.
    #[arg(
        long,
        default_value_t = 30.0,
        value_name = "S",
        allow_hyphen_values = true
    )]
    pub header_timeout: f64,
    /// Connections open at once; more wait in the listen queue until one closes.
    #[arg(
        long,
        default_value_t = 512,
        value_name = "N",
        allow_negative_numbers = true
    )]
    pub connections: usize,
    /// The browser app's built folder, served at / (default web/dist when it exists).
    #[arg(long, value_name = "DIR")]
    pub web_dir: Option<PathBuf>,
}

/// The most threads `--jobs` starts (as `serve --analyses`): each thread reserves its
/// stack, and a pool of tens of thousands took minutes to start on two cores.
pub const MAX_JOBS: u16 = 1024;

/// Options of `locate` for several parts.
#[derive(Debug, Args)]
pub struct BatchArgs {
    /// Write one JSON report per part into this existing folder, named after the input file
    /// (`part.stl` gives `part.json`).
    #[arg(long, value_name = "DIR", conflicts_with = "sample")]
    pub out_dir: Option<PathBuf>,
    /// Write one line per part to this file: JSON Lines if it ends in .jsonl or .ndjson, CSV
    /// if it ends in .csv.
    #[arg(long, value_name = "FILE.jsonl|FILE.csv", conflicts_with = "sample")]
    pub summary: Option<PathBuf>,
    /// TOML file listing parts, each with an optional unit and demolding direction of its own:
    /// `[[part]]` tables with `file` (relative to the manifest), `units`, `demold`.
    #[arg(long, value_name = "FILE.toml", conflicts_with = "sample")]
    pub manifest: Option<PathBuf>,
    /// Threads for the whole run, parts and their inner stages together, at most 1024
    /// [default: all cores].
    #[arg(short, long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=MAX_JOBS as i64), allow_negative_numbers = true)]
    pub jobs: Option<u16>,
    /// Time limit of each part's study, seconds: past it the study stops (within one step
    /// of the fill's cells, one march of the fill analysis, one facet of a wall map or one
    /// block of triangles of the gate's rays; the load runs to its end) and the part fails
    /// with exit code 6; from 0.001 to 86400 (a day) [default: none].
    #[arg(long, value_name = "S", allow_hyphen_values = true)]
    pub timeout: Option<f64>,
    /// No progress bar and no closing count.
    #[arg(short, long)]
    pub quiet: bool,
    /// How parts share the threads (for measurement; `parts` was the faster).
    #[arg(long, value_enum, default_value = "parts", hide = true)]
    pub schedule: Schedule,
}

/// How the parts of a batch share the pool.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Schedule {
    /// Several parts at once, each with the library's inner parallelism on the same pool.
    Parts,
    /// One part after the other, each using the whole pool inside.
    OneByOne,
}

impl LocateArgs {
    /// The study's options, flag for flag (validated later, once, by the library). The
    /// material is given by name: `--materials-file` is read by the caller and passed to
    /// [`StudyOptions::validate_with`].
    pub fn study_options(&self) -> StudyOptions {
        StudyOptions {
            demold: self.demold.clone(),
            material: MaterialChoice::Name(self.material.clone()),
            n: self.n,
            t_melt: self.t_melt,
            t_wall: self.t_wall,
            gamma_opt: self.gamma_opt,
            mu_opt: self.mu_opt,
            k: self.k,
            gate_radius: self.gate_radius,
            spacing: self.spacing,
            grid_offset: self.grid_offset,
            circle_points: self.circle_points,
            centre: match self.centre {
                CentreArg::Surface => CentreChoice::Surface,
                CentreArg::Volume => CentreChoice::Volume,
            },
            nearest: match self.nearest {
                NearestArg::ThreeD => NearestChoice::ThreeD,
                NearestArg::TwoD => NearestChoice::TwoD,
            },
            thickness_rule: match self.thickness_rule {
                ThicknessArg::Require => ThicknessChoice::Require,
                ThicknessArg::Ignore => ThicknessChoice::Ignore,
            },
            fit_radius: self.fit_radius,
            require_flat: self.require_flat,
            flat_tol: self.flat_tol,
            aesthetic: self.aesthetic,
            parting_line: match self.parting_line {
                PartingLineArg::Outline => moldgate::parting::PartingRule::Outline,
                PartingLineArg::Longest => moldgate::parting::PartingRule::Longest,
            },
            max_nodes: self.max_nodes,
            keep_out: self.keep_out.clone(),
            cosmetic: self.cosmetic.clone(),
            fill: self.fill,
            strategy: match self.strategy {
                StrategyArg::Paper => StrategyChoice::Paper,
                StrategyArg::Balanced => StrategyChoice::Balanced,
            },
            objective: match self.objective {
                ObjectiveArg::Length => ObjectiveChoice::Length,
                ObjectiveArg::Resistance => ObjectiveChoice::Resistance,
            },
            gates: self.gates,
            color_by: match self.color_by {
                ColorByArg::FlowLength => ColorByChoice::FlowLength,
                ColorByArg::FillOrder => ColorByChoice::FillOrder,
                ColorByArg::Wall => ColorByChoice::Wall,
                ColorByArg::Height => ColorByChoice::Height,
            },
            cell: self.cell,
            wall_thickness: self.wall_thickness,
            gate_at: self.gate_at.clone(),
            suitability: self.suitability,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The library's defaults are the command line's: a bare `locate FILE` gives
    /// `StudyOptions::default()`, so every front end starts from the same options.
    #[test]
    fn the_defaults_are_the_library_s() {
        let cli = Cli::try_parse_from(["moldgate", "locate", "part.stl"]).unwrap();
        let Command::Locate(a) = cli.command else {
            panic!("not locate")
        };
        assert_eq!(a.study_options(), StudyOptions::default());
    }

    #[test]
    fn every_flag_reaches_its_field() {
        let cli = Cli::try_parse_from([
            "moldgate",
            "locate",
            "p.stl",
            "--demold",
            "-y",
            "--material",
            "ABS",
            "--n",
            "0.3",
            "--t-melt",
            "200",
            "--t-wall",
            "40",
            "--gamma-opt",
            "9000",
            "--mu-opt",
            "11",
            "--k",
            "0.2",
            "--gate-radius",
            "1.1",
            "--spacing",
            "0.7",
            "--grid-offset",
            "0.25",
            "--circle-points",
            "8",
            "--centre",
            "volume",
            "--nearest",
            "2d",
            "--thickness-rule",
            "ignore",
            "--require-flat",
            "--flat-tol",
            "0.05",
            "--aesthetic",
            "--parting-line",
            "outline",
            "--max-nodes",
            "1000",
            "--keep-out",
            "sphere:0,0,0,1",
            "--cosmetic",
            "+z",
            "--fill",
            "--objective",
            "resistance",
            "--gates",
            "3",
            "--color-by",
            "wall",
            "--cell",
            "0.9",
            "--wall-thickness",
            "--gate-at",
            "1,2,3",
            "--gate-at",
            "-4,5,6",
            "--suitability",
        ])
        .unwrap();
        let Command::Locate(a) = cli.command else {
            panic!("not locate")
        };
        let json = serde_json::json!({
            "demold": "-y", "material": "ABS", "n": 0.3, "t_melt": 200.0, "t_wall": 40.0,
            "gamma_opt": 9000.0, "mu_opt": 11.0, "k": 0.2, "gate_radius": 1.1,
            "spacing": 0.7, "grid_offset": 0.25, "circle_points": 8, "centre": "volume",
            "nearest": "2d", "thickness_rule": "ignore", "require_flat": true,
            "flat_tol": 0.05, "aesthetic": true, "parting_line": "outline", "max_nodes": 1000,
            "keep_out": ["sphere:0,0,0,1"], "cosmetic": "+z", "fill": true,
            "strategy": "paper", "objective": "resistance", "gates": 3, "cell": 0.9,
            "wall_thickness": true, "color_by": "wall", "gate_at": ["1,2,3", "-4,5,6"],
            "suitability": true
        });
        let from_json: StudyOptions = serde_json::from_value(json).unwrap();
        assert_eq!(a.study_options(), from_json);
    }
}
