//! `--glb FILE.glb`: the checks of its path before any work (the file itself is
//! [`moldgate::Study::glb`], written whole or not at all).

use std::path::Path;

use crate::output::{refuse_input, same_file};
use crate::Failure;

/// Refuses a `--glb` path that names the input or the same file as `-o`.
pub fn check_path(glb: &Path, input: Option<&Path>, report: Option<&Path>) -> Result<(), Failure> {
    refuse_input(glb, input)?;
    if report.is_some_and(|r| same_file(glb, r)) {
        return Err(Failure::usage(format!(
            "--glb and -o name the same file: {}",
            moldgate::files::shown(&glb)
        )));
    }
    Ok(())
}
