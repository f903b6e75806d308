//! `moldgate locate --png` and `--report` end to end: the files are complete, the HTML page
//! is self-contained and renders in headless Chromium (skipped, with the reason printed, when
//! `chromium` is not installed), and bad output paths fail with one line and write nothing.

use std::process::{Command, Output, Stdio};

use serde_json::Value;
use tempfile::TempDir;

use crate::common::*;

/// Asserts exit code `code` and one line `moldgate: error: ...` on stderr holding `needle`.
#[track_caller]
fn assert_fails(out: &Output, code: i32, needle: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "stderr: {err}");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "one line: {err}");
    assert!(lines[0].starts_with("moldgate: error: "), "{err}");
    assert!(lines[0].contains(needle), "{err} lacks {needle}");
}

/// The gate point as the report prints it, "(x, y, z)" with 3 decimals.
fn gate_text(json: &Value) -> String {
    let p = &json["gate"]["point"];
    format!(
        "({:.3}, {:.3}, {:.3})",
        p[0].as_f64().unwrap(),
        p[1].as_f64().unwrap(),
        p[2].as_f64().unwrap()
    )
}

#[test]
fn png_and_report_are_written_whole_and_self_contained() {
    let dir = TempDir::new().unwrap();
    let out = moldgate(
        dir.path(),
        &[
            "locate", "--sample", "tray", "--png", "t.png", "--report", "t.html", "-o", "t.json",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let png = std::fs::read(dir.path().join("t.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let decoder = png::Decoder::new(std::io::Cursor::new(&png[..]));
    let info = decoder.read_info().unwrap().info().clone();
    assert_eq!((info.width, info.height), (1600, 900));

    let json: Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("t.json")).unwrap()).unwrap();
    let html = std::fs::read_to_string(dir.path().join("t.html")).unwrap();
    assert!(html.starts_with("<!DOCTYPE html>") && html.ends_with("</html>\n"));
    assert!(html.contains(&gate_text(&json)), "gate in the page");
    // The picture is the same PNG, inline.
    assert!(html.contains("src=\"data:image/png;base64,iVBORw0KGgo"));
    // Nothing to fetch: no scripts, no external links or sources.
    for bad in [
        "<script",
        "src=\"http",
        "href=\"http",
        "url(",
        "@import",
        "<link",
    ] {
        assert!(!html.contains(bad), "the page contains {bad}");
    }
    // The full JSON is in the page, escaped.
    assert!(html.contains("&quot;schema_version&quot;: 3"));
    assert!(!html.contains("\"schema_version\""));
    // No temporary files left.
    assert_eq!(listing(dir.path()), ["t.html", "t.json", "t.png"]);
}

#[test]
fn the_report_of_a_layout_names_its_values_and_whose_last_places_it_lists() {
    let dir = TempDir::new().unwrap();
    let out = moldgate(
        dir.path(),
        &[
            "locate",
            "--sample",
            "cover",
            "--demold",
            "+z",
            "--objective",
            "resistance",
            "--gates",
            "3",
            "--report",
            "c.html",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let html = std::fs::read_to_string(dir.path().join("c.html")).unwrap();
    let several = html
        .lines()
        .find(|l| l.starts_with("<p id=\"several\">"))
        .expect("the layout's line");
    assert!(
        several.contains("3 gates together: fill time 0.") && several.contains("% shorter than"),
        "{several}"
    );
    // The last places listed are the layout's own, all its gates open, and the page says
    // so, with the layout's L/t and pressure.
    assert!(
        html.contains("Last to fill from the 3 gates together"),
        "{html}"
    );
    assert!(!html.contains("Last to fill from the answer's gate"));
    assert!(!html.contains("gate alone"));
    assert!(html.contains("<p id=\"layout-fill\">With all 3 gates open: flow length / wall L/t "));
}

#[test]
fn bad_output_paths_fail_before_any_work_and_leave_nothing() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let out = moldgate(d, &["sample", "plate", "-o", "plate.stl"]);
    assert!(out.status.success());
    let input = std::fs::read(d.join("plate.stl")).unwrap();

    let out = moldgate(d, &["locate", "plate.stl", "--png", "no/such/folder/p.png"]);
    assert_fails(&out, OUTPUT, "does not exist");
    let out = moldgate(d, &["locate", "plate.stl", "--report", "missing/r.html"]);
    assert_fails(&out, OUTPUT, "does not exist");

    // Over the input, also through another spelling of the path.
    let out = moldgate(d, &["locate", "plate.stl", "--png", "plate.stl"]);
    assert_fails(&out, OUTPUT, "over the input");
    let out = moldgate(d, &["locate", "plate.stl", "--report", "./plate.stl"]);
    assert_fails(&out, OUTPUT, "over the input");

    // Two outputs on one file.
    let out = moldgate(
        d,
        &[
            "locate",
            "plate.stl",
            "--png",
            "x.out",
            "--report",
            "./x.out",
        ],
    );
    assert_fails(&out, USAGE, "same file");
    let out = moldgate(d, &["locate", "plate.stl", "-o", "x.out", "--png", "x.out"]);
    assert_fails(&out, USAGE, "same file");

    // A folder where the file should go.
    std::fs::create_dir(d.join("pic.png")).unwrap();
    let out = moldgate(d, &["locate", "plate.stl", "--png", "pic.png"]);
    assert_fails(&out, OUTPUT, "folder");

    assert_eq!(std::fs::read(d.join("plate.stl")).unwrap(), input);
    assert_eq!(listing(d), ["pic.png", "plate.stl"]);
}

#[test]
fn an_unwritable_folder_fails_and_leaves_nothing() {
    use std::os::unix::fs::PermissionsExt;
    let dir = TempDir::new().unwrap();
    let locked = dir.path().join("locked");
    std::fs::create_dir(&locked).unwrap();
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o555)).unwrap();
    if std::fs::write(locked.join("probe"), b"x").is_ok() {
        // Root ignores permissions, so this case cannot be made here.
        let _ = std::fs::remove_file(locked.join("probe"));
        println!("an_unwritable_folder_fails_and_leaves_nothing: skipped: running with permission to write anywhere (root)");
        eprintln!("an_unwritable_folder_fails_and_leaves_nothing: skipped: running with permission to write anywhere (root)");
        return;
    }
    let out = moldgate(
        dir.path(),
        &["locate", "--sample", "plate", "--png", "locked/p.png"],
    );
    assert_fails(&out, OUTPUT, "cannot write");
    assert!(listing(&locked).is_empty());
}

#[test]
fn without_a_gate_the_picture_and_report_are_still_written() {
    let dir = TempDir::new().unwrap();
    // A 100 mm gate fits nowhere on the 20 mm cap.
    let out = moldgate(
        dir.path(),
        &[
            "locate",
            "--sample",
            "cap",
            "--gate-radius",
            "100",
            "--png",
            "c.png",
            "--report",
            "c.html",
        ],
    );
    assert_eq!(out.status.code(), Some(NO_GATE));
    assert!(std::fs::read(dir.path().join("c.png"))
        .unwrap()
        .starts_with(b"\x89PNG"));
    let html = std::fs::read_to_string(dir.path().join("c.html")).unwrap();
    assert!(html.contains("No gate:"));
}

/// Opens the report in headless Chromium: the screenshot is not blank and the page's text
/// holds the gate coordinates.
#[test]
fn the_report_renders_in_headless_chromium() {
    let name = "the_report_renders_in_headless_chromium";
    let Some(chromium) = ["chromium", "chromium-browser"].into_iter().find(|c| {
        Command::new(c)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
    }) else {
        println!("{name}: skipped: chromium is not installed (apt-get install chromium)");
        eprintln!("{name}: skipped: chromium is not installed (apt-get install chromium)");
        return;
    };
    let dir = TempDir::new().unwrap();
    let out = moldgate(
        dir.path(),
        &[
            "locate", "--sample", "bracket", "--report", "b.html", "--json",
        ],
    );
    assert!(out.status.success());
    let json: Value = serde_json::from_slice(&out.stdout).unwrap();
    let page = dir.path().join("b.html");
    let url = format!("file://{}", page.display());
    let profile = dir.path().join("profile");
    let shot = dir.path().join("shot.png");
    let common = [
        "--headless".to_string(),
        "--no-sandbox".into(),
        "--disable-gpu".into(),
        "--disable-quic".into(),
        "--no-first-run".into(),
        "--disable-background-networking".into(),
        "--disable-component-update".into(),
        "--disable-sync".into(),
        format!("--user-data-dir={}", profile.display()),
    ];
    let run = |extra: &[String]| {
        Command::new(chromium)
            .args(&common)
            .args(extra)
            .arg(&url)
            .stdin(Stdio::null())
            .output()
            .expect("chromium runs")
    };
    let dom = run(&["--dump-dom".into()]);
    assert!(
        dom.status.success(),
        "{}",
        String::from_utf8_lossy(&dom.stderr)
    );
    let dom = String::from_utf8_lossy(&dom.stdout);
    let gate = gate_text(&json);
    assert!(
        dom.contains(&format!("Gate at <b id=\"gate\">{gate} mm</b>")),
        "gate {gate} not in the page"
    );

    let out = run(&[
        format!("--screenshot={}", shot.display()),
        "--window-size=1400,1000".into(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let bytes = std::fs::read(&shot).expect("a screenshot");
    let decoder = png::Decoder::new(std::io::Cursor::new(&bytes[..]));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    let channels = info.color_type.samples();
    let pixels: Vec<&[u8]> = buf[..info.buffer_size()].chunks_exact(channels).collect();
    assert_eq!((info.width, info.height), (1400, 1000));
    let white = pixels.iter().filter(|p| p[..3] == [255, 255, 255]).count();
    let mut colours: Vec<[u8; 3]> = pixels.iter().map(|p| [p[0], p[1], p[2]]).collect();
    colours.sort_unstable();
    colours.dedup();
    // The embedded picture brings hundreds of colours and covers much of the window.
    assert!(colours.len() > 200, "{} colours", colours.len());
    assert!(
        white < pixels.len() * 3 / 4,
        "{white} of {} pixels white",
        pixels.len()
    );
    // The gate's red is on screen: the picture was decoded and drawn.
    // (Within a few levels, in case the browser manages colours.)
    let red = pixels
        .iter()
        .filter(|p| p[0].abs_diff(230) < 8 && p[1].abs_diff(25) < 8 && p[2].abs_diff(45) < 8)
        .count();
    assert!(red > 10, "{red} gate-coloured pixels");
}
