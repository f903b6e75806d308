//! The real `moldgate` binary on small parts: every bad input ends with one line on stderr
//! that names the file and the place, and the documented exit code; outputs are written whole
//! or not at all, and never over the input.
//!
//! Exit codes (crates/moldgate-cli/src/main.rs and the README): 0 success, 1 internal error,
//! 2 command line or option value (a bad materials file included), 3 input file missing,
//! unreadable or malformed, 4 no gate, 5 output.

use std::path::PathBuf;
use std::process::{Command, Output, Stdio};

use serde_json::Value;
use tempfile::TempDir;

use crate::common::*;

const SAMPLES: [&str; 5] = ["plate", "cover", "cap", "tray", "bracket"];

// ---------------------------------------------------------------------------------------------
// Running the binary

/// Asserts success and returns stdout.
#[track_caller]
fn assert_ok(out: &Output) -> String {
    let err = stderr(out);
    assert!(!err.contains("panicked"), "panic: {err}");
    assert_eq!(out.status.code(), Some(OK), "stderr: {err}");
    stdout(out)
}

fn json(out: &Output) -> Value {
    let text = assert_ok(out);
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("stdout is not JSON ({e}): {text}"))
}

fn point(v: &Value) -> [f64; 3] {
    let a = v.as_array().unwrap_or_else(|| panic!("not a point: {v}"));
    assert_eq!(a.len(), 3, "{v}");
    [0, 1, 2].map(|i| a[i].as_f64().expect("a number"))
}

// ---------------------------------------------------------------------------------------------
// Building parts

fn ascii(facets: &[Facet]) -> String {
    let mut s = String::from("solid part\n");
    for facet in facets {
        s += "facet normal 0 0 0\n outer loop\n";
        for [x, y, z] in facet {
            s += &format!("  vertex {x} {y} {z}\n");
        }
        s += " endloop\nendfacet\n";
    }
    s + "endsolid part\n"
}

/// A 40 x 30 x 10 mm block: every default rule finds a gate on it.
fn block() -> Vec<Facet> {
    box_facets([0.0; 3], [40.0, 30.0, 10.0])
}

/// A temporary folder holding `name` with `bytes`.
fn part(name: &str, bytes: &[u8]) -> (TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).unwrap();
    (dir, path)
}

// ---------------------------------------------------------------------------------------------
// Bad input files: exit code 3, the file and the place named

#[test]
fn missing_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = moldgate(dir.path(), &["locate", "no-such-part.stl"]);
    assert_fails(&out, INPUT, &["no-such-part.stl", "cannot open"]);
}

#[test]
fn missing_file_whose_path_mentions_a_broken_pipe_is_still_an_error() {
    // Regression: main once treated any message containing "Broken pipe" as a closed stdout
    // and exited 0 in silence.
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("Broken pipe")).unwrap();
    let out = moldgate(dir.path(), &["locate", "Broken pipe/part.stl"]);
    assert_fails(&out, INPUT, &["Broken pipe/part.stl", "cannot open"]);
}

#[test]
fn directory_given_as_file() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("parts.stl")).unwrap();
    let out = moldgate(dir.path(), &["locate", "parts.stl"]);
    assert_fails(&out, INPUT, &["parts.stl", "folder"]);
}

#[test]
fn empty_file() {
    let (dir, _) = part("empty.stl", b"");
    let out = moldgate(dir.path(), &["locate", "empty.stl"]);
    assert_fails(&out, INPUT, &["empty.stl", "empty file"]);
}

#[test]
fn truncated_binary() {
    let bytes = binary_stl(&block());
    // Cut 20 bytes into triangle 5, which starts at byte 84 + 5 x 50 = 334.
    let (dir, _) = part("cut.stl", &bytes[..84 + 5 * 50 + 20]);
    let out = moldgate(dir.path(), &["locate", "cut.stl"]);
    assert_fails(
        &out,
        INPUT,
        &[
            "cut.stl",
            "truncated",
            "12 triangles",
            "triangle 5",
            "byte 334",
        ],
    );
}

#[test]
fn binary_shorter_than_its_header() {
    // Cut inside the triangle count, whose zero bytes show the file is not text.
    let bytes = binary_stl(&block());
    let (dir, _) = part("stub.stl", &bytes[..82]);
    let out = moldgate(dir.path(), &["locate", "stub.stl"]);
    assert_fails(&out, INPUT, &["stub.stl", "82 bytes", "84-byte header"]);
}

#[test]
fn count_mismatch() {
    // The header declares 10 triangles, 12 follow: extra data from byte 84 + 500.
    let (dir, _) = part("long.stl", &binary_stl_declaring(10, &block()));
    let out = moldgate(dir.path(), &["locate", "long.stl"]);
    assert_fails(
        &out,
        INPUT,
        &["long.stl", "does not match", "10 triangles", "byte 584"],
    );
}

#[test]
fn ascii_syntax_error() {
    let text = ascii(&block()).replacen("endloop", "endlop", 1);
    // The first bad keyword closes the first facet: line 1 solid, 2 facet, 3 outer loop,
    // 4-6 vertices, 7 endloop.
    let (dir, _) = part("typo.stl", text.as_bytes());
    let out = moldgate(dir.path(), &["locate", "typo.stl"]);
    assert_fails(&out, INPUT, &["typo.stl", "line 7", "'endlop'"]);
}

#[test]
fn ascii_file_cut_inside_a_facet() {
    let text = ascii(&block());
    let cut: String = text.lines().take(12).map(|l| format!("{l}\n")).collect();
    let (dir, _) = part("cut.stl", cut.as_bytes());
    let out = moldgate(dir.path(), &["locate", "cut.stl"]);
    assert_fails(&out, INPUT, &["cut.stl", "line 12", "facet 1"]);
}

#[test]
fn binary_nan_coordinate() {
    let mut bytes = binary_stl(&block());
    // Triangle 3, corner 1, y: 84 + 3 x 50 + 12 (normal) + 12 + 4.
    let at = 84 + 3 * 50 + 12 + 12 + 4;
    bytes[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    let (dir, _) = part("nan.stl", &bytes);
    let out = moldgate(dir.path(), &["locate", "nan.stl"]);
    assert_fails(
        &out,
        INPUT,
        &["nan.stl", &format!("byte {at}"), "triangle 3", "NaN"],
    );
}

#[test]
fn ascii_infinite_coordinate() {
    let text = ascii(&block());
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    // Line 13 is the last vertex of facet 1 (each facet takes 7 lines after `solid`).
    assert!(lines[12].trim_start().starts_with("vertex"));
    lines[12] = "  vertex 0 -inf 0".into();
    let (dir, _) = part("inf.stl", (lines.join("\n") + "\n").as_bytes());
    let out = moldgate(dir.path(), &["locate", "inf.stl"]);
    assert_fails(&out, INPUT, &["inf.stl", "line 13", "triangle 1", "-inf"]);
}

#[test]
fn mesh_without_area() {
    let flat: Vec<Facet> = (0..6)
        .map(|i| {
            let y = i as f32;
            [[0.0, y, 0.0], [1.0, y, 0.0], [2.0, y, 0.0]]
        })
        .collect();
    let (dir, _) = part("flat.stl", &binary_stl(&flat));
    let out = moldgate(dir.path(), &["locate", "flat.stl"]);
    assert_fails(&out, INPUT, &["flat.stl", "non-zero area", "6 facets"]);
}

#[test]
fn bad_input_is_reported_before_anything_is_written() {
    let (dir, _) = part("empty.stl", b"");
    let out = moldgate(dir.path(), &["locate", "empty.stl", "-o", "report.json"]);
    assert_fails(&out, INPUT, &["empty.stl"]);
    assert_eq!(listing(dir.path()), ["empty.stl"]);
    assert!(out.stdout.is_empty());
}

// ---------------------------------------------------------------------------------------------
// Bad options: exit code 2, the option named

#[test]
fn zero_demolding_vector() {
    let out = moldgate(
        &std::env::temp_dir(),
        &["locate", "--sample", "plate", "--demold", "0,0,0"],
    );
    assert_fails(&out, USAGE, &["--demold", "non-zero", "(0, 0, 0)"]);
}

#[test]
fn unreadable_demolding_direction() {
    for text in ["up", "1,2", "x,y,z", "1,2,3,4", "+w", ""] {
        let out = moldgate(
            &std::env::temp_dir(),
            &["locate", "--sample", "plate", "--demold", text],
        );
        assert_fails(
            &out,
            USAGE,
            &["--demold", &format!("cannot read direction '{text}'")],
        );
    }
}

#[test]
fn non_positive_material_parameters() {
    for (flag, value, parameter) in [
        ("--n", "0", "n must be"),
        ("--n", "-0.3", "n must be"),
        ("--k", "-1", "k must be"),
        ("--k", "0", "k must be"),
        ("--gamma-opt", "0", "gamma_opt must be"),
        ("--mu-opt", "-9.88", "mu_opt must be"),
        ("--mu-opt", "nan", "mu_opt must be"),
        ("--t-melt", "inf", "t_melt must be"),
    ] {
        let out = moldgate(
            &std::env::temp_dir(),
            &["locate", "--sample", "plate", flag, value],
        );
        assert_fails(&out, USAGE, &["material 'PP (modified)'", parameter]);
    }
}

#[test]
fn melt_not_above_the_wall() {
    for args in [
        &["--t-melt", "40"][..],
        &["--t-melt", "100", "--t-wall", "200"],
        &["--t-wall", "230"],
        &["--t-melt", "-20", "--t-wall", "-10"],
    ] {
        let mut all = vec!["locate", "--sample", "plate"];
        all.extend_from_slice(args);
        let out = moldgate(&std::env::temp_dir(), &all);
        assert_fails(&out, USAGE, &["melt temperature", "must be above the wall"]);
    }
}

#[test]
fn non_positive_lengths_and_counts() {
    for (args, says) in [
        (
            &["--gate-radius", "0"][..],
            "--gate-radius must be a positive",
        ),
        (
            &["--gate-radius", "-1.5"],
            "--gate-radius must be a positive",
        ),
        (&["--spacing", "0"], "--spacing must be a positive"),
        (&["--spacing", "-2"], "--spacing must be a positive"),
        (
            &["--circle-points", "2"],
            "--circle-points must be at least 3",
        ),
        (
            &["--flat-tol", "-0.1"],
            "--flat-tol must be zero or positive",
        ),
        (
            &["--grid-offset", "inf"],
            "--grid-offset must be a fraction of the spacing",
        ),
        (
            &["--grid-offset", "1"],
            "--grid-offset must be a fraction of the spacing, above -1 and below 1, got 1",
        ),
        (&["--max-nodes", "0"], "--max-nodes must be between 1 and"),
        // Clap's own errors are one line too.
        (&["--n", "abc"], "invalid value 'abc' for '--n"),
        // ... in plain words for a number that does not parse.
        (
            &["--n", "abc"],
            "invalid value 'abc' for '--n <N>': expected a number",
        ),
        (
            &["--gates", "1.5"],
            "invalid value '1.5' for '--gates <K>': expected a whole number",
        ),
        (
            &["--max-nodes", "99999999999999999999999"],
            "a whole number too large",
        ),
        (
            &["--jobs", "0"],
            "invalid value '0' for '--jobs <N>': expected a whole number from 1 to 1024, got 0",
        ),
        // A negative count or time is a value out of range, not an unknown flag.
        (
            &["--gates", "-1"],
            "invalid value '-1' for '--gates <K>': expected a whole number, not a negative one",
        ),
        (
            &["--jobs", "-2"],
            "expected a whole number from 1 to 1024, got -2",
        ),
        (
            &["--circle-points", "-3"],
            "expected a whole number, not a negative one",
        ),
        (&["--max-nodes", "-5"], "not a negative one"),
        // A pool of threads a machine can start in a moment.
        (
            &["--jobs", "65535"],
            "expected a whole number from 1 to 1024, got 65535",
        ),
        (&["--timeout", "-1"], "--timeout"),
        (
            &["--timeout", "-inf"],
            "--timeout must be a number of seconds from 0.001 to 86400 (a day), got -inf",
        ),
        (
            &["--no-such-option"],
            "unexpected argument '--no-such-option'",
        ),
        (
            &["--max-nodes", "18446744073709551615", "--spacing", "1e-6"],
            "--max-nodes must be between 1 and",
        ),
        (&["--units", "furlong"], "--units: unknown unit 'furlong'"),
    ] {
        let mut all = vec!["locate", "--sample", "plate"];
        all.extend_from_slice(args);
        let out = moldgate(&std::env::temp_dir(), &all);
        assert_fails(&out, USAGE, &[says]);
    }
}

#[test]
fn spacing_too_fine_suggests_a_spacing_that_works() {
    let out = moldgate(
        &std::env::temp_dir(),
        &["locate", "--sample", "plate", "--spacing", "1e-6"],
    );
    let line = assert_fails(&out, USAGE, &["spacing", "more than the limit of 4000000"]);
    let suggested = suggested_spacing(&line);
    assert!(suggested > 0.03 && suggested < 0.05, "{line}");
}

/// The spacing in "... use a spacing of at least X mm".
fn suggested_spacing(line: &str) -> f64 {
    let (_, tail) = line
        .split_once("use a spacing of at least ")
        .unwrap_or_else(|| panic!("no suggestion in: {line}"));
    tail.split_once(" mm")
        .map_or(tail, |(x, _)| x)
        .parse()
        .unwrap_or_else(|e| panic!("{e}: {line}"))
}

#[test]
fn suggested_minimum_spacing_is_accepted() {
    // Regression: the minimum was printed rounded to nearest, so on a 1 x 0.6 mm part with
    // --max-nodes 1024 it suggested 0.0250 mm, which gives 41 x 25 = 1025 nodes.
    let facets = box_facets([0.0; 3], [1.0, 0.6, 0.3]);
    let (dir, _) = part("small.stl", &binary_stl(&facets));
    for max_nodes in ["1024", "1577", "500", "3001"] {
        let out = moldgate(
            dir.path(),
            &[
                "locate",
                "small.stl",
                "--spacing",
                "1e-4",
                "--max-nodes",
                max_nodes,
            ],
        );
        let line = assert_fails(&out, USAGE, &["a spacing of 0.0001 mm", "at least"]);
        let suggested = suggested_spacing(&line);
        let again = moldgate(
            dir.path(),
            &[
                "locate",
                "small.stl",
                "--spacing",
                &suggested.to_string(),
                "--max-nodes",
                max_nodes,
                "--thickness-rule",
                "ignore",
                "--gate-radius",
                "0.05",
                "--json",
            ],
        );
        let report = json(&again);
        let nodes = report["counts"]["nodes"].as_u64().unwrap();
        assert!(nodes <= max_nodes.parse().unwrap(), "{nodes} nodes");
    }
}

#[test]
fn unknown_sample() {
    let out = moldgate(&std::env::temp_dir(), &["locate", "--sample", "teapot"]);
    let line = assert_fails(&out, USAGE, &["unknown sample 'teapot'"]);
    for name in SAMPLES {
        assert!(line.contains(name), "{line}");
    }
    let dir = tempfile::tempdir().unwrap();
    let out = moldgate(dir.path(), &["sample", "teapot", "-o", "teapot.stl"]);
    assert_fails(&out, USAGE, &["unknown sample 'teapot'"]);
    assert!(listing(dir.path()).is_empty());
}

#[test]
fn unknown_material() {
    let out = moldgate(
        &std::env::temp_dir(),
        &["locate", "--sample", "plate", "--material", "PA77"],
    );
    assert_fails(
        &out,
        USAGE,
        &["unknown material 'PA77'; closest: PA6, PA66, PA66-GF30"],
    );
}

#[test]
fn material_names_ignore_case_and_separators() {
    for spelling in ["pa66-gf30", "PA66 GF30", "pa66gf30"] {
        let report = json(&moldgate(
            &std::env::temp_dir(),
            &[
                "locate",
                "--sample",
                "plate",
                "--material",
                spelling,
                "--json",
            ],
        ));
        assert_eq!(report["material"]["name"], "PA66-GF30", "{spelling}");
        assert_eq!(report["material"]["max_flow_ratio"], 150.0);
    }
}

const MY_PP: &str =
    "[MyPP]\nn = 0.3\nt_melt = 230\nt_wall = 50\ngamma_opt = 10000\nmu_opt = 9.88\nk = 0.15\n";

#[test]
fn unknown_material_lists_the_user_materials_too() {
    let (dir, _) = part("materials.toml", MY_PP.as_bytes());
    let out = moldgate(
        dir.path(),
        &[
            "locate",
            "--sample",
            "plate",
            "--materials-file",
            "materials.toml",
            "--material",
            "MyPX",
        ],
    );
    assert_fails(&out, USAGE, &["unknown material 'MyPX'; closest: MyPP"]);
}

#[test]
fn the_summary_says_when_values_are_typical_of_a_family() {
    let summary = |material: &str| {
        assert_ok(&moldgate(
            &std::env::temp_dir(),
            &["locate", "--sample", "plate", "--material", material],
        ))
    };
    let peek = summary("peek");
    assert!(
        peek.contains(
            "material PEEK: gate radius 0.9278 mm (from the material) from typical high-temperature family values"
        ),
        "{peek}"
    );
    // The HTML report gives the same basis beside the material.
    let dir = tempfile::tempdir().unwrap();
    assert_ok(&moldgate(
        dir.path(),
        &[
            "locate",
            "--sample",
            "plate",
            "--material",
            "peek",
            "--report",
            "r.html",
        ],
    ));
    let html = std::fs::read_to_string(dir.path().join("r.html")).unwrap();
    assert!(
        html.contains("(Eq. 7), from typical high-temperature family values"),
        "no basis in the report's material row"
    );
    let dir = tempfile::tempdir().unwrap();
    assert_ok(&moldgate(
        dir.path(),
        &["locate", "--sample", "plate", "--report", "r.html"],
    ));
    let html = std::fs::read_to_string(dir.path().join("r.html")).unwrap();
    assert!(!html.contains("family values"));
    assert!(html.contains("from the centre of mass (the paper's gate: the qualifying node nearest the centre of mass)"));
    // The balanced strategy's gate is named so in the headline, not the grid's.
    assert_ok(&moldgate(
        dir.path(),
        &[
            "locate",
            "--sample",
            "plate",
            "--strategy",
            "balanced",
            "--report",
            "b.html",
        ],
    ));
    let html = std::fs::read_to_string(dir.path().join("b.html")).unwrap();
    assert!(html.contains("from the centre of mass (the balanced gate)"));
    // A layout's summary row gives every gate, not its first alone.
    assert_ok(&moldgate(
        dir.path(),
        &[
            "locate", "--sample", "plate", "--gates", "2", "--report", "g.html",
        ],
    ));
    let html = std::fs::read_to_string(dir.path().join("g.html")).unwrap();
    assert!(
        html.contains("<th>Gates</th><td>2 gates: ("),
        "the layout's row"
    );
    // The paper's values are Table 1's, not a family's.
    let pp = summary("PP");
    assert!(
        pp.contains("material PP: gate radius 1.4254 mm (from the material)\n"),
        "{pp}"
    );
    // Where the part lies, in the frame its gates and keep-outs are given in, is the
    // JSON's box.
    let json = assert_ok(&moldgate(
        &std::env::temp_dir(),
        &["locate", "--sample", "plate", "--json"],
    ));
    let m = &serde_json::from_str::<serde_json::Value>(&json).unwrap()["mesh"];
    let corner = |v: &serde_json::Value| {
        let c: Vec<String> = (0..3)
            .map(|i| format!("{:.3}", v[i].as_f64().unwrap()))
            .collect();
        format!("({})", c.join(", "))
    };
    let said = format!(
        "part box: {} to {} mm, size ",
        corner(&m["bounds_min"]),
        corner(&m["bounds_max"])
    );
    assert!(pp.contains(&said), "{said} in {pp}");
}

/// A user material of a built-in's name (ignoring case and separators) wins over it.
#[test]
fn user_material_overrides_a_built_in() {
    let text = MY_PP.replace("[MyPP]", "[\"pa-66\"]");
    let (dir, _) = part("materials.toml", text.as_bytes());
    let args = [
        "locate",
        "--sample",
        "plate",
        "--materials-file",
        "materials.toml",
        "--material",
        "PA66",
        "--json",
    ];
    let report = json(&moldgate(dir.path(), &args));
    assert_eq!(report["material"]["name"], "pa-66");
    assert_eq!(report["material"]["n"], 0.3);
    let listed = assert_ok(&moldgate(
        dir.path(),
        &["materials", "--materials-file", "materials.toml"],
    ));
    let rows: Vec<&str> = listed
        .lines()
        .filter(|l| l.starts_with("PA66") || l.starts_with("pa-66"))
        .collect();
    assert_eq!(rows.len(), 2, "{listed}");
    assert!(
        rows[0].starts_with("pa-66 ") && rows[0].contains(" user "),
        "{listed}"
    );
    assert!(rows[1].starts_with("PA66-GF30 "), "{listed}");
}

#[test]
fn materials_file_is_used() {
    let (dir, _) = part("materials.toml", MY_PP.as_bytes());
    let args = [
        "locate",
        "--sample",
        "plate",
        "--materials-file",
        "materials.toml",
        "--material",
        "mypp",
        "--json",
    ];
    let report = json(&moldgate(dir.path(), &args));
    assert_eq!(report["material"]["name"], "MyPP");
    assert_eq!(report["material"]["n"], 0.3);
    let listed = assert_ok(&moldgate(
        dir.path(),
        &["materials", "--materials-file", "materials.toml"],
    ));
    assert!(listed.lines().any(|l| l.starts_with("MyPP ")), "{listed}");
}

/// A materials file holds option values, so the README lists a bad one under code 2.
#[test]
fn malformed_materials_file_names_the_file_and_line() {
    let unknown_field = format!("{MY_PP}colour = 1\n");
    let cases = [
        // A key without a value on line 3.
        (
            "[MyPP]\nn = 0.3\ngarbage\nt_wall = 50\n",
            "line 3",
            "no value",
        ),
        // An extra '=' on line 3.
        ("[MyPP]\nn = 0.3\nt_melt = = 230\n", "line 3", "="),
        // Regression: an error at the start of line 8 was reported on line 7.
        (unknown_field.as_str(), "line 8", "unknown field `colour`"),
        // A value of the wrong type on line 2.
        ("[MyPP]\nn = \"thick\"\n", "line 2", ""),
    ];
    for (text, line, says) in cases {
        let (dir, _) = part("materials.toml", text.as_bytes());
        for args in [
            &[
                "locate",
                "--sample",
                "plate",
                "--materials-file",
                "materials.toml",
            ][..],
            &["materials", "--materials-file", "materials.toml"],
        ] {
            let out = moldgate(dir.path(), args);
            assert_fails(&out, USAGE, &["materials.toml: ", line, says]);
        }
    }
}

#[test]
fn a_materials_file_that_is_not_utf8_names_its_line_and_byte() {
    let (dir, _) = part("materials.toml", b"[MyPP]\nn = 0.3\n# caf\xe9\n");
    for args in [
        &[
            "locate",
            "--sample",
            "plate",
            "--materials-file",
            "materials.toml",
        ][..],
        &["materials", "--materials-file", "materials.toml"],
    ] {
        let out = moldgate(dir.path(), args);
        assert_fails(
            &out,
            USAGE,
            &["materials.toml: line 3: not UTF-8 text (byte 20 of the file)"],
        );
    }
}

#[test]
fn extreme_material_parameters_name_the_material_and_read_short() {
    // Each parameter in range, the gate radius of Eq. 7-8 not: the material is named.
    let text = MY_PP.replace("k = 0.15", "k = 1e308");
    let (dir, _) = part("materials.toml", text.as_bytes());
    let out = moldgate(
        dir.path(),
        &[
            "locate",
            "--sample",
            "plate",
            "--materials-file",
            "materials.toml",
            "--material",
            "MyPP",
        ],
    );
    assert_fails(
        &out,
        USAGE,
        &[
            "materials.toml",
            "material 'MyPP'",
            "an infinite gate radius",
        ],
    );
    // A huge option value is written in a few characters.
    let out = moldgate(
        dir.path(),
        &["locate", "--sample", "plate", "--t-wall", "1e308"],
    );
    assert_eq!(out.status.code(), Some(USAGE), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("1e308") && stderr(&out).len() < 300,
        "{}",
        stderr(&out)
    );
}

#[test]
fn timeout_stops_a_long_study_with_exit_code_6() {
    let dir = tempfile::tempdir().unwrap();
    let out = moldgate(
        dir.path(),
        &[
            "locate",
            "--sample",
            "cover",
            "--gates",
            "8",
            "--cell",
            "0.3",
            "--suitability",
            "--timeout",
            "0.2",
        ],
    );
    assert_fails(
        &out,
        TIMEOUT,
        &["stopped at --timeout 0.2 s, in the fill stage"],
    );
    for bad in ["0", "-1", "nan", "inf"] {
        let flag = format!("--timeout={bad}");
        let out = moldgate(dir.path(), &["locate", "--sample", "plate", &flag]);
        assert_fails(&out, USAGE, &["--timeout must be"]);
    }
    // A study that ends in time is unchanged by the limit.
    let out = moldgate(
        dir.path(),
        &["locate", "--sample", "plate", "--timeout", "600"],
    );
    assert_eq!(out.status.code(), Some(OK), "{}", stderr(&out));
}

#[test]
fn materials_file_with_an_invalid_value() {
    let text = MY_PP.replace("k = 0.15", "k = -0.15");
    let (dir, _) = part("materials.toml", text.as_bytes());
    let out = moldgate(
        dir.path(),
        &[
            "locate",
            "--sample",
            "plate",
            "--materials-file",
            "materials.toml",
        ],
    );
    assert_fails(
        &out,
        USAGE,
        &["materials.toml", "material 'MyPP'", "k must be"],
    );
}

#[test]
fn missing_materials_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = moldgate(
        dir.path(),
        &[
            "locate",
            "--sample",
            "plate",
            "--materials-file",
            "none.toml",
        ],
    );
    // A file that is not there is a missing input file, whatever it holds.
    assert_fails(&out, INPUT, &["none.toml", "cannot open"]);
}

#[test]
fn clap_usage_errors_exit_with_code_2() {
    // Missing or conflicting arguments are clap's to report (with a usage line), but the
    // exit code is still the documented one and nothing panics.
    let dir = tempfile::tempdir().unwrap();
    for args in [
        &["locate"][..],
        &["locate", "a.stl", "--sample", "plate"],
        &["locate", "--sample", "plate", "--n", "thick"],
        &["locate", "--sample", "plate", "--centre", "middle"],
        &["sample", "plate"],
        &["frobnicate"],
    ] {
        let out = moldgate(dir.path(), args);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(USAGE), "{args:?}: {err}");
        assert!(err.contains("error"), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}

// ---------------------------------------------------------------------------------------------
// No gate: exit code 4 with the reason

#[test]
fn no_node_qualifies_on_a_thin_plate_with_a_large_gate() {
    let plate = box_facets([0.0; 3], [100.0, 60.0, 0.5]);
    let (dir, _) = part("thin.stl", &binary_stl(&plate));
    let out = moldgate(dir.path(), &["locate", "thin.stl", "--gate-radius", "5"]);
    assert_fails(
        &out,
        NO_GATE,
        &[
            "thin.stl: no node qualifies for a gate",
            "0 of those have walls thicker than 5.000 mm",
        ],
    );
    // The summary still goes to stdout, saying why.
    assert!(stdout(&out).contains("no gate: "), "{}", stdout(&out));

    let out = moldgate(
        dir.path(),
        &[
            "locate",
            "thin.stl",
            "--gate-radius",
            "5",
            "--json",
            "-o",
            "r.json",
        ],
    );
    assert_fails(&out, NO_GATE, &["thin.stl"]);
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(report["gate"].is_null());
    assert!(report["no_gate_reason"]
        .as_str()
        .unwrap()
        .contains("no node qualifies"));
    assert_eq!(report["counts"]["qualifying"], 0);
    let written: Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("r.json")).unwrap()).unwrap();
    assert_eq!(written["no_gate_reason"], report["no_gate_reason"]);
}

// ---------------------------------------------------------------------------------------------
// Output safety

#[test]
fn output_over_the_input_is_refused() {
    let bytes = binary_stl(&block());
    let (dir, path) = part("part.stl", &bytes);
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    for output in ["part.stl", "./part.stl", "sub/../part.stl"] {
        let out = moldgate(dir.path(), &["locate", "part.stl", "-o", output]);
        assert_fails(&out, OUTPUT, &[output, "refusing to write", "input"]);
        assert_eq!(std::fs::read(&path).unwrap(), bytes, "-o {output}");
        assert!(out.stdout.is_empty());
    }
    assert_eq!(listing(dir.path()), ["part.stl", "sub"]);
}

#[test]
fn output_into_a_missing_folder_fails_and_leaves_nothing() {
    let (dir, _) = part("part.stl", &binary_stl(&block()));
    let out = moldgate(
        dir.path(),
        &["locate", "part.stl", "-o", "no/such/folder/report.json"],
    );
    assert_fails(
        &out,
        OUTPUT,
        &["no/such/folder/report.json", "cannot write"],
    );
    assert_eq!(listing(dir.path()), ["part.stl"]);
    assert!(!dir.path().join("no").exists());

    let out = moldgate(dir.path(), &["sample", "plate", "-o", "missing/plate.stl"]);
    assert_fails(&out, OUTPUT, &["missing/plate.stl", "cannot write"]);
    assert_eq!(listing(dir.path()), ["part.stl"]);
}

#[test]
fn output_onto_a_folder_fails() {
    let (dir, _) = part("part.stl", &binary_stl(&block()));
    std::fs::create_dir(dir.path().join("report.json")).unwrap();
    let out = moldgate(dir.path(), &["locate", "part.stl", "-o", "report.json"]);
    assert_fails(&out, OUTPUT, &["report.json", "folder"]);
    assert_eq!(listing(dir.path()), ["part.stl", "report.json"]);
    assert!(listing(&dir.path().join("report.json")).is_empty());
}

#[test]
fn output_is_written_whole_as_json_without_temporary_files() {
    let (dir, _) = part("part.stl", &binary_stl(&block()));
    // An older, longer report in the way is replaced whole.
    std::fs::write(dir.path().join("out.json"), "x".repeat(100_000)).unwrap();
    let out = moldgate(dir.path(), &["locate", "part.stl", "-o", "out.json"]);
    let summary = assert_ok(&out);
    assert!(summary.contains("GATE (paper)"), "{summary}");
    assert_eq!(listing(dir.path()), ["out.json", "part.stl"]);

    let text = std::fs::read_to_string(dir.path().join("out.json")).unwrap();
    let report: Value = serde_json::from_str(&text).unwrap();
    assert_eq!(report["schema_version"], 3);
    assert_eq!(report["input"]["path"], "part.stl");
    assert_eq!(report["input"]["bytes"], 84 + 12 * 50);
    assert_eq!(report["mesh"]["format"], "stl_binary");
    assert_eq!(report["mesh"]["vertices"], 8);
    assert_eq!(report["gate"]["mode"], "paper");
    let gate = point(&report["gate"]["point"]);
    assert_eq!(gate, point(&report["paper_gate"]["point"]));
    // The gate is on the top face of the 40 x 30 x 10 block, under the centre.
    assert!((gate[2] - 10.0).abs() < 1e-9, "{gate:?}");
    assert!(
        (gate[0] - 20.0).abs() <= 1.0 && (gate[1] - 15.0).abs() <= 1.0,
        "{gate:?}"
    );
    assert_eq!(point(&report["paper_gate"]["normal"]), [0.0, 0.0, 1.0]);
    assert!(report["no_gate_reason"].is_null());
    let distance = report["gate"]["distance_3d_mm"].as_f64().unwrap();
    assert!((distance - 5.0).abs() <= 1.0, "{distance}");
}

#[test]
fn json_on_stdout_matches_the_summary() {
    let (dir, _) = part("part.stl", ascii(&block()).as_bytes());
    let report = json(&moldgate(dir.path(), &["locate", "part.stl", "--json"]));
    assert_eq!(report["schema_version"], 3);
    assert_eq!(report["mesh"]["format"], "stl_ascii");
    assert_eq!(report["mesh"]["units"], "mm");
    assert_eq!(
        report["options"]["demold"],
        serde_json::json!([0.0, 0.0, 1.0])
    );
    assert_eq!(report["material"]["name"], "PP");
    assert!(report["warnings"].as_array().unwrap().is_empty());
    let gate = point(&report["gate"]["point"]);

    let summary = assert_ok(&moldgate(dir.path(), &["locate", "part.stl"]));
    let shown = format!(
        "GATE (paper): ({:.3}, {:.3}, {:.3}) mm",
        gate[0], gate[1], gate[2]
    );
    assert!(summary.contains(&shown), "{shown} not in {summary}");
}

#[test]
fn units_metres_scale_the_part_and_millimetres_warn() {
    // The 40 x 30 x 10 mm block written in metres.
    let facets = box_facets([0.0; 3], [0.04, 0.03, 0.01]);
    let (dir, _) = part("metres.stl", &binary_stl(&facets));
    let report = json(&moldgate(
        dir.path(),
        &["locate", "metres.stl", "--units", "m", "--json"],
    ));
    assert_eq!(report["mesh"]["units"], "m");
    let max = point(&report["mesh"]["bounds_max"]);
    for (got, want) in max.iter().zip([40.0, 30.0, 10.0]) {
        assert!((got - want).abs() < 1e-4, "{max:?}");
    }
    assert!(report["gate"].is_object());

    let out = moldgate(dir.path(), &["locate", "metres.stl", "--json"]);
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    let warnings = report["warnings"].to_string();
    assert!(
        warnings.contains("if the file is in metres, set its units to m (--units)"),
        "{warnings}"
    );
}

#[test]
fn a_written_sample_gives_the_same_gate_as_the_built_in_one() {
    let dir = tempfile::tempdir().unwrap();
    for name in SAMPLES {
        let file = format!("{name}.stl");
        let out = moldgate(dir.path(), &["sample", name, "-o", &file]);
        assert_ok(&out);
        assert!(stderr(&out).contains(&format!("wrote {file}")));
        let from_file = json(&moldgate(dir.path(), &["locate", &file, "--json"]));
        let built_in = json(&moldgate(
            dir.path(),
            &["locate", "--sample", name, "--json"],
        ));
        assert_eq!(from_file["mesh"]["format"], "stl_binary");
        assert_eq!(built_in["mesh"]["format"], "generated");
        assert_eq!(
            from_file["mesh"]["triangles"],
            built_in["mesh"]["triangles"]
        );
        assert_eq!(
            from_file["paper_gate"]["node"], built_in["paper_gate"]["node"],
            "{name}"
        );
        // The file stores f32 coordinates, so points agree to f32 precision.
        let a = point(&from_file["gate"]["point"]);
        let b = point(&built_in["gate"]["point"]);
        for k in 0..3 {
            assert!((a[k] - b[k]).abs() < 1e-4, "{name}: {a:?} vs {b:?}");
        }
    }
    let mut expected: Vec<String> = SAMPLES.iter().map(|n| format!("{n}.stl")).collect();
    expected.sort();
    assert_eq!(listing(dir.path()), expected, "no temporary files are left");
}

#[test]
fn sample_list_names_every_sample() {
    let listed = assert_ok(&moldgate(&std::env::temp_dir(), &["sample", "--list"]));
    let names: Vec<&str> = listed
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .collect();
    assert_eq!(names, SAMPLES);
}

#[test]
fn materials_lists_the_built_in_materials() {
    let listed = assert_ok(&moldgate(&std::env::temp_dir(), &["materials"]));
    let rows: Vec<Vec<&str>> = listed
        .lines()
        .skip(1)
        .map(|l| l.split_whitespace().collect())
        .collect();
    assert!(rows.len() >= 20, "{listed}");
    let names: Vec<&str> = rows.iter().map(|r| r[0]).collect();
    assert_eq!(names[..3], ["PP", "ABS", "PC"]);
    // The second column is Eq. 8's gate radius: the paper's Table 1 gives these unrounded.
    for (row, exact) in rows.iter().zip([1.4254, 1.9154, 1.4615]) {
        assert_eq!(row[1].parse::<f64>().unwrap(), exact, "{row:?}");
        assert_eq!(row[3], "paper", "{row:?}");
    }
    for row in &rows[3..] {
        assert_eq!(row[3], "typical", "{row:?}");
        let r: f64 = row[1].parse().unwrap();
        assert!((0.3..=4.0).contains(&r), "{row:?}");
        assert!(row[2].parse::<f64>().unwrap() > 0.0, "{row:?}");
    }
}

#[test]
fn materials_json_gives_every_value_with_its_source() {
    let listing = json(&moldgate(&std::env::temp_dir(), &["materials", "--json"]));
    assert_eq!(listing["schema_version"], 1);
    let materials = listing["materials"].as_array().unwrap();
    assert!(materials.len() >= 20);
    for m in materials {
        for parameter in [
            "n",
            "t_melt",
            "t_wall",
            "gamma_opt",
            "mu_opt",
            "k",
            "max_flow_ratio",
        ] {
            assert!(m[parameter].as_f64().unwrap() > 0.0, "{m}");
            let source = m["sources"][parameter].as_str().unwrap();
            assert!(!source.is_empty(), "{m}");
        }
        assert!(m["typical"].is_boolean() && m["family"].is_string(), "{m}");
        assert_eq!(m["origin"], "built-in");
    }
    let pc = &materials[2];
    assert_eq!(pc["name"], "PC");
    assert_eq!(pc["sources"]["mu_opt"], "the paper, Table 1");
    assert!((pc["gate_radius_mm"].as_f64().unwrap() - 1.4615).abs() < 1e-4);
}

/// docs/materials.md shows the library as `moldgate materials` prints it.
#[test]
fn materials_doc_matches_the_library() {
    let doc = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../docs/materials.md"
    ))
    .unwrap();
    let start = doc
        .find("<!-- materials table: begin -->\n```text\n")
        .unwrap();
    let block = &doc[start..];
    let block = &block[block.find("```text\n").unwrap() + 8..block.find("```\n<!--").unwrap()];
    let listed = assert_ok(&moldgate(&std::env::temp_dir(), &["materials"]));
    assert_eq!(
        block, listed,
        "regenerate the table of docs/materials.md with `moldgate materials`"
    );
}

/// The JSON report of `locate --sample cover --aesthetic` with `more` options.
fn aesthetic_cover(more: &[&str]) -> Value {
    let mut args = vec!["locate", "--sample", "cover", "--aesthetic", "--json"];
    args.extend_from_slice(more);
    json(&moldgate(&std::env::temp_dir(), &args))
}

#[test]
fn aesthetic_mode_gives_the_parting_line_gate() {
    let report = aesthetic_cover(&["--demold", "-z"]);
    assert_eq!(report["options"]["mode"], "aesthetic");
    assert_eq!(report["gate"]["mode"], "aesthetic");
    let gate = point(&report["gate"]["point"]);
    assert_eq!(gate, point(&report["aesthetic_gate"]["point"]));
    assert_ne!(gate, point(&report["paper_gate"]["point"]));
    // The cover is open to -z, demolded towards its opening: its parting line is the rim
    // at z = 0.
    assert!(gate[2].abs() < 1e-9, "{gate:?}");
    // Demolded the other way (its closed face towards +D), the fixed half forms its walls
    // and the line runs round its top, at z = 30.
    let gate = point(&aesthetic_cover(&[])["gate"]["point"]);
    assert!((gate[2] - 30.0).abs() < 1e-9, "{gate:?}");

    let summary = assert_ok(&moldgate(
        &std::env::temp_dir(),
        &["locate", "--sample", "cover", "--aesthetic"],
    ));
    assert!(summary.contains("GATE (aesthetic)"), "{summary}");
}

#[test]
fn parting_line_rule_is_chosen_by_flag() {
    // Both rules give the cover's rim at z = 0, closed, 400 mm.
    for rule in ["longest", "outline"] {
        let report = aesthetic_cover(&["--demold", "-z", "--parting-line", rule]);
        let line = &report["parting_line"];
        assert!(
            (line["length_mm"].as_f64().unwrap() - 400.0).abs() < 1e-9,
            "{rule}: {line}"
        );
        assert_eq!(line["closed"], true, "{rule}");
        assert!(point(&report["gate"]["point"])[2].abs() < 1e-9, "{rule}");
    }
    let out = moldgate(
        &std::env::temp_dir(),
        &["locate", "--sample", "cover", "--parting-line", "widest"],
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--parting-line"));
}

#[test]
fn a_closed_stdout_is_not_a_crash() {
    // Regression: `moldgate materials | head -0` panicked in print!. The reader is closed
    // before the child writes (it has to start first), so its write fails with a broken pipe.
    for args in [
        &["materials"][..],
        &["sample", "--list"],
        &["locate", "--sample", "tray"],
        &["locate", "--sample", "tray", "--json"],
    ] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_moldgate"))
            .args(args)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take());
        let out = child.wait_with_output().unwrap();
        let err = stderr(&out);
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert_eq!(out.status.code(), Some(OK), "{args:?}: {err}");
        assert!(err.is_empty(), "{args:?}: {err}");
    }
}

// ---------------------------------------------------------------------------------------------
// --demold auto and --wall-thickness

#[test]
fn demold_auto_picks_the_open_side_and_reports_every_direction() {
    let dir = tempfile::tempdir().unwrap();
    let r = json(&moldgate(
        dir.path(),
        &[
            "locate",
            "--sample",
            "cover",
            "--demold",
            "auto",
            "--wall-thickness",
            "--json",
        ],
    ));
    assert_eq!(point(&r["options"]["demold"]), [0.0, 0.0, -1.0]);
    let auto = &r["demold_auto"];
    let tried = auto["tried"].as_array().unwrap();
    assert!(tried.len() >= 3);
    let chosen = &tried[auto["chosen"].as_u64().unwrap() as usize];
    assert_eq!(chosen["area_mm2"].as_f64(), Some(0.0));
    assert!(tried.iter().any(|c| c["area_mm2"].as_f64().unwrap() > 0.0));
    let w = &r["wall_thickness"];
    assert!(
        (w["nominal_mm"].as_f64().unwrap() - 2.0).abs() < 1e-3,
        "{w}"
    );
    assert!(w["at_gate_mm"].as_f64().is_some(), "{w}");
    // Without the options, neither field is in the report.
    let r = json(&moldgate(
        dir.path(),
        &["locate", "--sample", "cover", "--json"],
    ));
    assert!(r.get("demold_auto").is_none() && r.get("wall_thickness").is_none());
}

#[test]
fn demold_auto_warns_when_every_direction_has_undercuts() {
    // A block with a side pocket open on +x and a through slot along x: along x the slot's
    // walls slide, but a second pocket open on +y makes every axis have some undercut.
    let mut facets = Vec::new();
    let mut part = moldgate::samples::BoxUnion::default();
    part.add([0.0, 0.0, 0.0], [40.0, 40.0, 20.0]);
    part.subtract([30.0, 10.0, 7.0], [40.0, 30.0, 13.0]);
    part.subtract([10.0, 30.0, 7.0], [30.0, 40.0, 13.0]);
    part.subtract([0.0, 15.0, 2.0], [20.0, 25.0, 4.0]);
    let mesh = part.mesh();
    for t in 0..mesh.triangles.len() {
        facets.push(mesh.corners(t).map(|v| v.as_vec3().to_array()));
    }
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("undercut.stl"), binary_stl(&facets)).unwrap();
    let out = moldgate(
        dir.path(),
        &[
            "locate",
            "undercut.stl",
            "--demold",
            "auto",
            "--thickness-rule",
            "ignore",
        ],
    );
    let text = assert_ok(&out);
    assert!(text.contains("no direction without undercuts"), "{text}");
    assert!(
        text.contains("demold auto: undercut of each direction tried"),
        "{text}"
    );
}

// ---------------------------------------------------------------------------------------------
// The largest gate radius that fits

#[test]
fn cap_too_thin_for_the_gate_gets_the_largest_radius_that_fits() {
    // The cap's wall is 1.6 mm: a 2.5 mm gate fails the thickness rule, and the bisection
    // (from 0.25 mm, 8 steps of (2.5 - 0.25) / 256 = 0.0088 mm) finds just under 1.6 mm.
    let dir = tempfile::tempdir().unwrap();
    let args = ["locate", "--sample", "cap", "--gate-radius", "2.5"];
    let out = moldgate(dir.path(), &args);
    assert_fails(
        &out,
        NO_GATE,
        &["largest gate radius that fits is 1.5", "--fit-radius"],
    );
    let text = stdout(&out);
    assert!(
        text.contains("largest gate radius that fits: 1.5"),
        "{text}"
    );
    // Why: the thickest wall under a disc wholly on the cap is its 1.6 mm wall.
    assert!(
        text.contains(
            "at R_gate = 2.500 mm every disc wholly on the part sits on a wall of at most 1.600 mm"
        ),
        "{text}"
    );
    let out = moldgate(dir.path(), &[&args[..], &["--json"]].concat());
    assert_fails(&out, NO_GATE, &["walls thicker than 2.500 mm"]);
    let r: Value = serde_json::from_str(&stdout(&out)).unwrap();
    assert!(r["gate"].is_null());
    let fit = &r["radius_fit"];
    let radius = fit["radius_mm"].as_f64().unwrap();
    assert!(radius < 1.6 && radius > 1.6 - 0.0088, "{fit}");
    assert_eq!(fit["refused_mm"].as_f64(), Some(2.5));
    let thickest = fit["thickest_wall_mm"].as_f64().unwrap();
    assert!((thickest - 1.6).abs() < 1e-6, "{fit}");
    assert!(fit["reason"]
        .as_str()
        .unwrap()
        .contains("(the thickest 1.600 mm; any thicker wall is too narrow for the disc)"));
    assert!(fit["reason"]
        .as_str()
        .unwrap()
        .contains("walls thicker than 2.500 mm"));
    assert_eq!(fit["accepted"], false);
    assert!(r["no_gate_reason"]
        .as_str()
        .unwrap()
        .contains("--fit-radius"));
    // Taken: the gate is that one, the refusal a warning.
    let r = json(&moldgate(
        dir.path(),
        &[&args[..], &["--fit-radius", "--json"]].concat(),
    ));
    assert_eq!(r["gate"]["point"], fit["gate"]["point"]);
    assert_eq!(r["radius_fit"]["accepted"], true);
    assert!(r["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .any(|w| w.as_str().unwrap().contains("R_gate = 2.500 mm")));
    // The radius in force is the fitted one, so named: the report's and the picture's.
    assert_eq!(r["options"]["gate_radius_mm"], fit["radius_mm"]);
    assert_eq!(r["options"]["gate_radius_source"], "fitted");
    let taken = assert_ok(&moldgate(
        dir.path(),
        &[&args[..], &["--fit-radius", "--report", "fit.html"]].concat(),
    ));
    assert!(
        taken.contains(&format!(
            "gate radius {radius:.4} mm (the largest that fits, taken with --fit-radius"
        )),
        "{taken}"
    );
    // The node counts are the grid's at the refused radius, and say so (they end in "0
    // qualify" above a gate).
    assert!(
        taken.contains("nodes (at R_gate = 2.500 mm, before the fit): "),
        "{taken}"
    );
    let html = std::fs::read_to_string(dir.path().join("fit.html")).unwrap();
    assert!(
        html.contains(&format!("radius R = {radius:.3} mm")),
        "the headline's radius"
    );
    assert!(html.contains("Grid nodes through the rules (at R = 2.500 mm, before the fit)"));
}

#[cfg(target_os = "linux")]
#[test]
fn help_that_cannot_be_written_is_an_output_error() {
    // /dev/full takes no byte: --help, like every command's output, fails with code 5.
    for args in [&["--help"][..], &["locate", "--help"], &["--version"]] {
        let full = std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap();
        let out = Command::new(env!("CARGO_BIN_EXE_moldgate"))
            .args(args)
            .stdout(full)
            .stderr(Stdio::piped())
            .output()
            .unwrap();
        assert_fails(&out, 5, &["stdout: No space left on device"]);
    }
}

/// Facets wound against their neighbours, or all wound inwards, are turned round at load
/// and said: the box's volume and volume centre are the solid's (the inverted box read a
/// volume of -1000 mm^3, the one with two facets turned 666.7 with a centre off by 1 mm).
#[test]
fn facets_wound_the_wrong_way_are_turned_round_and_said() {
    let dir = tempfile::tempdir().unwrap();
    let right = box_facets([0.0, 0.0, 0.0], [20.0, 10.0, 5.0]);
    let turned = |f: &Facet| [f[0], f[2], f[1]];
    let inverted: Vec<Facet> = right.iter().map(turned).collect();
    let mut two: Vec<Facet> = right.clone();
    two[3] = turned(&two[3]);
    two[8] = turned(&two[8]);
    for (name, facets, said, count) in [
        (
            "inverted.stl",
            &inverted,
            "every facet was wound inwards",
            12,
        ),
        (
            "two.stl",
            &two,
            "2 facets were wound against their neighbours",
            2,
        ),
    ] {
        std::fs::write(dir.path().join(name), binary_stl(facets)).unwrap();
        let out = moldgate(
            dir.path(),
            &[
                "locate",
                name,
                "--centre",
                "volume",
                "--json",
                "--spacing",
                "1",
            ],
        );
        assert_eq!(out.status.code(), Some(OK), "{}", stderr(&out));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(v["mesh"]["reoriented_triangles"], count, "{name}");
        let volume = v["centre_of_mass"]["volume_mm3"].as_f64().unwrap();
        assert!((volume - 1000.0).abs() < 1e-6, "{name}: {volume}");
        let centre = &v["centre_of_mass"]["volume"];
        for (k, want) in [10.0, 5.0, 2.5].into_iter().enumerate() {
            assert!(
                (centre[k].as_f64().unwrap() - want).abs() < 1e-9,
                "{name}: {centre}"
            );
        }
        let warnings = v["warnings"].to_string();
        assert!(warnings.contains(said), "{name}: {warnings}");
    }
}

/// The volume centre of an open mesh is said to be the surface's closed across its holes,
/// not the solid's.
#[test]
fn the_volume_centre_of_an_open_mesh_is_warned() {
    let dir = tempfile::tempdir().unwrap();
    let mut facets = box_facets([0.0, 0.0, 0.0], [20.0, 10.0, 5.0]);
    facets.truncate(10);
    std::fs::write(dir.path().join("open.stl"), binary_stl(&facets)).unwrap();
    let out = moldgate(
        dir.path(),
        &["locate", "open.stl", "--centre", "volume", "--spacing", "1"],
    );
    let said = format!("{}{}", stdout(&out), stderr(&out));
    assert!(
        said.contains("the mesh is open (4 edges of one facet), so the volume centre of mass is that of the surface closed"),
        "{said}"
    );
}

/// The README's first run is what the command prints (all but its times).
#[test]
fn the_readmes_first_run_is_what_the_command_prints() {
    let readme = include_str!("../../../../README.md");
    let start = readme
        .find("$ moldgate locate --sample cover\n")
        .expect("the first run in the README")
        + "$ moldgate locate --sample cover\n".len();
    let block = &readme[start..start + readme[start..].find("```").expect("its end")];
    let dir = tempfile::tempdir().unwrap();
    let out = moldgate(dir.path(), &["locate", "--sample", "cover"]);
    let printed = stdout(&out);
    let without_times = |text: &str| -> Vec<String> {
        text.lines()
            .filter(|l| !l.starts_with("time:"))
            .map(str::to_string)
            .collect()
    };
    assert_eq!(without_times(block), without_times(&printed));
}

/// No layout of the gates asked for is named by its file, as every other error of a part.
#[test]
fn too_few_places_for_the_gates_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let facets = box_facets([0.0, 0.0, 0.0], [20.0, 10.0, 5.0]);
    std::fs::write(dir.path().join("box.stl"), binary_stl(&facets)).unwrap();
    let out = moldgate(
        dir.path(),
        &["locate", "box.stl", "--spacing", "30", "--gates", "2"],
    );
    assert_eq!(out.status.code(), Some(NO_GATE), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("error: box.stl: 2 gates asked for"),
        "{}",
        stderr(&out)
    );
}
