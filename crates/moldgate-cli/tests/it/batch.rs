//! `moldgate locate` on many parts: folders and lists of files, the per-part reports, the
//! JSON Lines and CSV summaries, the end report and exit code, order and thread independence,
//! per-part units and directions from a manifest, and bad output paths.
//!
//! Exit codes of a batch: the most serious of its parts, internal (1) > output (5) > input (3)
//! > option (2) > no gate (4); 0 when every part has a gate.

use std::path::Path;

use serde_json::Value;
use tempfile::TempDir;

use crate::common::*;

const SAMPLES: [&str; 5] = ["plate", "cover", "cap", "tray", "bracket"];

// ---------------------------------------------------------------------------------------------
// Running the binary

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn json_file(path: &Path) -> Value {
    serde_json::from_str(&read(path)).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn json_lines(text: &str) -> Vec<Value> {
    text.lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("not JSON ({e}): {l}")))
        .collect()
}

/// Removes what changes from run to run (times) from a report or a summary row.
fn without_times(mut v: Value) -> Value {
    if let Some(o) = v.as_object_mut() {
        o.remove("timings");
        o.remove("time_s");
    }
    v
}

/// A minimal RFC 4180 reader: records of fields, quotes honoured.
fn parse_csv(text: &str) -> Vec<Vec<String>> {
    let mut records = Vec::new();
    let mut record = Vec::new();
    let mut field = String::new();
    let mut quoted = false;
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        match (quoted, c) {
            (true, '"') if chars.peek() == Some(&'"') => {
                chars.next();
                field.push('"');
            }
            (true, '"') => quoted = false,
            (true, c) => field.push(c),
            (false, '"') => quoted = true,
            (false, ',') => record.push(std::mem::take(&mut field)),
            (false, '\r') => {}
            (false, '\n') => {
                record.push(std::mem::take(&mut field));
                records.push(std::mem::take(&mut record));
            }
            (false, c) => field.push(c),
        }
    }
    assert!(
        field.is_empty() && record.is_empty(),
        "CSV ends with a line break"
    );
    records
}

// ---------------------------------------------------------------------------------------------
// Building parts

/// A folder `parts/` holding the five samples, a thin plate (no gate: 0.5 mm wall, under
/// R_gate), three bad files, and things batch mode must not take (a text file, an STL in a
/// subfolder). Returns the temporary root.
fn mixed_folder() -> TempDir {
    let dir = tempfile::tempdir().unwrap();
    let parts = dir.path().join("parts");
    std::fs::create_dir_all(parts.join("sub")).unwrap();
    for s in SAMPLES {
        let out = moldgate(dir.path(), &["sample", s, "-o", &format!("parts/{s}.stl")]);
        assert_code(&out, OK);
    }
    let thin = box_facets([0.0; 3], [40.0, 30.0, 0.5]);
    std::fs::write(parts.join("thin.STL"), binary_stl(&thin)).unwrap();
    std::fs::write(parts.join("empty.stl"), b"").unwrap();
    let block = binary_stl(&box_facets([0.0; 3], [40.0, 30.0, 10.0]));
    std::fs::write(parts.join("truncated.stl"), &block[..block.len() - 20]).unwrap();
    std::fs::write(parts.join("words.stl"), b"solid x\nfacet normal oops\n").unwrap();
    std::fs::write(parts.join("notes.txt"), b"not a part").unwrap();
    std::fs::write(parts.join("sub/deeper.stl"), &block).unwrap();
    dir
}

/// The files of `mixed_folder` that batch mode takes, in its order (sorted by name, bytes).
const TAKEN: [&str; 9] = [
    "bracket.stl",
    "cap.stl",
    "cover.stl",
    "empty.stl",
    "plate.stl",
    "thin.STL",
    "tray.stl",
    "truncated.stl",
    "words.stl",
];
const BAD: [&str; 3] = ["empty.stl", "truncated.stl", "words.stl"];

// ---------------------------------------------------------------------------------------------
// A folder of good and bad parts

#[test]
fn folder_of_good_and_bad_parts() {
    let dir = mixed_folder();
    let root = dir.path();
    std::fs::create_dir(root.join("out")).unwrap();
    let out = moldgate(
        root,
        &[
            "locate",
            "parts",
            "--out-dir",
            "out",
            "--summary",
            "summary.jsonl",
        ],
    );
    // Bad input files outrank the part without a gate.
    assert_code(&out, INPUT);

    // The end report: one line per failed part, in input order, naming file and reason.
    let err = stderr(&out);
    let lines: Vec<&str> = err.lines().collect();
    let failed: Vec<&str> = TAKEN
        .iter()
        .copied()
        .filter(|f| BAD.contains(f) || *f == "thin.STL")
        .collect();
    assert_eq!(lines.len(), failed.len(), "{err}");
    for (line, file) in lines.iter().zip(&failed) {
        assert!(
            line.starts_with(&format!("moldgate: error: parts/{file}: ")),
            "{line}"
        );
    }

    // One report per analysed part, none for the bad files, no temporary files left.
    let mut expected: Vec<String> = TAKEN
        .iter()
        .filter(|f| !BAD.contains(f))
        .map(|f| f.split('.').next().unwrap().to_string() + ".json")
        .collect();
    expected.sort();
    assert_eq!(listing(&root.join("out")), expected);
    assert_eq!(
        listing(root),
        ["out", "parts", "summary.jsonl"].map(String::from)
    );

    // Each report is the one `moldgate locate FILE --json` gives.
    for s in SAMPLES {
        let single = moldgate(root, &["locate", &format!("parts/{s}.stl"), "--json"]);
        assert_code(&single, OK);
        let single: Value = serde_json::from_str(&stdout(&single)).unwrap();
        let batch = json_file(&root.join(format!("out/{s}.json")));
        assert_eq!(without_times(batch), without_times(single), "{s}");
    }
    let thin = json_file(&root.join("out/thin.json"));
    assert!(thin["gate"].is_null());
    assert!(thin["no_gate_reason"].is_string());

    // The summary: one row per input, in input order, agreeing with the reports.
    let rows = json_lines(&read(&root.join("summary.jsonl")));
    assert_eq!(rows.len(), TAKEN.len());
    for (row, file) in rows.iter().zip(TAKEN) {
        assert_eq!(row["file"], format!("parts/{file}"));
        assert_eq!(row["units"], "mm");
        assert_eq!(row["demold"], "+z");
        let status = row["status"].as_str().unwrap();
        if BAD.contains(&file) {
            assert_eq!(status, "input_error", "{row}");
            assert_eq!(row["exit_code"], INPUT);
            assert!(row["triangles"].is_null(), "{row}");
            let reason = row["error"].as_str().unwrap();
            assert!(
                !reason.starts_with("parts/"),
                "the path is not repeated: {reason}"
            );
            continue;
        }
        let report = json_file(&root.join(format!("out/{}.json", file.split('.').next().unwrap())));
        assert_eq!(row["triangles"], report["mesh"]["triangles"], "{file}");
        assert_eq!(row["nodes"], report["counts"]["nodes"], "{file}");
        assert_eq!(row["qualifying"], report["counts"]["qualifying"], "{file}");
        assert_eq!(row["circle_on_part"], report["counts"]["circle_on_part"]);
        assert_eq!(row["gate_radius_mm"], report["options"]["gate_radius_mm"]);
        assert!(row["time_s"].as_f64().unwrap() >= 0.0);
        if file == "thin.STL" {
            assert_eq!(status, "no_gate");
            assert_eq!(row["exit_code"], NO_GATE);
            assert_eq!(row["error"], report["no_gate_reason"]);
            assert!(row["gate_x_mm"].is_null());
        } else {
            assert_eq!(status, "ok", "{row}");
            assert_eq!(row["exit_code"], OK);
            assert!(row["error"].is_null());
            let gate = &report["gate"]["point"];
            assert_eq!(row["gate_x_mm"], gate[0], "{file}");
            assert_eq!(row["gate_y_mm"], gate[1], "{file}");
            assert_eq!(row["gate_z_mm"], gate[2], "{file}");
            assert_eq!(row["distance_mm"], report["gate"]["distance_3d_mm"]);
        }
    }

    // The human table: a header, one line per part in order, the count.
    let table = stdout(&out);
    let lines: Vec<&str> = table.lines().collect();
    assert_eq!(lines.len(), TAKEN.len() + 2, "{table}");
    for (line, file) in lines[1..].iter().zip(TAKEN) {
        assert!(line.starts_with(&format!("parts/{file} ")), "{line}");
    }
    assert_eq!(
        lines[TAKEN.len() + 1],
        "9 parts: 5 with a gate, 1 without, 3 failed"
    );
}

#[test]
fn csv_summary_holds_the_same_rows_as_json_lines() {
    let dir = mixed_folder();
    let root = dir.path();
    let a = moldgate(root, &["locate", "parts", "--summary", "s.csv", "--quiet"]);
    assert_code(&a, INPUT);
    let b = moldgate(root, &["locate", "parts", "--json", "--quiet"]);
    assert_code(&b, INPUT);
    let csv = parse_csv(&read(&root.join("s.csv")));
    let rows = json_lines(&stdout(&b));
    let header = &csv[0];
    assert_eq!(header[0], "file");
    assert_eq!(csv.len(), rows.len() + 1);
    for (record, row) in csv[1..].iter().zip(&rows) {
        assert_eq!(record.len(), header.len());
        let obj = row.as_object().unwrap();
        let mut keys: Vec<&String> = obj.keys().collect();
        let mut columns: Vec<&String> = header.iter().collect();
        keys.sort();
        columns.sort();
        assert_eq!(keys, columns, "the CSV columns are the JSON keys");
        for (name, text) in header.iter().zip(record) {
            let v = &obj[name];
            if name == "time_s" {
                assert!(text.parse::<f64>().is_ok());
                continue;
            }
            match v {
                Value::Null => assert_eq!(text, "", "{name}"),
                Value::String(s) => assert_eq!(text, s, "{name}"),
                Value::Number(n) => {
                    // The same f64 (serde_json's reader, without its float_roundtrip
                    // feature, may land one unit in the last place away).
                    let (a, b) = (text.parse::<f64>().unwrap(), n.as_f64().unwrap());
                    assert!(
                        (a - b).abs() <= 4.0 * f64::EPSILON * a.abs(),
                        "{name}: {a} {b}"
                    )
                }
                _ => panic!("unexpected value {v}"),
            }
        }
    }
    // Quiet: no closing count, and with --json no table at all.
    assert!(stderr(&a)
        .lines()
        .all(|l| l.starts_with("moldgate: error: ")));
    assert!(!stdout(&a).contains("parts:"));
}

// ---------------------------------------------------------------------------------------------
// Order and threads

#[test]
fn results_follow_the_input_order_not_the_finishing_order() {
    let dir = mixed_folder();
    let root = dir.path();
    let files: Vec<String> = TAKEN.iter().map(|f| format!("parts/{f}")).collect();
    let mut reversed = files.clone();
    reversed.reverse();
    let run = |list: &[String]| {
        let mut args = vec!["locate", "--json"];
        args.extend(list.iter().map(String::as_str));
        let out = moldgate(root, &args);
        assert_code(&out, INPUT);
        json_lines(&stdout(&out))
            .into_iter()
            .map(without_times)
            .collect::<Vec<_>>()
    };
    let forward = run(&files);
    let mut backward = run(&reversed);
    let names: Vec<&str> = backward
        .iter()
        .map(|r| r["file"].as_str().unwrap())
        .collect();
    let expected: Vec<&str> = reversed.iter().map(String::as_str).collect();
    assert_eq!(names, expected);
    backward.reverse();
    assert_eq!(forward, backward);
}

#[test]
fn one_thread_and_two_give_the_same_outputs() {
    let dir = mixed_folder();
    let root = dir.path();
    let mut summaries = Vec::new();
    for jobs in ["1", "2"] {
        let out_dir = format!("out{jobs}");
        std::fs::create_dir(root.join(&out_dir)).unwrap();
        let summary = format!("s{jobs}.jsonl");
        let out = moldgate(
            root,
            &[
                "locate",
                "parts",
                "--jobs",
                jobs,
                "--out-dir",
                &out_dir,
                "--summary",
                &summary,
            ],
        );
        assert_code(&out, INPUT);
        summaries.push(
            json_lines(&read(&root.join(&summary)))
                .into_iter()
                .map(without_times)
                .collect::<Vec<_>>(),
        );
    }
    assert_eq!(summaries[0], summaries[1]);
    let names = listing(&root.join("out1"));
    assert_eq!(names, listing(&root.join("out2")));
    assert_eq!(names.len(), 6);
    for name in names {
        let a = json_file(&root.join("out1").join(&name));
        let b = json_file(&root.join("out2").join(&name));
        assert_eq!(without_times(a), without_times(b), "{name}");
    }
    // The one-part-at-a-time schedule gives the same rows too.
    let out = moldgate(
        root,
        &["locate", "parts", "--json", "--schedule", "one-by-one"],
    );
    assert_code(&out, INPUT);
    let rows: Vec<Value> = json_lines(&stdout(&out))
        .into_iter()
        .map(without_times)
        .collect();
    assert_eq!(rows, summaries[0]);
}

#[test]
fn batch_outputs_do_not_go_with_a_sample() {
    let dir = tempfile::tempdir().unwrap();
    for flag in ["--out-dir", "--summary", "--manifest"] {
        let out = moldgate(dir.path(), &["locate", "--sample", "cover", flag, "x.csv"]);
        assert_fails(&out, USAGE, &["--sample"]);
    }
    // --jobs and --quiet are fine with one part.
    let out = moldgate(
        dir.path(),
        &[
            "locate", "--sample", "cover", "--jobs", "1", "--quiet", "--json",
        ],
    );
    assert_code(&out, OK);
}

#[test]
fn zero_jobs_is_a_usage_error() {
    let dir = mixed_folder();
    let out = moldgate(dir.path(), &["locate", "parts", "--jobs", "0"]);
    assert_fails(&out, USAGE, &["--jobs"]);
}

// ---------------------------------------------------------------------------------------------
// Exit codes when nothing is wrong with the inputs

#[test]
fn all_good_parts_exit_zero_and_print_nothing_on_stderr() {
    let dir = mixed_folder();
    let root = dir.path();
    let out = moldgate(root, &["locate", "parts/cap.stl", "parts/plate.stl"]);
    assert_code(&out, OK);
    // Not a terminal: no progress bar, no error lines.
    assert_eq!(stderr(&out), "");
    assert!(stdout(&out).ends_with("2 parts: 2 with a gate, 0 without, 0 failed\n"));
}

#[test]
fn only_a_missing_gate_exits_4() {
    let dir = mixed_folder();
    let root = dir.path();
    let out = moldgate(root, &["locate", "parts/cap.stl", "parts/thin.STL"]);
    assert_code(&out, NO_GATE);
    let err = stderr(&out);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.starts_with("moldgate: error: parts/thin.STL: "),
        "{err}"
    );
}

#[test]
fn a_missing_file_among_others_is_reported_and_the_rest_is_done() {
    let dir = mixed_folder();
    let root = dir.path();
    std::fs::create_dir(root.join("out")).unwrap();
    let out = moldgate(
        root,
        &["locate", "parts/cap.stl", "gone.stl", "--out-dir", "out"],
    );
    assert_code(&out, INPUT);
    assert!(
        stderr(&out).contains("gone.stl: cannot open"),
        "{}",
        stderr(&out)
    );
    assert_eq!(listing(&root.join("out")), ["cap.json"]);
}

// ---------------------------------------------------------------------------------------------
// Folders

#[test]
fn a_folder_without_stl_files_is_an_input_error() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("empty")).unwrap();
    std::fs::write(dir.path().join("empty/readme.txt"), b"x").unwrap();
    let out = moldgate(dir.path(), &["locate", "empty"]);
    assert_fails(&out, INPUT, &["empty", "no .stl, .obj or .ply file"]);
}

#[test]
fn one_folder_with_one_part_is_a_batch() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("one")).unwrap();
    assert_code(
        &moldgate(dir.path(), &["sample", "tray", "-o", "one/tray.stl"]),
        OK,
    );
    let out = moldgate(dir.path(), &["locate", "one", "--json"]);
    assert_code(&out, OK);
    let rows = json_lines(&stdout(&out));
    assert_eq!(rows.len(), 1);
    assert_eq!(rows[0]["file"], "one/tray.stl");
}

// ---------------------------------------------------------------------------------------------
// A manifest: units and direction per part

#[test]
fn manifest_gives_each_part_its_unit_and_direction() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    std::fs::create_dir(root.join("m")).unwrap();
    // The same 40 x 30 x 10 mm block, in millimetres and in inches.
    let mm = box_facets([0.0; 3], [40.0, 30.0, 10.0]);
    let inch = 25.4f32;
    let inches = box_facets([0.0; 3], [40.0 / inch, 30.0 / inch, 10.0 / inch]);
    std::fs::write(root.join("m/block_mm.stl"), binary_stl(&mm)).unwrap();
    std::fs::write(root.join("m/block_in.stl"), binary_stl(&inches)).unwrap();
    std::fs::write(
        root.join("m/parts.toml"),
        "# paths relative to this file\n\
         [[part]]\nfile = \"block_mm.stl\"\n\n\
         [[part]]\nfile = \"block_in.stl\"\nunits = \"in\"\n\n\
         [[part]]\nfile = \"block_mm.stl\"\ndemold = \"-z\"\n",
    )
    .unwrap();
    let out = moldgate(root, &["locate", "--manifest", "m/parts.toml", "--json"]);
    assert_code(&out, OK);
    let rows = json_lines(&stdout(&out));
    assert_eq!(rows.len(), 3);
    assert_eq!(rows[0]["file"], "m/block_mm.stl");
    assert_eq!(
        [&rows[0]["units"], &rows[1]["units"], &rows[2]["units"]],
        ["mm", "in", "mm"]
    );
    assert_eq!(
        [&rows[0]["demold"], &rows[1]["demold"], &rows[2]["demold"]],
        ["+z", "+z", "-z"]
    );
    let gate = |r: &Value| ["gate_x_mm", "gate_y_mm", "gate_z_mm"].map(|k| r[k].as_f64().unwrap());
    let (a, b, c) = (gate(&rows[0]), gate(&rows[1]), gate(&rows[2]));
    // Rays from +z land on the top face, from -z on the bottom face; the inch block read in
    // inches is the millimetre block (to f32 rounding of the file).
    assert!((a[2] - 10.0).abs() < 1e-9, "{a:?}");
    assert!(c[2].abs() < 1e-9, "{c:?}");
    for i in 0..3 {
        assert!((a[i] - b[i]).abs() < 1e-4, "{a:?} {b:?}");
    }
    // Seen from -z the grid's w axis is reversed, so of the two nodes tied nearest the centre
    // (y = 15 -+ 0.2) the other one has the lower index: the gates mirror about y = 15.
    assert!((a[0] - c[0]).abs() < 1e-9, "{a:?} {c:?}");
    assert!(((a[1] - 15.0) + (c[1] - 15.0)).abs() < 1e-9, "{a:?} {c:?}");
    // The command line's --units and --demold are the default of every part.
    let out = moldgate(
        root,
        &[
            "locate",
            "--manifest",
            "m/parts.toml",
            "--json",
            "--demold",
            "-z",
        ],
    );
    let rows = json_lines(&stdout(&out));
    assert_eq!(rows[0]["demold"], "-z");
    assert!(rows[1]["gate_z_mm"].as_f64().unwrap().abs() < 1e-4);
    // A part of the manifest may have its direction chosen (it was refused as no
    // direction), and a layout's every gate is in its row.
    std::fs::write(
        root.join("m/auto.toml"),
        "[[part]]\nfile = \"block_mm.stl\"\ndemold = \"auto\"\n",
    )
    .unwrap();
    let out = moldgate(
        root,
        &[
            "locate",
            "--manifest",
            "m/auto.toml",
            "--json",
            "--gates",
            "2",
        ],
    );
    assert_code(&out, OK);
    let rows = json_lines(&stdout(&out));
    let alone = moldgate(
        root,
        &[
            "locate",
            "m/block_mm.stl",
            "--demold",
            "auto",
            "--gates",
            "2",
            "--json",
        ],
    );
    let alone: Value = serde_json::from_str(&stdout(&alone)).unwrap();
    let chosen = rows[0]["demold"].as_str().unwrap();
    assert!(chosen.ends_with(" (auto)"), "{chosen}");
    assert_eq!(rows[0]["gate_x_mm"], alone["gate"]["point"][0]);
    assert_eq!(rows[0]["gates"], 2);
    let second: Vec<f64> = alone["gate"]["gates"][1]["point"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let said: Vec<f64> = rows[0]["other_gates_mm"]
        .as_str()
        .unwrap()
        .split(',')
        .map(|x| x.parse().unwrap())
        .collect();
    assert_eq!(said, second);
}

#[test]
fn a_part_stopped_at_its_timeout_is_a_timeout_row() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    std::fs::create_dir(root.join("m")).unwrap();
    let out = moldgate(root, &["sample", "cover", "-o", "m/cover.stl"]);
    assert_code(&out, OK);
    let heavy = ["--gates", "8", "--cell", "0.3", "--suitability"];
    let args = [&["locate", "m", "--json", "--timeout", "0.2"][..], &heavy].concat();
    let out = moldgate(root, &args);
    assert_code(&out, TIMEOUT);
    let rows = json_lines(&stdout(&out));
    assert_eq!(rows.len(), 1);
    let row = &rows[0];
    assert_eq!(row["status"], "timeout", "{row}");
    assert_eq!(row["exit_code"], 6, "{row}");
    let error = row["error"].as_str().unwrap();
    assert!(
        error.contains("stopped at --timeout 0.2 s, in the fill stage"),
        "{error}"
    );
    // A layout asked for and not found: no gate in the row (the method's is not the
    // answer asked for).
    assert!(row["gate_x_mm"].is_null(), "{row}");
    // Stopped in the fill stage, a study whose answer is the method's gate keeps it in its
    // row: the gate of the part located without the fill, and says so.
    let single = ["--fill", "--cell", "0.3", "--suitability"];
    let args = [&["locate", "m", "--json", "--timeout", "0.2"][..], &single].concat();
    let out = moldgate(root, &args);
    let row = &json_lines(&stdout(&out))[0];
    assert_eq!(row["status"], "timeout", "{row}");
    let error = row["error"].as_str().unwrap();
    assert!(error.contains("in the fill stage"), "{error}");
    let located = moldgate(root, &["locate", "m/cover.stl", "--json"]);
    let located: Value = serde_json::from_str(&stdout(&located)).unwrap();
    let gate = &located["gate"]["point"];
    for (k, axis) in ["gate_x_mm", "gate_y_mm", "gate_z_mm"].iter().enumerate() {
        assert_eq!(row[axis], gate[k], "{row}");
    }
    assert_eq!(row["gates"], 1, "{row}");
    assert!(
        error.contains("; the method's gate, found before the stop: ("),
        "{error}"
    );
    assert!(
        row["warnings"]
            .as_str()
            .unwrap()
            .contains("the fill analysis was stopped before its end"),
        "{row}"
    );
    // A balanced gate asked for and not found: no gate in the row either.
    let args = [
        &[
            "locate",
            "m",
            "--json",
            "--timeout",
            "0.2",
            "--strategy",
            "balanced",
        ][..],
        &single[1..],
    ]
    .concat();
    let out = moldgate(root, &args);
    let row = &json_lines(&stdout(&out))[0];
    assert_eq!(row["status"], "timeout", "{row}");
    assert!(row["gate_x_mm"].is_null(), "{row}");
    // No report is written for it: it is not the one asked for.
    let out_dir = root.join("reports");
    std::fs::create_dir(&out_dir).unwrap();
    let args = [
        &["locate", "m", "--out-dir", "reports", "--timeout", "0.2"][..],
        &single,
    ]
    .concat();
    assert_code(&moldgate(root, &args), TIMEOUT);
    assert_eq!(std::fs::read_dir(&out_dir).unwrap().count(), 0);
    // The hint names only what was asked for; the table's last line counts the stops.
    let args = [&["locate", "m", "--timeout", "0.2"][..], &heavy[..4]].concat();
    let out = moldgate(root, &args);
    assert_code(&out, TIMEOUT);
    let err = stderr(&out);
    assert!(
        err.contains("(a coarser --cell or fewer --gates take less time)"),
        "{err}"
    );
    assert!(
        stdout(&out)
            .contains("1 part: 0 with a gate, 0 without, 1 failed (1 stopped at --timeout)"),
        "{}",
        stdout(&out)
    );
    // A part stopped after its gate was located keeps it, and the last line says so.
    let args = [&["locate", "m", "--timeout", "0.2"][..], &single].concat();
    let out = moldgate(root, &args);
    assert_code(&out, TIMEOUT);
    assert!(
        stdout(&out).contains(
            "1 part: 0 with a gate, 0 without, 1 failed (1 stopped at --timeout, with the method's gate found before the stop)"
        ),
        "{}",
        stdout(&out)
    );
    // An option refused for every part is still an option error.
    let out = moldgate(root, &["locate", "m", "--json", "--gates", "0"]);
    assert_code(&out, USAGE);
}

#[test]
fn summary_says_the_direction_demold_auto_chose() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    std::fs::create_dir(root.join("m")).unwrap();
    // A 40 x 30 x 4 mm plate: every axis is free of undercut, z is the shallowest draw.
    std::fs::write(
        root.join("m/plate.stl"),
        binary_stl(&box_facets([0.0; 3], [40.0, 30.0, 4.0])),
    )
    .unwrap();
    let out = moldgate(root, &["locate", "m", "--json", "--demold", "auto"]);
    assert_code(&out, OK);
    let rows = json_lines(&stdout(&out));
    assert_eq!(rows.len(), 1);
    assert_eq!(rows[0]["demold"], "+z (auto)", "{}", rows[0]);
}

#[test]
fn bad_manifests_are_usage_errors_naming_the_place() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    std::fs::write(
        root.join("typo.toml"),
        "[[part]]\nfile = \"a.stl\"\nunit = \"in\"\n",
    )
    .unwrap();
    let out = moldgate(root, &["locate", "--manifest", "typo.toml"]);
    assert_fails(&out, USAGE, &["typo.toml", "line 3", "unit"]);

    std::fs::write(
        root.join("units.toml"),
        "[[part]]\nfile = \"a.stl\"\nunits = \"ft\"\n",
    )
    .unwrap();
    let out = moldgate(root, &["locate", "--manifest", "units.toml"]);
    assert_fails(
        &out,
        USAGE,
        &["units.toml: line 3: part 1 (a.stl): units: unknown unit 'ft'"],
    );

    std::fs::write(
        root.join("dir.toml"),
        "[[part]]\nfile = \"a.stl\"\ndemold = \"0,0,0\"\n",
    )
    .unwrap();
    let out = moldgate(root, &["locate", "--manifest", "dir.toml"]);
    assert_fails(&out, USAGE, &["dir.toml: line 3: part 1 (a.stl): demold"]);

    // A value of the wrong type names its line and its key; a single table where a list
    // of them is wanted, and an empty file name, are said as such.
    for (name, text, says) in [
        (
            "type.toml",
            "[[part]]\nfile = 3\n",
            "type.toml: line 2: file: got the number 3, expected a file path in quotes",
        ),
        (
            "single.toml",
            "[part]\nfile = \"a.stl\"\n",
            "single.toml: line 1: part: got a table, expected a list of tables ([[part]])",
        ),
        (
            "empty.toml",
            "[[part]]\nfile = \"\"\n",
            "empty.toml: line 2: part 1: file is empty",
        ),
        (
            "nofile.toml",
            "[[part]]\nunits = \"mm\"\n",
            "nofile.toml: line 1: missing field `file`",
        ),
    ] {
        std::fs::write(root.join(name), text).unwrap();
        let out = moldgate(root, &["locate", "--manifest", name]);
        assert_fails(&out, USAGE, &[says]);
    }

    std::fs::write(root.join("none.toml"), "# nothing\n").unwrap();
    let out = moldgate(root, &["locate", "--manifest", "none.toml"]);
    assert_fails(&out, USAGE, &["none.toml", "no part"]);

    let out = moldgate(root, &["locate", "--manifest", "missing.toml"]);
    assert_fails(&out, INPUT, &["missing.toml", "cannot open"]);
}

// ---------------------------------------------------------------------------------------------
// Bad output paths: a clear error before any work, nothing written

#[test]
fn output_paths_are_checked_before_any_work() {
    let dir = mixed_folder();
    let root = dir.path();
    let before = listing(root);

    let out = moldgate(root, &["locate", "parts", "--out-dir", "no/such"]);
    assert_fails(&out, OUTPUT, &["no/such", "does not exist"]);

    let out = moldgate(root, &["locate", "parts", "--out-dir", "parts/cap.stl"]);
    assert_fails(&out, OUTPUT, &["parts/cap.stl", "not a folder"]);

    let out = moldgate(root, &["locate", "parts", "--summary", "no/such/s.csv"]);
    assert_fails(&out, OUTPUT, &["no/such/s.csv", "does not exist"]);

    let out = moldgate(root, &["locate", "parts", "--summary", "parts"]);
    assert_fails(&out, USAGE, &["parts", ".jsonl"]);

    std::fs::create_dir(root.join("folder.csv")).unwrap();
    let out = moldgate(root, &["locate", "parts", "--summary", "folder.csv"]);
    assert_fails(&out, OUTPUT, &["folder.csv", "is a folder"]);
    std::fs::remove_dir(root.join("folder.csv")).unwrap();

    let out = moldgate(root, &["locate", "parts", "--summary", "s.json"]);
    assert_fails(&out, USAGE, &["s.json", ".csv"]);

    let out = moldgate(root, &["locate", "parts", "-o", "r.json"]);
    assert_fails(&out, USAGE, &["--out-dir"]);

    assert_eq!(listing(root), before, "nothing was written");
    assert_eq!(listing(&root.join("parts")).len(), 11);
}

#[test]
fn output_over_an_input_is_refused() {
    let dir = mixed_folder();
    let root = dir.path();
    // A part whose name ends in .csv, given by name, and the summary aimed at it.
    std::fs::copy(root.join("parts/cap.stl"), root.join("part.csv")).unwrap();
    let original = std::fs::read(root.join("part.csv")).unwrap();
    let out = moldgate(
        root,
        &[
            "locate",
            "part.csv",
            "parts/plate.stl",
            "--summary",
            "./part.csv",
        ],
    );
    assert_fails(&out, OUTPUT, &["part.csv", "over an input"]);
    assert_eq!(std::fs::read(root.join("part.csv")).unwrap(), original);

    // A report in --out-dir that would replace an input.
    std::fs::copy(root.join("parts/cap.stl"), root.join("parts/cap.json")).unwrap();
    let out = moldgate(root, &["locate", "parts/cap.json", "--out-dir", "parts"]);
    assert_fails(&out, OUTPUT, &["cap.json", "over an input"]);
    assert_eq!(
        std::fs::read(root.join("parts/cap.json")).unwrap(),
        original
    );
}

#[test]
fn two_parts_with_one_report_name_are_refused() {
    let dir = mixed_folder();
    let root = dir.path();
    std::fs::create_dir_all(root.join("other")).unwrap();
    std::fs::copy(root.join("parts/cap.stl"), root.join("other/CAP.stl")).unwrap();
    std::fs::create_dir(root.join("out")).unwrap();
    let out = moldgate(
        root,
        &[
            "locate",
            "parts/cap.stl",
            "other/CAP.stl",
            "--out-dir",
            "out",
        ],
    );
    assert_fails(&out, USAGE, &["parts/cap.stl", "other/CAP.stl", "json"]);
    assert!(listing(&root.join("out")).is_empty());
    // Without --out-dir they are fine.
    let out = moldgate(root, &["locate", "parts/cap.stl", "other/CAP.stl"]);
    assert_code(&out, OK);
}

#[test]
fn an_unwritable_out_dir_fails_before_any_work() {
    use std::os::unix::fs::PermissionsExt;
    let dir = mixed_folder();
    let root = dir.path();
    let locked = root.join("locked");
    std::fs::create_dir(&locked).unwrap();
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o555)).unwrap();
    if std::fs::File::create(locked.join("probe")).is_ok() {
        // Root ignores permissions.
        println!("skipped: this user can write into a read-only folder (root)");
        eprintln!("skipped: this user can write into a read-only folder (root)");
        return;
    }
    let out = moldgate(root, &["locate", "parts", "--out-dir", "locked"]);
    assert_fails(&out, OUTPUT, &["locked", "cannot write"]);
    assert!(listing(&locked).is_empty());
}

/// A report that cannot be written once the run has started (the file name is taken by a
/// folder) is that part's output error; the other parts are written.
#[test]
fn a_report_that_cannot_be_written_is_an_output_error_of_its_part() {
    let dir = mixed_folder();
    let root = dir.path();
    std::fs::create_dir_all(root.join("out/cap.json")).unwrap();
    let out = moldgate(
        root,
        &[
            "locate",
            "parts/cap.stl",
            "parts/plate.stl",
            "--out-dir",
            "out",
            "--json",
        ],
    );
    assert_code(&out, OUTPUT);
    let rows = json_lines(&stdout(&out));
    assert_eq!(rows[0]["status"], "output_error");
    assert!(
        rows[0]["triangles"].is_number(),
        "the analysis is still reported"
    );
    assert_eq!(rows[1]["status"], "ok");
    assert!(root.join("out/plate.json").is_file());
    let err = stderr(&out);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("cap.json"), "{err}");
}

#[test]
fn a_run_of_more_parts_than_its_limit_is_refused_before_the_work() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    let out = moldgate(root, &["sample", "cover", "-o", "c.stl"]);
    assert_code(&out, OK);
    let n = moldgate_cli_max_parts() + 1;
    std::fs::write(
        root.join("many.toml"),
        "[[part]]\nfile = \"c.stl\"\n".repeat(n),
    )
    .unwrap();
    let out = moldgate(
        root,
        &["locate", "--manifest", "many.toml", "--summary", "s.jsonl"],
    );
    assert_code(&out, USAGE);
    assert!(
        stderr(&out).contains(&format!(
            "{n} parts given (files, folders' meshes and the manifest's), over the limit of {}",
            n - 1
        )),
        "{}",
        stderr(&out)
    );
    assert!(!root.join("s.jsonl").exists());
}

/// The limit as documented (docs/cli.md), 100,000 parts.
fn moldgate_cli_max_parts() -> usize {
    100_000
}

/// A summary that is a part's report by another name (a hard or a symbolic link) is
/// refused before the work: it would replace the report.
#[test]
fn a_summary_that_is_a_report_by_another_name_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    assert_code(&moldgate(root, &["sample", "cover", "-o", "c.stl"]), OK);
    std::fs::create_dir(root.join("od")).unwrap();
    std::fs::write(root.join("od/c.json"), "old").unwrap();
    std::fs::hard_link(root.join("od/c.json"), root.join("hard.jsonl")).unwrap();
    std::os::unix::fs::symlink("od/c.json", root.join("soft.jsonl")).unwrap();
    for summary in ["hard.jsonl", "soft.jsonl"] {
        let out = moldgate(
            root,
            &["locate", "c.stl", "--out-dir", "od", "--summary", summary],
        );
        assert_code(&out, USAGE);
        assert!(
            stderr(&out).contains(&format!(
                "--summary {summary} and the report of c.stl in --out-dir are one file"
            )),
            "{}",
            stderr(&out)
        );
        assert_eq!(
            std::fs::read_to_string(root.join("od/c.json")).unwrap(),
            "old"
        );
    }
}
