//! OBJ and PLY input through the real binary: the reader is chosen by the extension (any
//! case; STL for any other), the same part in each format gives the same report, folders in
//! batch mode take every format, and every malformed file ends with exit code 3 and one line
//! on stderr naming the file and the place (line, or byte offset in a binary PLY).

use std::fmt::Write as _;
use std::path::Path;
use std::process::Output;

use moldgate::mesh::{read_stl, Mesh, Units};
use serde_json::Value;
use tempfile::TempDir;

use crate::common::*;

/// Asserts exit code 3 and one stderr line `moldgate: error: ...` holding every needle.
#[track_caller]
fn assert_input_error(out: &Output, needles: &[&str]) {
    let err = stderr(out);
    assert!(!err.contains("panicked"), "panic: {err}");
    assert_eq!(out.status.code(), Some(INPUT), "stderr: {err}");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "stderr is one line: {err}");
    assert!(lines[0].starts_with("moldgate: error: "), "{err}");
    for needle in needles {
        assert!(lines[0].contains(needle), "'{needle}' is not in: {err}");
    }
}

/// The JSON report of `moldgate locate FILE --json`, without what differs between files of
/// one part (the path, its size, the format, the times).
fn report(dir: &Path, file: &str) -> (Value, Value) {
    let out = moldgate(dir, &["locate", file, "--json"]);
    assert_eq!(out.status.code(), Some(OK), "{file}: {}", stderr(&out));
    let mut v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let o = v.as_object_mut().unwrap();
    o.remove("input");
    o.remove("timings");
    let format = o["mesh"].as_object_mut().unwrap().remove("format").unwrap();
    (v, format)
}

/// The sample `name` as a binary STL and as it reads back (every coordinate an f32).
fn sample(name: &str) -> (Vec<u8>, Mesh) {
    let mut stl = Vec::new();
    moldgate::samples::sample(name)
        .unwrap()
        .write_stl(&mut stl)
        .unwrap();
    let part = read_stl(&stl[..], stl.len() as u64, Units::Mm).unwrap();
    (stl, part.mesh)
}

fn obj(mesh: &Mesh) -> String {
    let mut text = String::from("# test part\no part\n");
    for v in &mesh.vertices {
        writeln!(text, "v {} {} {}", v.x, v.y, v.z).unwrap();
    }
    for [a, b, c] in &mesh.triangles {
        writeln!(text, "f {} {} {}", a + 1, b + 1, c + 1).unwrap();
    }
    text
}

fn ply_header(format: &str, mesh: &Mesh) -> String {
    format!(
        "ply\nformat {format} 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\nelement face {}\nproperty list uchar uint vertex_indices\nend_header\n",
        mesh.vertices.len(),
        mesh.triangles.len()
    )
}

fn ply_ascii(mesh: &Mesh) -> String {
    let mut text = ply_header("ascii", mesh);
    for v in &mesh.vertices {
        writeln!(text, "{} {} {}", v.x, v.y, v.z).unwrap();
    }
    for [a, b, c] in &mesh.triangles {
        writeln!(text, "3 {a} {b} {c}").unwrap();
    }
    text
}

fn ply_binary(mesh: &Mesh) -> Vec<u8> {
    let mut out = ply_header("binary_little_endian", mesh).into_bytes();
    for v in &mesh.vertices {
        for c in v.to_array() {
            out.extend((c as f32).to_le_bytes());
        }
    }
    for tri in &mesh.triangles {
        out.push(3);
        for i in tri {
            out.extend(i.to_le_bytes());
        }
    }
    out
}

fn write(dir: &Path, name: &str, bytes: impl AsRef<[u8]>) {
    std::fs::write(dir.join(name), bytes).unwrap();
}

#[test]
fn the_same_part_in_every_format_gives_the_same_report() {
    let dir = TempDir::new().unwrap();
    let (stl, mesh) = sample("cover");
    write(dir.path(), "cover.stl", &stl);
    write(dir.path(), "cover.obj", obj(&mesh));
    write(dir.path(), "cover.OBJ", obj(&mesh));
    write(dir.path(), "cover_ascii.ply", ply_ascii(&mesh));
    write(dir.path(), "cover_binary.Ply", ply_binary(&mesh));
    let (expected, format) = report(dir.path(), "cover.stl");
    assert_eq!(format, "stl_binary");
    assert!(expected["gate"].is_object(), "the cover has a gate");
    for (file, format) in [
        ("cover.obj", "obj"),
        ("cover.OBJ", "obj"),
        ("cover_ascii.ply", "ply_ascii"),
        ("cover_binary.Ply", "ply_binary_little_endian"),
    ] {
        let (got, got_format) = report(dir.path(), file);
        assert_eq!(got_format, format, "{file}");
        assert_eq!(got, expected, "{file}");
    }
    // The summary names the format.
    let out = moldgate(dir.path(), &["locate", "cover_ascii.ply"]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("ASCII PLY"));
}

#[test]
fn an_unknown_extension_is_read_as_stl() {
    let dir = TempDir::new().unwrap();
    let (stl, mesh) = sample("cap");
    write(dir.path(), "cap.mesh", &stl);
    assert_eq!(report(dir.path(), "cap.mesh").1, "stl_binary");
    // An OBJ under another name is not guessed: it is refused, named as an OBJ, with the
    // extension to give it.
    write(dir.path(), "cap.txt", obj(&mesh));
    let out = moldgate(dir.path(), &["locate", "cap.txt"]);
    assert_input_error(&out, &["cap.txt", "Wavefront OBJ", ".obj extension"]);
}

#[test]
fn batch_folders_take_obj_and_ply() {
    let dir = TempDir::new().unwrap();
    let parts = dir.path().join("parts");
    std::fs::create_dir(&parts).unwrap();
    let (stl, mesh) = sample("tray");
    write(&parts, "a.stl", &stl);
    write(&parts, "b.OBJ", obj(&mesh));
    write(&parts, "c.ply", ply_binary(&mesh));
    write(&parts, "notes.txt", "not a part");
    let out = moldgate(
        dir.path(),
        &["locate", "parts", "--summary", "s.jsonl", "--quiet"],
    );
    assert_eq!(out.status.code(), Some(OK), "{}", stderr(&out));
    let text = std::fs::read_to_string(dir.path().join("s.jsonl")).unwrap();
    let rows: Vec<Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(rows.len(), 3, "{text}");
    for (row, name) in rows.iter().zip(["a.stl", "b.OBJ", "c.ply"]) {
        assert!(row.to_string().contains(name), "{row}");
    }
}

/// A small valid OBJ (a tetrahedron), one statement a line.
const TETRA_OBJ: [&str; 8] = [
    "v 0 0 0", "v 10 0 0", "v 0 10 0", "v 0 0 10", "f 1 3 2", "f 1 2 4", "f 2 3 4", "f 1 4 3",
];

#[test]
fn every_malformed_obj_names_its_line() {
    let dir = TempDir::new().unwrap();
    write(dir.path(), "good.obj", TETRA_OBJ.join("\n"));
    assert_eq!(
        moldgate(dir.path(), &["locate", "good.obj"]).status.code(),
        Some(OK)
    );
    for (name, row, bad, what) in [
        ("number.obj", 1, "v 10 zero 0", "expected a number"),
        ("range.obj", 5, "f 1 2 5", "out of range"),
        ("zero.obj", 6, "f 0 3 4", "index 0"),
        ("relative.obj", 7, "f -5 -1 -2", "out of range"),
        ("two.obj", 7, "f 1 4", "2 corners"),
        ("unknown.obj", 2, "vx 1 2 3", "unknown OBJ statement"),
    ] {
        let mut lines = TETRA_OBJ.to_vec();
        lines[row] = bad;
        write(dir.path(), name, lines.join("\n"));
        let out = moldgate(dir.path(), &["locate", name]);
        assert_input_error(&out, &[name, &format!("line {}", row + 1), what]);
    }
}

fn tetra() -> Mesh {
    Mesh {
        vertices: vec![
            [0.0, 0.0, 0.0].into(),
            [10.0, 0.0, 0.0].into(),
            [0.0, 10.0, 0.0].into(),
            [0.0, 0.0, 10.0].into(),
        ],
        triangles: vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
    }
}

#[test]
fn every_malformed_ascii_ply_names_its_line() {
    let dir = TempDir::new().unwrap();
    let good = ply_ascii(&tetra());
    write(dir.path(), "good.ply", &good);
    assert_eq!(
        moldgate(dir.path(), &["locate", "good.ply"]).status.code(),
        Some(OK)
    );
    let lines: Vec<&str> = good.lines().collect();
    // Lines 1-9 are the header, 10-13 the vertices, 14-17 the faces.
    for (name, line, bad, what) in [
        ("magic.ply", 1, "plyx", "not a PLY file"),
        ("format.ply", 2, "format binary 1.0", "unknown PLY format"),
        ("type.ply", 4, "property real x", "unknown PLY type"),
        ("count.ply", 3, "element vertex four", "not a whole number"),
        ("number.ply", 11, "10 0 zero", "expected a number"),
        ("short.ply", 12, "0 10", "too few values"),
        ("range.ply", 15, "3 0 1 4", "out of range"),
        ("negative.ply", 16, "3 1 -2 3", "expected an integer"),
        ("corners.ply", 17, "2 0 3", "2 corners"),
        ("nan.ply", 13, "0 0 nan", "non-finite"),
    ] {
        let mut edited = lines.clone();
        edited[line - 1] = bad;
        write(dir.path(), name, edited.join("\n") + "\n");
        let out = moldgate(dir.path(), &["locate", name]);
        assert_input_error(&out, &[name, &format!("line {line}"), what]);
    }
    // A header without end_header, and a body that stops early.
    write(dir.path(), "header.ply", lines[..8].join("\n") + "\n");
    assert_input_error(
        &moldgate(dir.path(), &["locate", "header.ply"]),
        &["header.ply", "line 8", "end_header"],
    );
    write(dir.path(), "cut.ply", lines[..15].join("\n") + "\n");
    assert_input_error(
        &moldgate(dir.path(), &["locate", "cut.ply"]),
        &[
            "cut.ply",
            "line 15",
            "ends before face 2 of the 4 the header declares",
        ],
    );
}

#[test]
fn every_malformed_binary_ply_names_its_byte() {
    let dir = TempDir::new().unwrap();
    let mesh = tetra();
    let good = ply_binary(&mesh);
    write(dir.path(), "good.ply", &good);
    assert_eq!(
        moldgate(dir.path(), &["locate", "good.ply"]).status.code(),
        Some(OK)
    );
    let body = ply_header("binary_little_endian", &mesh).len();
    // Vertices take 12 bytes each, faces 13 (a count byte and three u32).
    let face = |f: usize| body + 4 * 12 + 13 * f;
    let edit = |at: usize, bytes: &[u8]| {
        let mut b = good.clone();
        b[at..at + bytes.len()].copy_from_slice(bytes);
        b
    };
    for (name, bytes, at, what) in [
        (
            "range.ply",
            edit(face(2) + 5, &9u32.to_le_bytes()),
            face(2) + 5,
            "out of range",
        ),
        ("corners.ply", edit(face(1), &[2]), face(1), "2 corners"),
        (
            "nan.ply",
            edit(body + 12 + 4, &f32::NAN.to_le_bytes()),
            body + 16,
            "non-finite",
        ),
        (
            "cut.ply",
            good[..face(3) + 6].to_vec(),
            face(3) + 5,
            "ends inside face 3 of the 4 the header declares",
        ),
    ] {
        write(dir.path(), name, bytes);
        let out = moldgate(dir.path(), &["locate", name]);
        assert_input_error(&out, &[name, &format!("byte {at}"), what]);
    }
}
