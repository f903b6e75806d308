//! `moldgate locate`: one part (a file or a sample) studied and its outputs written, or a
//! batch handed to [`crate::batch`].

use std::path::PathBuf;

use moldgate::study::Hooks;

use crate::analyse::{analyse, failure, settings, Analysed, Source};
use crate::args::LocateArgs;
use crate::output::{print_stdout, refuse_input, write_atomic};
use crate::progress::Progress;
use crate::summary;
use crate::Failure;

/// Runs `locate`: batch mode when several parts are given, one part otherwise.
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
    // A long study shows its stages on a terminal, like a batch its parts.
    let progress = Progress::start_study(!a.batch.quiet);
    let observer = |p| progress.study(p);
    let hooks = Hooks {
        progress: Some(&observer),
        cancel: None,
    };
    let analysed = analyse(source, &settings, &hooks);
    progress.finish();
    let Analysed { part, study } = analysed?;
    let json = study.report_json().map_err(|e| failure(&e, ""))?;
    if let Some(out) = &a.output {
        write_atomic(out, json.as_bytes())?;
    }
    if let Some(path) = &a.glb {
        let bytes = study
            .glb(&part, source.title())
            .map_err(|e| failure(&e, &moldgate::files::shown(&path)))?;
        write_atomic(path, &bytes)?;
        eprintln!("wrote {}", moldgate::files::shown(&path));
    }
    crate::pictures::write(&a, &study, &part, source.title())?;
    let report = study.report();
    if a.json {
        print_stdout(&json)?;
    } else {
        print_stdout(&summary::render(report))?;
    }
    let outcome = match (&report.gate, &report.no_gate_reason) {
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
    };
    // The process ends next: returning the part's and the study's large blocks to the
    // system one by one (an unmapping each) is work that nobody waits for.
    std::mem::forget(part);
    std::mem::forget(study);
    outcome
}
