//! Files that are not meshes, recognised by their first bytes, so that a STEP model or a
//! ZIP archive given by mistake is named as what it is instead of being read as a broken
//! binary STL.

use crate::error::LoadError;

/// What to do with a CAD model.
const EXPORT: &str =
    "export the part as STL, OBJ or PLY from your CAD tool (in millimetres, with a fine tessellation) and give moldgate that file";

/// The kind of file `head` (the first bytes of a file, up to a kilobyte) starts, when it is
/// a known kind that is not a mesh moldgate reads; `text` says whether to name plain text
/// (for the STL reader, text that does not start with `solid`; text shorter than a binary
/// STL's 84-byte header is named as such, since a binary header cut short could be text).
pub fn not_a_mesh(head: &[u8], text: bool) -> Option<LoadError> {
    let trimmed = head
        .strip_prefix(b"\xEF\xBB\xBF")
        .unwrap_or(head)
        .trim_ascii_start();
    let starts = |magic: &[u8]| trimmed.starts_with(magic);
    let (what, advice) = if starts(b"ISO-10303-21") {
        ("a STEP file (ISO-10303-21)", EXPORT)
    } else if head.starts_with(b"PK\x03\x04") {
        if contains(head, b"3dmodel.model") || contains(head, b"[Content_Types].xml") {
            (
                "a 3MF file (a ZIP package of an XML model)",
                "export the part as STL, OBJ or PLY (moldgate does not read 3MF)",
            )
        } else {
            (
                "a ZIP archive",
                "unpack it and give moldgate the STL, OBJ or PLY file inside",
            )
        }
    } else if head.starts_with(b"\x1f\x8b") {
        (
            "a gzip-compressed file",
            "decompress it (gunzip) and give moldgate the mesh file inside",
        )
    } else if head.starts_with(b"%PDF-") {
        ("a PDF document", EXPORT)
    } else if head.starts_with(b"\x89PNG\r\n\x1a\n") {
        ("a PNG image", EXPORT)
    } else if head.starts_with(b"\xff\xd8\xff") {
        ("a JPEG image", EXPORT)
    } else if head.starts_with(b"glTF") {
        (
            "a binary glTF (GLB) scene",
            "export the part as STL, OBJ or PLY (moldgate writes GLB but does not read it)",
        )
    } else if is_iges(head) {
        ("an IGES file", EXPORT)
    } else if starts(b"ply") && trimmed.get(3).is_some_and(|&b| b == b'\n' || b == b'\r') {
        (
            "a PLY file",
            "give it a .ply extension so that it is read as PLY",
        )
    } else if text && is_text(head) && (head.len() >= 84 || std::str::from_utf8(head).is_ok()) {
        // A vertex statement, at the start or on a later line (a comment line alone, as in
        // any notes or Markdown file, is no sign of OBJ).
        if trimmed.starts_with(b"v ") || contains(head, b"\nv ") {
            (
                "a text file that looks like a Wavefront OBJ",
                "give it an .obj extension so that it is read as OBJ",
            )
        } else if head.len() < 84 {
            (
                "a short text file (not an ASCII STL: it does not start with 'solid'; and shorter than a binary STL's 84-byte header)",
                "give moldgate an STL, OBJ or PLY mesh",
            )
        } else {
            (
                "a text file that is not an ASCII STL (it does not start with 'solid')",
                "give moldgate an STL, OBJ or PLY mesh",
            )
        }
    } else {
        return None;
    };
    Some(LoadError::NotAMesh { what, advice })
}

/// For the OBJ and PLY readers: an STL given another extension, named as the STL reader
/// names an OBJ or a PLY given `.stl` (`head` as for [`not_a_mesh`]): an ASCII STL (`solid`
/// then a `facet`), or binary data past a binary STL's 84-byte header, which neither OBJ
/// nor PLY (whose header is text) starts with.
pub fn stl_by_another_name(head: &[u8]) -> Option<LoadError> {
    let trimmed = head.trim_ascii_start();
    let what = if trimmed.starts_with(b"solid") && contains(head, b"facet") {
        "an ASCII STL"
    } else if head.len() >= 84 && !head.starts_with(b"ply") && !is_text(head) {
        "binary data, most likely a binary STL (an 80-byte header, a count and 50-byte facets)"
    } else {
        return None;
    };
    Some(LoadError::NotAMesh {
        what,
        advice: "give it an .stl extension so that it is read as STL",
    })
}

fn contains(haystack: &[u8], needle: &[u8]) -> bool {
    haystack.windows(needle.len()).any(|w| w == needle)
}

/// Text: no control characters but white space (and at least one character).
pub fn is_text(head: &[u8]) -> bool {
    !head.is_empty()
        && head
            .iter()
            .all(|&b| b >= 0x20 && b != 0x7f || matches!(b, b'\t' | b'\n' | b'\r' | 0x0c))
}

/// An IGES file: fixed 80-column records whose column 73 is the section letter (`S` for the
/// first, start section) followed by a sequence number.
fn is_iges(head: &[u8]) -> bool {
    let first = head.split(|&b| b == b'\n').next().unwrap_or_default();
    let first = first.strip_suffix(b"\r").unwrap_or(first);
    first.len() == 80
        && first[72] == b'S'
        && first[73..].iter().all(|&b| b == b' ' || b.is_ascii_digit())
        && first[79].is_ascii_digit()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn what(head: &[u8]) -> Option<&'static str> {
        match not_a_mesh(head, true) {
            Some(LoadError::NotAMesh { what, .. }) => Some(what),
            _ => None,
        }
    }

    /// An STL given an .obj or .ply extension is named, as an OBJ or PLY given .stl is.
    #[test]
    fn an_stl_by_another_name_is_named() {
        let ascii = b"solid part\n  facet normal 0 0 1\n    outer loop\n";
        let mut binary = vec![b' '; 80];
        binary.extend(1u32.to_le_bytes());
        binary.extend([0u8; 50]);
        for head in [&ascii[..], &binary] {
            let Some(LoadError::NotAMesh { advice, .. }) = stl_by_another_name(head) else {
                panic!("{head:?}");
            };
            assert!(advice.contains(".stl extension"));
        }
        for head in [
            &b"v 0 0 0\nv 1 0 0\nf 1 2 3\n"[..],
            b"ply\nformat binary_little_endian 1.0\nelement vertex 3\n",
            b"solid but nothing else here\n",
        ] {
            assert!(stl_by_another_name(head).is_none(), "{head:?}");
        }
    }

    #[test]
    fn every_signature_is_named() {
        let iges = format!("{:<72}S{:>7}\n", "IGES file written by a CAD tool", 1);
        for (head, name) in [
            (&b"ISO-10303-21;\nHEADER;\n"[..], "STEP"),
            (b"PK\x03\x04\x14\x00\x00\x00[Content_Types].xml", "3MF"),
            (b"PK\x03\x04\x14\x00\x00\x003D/3dmodel.model", "3MF"),
            (b"PK\x03\x04\x14\x00\x00\x00part.stl", "ZIP"),
            (b"\x1f\x8b\x08\x00\x00\x00\x00\x00", "gzip"),
            (b"%PDF-1.7\n%\xe2\xe3", "PDF"),
            (b"\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR", "PNG"),
            (b"\xff\xd8\xff\xe0\x00\x10JFIF", "JPEG"),
            (b"glTF\x02\x00\x00\x00", "GLB"),
            (iges.as_bytes(), "IGES"),
            (b"ply\nformat ascii 1.0\n", "PLY"),
            (&b"# made by hand\nv 0 0 0\n".repeat(8), "OBJ"),
            (&b"hello, this is a note\n".repeat(8), "not an ASCII STL"),
            // Comment lines alone are not OBJ: a Markdown file, a shell script.
            (
                &b"# moldgate\n\n```bash\ncargo run\n```\n".repeat(4),
                "not an ASCII STL",
            ),
            (b"# notes\nsome text\n", "short text file"),
        ] {
            let w = what(head).unwrap_or_else(|| panic!("{name} not recognised"));
            assert!(w.contains(name), "{name}: {w}");
        }
    }

    #[test]
    fn binary_stl_data_is_not_named() {
        let mut head = vec![0u8; 84];
        head[..5].copy_from_slice(b"solid");
        head[80] = 12;
        head.extend([0x80, 0x3f, 0x00, 0x00, 0x01]);
        assert!(what(&head).is_none());
    }
}
