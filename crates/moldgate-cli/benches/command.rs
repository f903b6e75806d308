//! The whole `moldgate locate` command, from process start to exit, as a user runs it: on a
//! built-in sample and, when `../shared/data/parts` is beside the repository (or
//! `MOLDGATE_PARTS` names the folder), on the 352k-triangle ESP32 housing (demold +y).

use std::path::PathBuf;
use std::process::{Command, Stdio};

use criterion::{criterion_group, criterion_main, Criterion};

fn run(args: &[&str]) {
    let status = Command::new(env!("CARGO_BIN_EXE_moldgate"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .expect("run moldgate");
    assert!(status.success(), "moldgate {args:?} failed");
}

fn parts_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("MOLDGATE_PARTS")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/parts")
        });
    dir.is_dir().then_some(dir)
}

fn bench_command(c: &mut Criterion) {
    let mut group = c.benchmark_group("command");
    group.sample_size(30);
    group.bench_function("locate_sample_cover", |b| {
        b.iter(|| run(&["locate", "--sample", "cover"]))
    });
    match parts_dir() {
        Some(dir) => {
            let part = dir.join("esp32s3box_bottom_housing_352k.stl");
            let part = part.to_str().expect("UTF-8 path");
            group.bench_function("locate_esp32_bottom_352k", |b| {
                b.iter(|| run(&["locate", part, "--demold", "+y"]))
            });
        }
        None => eprintln!("skipping the real-part benchmark: ../shared/data/parts not found"),
    }
    group.finish();
}

criterion_group!(benches, bench_command);
criterion_main!(benches);
