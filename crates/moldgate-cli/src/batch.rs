//! `moldgate locate` on many parts at once: several files, folders, or a manifest.
//!
//! Every part is analysed with the same options (the manifest may give a part its own unit
//! and demolding direction), on a rayon pool of `--jobs` threads shared by the parts and by
//! the library's own parallel stages. Results are put back in input order before anything is
//! printed, so the output does not depend on which part finished first. A bad part does not
//! stop the others: it is a row with its status and reason, one line on stderr at the end,
//! and a non-zero exit code (see [`exit_code`]).
//!
//! Outputs are checked before any work (the folders exist and can be written, no output is an
//! input), then each is written whole or not at all with [`write_atomic`].

use std::collections::{BTreeMap, HashSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use rayon::prelude::*;
use serde::Deserialize;

use moldgate::batch_row::{BatchRow, Status};
use moldgate::mesh::Units;
use moldgate::report::Report;
use moldgate::study::{Demold, Hooks};
use moldgate::Direction;

use crate::analyse::{analyse, settings, Settings, Source};
use crate::args::{LocateArgs, Schedule};
use crate::output::{print_stdout, write_atomic};
use crate::progress::Progress;
use crate::Failure;

/// Whether the command line asks for batch mode: several inputs, a folder, a manifest, or an
/// output that only batch mode writes. One plain file keeps the single-part behaviour.
pub fn wanted(a: &LocateArgs) -> bool {
    let b = &a.batch;
    a.files.len() > 1
        || a.files.iter().any(|f| f.is_dir())
        || b.manifest.is_some()
        || b.out_dir.is_some()
        || b.summary.is_some()
}

/// Runs `f` on a pool of `jobs` threads, or on rayon's default pool (all cores).
pub fn with_jobs<T: Send>(
    jobs: Option<u16>,
    f: impl FnOnce() -> Result<T, Failure> + Send,
) -> Result<T, Failure> {
    match jobs {
        None => f(),
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(usize::from(n))
            .build()
            .map_err(|e| Failure::new(1, format!("cannot start {n} threads: {e}")))?
            .install(f),
    }
}

/// One part to analyse.
#[derive(Debug)]
struct Part {
    path: PathBuf,
    settings: Settings,
    /// The demolding direction as written (command line or manifest).
    demold: String,
    /// Why a folder's entry is not read (a FIFO, a folder, a link that points nowhere), or
    /// `None` for a part to analyse.
    skipped: Option<String>,
}

/// What came of one part.
struct Outcome {
    /// The report, when the part could be analysed (with or without a gate).
    report: Option<Report>,
    /// Why the part is not a success, or `None`.
    failure: Option<Failure>,
    /// Seconds to load and analyse the part.
    time_s: f64,
}

/// The format of `--summary`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum SummaryFormat {
    JsonLines,
    Csv,
}

/// `locate` in batch mode.
pub fn run(a: LocateArgs) -> Result<(), Failure> {
    let b = &a.batch;
    if a.output.is_some() {
        return Err(Failure::usage(
            "-o writes the report of one part; for several use --out-dir DIR or --summary FILE",
        ));
    }
    for (flag, given) in [
        ("--glb", a.glb.is_some()),
        ("--png", a.png.is_some()),
        ("--report", a.report.is_some()),
    ] {
        if given {
            return Err(Failure::usage(format!(
                "{flag} draws one part; run it on each part separately"
            )));
        }
    }
    let base = settings(&a)?;
    let summary_format = b.summary.as_deref().map(summary_format).transpose()?;
    let mut parts = Vec::new();
    for (path, skipped) in expand(&a.files)? {
        parts.push(Part {
            path,
            settings: base.clone(),
            demold: a.demold.clone(),
            skipped,
        });
    }
    if let Some(m) = &b.manifest {
        parts.extend(read_manifest(m, &base, &a.demold)?);
    }
    if parts.len() > MAX_PARTS {
        return Err(Failure::usage(format!(
            "{} parts given (files, folders' meshes and the manifest's), over the limit of {MAX_PARTS} a run takes: split them into several runs",
            parts.len()
        )));
    }
    if parts.is_empty() {
        let m = b.manifest.as_deref().unwrap_or(Path::new("manifest"));
        return Err(Failure::usage(format!(
            "{}: lists no part ([[part]] tables with file = \"...\")",
            moldgate::files::shown(&m)
        )));
    }
    let outputs = check_outputs(&parts, b.out_dir.as_deref(), b.summary.as_deref())?;

    let progress = Progress::start(parts.len(), !b.quiet);
    let one = |(part, out): (&Part, &Option<PathBuf>)| {
        let outcome = run_part(part, out.as_deref());
        progress.tick();
        outcome
    };
    let outcomes: Vec<Outcome> = with_jobs(b.jobs, || {
        Ok(match b.schedule {
            Schedule::Parts => parts.par_iter().zip(&outputs).map(one).collect(),
            Schedule::OneByOne => parts.iter().zip(&outputs).map(one).collect(),
        })
    })?;
    progress.finish();

    let rows: Vec<BatchRow> = parts
        .iter()
        .zip(&outcomes)
        .map(|(p, o)| row(p, o))
        .collect();
    let mut failures: Vec<Failure> = Vec::new();
    if let (Some(path), Some(format)) = (&b.summary, summary_format) {
        let text = match format {
            SummaryFormat::JsonLines => json_lines(&rows),
            SummaryFormat::Csv => csv(&rows),
        };
        if let Err(f) = write_atomic(path, text.as_bytes()) {
            failures.push(f);
        }
    }
    if a.json {
        print_stdout(&json_lines(&rows))?;
    } else {
        print_stdout(&table(&rows, b.quiet))?;
    }
    // The end report: one line per failed part or skipped entry, in input order.
    for row in &rows {
        match (&row.error, row.status) {
            (Some(reason), Status::Skipped) => {
                eprintln!(
                    "moldgate: skipped {}: {}",
                    crate::printable(&row.file),
                    crate::printable(reason)
                )
            }
            (Some(reason), _) => eprintln!(
                "moldgate: error: {}: {}",
                crate::printable(&row.file),
                crate::printable(reason)
            ),
            _ => {}
        }
    }
    for f in &failures {
        eprintln!("moldgate: error: {}", crate::printable(&f.message));
    }
    let codes = outcomes
        .iter()
        .filter_map(|o| o.failure.as_ref().map(|f| f.code))
        .chain(failures.iter().map(|f| f.code));
    match exit_code(codes) {
        0 => Ok(()),
        // The lines are printed; main prints nothing for an empty message.
        code => Err(Failure::new(code, String::new())),
    }
}

/// The exit code of a batch from the codes of its failed parts: the most serious one, in the
/// order internal error (1), output (5), input (3), option (2), stopped at `--timeout` (6),
/// no gate (4); 0 when every part has a gate.
pub fn exit_code(codes: impl IntoIterator<Item = u8>) -> u8 {
    const SEVERITY: [u8; 6] = [1, 5, 3, 2, 6, 4];
    codes
        .into_iter()
        .filter(|&c| c != 0)
        .min_by_key(|c| SEVERITY.iter().position(|s| s == c).unwrap_or(0))
        .unwrap_or(0)
}

/// Analyses one part and writes its report; a panic is this part's internal error.
fn run_part(part: &Part, out: Option<&Path>) -> Outcome {
    if part.skipped.is_some() {
        return Outcome {
            report: None,
            failure: None,
            time_s: 0.0,
        };
    }
    let t = Instant::now();
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        analyse(Source::File(&part.path), &part.settings, &Hooks::default())
            .map(|a| a.study.into_report())
    }))
    .unwrap_or_else(|_| {
        Err(Failure::new(
            1,
            "internal error, please report it (see the panic message above)",
        ))
    });
    let time_s = t.elapsed().as_secs_f64();
    let report = match result {
        Ok(r) => r,
        // A study stopped at --timeout in its fill stage gives its row the gate found
        // before the stop; no report is written for it (it is not the one asked for).
        Err(mut f) => {
            return Outcome {
                report: f.located.take().map(|r| *r),
                failure: Some(f),
                time_s,
            }
        }
    };
    let mut failure = report
        .no_gate_reason
        .as_ref()
        .filter(|_| report.gate.is_none())
        .map(|reason| Failure::no_gate(reason.clone()));
    if let Some(out) = out {
        let written = serde_json::to_string_pretty(&report)
            .map_err(|e| Failure::new(1, format!("cannot encode the report: {e}")))
            .and_then(|json| write_atomic(out, (json + "\n").as_bytes()));
        if let Err(f) = written {
            failure = Some(f);
        }
    }
    Outcome {
        report: Some(report),
        failure,
        time_s,
    }
}

/// The summary's format from its extension.
fn summary_format(path: &Path) -> Result<SummaryFormat, Failure> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "jsonl" | "ndjson" => Ok(SummaryFormat::JsonLines),
        "csv" => Ok(SummaryFormat::Csv),
        _ => Err(Failure::usage(format!(
            "--summary {}: the name must end in .jsonl, .ndjson or .csv",
            moldgate::files::shown(&path)
        ))),
    }
}

/// The inputs in order: each file as given; each folder's entries named `.stl`, `.obj` and
/// `.ply` (any case, not in subfolders) sorted by name. An entry of such a name that is not a
/// regular file (a FIFO, a folder, a link that points nowhere) comes with the reason it is
/// skipped, so the batch reports it instead of dropping it or hanging on it. A folder that
/// cannot be listed or holds no mesh file is an error of the command line, found before any
/// work.
fn expand(inputs: &[PathBuf]) -> Result<Vec<(PathBuf, Option<String>)>, Failure> {
    let mut out = Vec::new();
    for input in inputs {
        if !input.is_dir() {
            out.push((input.clone(), None));
            continue;
        }
        let fail = |e: &dyn std::fmt::Display| {
            Failure::input(format!("{}: {e}", moldgate::files::shown(&input)))
        };
        let mut found: Vec<(PathBuf, Option<String>)> = std::fs::read_dir(input)
            .map_err(|e| fail(&format_args!("cannot list the folder: {e}")))?
            .filter_map(|entry| entry.ok().map(|e| e.path()))
            .filter(|p| crate::formats::is_mesh_file(p))
            .map(|p| {
                let skipped = match std::fs::metadata(&p) {
                    Ok(m) if m.is_file() => None,
                    Ok(m) => Some(format!(
                        "is {}, not a mesh file",
                        moldgate::files::file_kind(&m)
                    )),
                    Err(_) if p.is_symlink() => {
                        Some("is a symbolic link that points nowhere".into())
                    }
                    Err(e) => Some(format!("cannot read: {e}")),
                };
                (p, skipped)
            })
            .collect();
        if found.iter().all(|(_, skipped)| skipped.is_some()) {
            let skipped: Vec<String> = found
                .iter()
                .filter_map(|(p, why)| {
                    Some(format!("{} {}", moldgate::files::shown(&p), why.as_ref()?))
                })
                .collect();
            return Err(fail(&format_args!(
                "is a folder holding no .stl, .obj or .ply file{}",
                if skipped.is_empty() {
                    String::new()
                } else {
                    format!(" (skipped: {})", skipped.join("; "))
                }
            )));
        }
        found.sort();
        out.extend(found);
    }
    Ok(out)
}

/// One `[[part]]` table of a manifest.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Entry {
    /// The mesh file, relative to the manifest's folder.
    file: toml::Spanned<PathBuf>,
    /// Its unit [default: `--units`].
    units: Option<toml::Spanned<String>>,
    /// Its demolding direction [default: `--demold`].
    demold: Option<toml::Spanned<String>>,
}

/// A manifest file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Manifest {
    #[serde(default)]
    part: Vec<Entry>,
}

/// Reads a manifest: its parts in order, each with the shared settings and its own unit and
/// direction. Syntax errors and bad values are errors of the command line (exit code 2), with
/// the line or the part named.
/// The most parts one batch run takes (files, the meshes of folders and the manifest's
/// parts together): its rows are held until the end, about 2 KiB each.
pub const MAX_PARTS: usize = 100_000;

fn read_manifest(path: &Path, base: &Settings, demold: &str) -> Result<Vec<Part>, Failure> {
    let (manifest, text): (Manifest, String) =
        crate::toml_file::read_toml(path, moldgate::files::MAX_TOML_BYTES)?;
    // The line (from 1) of a value's first byte.
    let line_of = |at: usize| 1 + text[..at.min(text.len())].matches('\n').count();
    let folder = path.parent().unwrap_or(Path::new(""));
    let mut parts = Vec::with_capacity(manifest.part.len());
    for (i, entry) in manifest.part.into_iter().enumerate() {
        let file = entry.file.get_ref();
        // A value's fault, at its line.
        let fail = |at: usize, what: String| {
            Failure::usage(format!(
                "{}: line {}: part {} ({}): {what}",
                moldgate::files::shown(&path),
                line_of(at),
                i + 1,
                moldgate::files::shown(&file)
            ))
        };
        if file.as_os_str().is_empty() {
            return Err(Failure::usage(format!(
                "{}: line {}: part {}: file is empty: give the mesh file's path, relative to the manifest",
                moldgate::files::shown(&path),
                line_of(entry.file.span().start),
                i + 1
            )));
        }
        let mut settings = base.clone();
        if let Some(u) = &entry.units {
            settings.units = u
                .get_ref()
                .parse::<Units>()
                .map_err(|e| fail(u.span().start, format!("units: {e}")))?;
        }
        // `auto` as on the command line: the part's own direction is chosen for it.
        match &entry.demold {
            Some(d) if d.get_ref().trim().eq_ignore_ascii_case("auto") => {
                settings.study.locate.direction = Direction::default();
                settings.study.demold = Demold::Auto;
            }
            Some(d) => {
                let direction = d
                    .get_ref()
                    .parse::<Direction>()
                    .map_err(|e| fail(d.span().start, format!("demold: {e}")))?;
                settings.study.locate.direction = direction;
                settings.study.demold = Demold::Given(direction);
            }
            None => {}
        }
        parts.push(Part {
            path: folder.join(file),
            settings,
            demold: entry
                .demold
                .map(toml::Spanned::into_inner)
                .unwrap_or_else(|| demold.to_string()),
            skipped: None,
        });
    }
    Ok(parts)
}

/// Checks every output before any work: the folders exist and can be written, no two parts
/// write the same report, and no output is an input. Gives each part's report path.
fn check_outputs(
    parts: &[Part],
    out_dir: Option<&Path>,
    summary: Option<&Path>,
) -> Result<Vec<Option<PathBuf>>, Failure> {
    let same_file = |p: &Path| p.canonicalize().unwrap_or_else(|_| p.to_path_buf());
    // Every part is an input from the start, so no report written as parts finish may go
    // over a part not yet read.
    for p in parts.iter().filter(|p| p.skipped.is_none()) {
        crate::output::register_input(&p.path);
    }
    let inputs: HashSet<PathBuf> = parts
        .iter()
        .filter(|p| p.skipped.is_none())
        .map(|p| same_file(&p.path))
        .collect();
    let refuse = |out: &Path| {
        // By name, and by device and inode (a hard link to an input is that input).
        if inputs.contains(&same_file(out)) || crate::output::is_input(out) {
            Err(Failure::output(format!(
                "{}: refusing to write the output over an input file",
                moldgate::files::shown(&out)
            )))
        } else {
            Ok(())
        }
    };
    if let Some(summary) = summary {
        if summary.is_dir() {
            return Err(Failure::output(format!(
                "{}: is a folder, not a file",
                moldgate::files::shown(&summary)
            )));
        }
        let folder = match summary.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        writable_folder(folder, summary)?;
        refuse(summary)?;
    }
    let Some(dir) = out_dir else {
        return Ok(vec![None; parts.len()]);
    };
    writable_folder(dir, dir)?;
    // Two parts named alike (in two folders, or `a.stl` and `a.STL`) would write one file.
    let mut taken: BTreeMap<String, &Path> = BTreeMap::new();
    let mut outputs = Vec::with_capacity(parts.len());
    for part in parts {
        if part.skipped.is_some() {
            outputs.push(None);
            continue;
        }
        let stem = part
            .path
            .file_stem()
            .ok_or_else(|| {
                Failure::usage(format!(
                    "{}: not a file name",
                    moldgate::files::shown(&part.path)
                ))
            })?
            .to_string_lossy()
            .into_owned();
        if let Some(first) = taken.insert(stem.to_lowercase(), &part.path) {
            return Err(Failure::usage(format!(
                "{} and {} would both write {}.json in {}; run them separately",
                moldgate::files::shown(&first),
                moldgate::files::shown(&part.path),
                stem,
                moldgate::files::shown(&dir)
            )));
        }
        let out = dir.join(format!("{stem}.json"));
        refuse(&out)?;
        // The summary and a report are one file when one is a link to the other, or both
        // links to one file: the summary would replace the report.
        if let Some(summary) = summary.filter(|s| crate::output::same_file(s, &out)) {
            return Err(Failure::usage(format!(
                "--summary {} and the report of {} in --out-dir are one file; give the summary another name",
                moldgate::files::shown(&summary),
                moldgate::files::shown(&part.path)
            )));
        }
        outputs.push(Some(out));
    }
    Ok(outputs)
}

/// Fails unless `folder` exists and a file can be created in it (`what` names the output in
/// the message).
fn writable_folder(folder: &Path, what: &Path) -> Result<(), Failure> {
    let fail = |e: &dyn std::fmt::Display| {
        Failure::output(format!("{}: {e}", moldgate::files::shown(&what)))
    };
    if !folder.exists() {
        return Err(fail(&format_args!(
            "cannot write: the folder {} does not exist",
            moldgate::files::shown(&folder)
        )));
    }
    if !folder.is_dir() {
        return Err(fail(&format_args!(
            "{} is not a folder",
            moldgate::files::shown(&folder)
        )));
    }
    // Created exclusively under a random name, removed when dropped.
    crate::output::temporary_in(folder)
        .map(|tmp| {
            let path = tmp.path().to_path_buf();
            drop(tmp);
            crate::output::release(&path);
        })
        .map_err(|e| fail(&format_args!("cannot write: {e}")))
}

/// An axis as "+x" .. "-z", any other direction as its three components.
fn direction_name(d: [f64; 3]) -> String {
    for (i, axis) in ["x", "y", "z"].iter().enumerate() {
        if d[i].abs() == 1.0 {
            return format!("{}{axis}", if d[i] > 0.0 { "+" } else { "-" });
        }
    }
    format!("{:.4},{:.4},{:.4}", d[0], d[1], d[2])
}

/// The summary's row of one part: the library's [`BatchRow`], with the direction chosen for
/// `auto` ("-z (auto)") and a folder's skipped entry as its own status.
fn row(part: &Part, o: &Outcome) -> BatchRow {
    let file = moldgate::files::shown(&part.path);
    let report = o.report.as_ref();
    let failure = match (&part.skipped, &o.failure) {
        (Some(reason), _) => Some((Status::Skipped, reason.as_str())),
        (None, Some(f)) if f.timed_out => Some((Status::Timeout, f.message.as_str())),
        (None, Some(f)) => Some((Status::from_exit_code(f.code), f.message.as_str())),
        (None, None) => None,
    };
    let demold = match report.and_then(|r| r.demold_auto.as_ref()) {
        Some(auto) => format!("{} (auto)", direction_name(auto.candidate().direction)),
        None => part.demold.clone(),
    };
    BatchRow::new(
        &file,
        part.settings.units,
        &demold,
        report,
        failure,
        o.time_s,
    )
}

/// The rows as JSON Lines.
fn json_lines(rows: &[BatchRow]) -> String {
    let mut out = String::new();
    for row in rows {
        out += &row.to_json();
        out.push('\n');
    }
    out
}

/// The CSV header, in the order of [`BatchRow`]'s fields.
const CSV_HEADER: &str = "file,status,exit_code,units,demold,triangles,gate_x_mm,gate_y_mm,\
gate_z_mm,gates,other_gates_mm,distance_mm,gate_radius_mm,nodes,circle_on_part,qualifying,\
warnings,time_s,error";

/// The rows as CSV (RFC 4180: fields with a comma, quote or line break are quoted, quotes
/// doubled); a missing value is an empty field.
fn csv(rows: &[BatchRow]) -> String {
    fn field(out: &mut String, s: &str) {
        if s.contains([',', '"', '\n', '\r']) {
            out.push('"');
            out.push_str(&s.replace('"', "\"\""));
            out.push('"');
        } else {
            out.push_str(s);
        }
    }
    fn opt<T: ToString>(v: Option<T>) -> String {
        v.map(|v| v.to_string()).unwrap_or_default()
    }
    let mut out = String::from(CSV_HEADER);
    out += "\r\n";
    for r in rows {
        let fields = [
            r.file.clone(),
            r.status.name().to_string(),
            r.exit_code.to_string(),
            r.units.clone(),
            r.demold.clone(),
            opt(r.triangles),
            opt(r.gate_x_mm),
            opt(r.gate_y_mm),
            opt(r.gate_z_mm),
            opt(r.gates),
            r.other_gates_mm.clone().unwrap_or_default(),
            opt(r.distance_mm),
            opt(r.gate_radius_mm),
            opt(r.nodes),
            opt(r.circle_on_part),
            opt(r.qualifying),
            r.warnings.clone().unwrap_or_default(),
            r.time_s.to_string(),
            r.error.clone().unwrap_or_default(),
        ];
        for (i, f) in fields.iter().enumerate() {
            if i > 0 {
                out.push(',');
            }
            field(&mut out, f);
        }
        out += "\r\n";
    }
    out
}

/// A row's warnings in the table: a warning about the units in full (it changes the answer),
/// else the first one, cut to fit, and how many more.
fn short_warning(joined: &str) -> String {
    let all: Vec<&str> = joined.split(" | ").collect();
    let units = all.iter().find(|w| w.contains("--units"));
    let first = units.unwrap_or(&all[0]);
    let mut shown: String = first.chars().take(100).collect();
    if units.is_none() && shown.len() < first.len() {
        shown += "...";
    } else {
        shown = first.to_string();
    }
    if all.len() > 1 {
        shown += &format!(" (+{} more)", all.len() - 1);
    }
    shown
}

/// The human table, and a closing count unless `quiet`.
fn table(rows: &[BatchRow], quiet: bool) -> String {
    // File names as given, with any control character escaped (a name is not a terminal
    // command).
    let names: Vec<String> = rows
        .iter()
        .map(|r| crate::printable(&r.file).into_owned())
        .collect();
    let width = names
        .iter()
        .map(|n| n.chars().count())
        .max()
        .unwrap_or(0)
        .max(4);
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:<width$}  {:<14} {:>9}  {:>28}  {:>8} {:>6} {:>7}  warnings",
        "part", "status", "triangles", "gate x, y, z (mm)", "dist mm", "R mm", "time s"
    );
    let dash = |v: Option<String>| v.unwrap_or_else(|| "-".into());
    for (r, name) in rows.iter().zip(&names) {
        // A layout's first gate, and how many more (the JSON and CSV rows list them).
        let more = match r.gates {
            Some(k) if k > 1 => format!(" +{}", k - 1),
            _ => String::new(),
        };
        let gate = match (r.gate_x_mm, r.gate_y_mm, r.gate_z_mm) {
            // A coordinate that rounds to zero reads 0.000, not -0.000.
            (Some(x), Some(y), Some(z)) => Some(moldgate::report::without_negative_zeros(
                &format!("{x:.3}, {y:.3}, {z:.3}{more}"),
                false,
            )),
            _ => None,
        };
        let _ = writeln!(
            out,
            "{:<width$}  {:<14} {:>9}  {:>28}  {:>8} {:>6} {:>7.3}  {}",
            name,
            r.status.name().replace('_', " "),
            dash(r.triangles.map(|t| t.to_string())),
            dash(gate),
            dash(r.distance_mm.map(|d| format!("{d:.3}"))),
            dash(r.gate_radius_mm.map(|d| format!("{d:.3}"))),
            r.time_s,
            r.warnings.as_deref().map_or(String::new(), short_warning),
        );
    }
    if !quiet {
        let skipped = rows.iter().filter(|r| r.status == Status::Skipped).count();
        let ok = rows.iter().filter(|r| r.status == Status::Ok).count();
        let no_gate = rows.iter().filter(|r| r.exit_code == 4).count();
        let failed = rows.len() - skipped - ok - no_gate;
        let timed_out = rows.iter().filter(|r| r.status == Status::Timeout).count();
        let parts = rows.len() - skipped;
        let _ = write!(
            out,
            "{parts} part{}: {ok} with a gate, {no_gate} without, {failed} failed",
            if parts == 1 { "" } else { "s" }
        );
        if timed_out > 0 {
            // A part stopped after its gate was located keeps that gate in its row.
            let kept = rows
                .iter()
                .filter(|r| r.status == Status::Timeout && r.gate_x_mm.is_some())
                .count();
            let _ = match kept {
                0 => write!(out, " ({timed_out} stopped at --timeout)"),
                1 if timed_out == 1 => write!(
                    out,
                    " (1 stopped at --timeout, with the method's gate found before the stop)"
                ),
                k if k == timed_out => write!(
                    out,
                    " ({timed_out} stopped at --timeout, each with the method's gate found before the stop)"
                ),
                k => write!(
                    out,
                    " ({timed_out} stopped at --timeout, {k} of them with the method's gate found before the stop)"
                ),
            };
        }
        if skipped > 0 {
            let _ = write!(out, ", {skipped} skipped (not regular files)");
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exit_code_takes_the_most_serious() {
        assert_eq!(exit_code([]), 0);
        assert_eq!(exit_code([0, 0]), 0);
        assert_eq!(exit_code([4, 4]), 4);
        assert_eq!(exit_code([4, 2]), 2);
        assert_eq!(exit_code([4, 3, 2]), 3);
        assert_eq!(exit_code([3, 5, 4]), 5);
        assert_eq!(exit_code([5, 1, 3]), 1);
        assert_eq!(exit_code([4, 6]), 6);
        assert_eq!(exit_code([6, 2]), 2);
    }

    #[test]
    fn summary_format_by_extension() {
        let f = |s: &str| summary_format(Path::new(s)).ok();
        assert_eq!(f("a.jsonl"), Some(SummaryFormat::JsonLines));
        assert_eq!(f("a.NDJSON"), Some(SummaryFormat::JsonLines));
        assert_eq!(f("dir/a.Csv"), Some(SummaryFormat::Csv));
        assert_eq!(f("a.json"), None);
        assert_eq!(f("a"), None);
    }

    #[test]
    fn csv_quotes_what_needs_it() {
        let row = BatchRow {
            file: "a, \"b\".stl".into(),
            status: Status::InputError,
            exit_code: 3,
            units: "mm".into(),
            demold: "0,0,1".into(),
            triangles: None,
            gate_x_mm: None,
            gate_y_mm: None,
            gate_z_mm: None,
            gates: None,
            other_gates_mm: None,
            distance_mm: None,
            gate_radius_mm: None,
            nodes: None,
            circle_on_part: None,
            qualifying: None,
            warnings: None,
            time_s: 0.5,
            error: Some("line 3: bad\nthing".into()),
        };
        let text = csv(&[row]);
        let lines: Vec<&str> = text.split("\r\n").collect();
        assert_eq!(lines[0], CSV_HEADER);
        assert_eq!(
            lines[1],
            "\"a, \"\"b\"\".stl\",input_error,3,mm,\"0,0,1\",,,,,,,,,,,,,0.5,\"line 3: bad\nthing\""
        );
    }

    #[test]
    fn the_table_shows_a_layout_s_first_gate_and_how_many_more_without_negative_zeros() {
        let row = BatchRow {
            file: "a.stl".into(),
            status: Status::Ok,
            exit_code: 0,
            units: "mm".into(),
            demold: "+z".into(),
            triangles: Some(12),
            gate_x_mm: Some(-0.0001),
            gate_y_mm: Some(1.5),
            gate_z_mm: Some(2.0),
            gates: Some(3),
            other_gates_mm: Some("1,2,3; 4,5,6".into()),
            distance_mm: Some(1.0),
            gate_radius_mm: Some(1.4),
            nodes: Some(10),
            circle_on_part: Some(5),
            qualifying: Some(2),
            warnings: None,
            time_s: 0.1,
            error: None,
        };
        let text = table(std::slice::from_ref(&row), true);
        assert!(text.contains("0.000, 1.500, 2.000 +2"), "{text}");
        assert!(!text.contains("-0.000"), "{text}");
        assert!(csv(&[row]).contains(",3,\"1,2,3; 4,5,6\","));
    }

    #[test]
    fn csv_header_matches_the_row_fields() {
        // The JSON keys of a row, in order, are the CSV header.
        let row = BatchRow {
            file: String::new(),
            status: Status::Ok,
            exit_code: 0,
            units: String::new(),
            demold: String::new(),
            triangles: None,
            gate_x_mm: None,
            gate_y_mm: None,
            gate_z_mm: None,
            gates: None,
            other_gates_mm: None,
            distance_mm: None,
            gate_radius_mm: None,
            nodes: None,
            circle_on_part: None,
            qualifying: None,
            warnings: None,
            time_s: 0.0,
            error: None,
        };
        let json = serde_json::to_string(&row).unwrap();
        let keys: Vec<String> = json
            .trim_matches(['{', '}'])
            .split(',')
            .map(|kv| kv.split(':').next().unwrap().trim_matches('"').to_string())
            .collect();
        assert_eq!(keys.join(","), CSV_HEADER);
    }
}
