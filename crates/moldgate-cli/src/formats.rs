//! Which files of a folder are meshes, by their extension (the reader each goes to is
//! `moldgate::files::mesh_kind`).

use std::path::Path;

/// Whether a file name ends in `.stl`, `.obj` or `.ply`, in any case: the files a folder
/// given to `locate` contributes.
pub fn is_mesh_file(path: &Path) -> bool {
    path.extension().is_some_and(|e| {
        ["stl", "obj", "ply"]
            .iter()
            .any(|known| e.eq_ignore_ascii_case(known))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mesh_files_by_extension_in_any_case() {
        assert!(is_mesh_file(Path::new("x.PLY")));
        assert!(is_mesh_file(Path::new("x.sTl")));
        assert!(!is_mesh_file(Path::new("x.json")));
        assert!(!is_mesh_file(Path::new("ply")));
    }
}
