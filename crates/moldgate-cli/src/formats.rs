//! Which reader a mesh file goes to, by its extension.

use std::path::Path;

/// A mesh reader of the library.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshKind {
    /// Binary or ASCII STL (also the choice for an unknown extension).
    Stl,
    /// Wavefront OBJ.
    Obj,
    /// PLY, ASCII or binary.
    Ply,
}

/// The reader for `path`: `.obj` and `.ply` (any case) by name, STL otherwise.
pub fn mesh_kind(path: &Path) -> MeshKind {
    let ext = path.extension().unwrap_or_default();
    if ext.eq_ignore_ascii_case("obj") {
        MeshKind::Obj
    } else if ext.eq_ignore_ascii_case("ply") {
        MeshKind::Ply
    } else {
        MeshKind::Stl
    }
}

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
    fn kind_by_extension_in_any_case() {
        assert_eq!(mesh_kind(Path::new("a/b.OBJ")), MeshKind::Obj);
        assert_eq!(mesh_kind(Path::new("b.Ply")), MeshKind::Ply);
        assert_eq!(mesh_kind(Path::new("b.stl")), MeshKind::Stl);
        assert_eq!(mesh_kind(Path::new("b.mesh")), MeshKind::Stl);
        assert_eq!(mesh_kind(Path::new("obj")), MeshKind::Stl);
        assert!(is_mesh_file(Path::new("x.PLY")));
        assert!(is_mesh_file(Path::new("x.sTl")));
        assert!(!is_mesh_file(Path::new("x.json")));
        assert!(!is_mesh_file(Path::new("ply")));
    }
}
