//! The whole `moldgate locate` command on the 18 shared parts at once, from process start to
//! exit (the target: under 1 s in total). Needs `../shared/data/parts` beside the
//! repository, or `MOLDGATE_PARTS` naming the folder; without it the benchmark says so and
//! measures nothing.
//!
//! - `manifest`: every part with its own unit and natural demolding direction (the table
//!   below, from the folder's `SOURCES.md`), a JSON Lines summary written, all cores. This is
//!   the figure quoted in the README.
//! - `manifest_jobs_1`: the same on one thread.
//! - `manifest_one_by_one`: the same, parts one after the other, each with all the cores
//!   inside (the schedule that was not kept).
//! - `folder_defaults`: `moldgate locate FOLDER`, every part in mm along +z (three parts then
//!   have no gate, which is the answer for those options).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use criterion::{criterion_group, criterion_main, Criterion};

/// File, unit and natural demolding direction of each shared part (SOURCES.md).
const PARTS: [(&str, &str, &str); 18] = [
    ("comma2_injection_molded_mount.stl", "mm", "+x"),
    ("comma_ram_connector_cap.stl", "mm", "-z"),
    ("deskhop_case_bottom.stl", "mm", "+z"),
    ("esp32s3box_bottom_housing_352k.stl", "mm", "+y"),
    ("esp32s3box_top_housing.stl", "mm", "-y"),
    ("framework_desktop_blank_tile.stl", "mm", "-z"),
    ("framework_desktop_top_cover_121k.stl", "mm", "-x"),
    ("framework_expansion_card_shell.stl", "mm", "+y"),
    ("prusa_heatbed_cable_cover_clip_ascii.stl", "mm", "+z"),
    ("prusa_lcd_knob.stl", "mm", "+z"),
    ("prusa_psu_cover_mk3_ascii.stl", "mm", "+z"),
    ("prusa_raspberry_cover_ascii_open.stl", "mm", "+z"),
    ("sc64_shell_back.stl", "mm", "-z"),
    ("screwcap_oralb_75ml_ascii.stl", "mm", "+z"),
    ("trimesh_ADIS16480_meters_ascii.STL", "m", "+y"),
    ("trimesh_featuretype_inches.STL", "in", "+z"),
    ("watchy_yatari_bottom.stl", "mm", "-z"),
    ("watchy_yatari_top.stl", "mm", "+z"),
];

fn parts_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("MOLDGATE_PARTS")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/parts")
        });
    dir.is_dir().then_some(dir)
}

/// Writes the manifest of the shared parts (absolute paths) into `dir`.
fn write_manifest(parts: &Path, dir: &Path) -> PathBuf {
    let parts = parts.canonicalize().expect("the parts folder");
    let mut text = String::new();
    for (file, units, demold) in PARTS {
        let path = parts.join(file);
        text += &format!(
            "[[part]]\nfile = {:?}\nunits = \"{units}\"\ndemold = \"{demold}\"\n\n",
            path.to_str().expect("a UTF-8 path")
        );
    }
    let manifest = dir.join("shared-parts.toml");
    std::fs::write(&manifest, text).expect("write the manifest");
    manifest
}

/// Runs the command; the raspberry cover has no gate along +z (exit code 4), every other
/// part one, so 4 is the expected code of the manifest runs and of the folder run.
fn run(args: &[&str]) {
    let status = Command::new(env!("CARGO_BIN_EXE_moldgate"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .expect("run moldgate");
    assert_eq!(status.code(), Some(4), "moldgate {args:?}");
}

fn bench_batch(c: &mut Criterion) {
    let Some(parts) = parts_dir() else {
        eprintln!("skipping the batch benchmark: ../shared/data/parts not found");
        return;
    };
    let tmp = tempfile::tempdir().expect("a temporary folder");
    let manifest = write_manifest(&parts, tmp.path());
    let manifest = manifest.to_str().expect("UTF-8");
    let summary = tmp.path().join("summary.jsonl");
    let summary = summary.to_str().expect("UTF-8");
    let folder = parts.to_str().expect("UTF-8");
    let base = [
        "locate",
        "--quiet",
        "--manifest",
        manifest,
        "--summary",
        summary,
    ];

    let mut group = c.benchmark_group("batch_18_shared_parts");
    group.sample_size(10);
    group.bench_function("manifest", |b| b.iter(|| run(&base)));
    group.bench_function("manifest_jobs_1", |b| {
        b.iter(|| run(&[&base[..], &["--jobs", "1"]].concat()))
    });
    group.bench_function("manifest_one_by_one", |b| {
        b.iter(|| run(&[&base[..], &["--schedule", "one-by-one"]].concat()))
    });
    group.bench_function("folder_defaults", |b| {
        b.iter(|| run(&["locate", "--quiet", folder, "--summary", summary]))
    });
    group.finish();
}

criterion_group!(benches, bench_batch);
criterion_main!(benches);
