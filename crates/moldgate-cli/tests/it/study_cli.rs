//! The command line over the library's study: several-gate answers everywhere, refused
//! conflicting or empty choices, honest messages, timings that add up.

use std::process::{Command, Output, Stdio};

use serde_json::Value;

fn moldgate(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_moldgate"))
        .args(args)
        .stdin(Stdio::null())
        .output()
        .expect("the moldgate binary runs")
}

fn stdout(args: &[&str]) -> String {
    let out = moldgate(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Runs a command that must fail with `code` and one line on stderr containing `needle`.
fn fails(args: &[&str], code: i32, needle: &str) {
    let out = moldgate(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "{args:?}: {err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.starts_with("moldgate: error: ") && err.contains(needle),
        "{err}"
    );
}

#[test]
fn several_gates_are_the_answer_in_the_json_and_the_summary() {
    let report: Value = serde_json::from_str(&stdout(&[
        "locate", "--sample", "plate", "--gates", "2", "--json",
    ]))
    .unwrap();
    let several = &report["fill"]["several"]["gates"];
    let gates = report["gate"]["gates"].as_array().expect("gate.gates");
    assert_eq!(gates.len(), 2);
    for (g, s) in gates.iter().zip(several.as_array().unwrap()) {
        assert_eq!(g["point"], s["point"]);
        assert_eq!(g["volume_share"], s["volume_share"]);
        assert_eq!(g["l_max_mm"], s["l_max_mm"]);
        let n: Vec<f64> = (0..3).map(|i| g["normal"][i].as_f64().unwrap()).collect();
        let length = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        assert!((length - 1.0).abs() < 1e-9, "normal {n:?}");
    }
    assert_eq!(report["gate"]["point"], gates[0]["point"]);
    let summary = stdout(&["locate", "--sample", "plate", "--gates", "2"]);
    let last = summary
        .lines()
        .find(|l| l.starts_with("GATE"))
        .expect("a GATE line");
    assert!(last.starts_with("GATES (2 gates"), "{last}");
    // One gate: the answer is as before, without a list.
    let one: Value = serde_json::from_str(&stdout(&[
        "locate", "--sample", "plate", "--fill", "--json",
    ]))
    .unwrap();
    assert!(one["gate"].get("gates").is_none());
}

#[test]
fn balanced_with_aesthetic_is_refused() {
    fails(
        &[
            "locate",
            "--sample",
            "plate",
            "--strategy",
            "balanced",
            "--aesthetic",
        ],
        2,
        "--strategy and --aesthetic cannot be used together",
    );
}

#[test]
fn a_grid_of_few_nodes_warns() {
    let summary = stdout(&["locate", "--sample", "plate", "--spacing", "1000"]);
    assert!(
        summary.contains("warning: only 1 grid nodes fall on the part"),
        "{summary}"
    );
    let plain = stdout(&["locate", "--sample", "plate"]);
    assert!(!plain.contains("grid nodes fall on the part"), "{plain}");
}

#[test]
fn outputs_must_have_their_format_s_extension() {
    let dir = tempfile::tempdir().unwrap();
    for (flag, name, needle) in [
        ("--png", "x.jpg", "--png"),
        ("--glb", "x.gltf", "--glb"),
        ("--report", "x.txt", "--report"),
    ] {
        let path = dir.path().join(name);
        fails(
            &["locate", "--sample", "plate", flag, path.to_str().unwrap()],
            2,
            needle,
        );
        assert!(!path.exists(), "{name} was written");
    }
    let page = dir.path().join("x.HTM");
    let out = moldgate(&[
        "locate",
        "--sample",
        "plate",
        "--report",
        page.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    assert!(page.exists());
}

#[test]
fn locate_without_a_part_names_what_is_missing() {
    fails(&["locate"], 2, "not provided: <FILE|FOLDER>");
}

#[test]
fn no_negative_zeros_in_the_summary_or_the_json() {
    // The cover's centre of mass is at x = y = 0 up to round-off.
    let summary = stdout(&["locate", "--sample", "cover"]);
    assert!(!summary.contains("-0.000"), "{summary}");
    let json = stdout(&["locate", "--sample", "cover", "--json", "--aesthetic"]);
    assert!(
        !json.contains("-0.0,") && !json.contains("-0.0\n"),
        "{json}"
    );
}

#[test]
fn unknown_thickness_on_a_closed_mesh_does_not_blame_holes() {
    // No gate qualifies with a gate radius larger than every wall: the wall at the gate is
    // "none (no gate)", and nothing speaks of an open mesh on this closed part.
    let out = moldgate(&[
        "locate",
        "--sample",
        "plate",
        "--gate-radius",
        "50",
        "--wall-thickness",
    ]);
    assert_eq!(out.status.code(), Some(4));
    let summary = String::from_utf8_lossy(&out.stdout);
    assert!(!summary.contains("open mesh"), "{summary}");
    assert!(
        summary.contains("at the paper gate's facet none (no gate)"),
        "{summary}"
    );
}

#[test]
fn the_time_line_includes_every_stage_that_ran() {
    let summary = stdout(&[
        "locate",
        "--sample",
        "plate",
        "--fill",
        "--wall-thickness",
        "--demold",
        "auto",
    ]);
    let time = summary.lines().find(|l| l.starts_with("time:")).unwrap();
    for stage in [
        "load",
        "ray tree",
        "demold auto",
        "rays",
        "wall thickness",
        "fill",
    ] {
        assert!(time.contains(stage), "{stage}: {time}");
    }
    let report: Value = serde_json::from_str(&stdout(&[
        "locate",
        "--sample",
        "plate",
        "--fill",
        "--wall-thickness",
        "--demold",
        "auto",
        "--json",
    ]))
    .unwrap();
    let t = &report["timings"];
    let f = |k: &str| t[k].as_f64().unwrap();
    // The centre of mass and the parting line run alongside the rays: the longest of the
    // three is on the critical path.
    let alongside =
        |f: &dyn Fn(&str) -> f64| f("projection_s").max(f("parting_s")).max(f("centre_s"));
    // With the automatic direction the tree (and the fill's cells) are made beside its
    // choice: the longer of the two is on the critical path.
    let sum = f("load_s")
        + f("tree_s").max(f("demold_s"))
        + f("grid_s")
        + alongside(&f)
        + f("select_s")
        + f("wall_s")
        + f("fill_s");
    // The locate stages' own total is measured end to end, so the parts add up to it within
    // the small gaps between them.
    assert!(
        f("total_s") >= sum * 0.99,
        "total {} < stages {sum}",
        f("total_s")
    );
    assert!(
        f("total_s") <= sum * 1.5 + 0.01,
        "total {} > stages {sum}",
        f("total_s")
    );
    // With the direction given, the tree is built alongside the gate search: the total
    // counts at most the tree's time past it, and never the two one after the other.
    let report: Value = serde_json::from_str(&stdout(&[
        "locate", "--sample", "plate", "--fill", "--json",
    ]))
    .unwrap();
    let t = &report["timings"];
    let f = |k: &str| t[k].as_f64().unwrap();
    let own = f("load_s") + f("grid_s") + alongside(&f) + f("select_s") + f("fill_s");
    let longer = f("tree_s").max(f("grid_s") + alongside(&f) + f("select_s"));
    assert!(
        f("total_s") >= 0.99 * (f("load_s") + longer + f("fill_s")),
        "{t}"
    );
    // The gaps between stages (threads waking, the join) grow with the machine's load: 2 %
    // of the stages and 10 ms, far less than the tree and the gate search one after the other.
    // The fill's cells are made beside them too (in the join, not in `fill_s`).
    let beside = report["fill"]["times"]["cells_beside_s"].as_f64().unwrap();
    assert!(beside > 0.0, "{}", report["fill"]["times"]);
    assert!(
        f("total_s") <= (own + f("tree_s") + beside) * 1.02 + 0.01,
        "{t}"
    );
}

#[test]
fn the_html_report_shows_the_fill() {
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("r.html");
    let out = moldgate(&[
        "locate",
        "--sample",
        "plate",
        "--gates",
        "2",
        "--report",
        page.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    let html = std::fs::read_to_string(&page).unwrap();
    let readable = &html[..html.find("Full JSON report").unwrap()];
    for needle in [
        "id=\"fill\"",
        "L_max",
        "L/t",
        "material's limit",
        "MPa",
        "2 gates together",
        "Last to fill",
        "Weld lines",
        "2 gates at",
        "Fill analysis</td>",
    ] {
        assert!(readable.contains(needle), "{needle}");
    }
}

/// In aesthetic mode the fill table's first row is the aesthetic gate's fill (the answer),
/// named as such, not as the paper gate.
#[test]
fn the_html_fill_table_names_the_parting_line_gate_in_aesthetic_mode() {
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("r.html");
    let out = moldgate(&[
        "locate",
        "--sample",
        "cover",
        "--fill",
        "--aesthetic",
        "--report",
        page.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(html.contains("<tr><th>aesthetic gate</th>"));
    assert!(!html.contains("<tr><th>paper gate</th>"));
    // The parting line's gate is an edge gate: the summary and the page say that the
    // paper's rules along D (which it would fail, on the outline) are not its rules.
    let said = "(an edge gate in the parting plane: the paper's rules for a gate seen along D, its disc on the part and the wall along D, do not apply to it; check the wall where it enters)";
    assert!(String::from_utf8_lossy(&out.stdout).contains(said));
    assert!(html.contains(said), "the page");
    // With a gate of the designer's, the table of their fill names the aesthetic gate's row
    // so, and the balanced gate, the cover's paper gate here, as the paper gate.
    let out = moldgate(&[
        "locate",
        "--sample",
        "cover",
        "--fill",
        "--aesthetic",
        "--gate-at",
        "0,0,30",
        "--report",
        page.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("\n  aesthetic gate    "), "{text}");
    assert!(
        text.contains("\n  balanced gate (the paper gate)  "),
        "{text}"
    );
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(
        html.contains("<tr><th>balanced gate (the paper gate)</th>"),
        "the page"
    );
}
