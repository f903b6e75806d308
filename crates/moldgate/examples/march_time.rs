//! Times the fast march alone on one part, and prints a digest of the fields' bits so that
//! two builds can be checked to give the same fields:
//! `march_time PART.stl [MARCHES] [CELL_MM]`. Run with `RAYON_NUM_THREADS=1` for the work of
//! one thread (the marches run one after the other either way).
use std::hash::{Hash, Hasher};
use std::time::Instant;

use moldgate::flow::{self, Domain, Source};
use moldgate::Material;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 2 {
        eprintln!("usage: march_time PART.stl [MARCHES] [CELL_MM]");
        std::process::exit(2);
    }
    let file = std::fs::File::open(&args[1]).expect("open the part");
    let len = file.metadata().expect("metadata").len();
    let part = moldgate::mesh::read_stl(
        std::io::BufReader::new(file),
        len,
        moldgate::mesh::Units::Mm,
    )
    .expect("load");
    let marches: usize = args.get(2).map_or(8, |s| s.parse().expect("marches"));
    let c = moldgate::Centres::of(&part.mesh);
    let nominal = 2.0 * c.volume_mm3 / c.area_mm2;
    let h = args.get(3).map_or_else(
        || {
            flow::cell_size(&part.mesh, nominal, &flow::FlowOptions::default())
                .expect("a cell size within the limits")
                .0
        },
        |s| s.parse().expect("cell"),
    );
    let pp = Material::builtin("PP").expect("PP");
    let t = Instant::now();
    let domain = Domain::new(&part.mesh, h, None, nominal, &pp);
    let voxel_ms = t.elapsed().as_secs_f64() * 1e3;
    let v = &domain.voxels;
    let n = v.len() as u32;
    // A cost that varies from cell to cell, as a wall-dependent one does.
    let cost: Vec<f32> = (0..n).map(|i| 1.0 + (i % 7) as f32 * 0.37).collect();
    let mut digest = std::collections::hash_map::DefaultHasher::new();
    let mut times = Vec::new();
    for m in 0..marches {
        let cell = (m as u64 * n as u64 / marches as u64) as u32;
        let src = [Source {
            point: v.centre(cell),
            cell,
        }];
        let c = (m % 2 == 1).then_some(&cost[..]);
        let t = Instant::now();
        let f = flow::march(v, &src, c);
        times.push(t.elapsed().as_secs_f64() * 1e3);
        for x in &f.t {
            x.to_bits().hash(&mut digest);
        }
        f.source.hash(&mut digest);
    }
    times.sort_by(f64::total_cmp);
    println!(
        "h {h:.4} mm, {n} cells, voxels {voxel_ms:.1} ms; {marches} marches: median {:.2} ms, best {:.2} ms ({:.0} ns a cell); digest {:016x}",
        times[times.len() / 2],
        times[0],
        times[0] * 1e6 / n as f64,
        digest.finish()
    );
}
