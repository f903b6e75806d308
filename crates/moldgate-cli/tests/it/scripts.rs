//! The repository's measuring scripts refuse bad arguments before any run: one line on
//! standard error, a documented exit status, and no table.

use std::path::Path;
use std::process::{Command, Output, Stdio};

/// `python3 scripts/NAME ARGS` from the repository's root, or `None` (with the reason
/// printed) when there is no python3.
fn script(name: &str, args: &[&str]) -> Option<Output> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    match Command::new("python3")
        .arg(Path::new("scripts").join(name))
        .args(args)
        .current_dir(&root)
        .stdin(Stdio::null())
        .output()
    {
        Ok(out) => Some(out),
        Err(e) => {
            eprintln!("skipped: python3 does not run ({e})");
            None
        }
    }
}

/// Runs script `name` with `base` and each case's arguments after them: each must stop
/// with exit status 1 and one line on standard error that says the case's words, and print
/// no table.
fn refuses(name: &str, base: &[&str], cases: &[(&[&str], &str)]) {
    for &(extra, says) in cases {
        let args: Vec<&str> = base.iter().chain(extra).copied().collect();
        let Some(out) = script(name, &args) else {
            return;
        };
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{extra:?}: {err}");
        assert!(err.contains(says), "{extra:?}: {err}");
        assert!(!err.contains("Traceback"), "{extra:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{extra:?}: {err}");
        assert!(
            out.stdout.is_empty(),
            "{extra:?}: no table before the checks"
        );
    }
}

/// Stand-ins for a script's files, in a folder kept while the value lives: a part that
/// exists but is never read, the command line (a binary that exists), and a path that does
/// not exist.
struct StandIns {
    _dir: tempfile::TempDir,
    part: String,
    binary: &'static str,
    missing: String,
}

impl StandIns {
    fn new() -> StandIns {
        let dir = tempfile::tempdir().unwrap();
        let part = dir.path().join("part.stl");
        std::fs::write(&part, b"not read").unwrap();
        StandIns {
            part: part.to_str().unwrap().to_string(),
            binary: env!("CARGO_BIN_EXE_moldgate"),
            missing: dir.path().join("missing").to_str().unwrap().to_string(),
            _dir: dir,
        }
    }
}

#[test]
fn the_speed_table_refuses_bad_arguments_before_any_run() {
    // Files that exist stand in for the binaries and the part: each check below comes
    // before anything is run.
    let s = StandIns::new();
    let (part, binary, missing) = (s.part.as_str(), s.binary, s.missing.as_str());
    let base = [
        "--binary",
        binary,
        "--floor",
        binary,
        "--part",
        part,
        "--reference-python",
        missing,
    ];
    let cases: [(&[&str], &str); 5] = [
        (&["--runs", "0"], "--runs must be at least 1, not 0"),
        (&["--threads", "0"], "--threads must be at least 1, not 0"),
        (&["--before", missing], "--before"),
        (&["--only=--fil"], "--only: no row named --fil"),
        (&["--binary", missing], "not found"),
    ];
    refuses("speed_table.py", &base, &cases);
}

#[test]
fn the_scaling_table_refuses_bad_arguments_before_any_run() {
    let s = StandIns::new();
    let (part, binary, missing) = (s.part.as_str(), s.binary, s.missing.as_str());
    // The command line stands in for the tiler too: each check below comes before either
    // is run.
    let base = ["--binary", binary, "--tiler", binary, "--part", part];
    let cases: [(&[&str], &str); 7] = [
        (&["--runs", "0"], "--runs 0: at least 1"),
        (&["--copies", "1,x"], "--copies '1,x'"),
        (&["--copies", "0"], "--copies '0'"),
        (&["--with=\"--fill"], "No closing quotation"),
        (&["--binary", missing], "not found"),
        (&["--part", missing], "part not found"),
        (&["--dir", missing], "not a folder"),
    ];
    refuses("scaling_table.py", &base, &cases);
}
