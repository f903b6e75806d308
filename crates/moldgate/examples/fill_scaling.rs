//! How the fill analysis's time grows with triangles and with resolution: prints the
//! Markdown table quoted in the README.
//!
//! ```text
//! cargo run --release -p moldgate --example fill_scaling -- [PART.stl DEMOLD] [REPEATS]
//! ```
//!
//! Without a part it uses `../shared/data/parts/esp32s3box_bottom_housing_352k.stl` (demold
//! +y) when present, else the built-in `cover` sample. Triangles grow by splitting every
//! triangle into four (the same shape, default cells); resolution grows by shrinking the
//! cells (each row about twice the cells of the one before). Each row is the best of REPEATS
//! runs (default 3).

use std::path::PathBuf;
use std::time::Instant;

use moldgate::flow::{self, FillOptions, FlowOptions, Walls};
use moldgate::mesh::{self, LoadedMesh, Units};
use moldgate::raycast::Bvh;
use moldgate::{locate, Direction, LocateOptions, Material};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let default_part = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/parts/esp32s3box_bottom_housing_352k.stl");
    let (name, part, direction): (String, LoadedMesh, Direction) = if args.len() >= 2 {
        let bytes = std::fs::read(&args[0]).expect("read the part");
        let part = mesh::read_stl(&bytes[..], bytes.len() as u64, Units::Mm).expect("load");
        (args[0].clone(), part, args[1].parse().expect("demold"))
    } else if default_part.exists() {
        let bytes = std::fs::read(&default_part).expect("read the part");
        let part = mesh::read_stl(&bytes[..], bytes.len() as u64, Units::Mm).expect("load");
        (
            "esp32s3box_bottom_housing_352k".into(),
            part,
            "+y".parse().unwrap(),
        )
    } else {
        let part = mesh::from_generated(moldgate::samples::sample("cover").unwrap());
        ("sample cover".into(), part, Direction::PLUS_Z)
    };
    let repeats: usize = args.get(2).map_or(3, |s| s.parse().expect("repeats"));
    println!(
        "Part: {name}; {} threads; best of {repeats}; times in ms.\n",
        rayon::current_num_threads()
    );
    println!("| triangles | cell mm | cells | wall (tree + rays) | voxels | paper gate fields | balanced search | total | marches |");
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    let default_cell = row(&part, direction, None, repeats);
    let mut mesh = part.mesh.clone();
    for _ in 0..2 {
        mesh = mesh.subdivided();
        let finer = mesh::from_generated(mesh.clone());
        row(&finer, direction, Some(default_cell), repeats);
    }
    for k in 1..4 {
        // Each step about doubles the cells (h / 2^(1/3)).
        let h = default_cell / 2f64.powf(k as f64 / 3.0);
        row(&part, direction, Some(h), repeats);
    }
}

/// One row; returns the cell size used.
fn row(part: &LoadedMesh, direction: Direction, cell: Option<f64>, repeats: usize) -> f64 {
    let options = LocateOptions {
        direction,
        ..LocateOptions::default()
    };
    let analysis = locate(part, &options).expect("locate");
    let pp = Material::builtin("PP").unwrap();
    let fill_options = FillOptions {
        flow: FlowOptions {
            cell_mm: cell,
            ..FlowOptions::default()
        },
        ..FillOptions::default()
    };
    let mut best = [f64::INFINITY; 5];
    let mut last = None;
    for _ in 0..repeats {
        let t = Instant::now();
        let bvh = Bvh::new(&part.mesh);
        let tree = t.elapsed().as_secs_f64();
        let f = flow::analyse(
            &part.mesh,
            &analysis,
            &pp,
            Walls::Measure(&bvh),
            &fill_options,
        )
        .expect("fill");
        let total = t.elapsed().as_secs_f64();
        let s = f.times;
        for (b, v) in
            best.iter_mut()
                .zip([tree + s.wall_s, s.voxels_s, s.paper_s, s.balanced_s, total])
        {
            *b = b.min(v);
        }
        last = Some(f);
    }
    let f = last.expect("one run");
    let ms = best.map(|s| s * 1e3);
    println!(
        "| {} | {:.3} | {} | {:.0} | {:.0} | {:.0} | {:.0} | {:.0} | {} |",
        part.mesh.triangles.len(),
        f.cell_mm,
        f.cells,
        ms[0],
        ms[1],
        ms[2],
        ms[3],
        ms[4],
        3 + f.balanced.as_ref().map_or(0, |b| b.search.runs + 3)
    );
    f.cell_mm
}
