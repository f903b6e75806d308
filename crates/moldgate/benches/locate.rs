//! Benchmarks of loading and locating, on a built-in sample and (when `../shared/data/parts`
//! is beside the repository) on real parts.

use std::path::PathBuf;

use criterion::{criterion_group, criterion_main, Criterion};
use moldgate::mesh::{self, Units};
use moldgate::raycast::{Bvh, Sampling};
use moldgate::thickness::{wall_thickness_with, CrossCheck, ThicknessOptions};
use moldgate::undercut::auto_direction;
use moldgate::{locate, LocateOptions};

fn parts_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("MOLDGATE_PARTS")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/parts")
        });
    dir.is_dir().then_some(dir)
}

fn bench_sample(c: &mut Criterion) {
    let part = mesh::from_generated(moldgate::samples::sample("cover").expect("sample"));
    c.bench_function("locate/sample_cover", |b| {
        b.iter(|| locate(&part, &LocateOptions::default()).unwrap())
    });
}

fn bench_real(c: &mut Criterion) {
    let Some(dir) = parts_dir() else {
        eprintln!("skipping real-part benchmarks: ../shared/data/parts not found");
        return;
    };
    let path = dir.join("esp32s3box_bottom_housing_352k.stl");
    let bytes = std::fs::read(&path).expect("read part");
    let load = || mesh::read_stl(&bytes[..], bytes.len() as u64, Units::Mm).unwrap();
    let mut group = c.benchmark_group("esp32_bottom_352k");
    group.sample_size(20);
    group.bench_function("load_from_memory_one_thread", |b| b.iter(load));
    let len = bytes.len() as u64;
    let open = || std::fs::File::open(&path).map(std::io::BufReader::new);
    group.bench_function("load_from_file", |b| {
        b.iter(|| mesh::read_stl_reopen(open, len, Units::Mm).unwrap())
    });
    let part = load();
    let options = LocateOptions {
        direction: "+y".parse().unwrap(),
        ..LocateOptions::default()
    };
    group.bench_function("locate", |b| b.iter(|| locate(&part, &options).unwrap()));
    group.bench_function("bvh_build", |b| b.iter(|| Bvh::new(&part.mesh)));
    let bvh = Bvh::new(&part.mesh);
    group.bench_function("wall_thickness", |b| {
        b.iter(|| wall_thickness_with(&part.mesh, &bvh, &ThicknessOptions::default()))
    });
    let rays_only = ThicknessOptions {
        cross_check: CrossCheck::Off,
        ..ThicknessOptions::default()
    };
    group.bench_function("wall_thickness_rays_only", |b| {
        b.iter(|| wall_thickness_with(&part.mesh, &bvh, &rays_only))
    });
    group.bench_function("demold_auto", |b| {
        b.iter(|| auto_direction(&part.mesh, Sampling::Centroid).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench_sample, bench_real);
criterion_main!(benches);
