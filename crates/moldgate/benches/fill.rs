//! Benchmarks of the fill analysis (voxels, fields from the paper gate, balanced-gate
//! search) on the real 352k-triangle part when `../shared/data/parts` is beside the
//! repository, and on a sample; and how its time grows with the cell size.

use std::path::PathBuf;

use criterion::{criterion_group, criterion_main, Criterion};
use moldgate::flow::{self, FillOptions, FlowOptions, Walls};
use moldgate::mesh::{self, LoadedMesh, Units};
use moldgate::raycast::Bvh;
use moldgate::{locate, Analysis, LocateOptions, Material};

fn parts_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("MOLDGATE_PARTS")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/parts")
        });
    dir.is_dir().then_some(dir)
}

fn located(part: &LoadedMesh, demold: &str) -> Analysis {
    let options = LocateOptions {
        direction: demold.parse().unwrap(),
        ..LocateOptions::default()
    };
    locate(part, &options).unwrap()
}

fn bench_sample(c: &mut Criterion) {
    let part = mesh::from_generated(moldgate::samples::sample("cover").expect("sample"));
    let analysis = located(&part, "+z");
    let pp = Material::builtin("PP").unwrap();
    let mut group = c.benchmark_group("fill_sample_cover");
    group.sample_size(10);
    group.bench_function("analyse", |b| {
        b.iter(|| {
            flow::analyse(
                &part.mesh,
                &analysis,
                &pp,
                Walls::Estimate,
                &FillOptions::default(),
            )
            .unwrap()
        })
    });
    group.finish();
}

fn bench_real(c: &mut Criterion) {
    let Some(dir) = parts_dir() else {
        eprintln!("skipping real-part benchmarks: ../shared/data/parts not found");
        return;
    };
    let path = dir.join("esp32s3box_bottom_housing_352k.stl");
    let bytes = std::fs::read(&path).expect("read part");
    let part = mesh::read_stl(&bytes[..], bytes.len() as u64, Units::Mm).unwrap();
    let analysis = located(&part, "+y");
    let pp = Material::builtin("PP").unwrap();
    let mut group = c.benchmark_group("fill_esp32_bottom_352k");
    group.sample_size(10);
    // The figure: wall thickness (tree and rays), flow fields and balanced gate.
    group.bench_function("thickness_flow_balanced", |b| {
        b.iter(|| {
            let bvh = Bvh::new(&part.mesh);
            flow::analyse(
                &part.mesh,
                &analysis,
                &pp,
                Walls::Measure(&bvh),
                &FillOptions::default(),
            )
            .unwrap()
        })
    });
    group.bench_function("flow_balanced_uniform_wall", |b| {
        b.iter(|| {
            flow::analyse(
                &part.mesh,
                &analysis,
                &pp,
                Walls::Estimate,
                &FillOptions::default(),
            )
            .unwrap()
        })
    });
    // Resolution: the default cell here is 0.69 mm; halving it multiplies the cells by 8.
    for cell in [1.0, 0.69, 0.5, 0.35] {
        let options = FillOptions {
            flow: FlowOptions {
                cell_mm: Some(cell),
                ..FlowOptions::default()
            },
            ..FillOptions::default()
        };
        group.bench_function(format!("analyse_cell_{cell}mm"), |b| {
            b.iter(|| flow::analyse(&part.mesh, &analysis, &pp, Walls::Estimate, &options).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, bench_sample, bench_real);
criterion_main!(benches);
