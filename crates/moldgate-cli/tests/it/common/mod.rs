//! Helpers shared by the CLI's integration tests: the documented exit codes, running the
//! binary, and reading what it left behind; `http` is the service's client.
#![allow(dead_code)]

pub mod http;

use std::path::Path;
use std::process::{Command, Output, Stdio};

pub const OK: i32 = 0;
pub const USAGE: i32 = 2;
pub const INPUT: i32 = 3;
pub const NO_GATE: i32 = 4;
pub const OUTPUT: i32 = 5;
pub const TIMEOUT: i32 = 6;

/// Runs the binary in `dir` with no standard input.
pub fn moldgate(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_moldgate"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .output()
        .expect("the moldgate binary runs")
}

/// Runs the binary in `dir` as user `nobody` (through `setpriv`), for a test of
/// permissions that do not stop the superuser; `None`, with the skip said under `test`'s
/// name, when setpriv cannot drop to that user.
pub fn moldgate_as_nobody(dir: &Path, args: &[&str], test: &str) -> Option<Output> {
    let run = Command::new("setpriv")
        .args(["--reuid=65534", "--regid=65534", "--clear-groups"])
        .arg(env!("CARGO_BIN_EXE_moldgate"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .output();
    match run {
        Ok(out) if !String::from_utf8_lossy(&out.stderr).contains("setpriv") => Some(out),
        _ => {
            let why = "running as root, and setpriv cannot drop to user nobody";
            eprintln!("{test}: skipped: {why}");
            println!("{test}: skipped: {why}");
            None
        }
    }
}

pub fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Names of the files in `dir` (temporary files included), sorted.
pub fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// A triangle's three corners.
pub type Facet = [[f32; 3]; 3];

/// The 12 facets of the box `min..max`, wound outwards.
pub fn box_facets(min: [f32; 3], max: [f32; 3]) -> Vec<Facet> {
    let p = |i: usize, j: usize, k: usize| {
        [
            [min[0], max[0]][i],
            [min[1], max[1]][j],
            [min[2], max[2]][k],
        ]
    };
    let quads = [
        [p(0, 0, 0), p(0, 1, 0), p(1, 1, 0), p(1, 0, 0)],
        [p(0, 0, 1), p(1, 0, 1), p(1, 1, 1), p(0, 1, 1)],
        [p(0, 0, 0), p(1, 0, 0), p(1, 0, 1), p(0, 0, 1)],
        [p(0, 1, 0), p(0, 1, 1), p(1, 1, 1), p(1, 1, 0)],
        [p(0, 0, 0), p(0, 0, 1), p(0, 1, 1), p(0, 1, 0)],
        [p(1, 0, 0), p(1, 1, 0), p(1, 1, 1), p(1, 0, 1)],
    ];
    quads
        .iter()
        .flat_map(|[a, b, c, d]| [[*a, *b, *c], [*a, *c, *d]])
        .collect()
}

/// A binary STL of `facets` (normals left zero).
pub fn binary_stl(facets: &[Facet]) -> Vec<u8> {
    binary_stl_declaring(facets.len() as u32, facets)
}

/// A binary STL whose header declares `declared` triangles (its header starts with
/// `solid`, as some exporters' do).
pub fn binary_stl_declaring(declared: u32, facets: &[Facet]) -> Vec<u8> {
    let mut bytes = b"solid written by the moldgate CLI tests".to_vec();
    bytes.resize(80, b' ');
    bytes.extend_from_slice(&declared.to_le_bytes());
    for facet in facets {
        bytes.extend_from_slice(&[0u8; 12]);
        for v in facet.iter().flatten() {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        bytes.extend_from_slice(&[0u8; 2]);
    }
    bytes
}

/// Asserts a failure with exit code `code` whose stderr is exactly one line
/// `moldgate: error: ...` containing every one of `needles`; returns that line.
#[track_caller]
pub fn assert_fails(out: &Output, code: i32, needles: &[&str]) -> String {
    assert_code(out, code);
    let err = stderr(out);
    assert!(err.ends_with('\n'), "stderr ends with a newline: {err:?}");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "stderr is one line: {err}");
    let line = lines[0];
    assert!(line.starts_with("moldgate: error: "), "{line}");
    for needle in needles {
        assert!(line.contains(needle), "'{needle}' is not in: {line}");
    }
    line.to_string()
}

/// Asserts exit code `code` and no panic, showing stderr and stdout when it fails.
#[track_caller]
pub fn assert_code(out: &Output, code: i32) {
    let err = stderr(out);
    assert!(!err.contains("panicked"), "panic: {err}");
    assert_eq!(
        out.status.code(),
        Some(code),
        "exit code; stderr: {err}; stdout: {}",
        stdout(out)
    );
}
