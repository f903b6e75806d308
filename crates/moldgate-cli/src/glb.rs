//! `--glb FILE.glb`: the analysis as a binary glTF file, written whole or not at all.

use std::path::Path;

use moldgate::scene::Scene;

use crate::output::{refuse_input, same_file, write_atomic};
use crate::Failure;

/// Refuses a `--glb` path that names the input or the same file as `-o`.
pub fn check_path(glb: &Path, input: Option<&Path>, report: Option<&Path>) -> Result<(), Failure> {
    refuse_input(glb, input)?;
    if report.is_some_and(|r| same_file(glb, r)) {
        return Err(Failure::usage(format!(
            "--glb and -o name the same file: {}",
            glb.display()
        )));
    }
    Ok(())
}

/// Writes `scene` to `path` as GLB (see `moldgate::gltf` for what the file holds, its units
/// and axes).
pub fn write(path: &Path, scene: &Scene) -> Result<(), Failure> {
    let bytes = moldgate::gltf::glb(scene)
        .map_err(|e| Failure::output(format!("{}: {e}", path.display())))?;
    write_atomic(path, &bytes)
}
