//! The fill analysis, keep-out regions and cosmetic faces from the command line.

use std::process::{Command, Output, Stdio};

use serde_json::Value;

fn moldgate(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_moldgate"))
        .args(args)
        .stdin(Stdio::null())
        .output()
        .expect("the moldgate binary runs")
}

fn json(args: &[&str]) -> Value {
    let out = moldgate(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("JSON on stdout")
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

fn point(v: &Value) -> [f64; 3] {
    [0, 1, 2].map(|i| v[i].as_f64().unwrap())
}

#[test]
fn fill_reports_both_gates_and_the_balanced_one_never_does_worse() {
    let r = json(&["locate", "--sample", "bracket", "--fill", "--json"]);
    let f = &r["fill"];
    let paper = &f["paper"];
    let balanced = &f["balanced"]["fill"];
    for g in [paper, balanced] {
        for key in [
            "l_max_mm",
            "l_mean_mm",
            "flow_ratio",
            "pressure_mpa",
            "fill_time_s",
        ] {
            assert!(g[key].as_f64().unwrap() > 0.0, "{key}: {g}");
        }
        // 99 % of the volume is filled before the last place, not after.
        let most = g["fill_time_99_s"].as_f64().unwrap();
        assert!(
            most > 0.0 && most <= g["fill_time_s"].as_f64().unwrap(),
            "{g}"
        );
        assert!(!g["last_to_fill"].as_array().unwrap().is_empty());
    }
    assert!(balanced["l_max_mm"].as_f64() <= paper["l_max_mm"].as_f64());
    assert_eq!(r["gate"]["strategy"], "paper");
    assert_eq!(point(&r["gate"]["point"]), point(&paper["gate"]));
    // Without --fill there is no fill analysis.
    let r = json(&["locate", "--sample", "bracket", "--json"]);
    assert!(r["fill"].is_null());
}

#[test]
fn balanced_strategy_makes_the_balanced_gate_the_answer() {
    let r = json(&[
        "locate",
        "--sample",
        "bracket",
        "--strategy",
        "balanced",
        "--json",
    ]);
    assert_eq!(r["gate"]["strategy"], "balanced");
    assert_eq!(
        point(&r["gate"]["point"]),
        point(&r["fill"]["balanced"]["fill"]["gate"])
    );
    let text = String::from_utf8(
        moldgate(&["locate", "--sample", "bracket", "--strategy", "balanced"]).stdout,
    )
    .unwrap();
    assert!(
        text.contains("GATE (balanced)") || text.contains("balanced gate: the paper gate"),
        "{text}"
    );
}

#[test]
fn several_gates_share_the_volume() {
    let r = json(&["locate", "--sample", "tray", "--gates", "2", "--json"]);
    let m = &r["fill"]["several"];
    let gates = m["gates"].as_array().unwrap();
    assert_eq!(gates.len(), 2);
    let shares: f64 = gates
        .iter()
        .map(|g| g["volume_share"].as_f64().unwrap())
        .sum();
    assert!((shares - 1.0).abs() < 1e-9, "{shares}");
    assert!(m["l_max_mm"].as_f64() <= r["fill"]["paper"]["l_max_mm"].as_f64());
    // The layout's own fill, all gates open: its L_max is the layout's, its fill time the
    // one given beside it, its L/t that L_max over the nominal wall (one body), and it has
    // a pressure and last places of its own.
    let f = &m["fill"];
    let num = |v: &Value| v.as_f64().unwrap();
    assert!(
        (num(&f["l_max_mm"]) - num(&m["l_max_mm"])).abs() < 1e-9,
        "{f}"
    );
    assert!((num(&f["fill_time_s"]) - num(&m["layout_fill_time_s"])).abs() < 1e-12);
    let nominal = num(&r["fill"]["nominal_wall_mm"]);
    assert!((num(&f["flow_ratio"]) - num(&f["l_max_mm"]) / nominal).abs() < 1e-9);
    assert!(num(&f["pressure_mpa"]) > 0.0);
    assert!(!f["last_to_fill"].as_array().unwrap().is_empty());
    let text = String::from_utf8(moldgate(&["locate", "--sample", "tray", "--gates", "2"]).stdout)
        .unwrap();
    let said = format!(
        "  all 2 gates open: flow length / wall L/t {:.0} (limit 250), pressure ",
        num(&f["flow_ratio"])
    );
    assert!(text.contains(&said), "{text}");
}

/// Each place last to fill says what its length is (the flow path from the gate) and when it
/// fills, with the report's numbers.
#[test]
fn last_to_fill_places_name_their_flow_path_length_and_fill_time() {
    let args = ["locate", "--sample", "bracket", "--fill"];
    let out = moldgate(&args);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<&str> = text
        .lines()
        .filter(|l| l.trim_start().starts_with("last to fill #"))
        .collect();
    let r = json(&[&args[..], &["--json"]].concat());
    let places = r["fill"]["paper"]["last_to_fill"].as_array().unwrap();
    assert!(!lines.is_empty());
    assert_eq!(lines.len(), places.len().min(3), "{text}");
    for (line, q) in lines.iter().zip(places) {
        let length = q["flow_length_mm"].as_f64().unwrap();
        let time = q["fill_time_s"].as_f64().unwrap();
        // Three significant figures: the order of places that fill within a millisecond shows.
        let time = moldgate::report::seconds_text(time);
        let said = format!("{length:.1} mm of flow path from the gate, filled at {time} s");
        assert!(line.ends_with(&said), "{line} / {said}");
    }
}

#[test]
fn the_summary_names_where_a_layout_of_gates_was_seeded() {
    let out = moldgate(&["locate", "--sample", "tray", "--gates", "2"]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text
        .lines()
        .find(|l| l.starts_with("GATES ("))
        .expect("a GATES line");
    assert!(line.starts_with("GATES (2 gates, one layout): "), "{line}");
}

#[test]
fn several_gates_minimising_the_fill_time_are_summarised_in_seconds() {
    let out = moldgate(&[
        "locate",
        "--sample",
        "tray",
        "--gates",
        "2",
        "--objective",
        "resistance",
    ]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    // The layout's line and its gates' lines (the fill of all gates open, its L/t and last
    // places, are lines of their own).
    let layout: Vec<&str> = text
        .lines()
        .skip_while(|l| !l.starts_with("  2 gates: "))
        .filter(|l| l.starts_with("  2 gates: ") || l.starts_with("    gate "))
        .take(3)
        .collect();
    assert_eq!(layout.len(), 3, "{text}");
    // What a fill time is, said once beside the numbers.
    assert_eq!(
        text.lines()
            .filter(|l| l.starts_with("  (fill time: ")
                && l.contains("not the fill time of a moulding machine"))
            .count(),
        1,
        "{text}"
    );
    for line in layout {
        assert!(
            line.contains("fill time 0.")
                && (line.contains(" s,") || line.contains(" s (") || line.ends_with(" s"))
                && !line.contains(" mm"),
            "{line}"
        );
    }
}

#[test]
fn keep_out_and_cosmetic_move_or_refuse_the_gate() {
    let free = json(&["locate", "--sample", "plate", "--json"]);
    let g = point(&free["gate"]["point"]);
    let sphere = format!("sphere:{},{},{},5", g[0], g[1], g[2]);
    let moved = json(&[
        "locate",
        "--sample",
        "plate",
        "--keep-out",
        &sphere,
        "--json",
    ]);
    let m = point(&moved["gate"]["point"]);
    let d = ((m[0] - g[0]).powi(2) + (m[1] - g[1]).powi(2) + (m[2] - g[2]).powi(2)).sqrt();
    let r = moved["options"]["gate_radius_mm"].as_f64().unwrap();
    assert!(d >= 5.0 + r, "{d}");
    assert!(moved["counts"]["kept_out"].as_u64().unwrap() > 0);
    fails(
        &[
            "locate",
            "--sample",
            "plate",
            "--keep-out",
            "box:-1e3,-1e3,-1e3,1e3,1e3,1e3",
        ],
        4,
        "kept out by the keep-out regions",
    );
    fails(
        &["locate", "--sample", "plate", "--cosmetic", "+z"],
        4,
        "cosmetic faces",
    );
    // The plate's +Z top is the only face seen from +Z; a cosmetic bottom changes nothing.
    let bottom = json(&["locate", "--sample", "plate", "--cosmetic", "-z", "--json"]);
    assert_eq!(point(&bottom["gate"]["point"]), g);
}

#[test]
fn bad_fill_options_are_refused_with_one_line() {
    fails(
        &["locate", "--sample", "plate", "--gates", "0"],
        2,
        "--gates",
    );
    fails(
        &["locate", "--sample", "plate", "--fill", "--cell", "-1"],
        2,
        "--cell",
    );
    fails(
        &["locate", "--sample", "plate", "--keep-out", "box:1,2,3"],
        2,
        "--keep-out",
    );
    fails(
        &[
            "locate",
            "--sample",
            "plate",
            "--keep-out",
            "sphere:0,0,0,0",
        ],
        2,
        "--keep-out",
    );
    fails(
        &["locate", "--sample", "plate", "--cosmetic", "0,0,0"],
        2,
        "--cosmetic",
    );
    fails(
        &["locate", "--sample", "plate", "--strategy", "best"],
        2,
        "strategy",
    );
    // A 3D view is of one part.
    fails(&["locate", "a.stl", "b.stl", "--glb", "x.glb"], 2, "--glb");
    // More gates than qualifying candidates.
    fails(
        &[
            "locate",
            "--sample",
            "plate",
            "--spacing",
            "40",
            "--gates",
            "20",
        ],
        4,
        "gates asked for",
    );
}

#[test]
fn heavy_fill_options_are_refused_before_the_work_with_the_number_and_the_limit() {
    fails(
        &["locate", "--sample", "cover", "--fill", "--cell", "1000"],
        2,
        "larger than 0.1 of the part's diagonal",
    );
    fails(
        &["locate", "--sample", "cover", "--gates", "1000"],
        2,
        "--gates must be at most 32, got 1000",
    );
    fails(
        &["locate", "--sample", "cover", "--fill", "--cell", "0.05"],
        2,
        "over the limit of",
    );
}

#[test]
fn color_by_chooses_the_field_of_the_pictures() {
    let dir = std::env::temp_dir().join(format!("moldgate-color-by-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for by in ["flow-length", "fill-order", "wall", "height"] {
        let png = dir.join(format!("{by}.png"));
        let out = moldgate(&[
            "locate",
            "--sample",
            "cover",
            "--fill",
            "--color-by",
            by,
            "--png",
            png.to_str().unwrap(),
        ]);
        assert!(
            out.status.success(),
            "{by}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(std::fs::metadata(&png).unwrap().len() > 1000);
    }
    fails(
        &[
            "locate",
            "--sample",
            "cover",
            "--fill",
            "--color-by",
            "rainbow",
        ],
        2,
        "--color-by",
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn gates_placed_with_gate_at_are_judged_in_every_output() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let (png, glb, html, report) = (path("b.png"), path("b.glb"), path("b.html"), path("b.json"));
    // The bracket: a base 60 x 40 x 5 and an upright 5 x 40 x 50. One point 2 mm above the
    // base, one above the upright's top, one beside the upright's face (not seen along +z).
    let args = [
        "locate",
        "--sample",
        "bracket",
        "--fill",
        "--gate-at",
        "30,20,7",
        "--gate-at",
        "2.5,20,52",
        "--gate-at",
        "5.5,20,30",
        "--png",
        &png,
        "--glb",
        &glb,
        "--report",
        &html,
        "-o",
        &report,
    ];
    let out = moldgate(&args);
    let summary = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    println!("{summary}");
    for needle in [
        "your gate 1    (30.000, 20.000, 5.000)       2.00 mm  5.00 mm",
        "your gate 2    (2.500, 20.000, 50.000)       2.00 mm  50.00 mm",
        "your gate 3    (5.000, 20.000, 30.000)       0.50 mm  -",
        "FAILS: not reachable from the +D mould half",
        "your gates together",
        "balanced gate",
        "your gate 3 fills",
    ] {
        assert!(summary.contains(needle), "{needle}\n{summary}");
    }
    let r: Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    let p = &r["placed_gates"];
    assert_eq!(p["gates"].as_array().unwrap().len(), 3);
    assert_eq!(p["gates"][0]["qualifies"], true);
    assert_eq!(p["gates"][1]["qualifies"], true);
    assert_eq!(p["gates"][2]["failed_rule"], "not_seen_along_d");
    assert_eq!(point(&p["gates"][2]["normal"]), [1.0, 0.0, 0.0]);
    assert!(p["fill"]["l_max_mm"].as_f64().unwrap() > 0.0);
    let shares: f64 = (0..3)
        .map(|i| p["gates"][i]["volume_share"].as_f64().unwrap())
        .sum();
    assert!((shares - 1.0).abs() < 1e-9, "{shares}");
    // The GLB names each placed gate's node; the page has its section.
    let glb = std::fs::read(&glb).unwrap();
    let text = String::from_utf8_lossy(&glb);
    for i in 1..=3 {
        assert!(
            text.contains(&format!("\"name\":\"your gate {i}\"")),
            "node {i}"
        );
    }
    assert!(text.contains("\"placed_gates\""));
    let html = std::fs::read_to_string(&html).unwrap();
    assert!(html.contains("<h2 id=\"placed-gates\">Your gates</h2>"));
    assert_eq!(html.matches("<tr class=\"placed\"").count(), 3);
    // The weld lines of the designer's gates are listed under their own name, apart from
    // the answer's.
    let placed: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let welds = placed["placed_gates"]["fill"]["weld_lines"]
        .as_array()
        .unwrap()
        .len();
    let heading = match welds {
        0 => "Weld lines from your gates together: none found.",
        _ => "Weld lines from your gates together:",
    };
    assert!(html.contains(heading), "{heading}");
    assert!(html.contains("Weld lines from the answer's gate"));
    assert!(std::fs::metadata(&png).unwrap().len() > 1000);
}

#[test]
fn bad_gate_at_values_name_the_flag() {
    let base = ["locate", "--sample", "bracket", "--gate-at"];
    for (value, needle) in [
        ("1,2", "--gate-at 1 '1,2': expected x,y,z (three numbers in mm), got 2 values"),
        ("a,b,c", "--gate-at 1 'a,b,c': x is not a number"),
        ("1,NaN,2", "--gate-at 1 '1,NaN,2': y must be a finite number"),
        ("1,2,inf", "--gate-at 1 '1,2,inf': z must be a finite number"),
        ("1,2,3,4", "got 4 values"),
        (
            "30,20,500",
            "--gate-at 1 (30.000, 20.000, 500.000) is 450.694 mm from the part's surface, over the limit of 8.775 mm",
        ),
    ] {
        let mut args = base.to_vec();
        args.push(value);
        fails(&args, 2, needle);
    }
    // The limit on their number, checked before any work.
    let mut args = vec!["locate", "--sample", "bracket"];
    for _ in 0..33 {
        args.extend(["--gate-at", "30,20,5"]);
    }
    fails(
        &args,
        2,
        "--gate-at is given 33 times, over the limit of 32 gates",
    );
}

#[test]
fn suitability_scores_every_qualifying_node_and_leaves_other_runs_unchanged() {
    let with = json(&["locate", "--sample", "cap", "--suitability", "--json"]);
    let without = json(&["locate", "--sample", "cap", "--fill", "--json"]);
    let map = &with["fill"]["suitability"];
    let nodes = map["nodes"].as_array().unwrap();
    assert_eq!(
        nodes.len() as u64 + map["off_part"].as_u64().unwrap(),
        with["counts"]["qualifying"].as_u64().unwrap()
    );
    assert_eq!(map["unit"], "mm");
    for n in nodes {
        let (score, upper) = (n["score"].as_f64().unwrap(), n["upper"].as_f64().unwrap());
        assert!(score > 0.0 && upper >= score, "{n}");
        assert!(n["kind"] == "exact" || n["kind"] == "lower_bound", "{n}");
    }
    // The best node is exact and the balanced gate's value, to the tolerance.
    let best = &nodes[map["best"].as_u64().unwrap() as usize];
    let balanced = with["fill"]["balanced"]["search"]["value"]
        .as_f64()
        .unwrap();
    assert_eq!(best["kind"], "exact");
    assert!(
        (best["score"].as_f64().unwrap() - balanced).abs()
            <= 2.0 * map["tolerance"].as_f64().unwrap(),
        "{best} vs {balanced}"
    );
    // Without the option the report has no map and no map timing; the rest is the same.
    assert!(without["fill"].get("suitability").is_none());
    assert!(without["fill"]["times"].get("suitability_s").is_none());
    assert_eq!(
        with["fill"]["balanced"]["fill"],
        without["fill"]["balanced"]["fill"]
    );
    assert_eq!(with["gate"], without["gate"]);
}

#[test]
fn bodies_are_counted_from_one_in_words_and_from_zero_in_json() {
    use crate::common::{binary_stl, box_facets};
    let dir = tempfile::tempdir().unwrap();
    // Two boxes side by side: the larger first in the file, holding the centre of mass.
    let mut facets = box_facets([0.0; 3], [40.0, 30.0, 10.0]);
    facets.extend(box_facets([50.0, 0.0, 0.0], [70.0, 30.0, 10.0]));
    let part = dir.path().join("two.stl");
    std::fs::write(&part, binary_stl(&facets)).unwrap();
    let part = part.to_str().unwrap();
    let out = moldgate(&["locate", part, "--demold", "+z", "--fill"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("  body 1 (66.7 % of the volume, holds the answer's gate)"),
        "{text}"
    );
    assert!(text.contains("  body 2 (33.3 % of the volume)"), "{text}");
    assert!(!text.contains("body 0"), "{text}");
    assert!(
        text.contains("warning: the paper gate feeds body 1 only"),
        "{text}"
    );
    // A layout of two gates gives each body one; of three over three bodies, with one gate
    // short, the body left out is named.
    let v = json(&["locate", part, "--demold", "+z", "--gates", "2", "--json"]);
    let mut xs: Vec<bool> = v["gate"]["gates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|g| g["point"][0].as_f64().unwrap() > 45.0)
        .collect();
    xs.sort_unstable();
    assert_eq!(xs, [false, true], "{}", v["gate"]);
    let warned = |v: &Value| {
        v["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .filter_map(|w| w.as_str().filter(|w| w.contains("none of its gates")))
            .map(str::to_string)
            .collect::<Vec<_>>()
    };
    assert!(warned(&v).is_empty(), "{:?}", warned(&v));
    let mut three = box_facets([0.0; 3], [40.0, 30.0, 10.0]);
    three.extend(box_facets([50.0, 0.0, 0.0], [70.0, 30.0, 10.0]));
    three.extend(box_facets([80.0, 0.0, 0.0], [90.0, 30.0, 10.0]));
    let part3 = dir.path().join("three.stl");
    std::fs::write(&part3, binary_stl(&three)).unwrap();
    let v = json(&[
        "locate",
        part3.to_str().unwrap(),
        "--demold",
        "+z",
        "--gates",
        "2",
        "--json",
    ]);
    let w = warned(&v);
    assert!(
        w.len() == 1
            && w[0].contains("on body 1, body 2 only")
            && w[0].contains("body 3 gets none of its gates (ask for at least 3 gates, one a body"),
        "{w:?}"
    );
    // JSON keeps indices from 0.
    let v = json(&["locate", part, "--demold", "+z", "--fill", "--json"]);
    let bodies: Vec<u64> = v["fill"]["body_gates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| b["body"].as_u64().unwrap())
        .collect();
    assert_eq!(bodies, [0, 1]);
    // The suitability map: each node's body in the JSON, and each body's best in words.
    let v = json(&["locate", part, "--demold", "+z", "--suitability", "--json"]);
    let map = &v["fill"]["suitability"];
    let nodes = map["nodes"].as_array().unwrap();
    for n in nodes {
        let on_second = n["point"][0].as_f64().unwrap() > 45.0;
        assert_eq!(n["body"], u64::from(on_second), "{n}");
    }
    let best = |body: usize| &nodes[map["best_per_body"][body].as_u64().unwrap() as usize];
    let out = moldgate(&["locate", part, "--demold", "+z", "--suitability"]);
    let text = String::from_utf8_lossy(&out.stdout);
    let line = text
        .lines()
        .find(|l| l.contains("each node is scored by the fill of its own body"))
        .unwrap_or_else(|| panic!("{text}"));
    for body in [0, 1] {
        let score = best(body)["score"].as_f64().unwrap();
        assert!(
            line.contains(&format!("body {} (", body + 1))
                && line.contains(&format!(": {score:.1} mm")),
            "{line}"
        );
    }
}

#[test]
fn a_placed_gate_off_a_flat_seat_qualifies_with_a_warning() {
    // The cover opened to -z: its grid gate sits on the boss inside, whose disc reaches 10 mm
    // off its height; (-3.6, 3.6, 28) is a flat seat on the floor.
    let dir = tempfile::tempdir().unwrap();
    let html = dir.path().join("c.html");
    let html = html.to_str().unwrap();
    let base = [
        "locate",
        "--sample",
        "cover",
        "--demold",
        "-z",
        "--gate-at",
        "0,0,18",
        "--gate-at",
        "-3.6,3.6,28",
    ];
    let out = moldgate(&[&base[..], &["--report", html]].concat());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    let line = |k: &str| {
        text.lines()
            .find(|l| l.trim_start().starts_with(k))
            .unwrap_or("")
    };
    assert!(
        line("your gate 1 ").ends_with(
            "qualifies, off a flat seat (its disc reaches 10.00 mm off its height along D)"
        ),
        "{text}"
    );
    assert!(line("your gate 2 ").ends_with("qualifies"), "{text}");
    // Gate 1 is the paper gate's point: the paper gate's row gives it the same verdict.
    assert!(
        line("paper gate ").ends_with(
            "qualifies, off a flat seat (its disc reaches 10.00 mm off its height along D); the method's proposal"
        ),
        "{text}"
    );
    assert!(
        text.contains("warning: your gate 1 at (0.000, 0.000, 18.000) qualifies but is not on a flat seat: its disc reaches 10.00 mm off its height along D"),
        "{text}"
    );
    assert!(!text.contains("your gate 2 at"), "{text}");
    let page = std::fs::read_to_string(html).unwrap();
    assert!(page.contains("off a flat seat</b> (its disc reaches 10.00 mm"));
    let v = json(&[&base[..], &["--json"]].concat());
    let gates = v["placed_gates"]["gates"].as_array().unwrap();
    assert_eq!(gates[0]["flat"], false);
    assert!((gates[0]["step_mm"].as_f64().unwrap() - 10.0).abs() < 1e-6);
    assert_eq!(gates[1]["flat"], true);
    assert!(gates[1]["step_mm"].as_f64().unwrap() < 0.143);
}

#[test]
fn a_flow_ratio_over_the_material_s_limit_is_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("low.toml");
    std::fs::write(
        &file,
        "[Low]\nn = 0.3\nt_melt = 230\nt_wall = 40\ngamma_opt = 1000\nmu_opt = 300\nk = 0.2\nmax_flow_ratio = 10\n",
    )
    .unwrap();
    let file = file.to_str().unwrap();
    let args = [
        "locate",
        "--sample",
        "cover",
        "--materials-file",
        file,
        "--material",
        "Low",
    ];
    let v = json(&[&args[..], &["--fill", "--json"]].concat());
    let ratio = v["fill"]["paper"]["flow_ratio"].as_f64().unwrap();
    assert!(ratio > 10.0, "{ratio}");
    let said = format!(
        "from the paper gate the longest flow is {ratio:.0} times the wall (L/t), over the material's limit of 10"
    );
    let warnings = v["warnings"].as_array().unwrap();
    assert!(
        warnings
            .iter()
            .any(|w| w.as_str().unwrap().starts_with(&said)),
        "{warnings:?}"
    );
    // Within the limit (PP's 250), no such warning.
    let v = json(&["locate", "--sample", "cover", "--fill", "--json"]);
    let text = v["warnings"].to_string();
    assert!(!text.contains("times the wall (L/t)"), "{text}");
}

#[test]
fn a_keep_out_region_that_keeps_nothing_out_is_said() {
    // The cover is 120 x 80 x 30 mm about the origin: one region far off (a slip of units),
    // one over its middle, one on the part's corner where no node qualifies.
    let out = moldgate(&[
        "locate",
        "--sample",
        "cover",
        "--keep-out",
        "sphere:1000,0,0,1",
        "--keep-out",
        "box:-10,-10,-10,10,10,40",
        "--keep-out",
        "box:-60,-40,0,-59,-39,1",
    ]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    let warned: Vec<&str> = text
        .lines()
        .filter(|l| l.starts_with("warning: keep-out region"))
        .collect();
    assert_eq!(
        warned,
        [
            "warning: keep-out region 1 (the sphere of radius 1.000 mm at (1000.000, 0.000, 0.000) mm) keeps out no node that qualifies: it lies outside the part's box (check its coordinates and units)",
            "warning: keep-out region 3 (the box (-60.000, -40.000, 0.000) to (-59.000, -39.000, 1.000) mm) keeps out no node that qualifies: no node that passes the paper's rules lies within the gate radius of it",
        ],
        "{text}"
    );
}

/// Beside the designer's gates the table gives the answer's verdict when the answer is not
/// the paper gate: the balanced gate judged as a placed gate ("the answer, chosen by the
/// fill"; the bracket's, 8.4 mm from its paper gate), the aesthetic gate as an edge gate
/// that the paper's rules along D do not judge; the paper gate is then not "the method's
/// proposal". The page's table has the same rows.
#[test]
fn the_placed_gates_table_gives_the_answers_verdict() {
    let dir = tempfile::tempdir().unwrap();
    let html = dir.path().join("r.html");
    let html = html.to_str().unwrap();
    let text = |args: &[&str]| {
        let out = moldgate(args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    // A row of the table of the designer's gates (the fill's own lines name gates too).
    let row = |text: &str, name: &str| {
        text.lines()
            .skip_while(|l| !l.starts_with("your gates (--gate-at"))
            .find(|l| l.starts_with(&format!("  {name} ")))
            .unwrap_or_else(|| panic!("no {name} row in\n{text}"))
            .to_string()
    };
    let balanced = text(&[
        "locate",
        "--sample",
        "bracket",
        "--strategy",
        "balanced",
        "--gate-at",
        "18.6,20,5",
        "--report",
        html,
    ]);
    assert!(row(&balanced, "balanced gate").starts_with("  balanced gate  (10.200, 20.000, 5.000)"));
    assert!(row(&balanced, "balanced gate").ends_with("qualifies; the answer, chosen by the fill"));
    assert!(
        row(&balanced, "paper gate").ends_with("qualifies"),
        "{balanced}"
    );
    let page = std::fs::read_to_string(html).unwrap();
    assert!(
        page.contains("<tr class=\"beside\"><th>balanced gate</th>")
            && page.contains("qualifies; the answer, chosen by the fill</td>"),
        "{page}"
    );
    let aesthetic = text(&[
        "locate",
        "--sample",
        "cover",
        "--aesthetic",
        "--gate-at",
        "0,0,18",
    ]);
    assert!(
        row(&aesthetic, "aesthetic gate").ends_with(
            "the answer, an edge gate on the parting line: the paper's rules along D are not its rules (a gate placed there fails them)"
        ),
        "{aesthetic}"
    );
    assert!(!aesthetic.contains("the method's proposal"), "{aesthetic}");
    assert!(!aesthetic.contains("  balanced gate  ("), "{aesthetic}");
}

/// Two gates whose discs overlap are one gate in the mould: a warning says so (a point
/// given twice has its own warning, not this one).
#[test]
fn gates_whose_discs_overlap_are_warned_as_one() {
    let run = |second: &str| {
        let out = moldgate(&[
            "locate",
            "--sample",
            "plate",
            "--fill",
            "--gate-at",
            "10,10,3",
            "--gate-at",
            second,
            "--gate-at",
            "-20,5,3",
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let text = run("11,10,3");
    assert!(
        text.contains("warning: your gates 1 and 2 (1.00 mm apart) overlap"),
        "{text}"
    );
    assert!(
        !text.contains("gates 1 and 3") && !text.contains("gates 2 and 3"),
        "{text}"
    );
    let text = run("10,10,3");
    assert!(
        text.contains("warning: --gate-at gives gate 2 at the point of gate 1"),
        "{text}"
    );
    assert!(!text.contains("overlap"), "{text}");
}
