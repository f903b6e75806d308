//! `moldgate locate --glb FILE.glb` end to end: the file is a complete GLB of the part, and
//! every bad output path (missing folder, no permission, a folder, the input itself, the
//! same file as `-o`) ends with one line on stderr, the documented exit code and nothing
//! half-written. Exit codes as in main.rs: 2 command line, 3 input, 4 no gate, 5 output.

use std::path::Path;
use std::process::Output;

use serde_json::Value;

use crate::common::*;

#[track_caller]
fn assert_ok(out: &Output) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(OK), "stderr: {err}");
}

/// A folder holding `part.stl`, the `cover` sample written by the binary itself.
fn folder_with_part() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    assert_ok(&moldgate(
        dir.path(),
        &["sample", "cover", "-o", "part.stl"],
    ));
    dir
}

/// The JSON chunk of a GLB, after checking the header's magic, version and length.
fn glb_json(bytes: &[u8]) -> Value {
    assert_eq!(&bytes[0..4], b"glTF");
    assert_eq!(u32::from_le_bytes(bytes[4..8].try_into().unwrap()), 2);
    let length = u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize;
    assert_eq!(length, bytes.len(), "the header's length is the file's");
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    assert_eq!(&bytes[16..20], b"JSON");
    serde_json::from_slice(&bytes[20..20 + json_len]).unwrap()
}

#[test]
fn glb_is_written_whole_beside_the_json() {
    let dir = folder_with_part();
    // An older, longer file in the way is replaced whole.
    std::fs::write(dir.path().join("part.glb"), vec![b'x'; 3_000_000]).unwrap();
    let out = moldgate(
        dir.path(),
        &["locate", "part.stl", "--glb", "part.glb", "-o", "r.json"],
    );
    assert_ok(&out);
    assert_eq!(listing(dir.path()), ["part.glb", "part.stl", "r.json"]);
    let bytes = std::fs::read(dir.path().join("part.glb")).unwrap();
    let json = glb_json(&bytes);
    assert_eq!(json["asset"]["version"], "2.0");
    assert_eq!(json["asset"]["extras"]["title"], "part.stl");
    let report: Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("r.json")).unwrap()).unwrap();
    // The GLB's gate and demolding direction are the report's.
    let gate = &json["asset"]["extras"]["gates"][0]["point_mm"];
    assert_eq!(gate, &report["gate"]["point"]);
    let names: Vec<&str> = json["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n["name"].as_str().unwrap())
        .collect();
    for name in [
        "part",
        "gate 1",
        "centre of mass",
        "parting line",
        "moldgate",
    ] {
        assert!(names.contains(&name), "{name} missing from {names:?}");
    }

    // A sample and a demolding direction of its own.
    let out = moldgate(
        dir.path(),
        &[
            "locate", "--sample", "tray", "--demold", "-x", "--glb", "tray.glb",
        ],
    );
    assert_ok(&out);
    let json = glb_json(&std::fs::read(dir.path().join("tray.glb")).unwrap());
    assert_eq!(json["asset"]["extras"]["title"], "sample 'tray'");
    assert_eq!(
        json["asset"]["extras"]["demolding_direction"],
        serde_json::json!([-1.0, 0.0, 0.0])
    );
}

#[test]
fn glb_into_a_missing_folder_fails_and_leaves_nothing() {
    let dir = folder_with_part();
    let out = moldgate(
        dir.path(),
        &["locate", "part.stl", "--glb", "no/such/folder/part.glb"],
    );
    assert_fails(&out, OUTPUT, &["no/such/folder/part.glb", "cannot write"]);
    assert_eq!(listing(dir.path()), ["part.stl"]);
}

#[test]
fn glb_over_the_input_is_refused() {
    let dir = folder_with_part();
    let input = std::fs::read(dir.path().join("part.stl")).unwrap();
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    for output in ["part.stl", "./part.stl", "sub/../part.stl"] {
        let out = moldgate(dir.path(), &["locate", "part.stl", "--glb", output]);
        assert_fails(&out, OUTPUT, &[output, "refusing to write", "input"]);
        assert!(out.stdout.is_empty(), "refused before any work");
        assert_eq!(std::fs::read(dir.path().join("part.stl")).unwrap(), input);
    }
    assert_eq!(listing(dir.path()), ["part.stl", "sub"]);
}

#[test]
fn glb_onto_a_folder_fails() {
    let dir = folder_with_part();
    std::fs::create_dir(dir.path().join("out.glb")).unwrap();
    let out = moldgate(dir.path(), &["locate", "part.stl", "--glb", "out.glb"]);
    assert_fails(&out, OUTPUT, &["out.glb", "folder"]);
    assert!(listing(&dir.path().join("out.glb")).is_empty());
    assert_eq!(listing(dir.path()), ["out.glb", "part.stl"]);
}

#[test]
fn glb_and_json_report_cannot_share_a_file() {
    let dir = folder_with_part();
    let out = moldgate(
        dir.path(),
        &["locate", "part.stl", "--glb", "out", "-o", "./out"],
    );
    assert_fails(&out, USAGE, &["--glb and -o name the same file"]);
    assert_eq!(listing(dir.path()), ["part.stl"]);
}

#[cfg(unix)]
#[test]
fn glb_into_a_folder_without_write_permission_fails_and_leaves_nothing() {
    use std::os::unix::fs::PermissionsExt;
    let test = "glb_into_a_folder_without_write_permission";
    let dir = folder_with_part();
    let mode = |p: &Path, m: u32| std::fs::set_permissions(p, std::fs::Permissions::from_mode(m));
    let locked = dir.path().join("locked");
    std::fs::create_dir(&locked).unwrap();
    mode(&locked, 0o555).unwrap();
    let args = ["locate", "part.stl", "--glb", "locked/part.glb"];
    // Permissions do not stop the superuser: then run the binary as `nobody` through
    // setpriv, with the part readable to it.
    let out = if std::fs::write(locked.join("probe"), b"").is_err() {
        moldgate(dir.path(), &args)
    } else {
        std::fs::remove_file(locked.join("probe")).unwrap();
        mode(dir.path(), 0o755).unwrap();
        mode(&dir.path().join("part.stl"), 0o644).unwrap();
        let Some(out) = moldgate_as_nobody(dir.path(), &args, test) else {
            return;
        };
        out
    };
    mode(&locked, 0o755).unwrap();
    assert_fails(&out, OUTPUT, &["locked/part.glb", "cannot write"]);
    assert!(listing(&locked).is_empty());
}

#[test]
fn bad_input_writes_no_glb() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.stl"), b"solid x\nfacet normal 0 0\n").unwrap();
    let out = moldgate(dir.path(), &["locate", "bad.stl", "--glb", "bad.glb"]);
    assert_fails(&out, INPUT, &["bad.stl"]);
    assert_eq!(listing(dir.path()), ["bad.stl"]);
}

#[test]
fn no_gate_still_writes_the_part() {
    // A gate radius larger than the cover's wall leaves no node; the GLB shows the part, the
    // centre and the parting line without a gate, as the JSON report is still written.
    let dir = folder_with_part();
    let out = moldgate(
        dir.path(),
        &[
            "locate",
            "part.stl",
            "--gate-radius",
            "40",
            "--glb",
            "p.glb",
        ],
    );
    // The GLB is written, and said so, before the failure's one line.
    assert_code(&out, NO_GATE);
    let err = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 2, "{err}");
    assert_eq!(lines[0], "wrote p.glb");
    assert!(lines[1].starts_with("moldgate: error: part.stl"), "{err}");
    let json = glb_json(&std::fs::read(dir.path().join("p.glb")).unwrap());
    let names: Vec<&str> = json["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n["name"].as_str().unwrap())
        .collect();
    assert!(names.contains(&"part"));
    assert!(!names.contains(&"gate 1"), "{names:?}");
    assert_eq!(json["asset"]["extras"]["gates"], serde_json::json!([]));
}

/// The keep-out regions are in the file, each a node of lines: a box's 12 edges, a sphere's
/// three great circles.
#[test]
fn keep_out_regions_are_nodes_of_lines() {
    let dir = folder_with_part();
    let out = moldgate(
        dir.path(),
        &[
            "locate",
            "part.stl",
            "--glb",
            "part.glb",
            "--keep-out",
            "box:-10,-10,0,10,10,40",
            "--keep-out",
            "sphere:30,0,30,5",
        ],
    );
    assert_ok(&out);
    let json = glb_json(&std::fs::read(dir.path().join("part.glb")).unwrap());
    for (name, points) in [("keep-out 1", 24), ("keep-out 2", 3 * 48 * 2)] {
        let node = json["nodes"]
            .as_array()
            .unwrap()
            .iter()
            .find(|n| n["name"] == name)
            .unwrap_or_else(|| panic!("no node {name}"));
        let mesh = &json["meshes"][node["mesh"].as_u64().unwrap() as usize];
        let primitive = &mesh["primitives"][0];
        assert_eq!(primitive["mode"], 1, "{name}: LINES");
        let accessor =
            &json["accessors"][primitive["attributes"]["POSITION"].as_u64().unwrap() as usize];
        assert_eq!(accessor["count"], points, "{name}");
    }
}
