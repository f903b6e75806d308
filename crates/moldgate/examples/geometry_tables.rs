//! Prints the per-part table of the outline parting rule (for `docs/parting-line.md`) and
//! writes `docs/demold-auto.md`, from the shared parts:
//!
//! ```text
//! cargo run --release -p moldgate --example geometry_tables -- PARTS_DIR DOCS_DIR
//! ```
//!
//! PARTS_DIR holds the parts and their `SOURCES.md` (natural demolding directions). The
//! parting line (natural direction, default options) is set against the perimeter of the
//! part's outline from a raster of its projected triangles (`tests/it/common/outline.rs`); the
//! automatic direction against the natural one, with a gate check for tied lines as the
//! command line does it.

#[path = "../tests/it/common/outline.rs"]
mod outline;

use std::fmt::Write as _;
use std::fs::File;
use std::io::BufReader;
use std::path::PathBuf;
use std::time::Instant;

use moldgate::mesh::{self, Units};
use moldgate::raycast::Sampling;
use moldgate::undercut::{auto_direction_checked, TIE_SHARE};
use moldgate::{locate, Direction, Frame, LocateOptions};

fn axis_name(d: [f64; 3]) -> String {
    for (i, axis) in ["x", "y", "z"].iter().enumerate() {
        if d[i].abs() == 1.0 {
            return format!("{}{axis}", if d[i] > 0.0 { "+" } else { "-" });
        }
    }
    format!("({:.3}, {:.3}, {:.3})", d[0], d[1], d[2])
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (parts, docs) = match &args[..] {
        [_, p, d] => (PathBuf::from(p), PathBuf::from(d)),
        _ => {
            eprintln!("usage: geometry_tables PARTS_DIR DOCS_DIR");
            std::process::exit(2);
        }
    };
    let sources = std::fs::read_to_string(parts.join("SOURCES.md")).expect("SOURCES.md");
    // Rows of the table: file in column 1, natural direction in column 12 ("-Y (axis Y; ..").
    let mut list = Vec::new();
    for line in sources
        .lines()
        .filter(|l| l.starts_with("| ") && l.to_lowercase().contains(".stl |"))
    {
        let cols: Vec<&str> = line.split('|').map(str::trim).collect();
        let natural = cols[11]
            .split_whitespace()
            .next()
            .unwrap_or("")
            .to_lowercase();
        list.push((cols[1].to_string(), natural));
    }
    let mut parting = String::from(
        "| part | D | parting line mm | outline perimeter mm | ratio | rims (mm, closed) | outline loops | edges between sides |\n|---|---|---|---|---|---|---|---|\n",
    );
    let mut demold = String::from(
        "| part | natural | auto | undercut of auto mm^2 | undercut of natural mm^2 | tie (mm^2) | same line | gate with auto | auto s | locate s |\n|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let (mut same, mut total) = (0, 0);
    for (file, natural) in &list {
        let units = if file.contains("meters") {
            Units::M
        } else if file.contains("inches") {
            Units::In
        } else {
            Units::Mm
        };
        let f = File::open(parts.join(file)).expect("part");
        let len = f.metadata().unwrap().len();
        let part = mesh::read_stl(BufReader::new(f), len, units).expect("readable part");
        // The natural direction; SOURCES.md gives "Y" without a sign for one part: +y.
        let nat = if natural.starts_with(['+', '-']) {
            natural.clone()
        } else {
            format!("+{natural}")
        };
        let d: Direction = nat.parse().expect("direction");
        let t = Instant::now();
        let a = locate(
            &part,
            &LocateOptions {
                direction: d,
                parting: moldgate::gate::PartingRule::Outline,
                ..LocateOptions::default()
            },
        )
        .unwrap();
        let locate_s = t.elapsed().as_secs_f64();
        let perimeter = outline::outline_perimeter(&part.mesh, &Frame::new(d), 1500);
        let rims: Vec<String> = a
            .parting
            .rims
            .iter()
            .map(|r| format!("{:.1}{}", r.length_mm, if r.closed { "" } else { " open" }))
            .collect();
        let _ = writeln!(
            parting,
            "| {file} | {nat} | {:.1} | {perimeter:.1} | {:.3} | {} | {} | {} |",
            a.parting.length_mm,
            a.parting.length_mm / perimeter,
            rims.join(", "),
            a.parting.loops,
            a.parting.edges_all
        );
        let t = Instant::now();
        let auto = auto_direction_checked(&part.mesh, Sampling::Centroid, |d| {
            locate(
                &part,
                &LocateOptions {
                    direction: d,
                    parting: moldgate::gate::PartingRule::Outline,
                    ..LocateOptions::default()
                },
            )
            .is_ok_and(|a| a.gate().is_ok())
        })
        .unwrap();
        let auto_s = t.elapsed().as_secs_f64();
        let c = auto.candidate();
        let natural_undercut = moldgate::undercut::undercut(&part.mesh, d, Sampling::Centroid);
        let line_same = moldgate::math::DVec3::from_array(c.direction)
            .dot(d.vector())
            .abs()
            > 1.0 - 1e-9;
        let chosen = locate(
            &part,
            &LocateOptions {
                direction: auto.direction(),
                parting: moldgate::gate::PartingRule::Outline,
                ..LocateOptions::default()
            },
        )
        .unwrap();
        total += 1;
        same += line_same as usize;
        let _ = writeln!(
            demold,
            "| {file} | {nat} | {} | {:.1} | {:.1} | {:.1} | {} | {} | {auto_s:.3} | {locate_s:.3} |",
            axis_name(c.direction),
            c.undercut.area_mm2,
            natural_undercut.area_mm2,
            auto.tie_mm2,
            if line_same { "yes" } else { "no" },
            if chosen.gate().is_ok() { "yes" } else { "no" }
        );
        eprintln!("{file}: done");
    }
    let head = "<!-- Generated by `cargo run --release -p moldgate --example geometry_tables -- PARTS_DIR docs`; edit the example, not this file. -->\n\n";
    // The parting table goes to stdout: docs/parting-line.md is written by hand around it.
    println!("{PARTING_INTRO}\n{parting}");
    std::fs::write(
        docs.join("demold-auto.md"),
        format!(
            "{head}{DEMOLD_INTRO}\n{demold}\nSame line as the natural direction on {same} of {total} parts (tie: {:.0} % of the surface area).\n",
            100.0 * TIE_SHARE
        ),
    )
    .unwrap();
}

const PARTING_INTRO: &str =
    "Outline rule (`PartingRule::Outline`) against the raster outline perimeter (mm):";

const DEMOLD_INTRO: &str = "# The automatic demolding direction on the shared parts

`--demold auto` (`crates/moldgate/src/undercut.rs`) tries the three axes and the principal
axes of the surface and takes the least undercut area; areas within 1 % of the surface area
of the least are a tie, broken by the shallowest draw (extents within 1 %), then by whether
a gate qualifies along the line (the command line asks `locate`), then by the order tried.
The natural direction is the one `SOURCES.md` gives (its ADIS16480 line has no sign: +y is
used). D and -D mould alike: `same line` compares lines; the sign follows the open side.
A line whose lower bound (the rays of its largest facets) already exceeds the least undercut
by more than the tie is not drawn ray by ray: the choice is the same (see the module).
Times: `auto s` is the choice (up to six lines of drawn rays, gate checks for ties), `locate s` one
plain `locate` along the natural direction, on this machine's 2 shared cores.
";
