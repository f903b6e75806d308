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

/// Runs the binary in `dir` with no standard input.
pub fn moldgate(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_moldgate"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .output()
        .expect("the moldgate binary runs")
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
