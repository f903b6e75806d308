//! How the time of each stage grows with triangles and with grid nodes: prints the Markdown
//! table quoted in the README.
//!
//! ```text
//! cargo run --release -p moldgate --example scaling -- [PART.stl DEMOLD] [REPEATS]
//! ```
//!
//! Without a part it uses `../shared/data/parts/esp32s3box_bottom_housing_352k.stl` (demold
//! +y) when present, else the built-in `cover` sample. Triangles grow by splitting every
//! triangle into four at its edge midpoints (the same shape, 4x and 16x the triangles, written
//! to STL bytes and read back, so loading is measured too); nodes grow by halving the
//! spacing. Each row is the best of REPEATS runs (default 5).

use std::path::PathBuf;
use std::time::Instant;

use moldgate::gate::quadrature::Spacing;
use moldgate::mesh::{self, Units};
use moldgate::{locate, Direction, LocateOptions};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let default_part = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/parts/esp32s3box_bottom_housing_352k.stl");
    let (name, bytes, direction): (String, Vec<u8>, Direction) = if args.len() >= 2 {
        let bytes = std::fs::read(&args[0]).expect("read the part");
        (args[0].clone(), bytes, args[1].parse().expect("demold"))
    } else if default_part.exists() {
        let bytes = std::fs::read(&default_part).expect("read the part");
        (
            "esp32s3box_bottom_housing_352k".into(),
            bytes,
            "+y".parse().unwrap(),
        )
    } else {
        let mut bytes = Vec::new();
        let mesh = moldgate::samples::sample("cover").unwrap();
        mesh.write_stl(&mut bytes).unwrap();
        ("sample cover".into(), bytes, Direction::PLUS_Z)
    };
    let repeats: usize = args.get(2).map_or(5, |s| s.parse().expect("repeats"));
    let base = mesh::read_stl(&bytes[..], bytes.len() as u64, Units::Mm).expect("load");
    let auto = locate(
        &base,
        &LocateOptions {
            direction,
            ..LocateOptions::default()
        },
    )
    .expect("locate")
    .grid
    .spacing;

    println!(
        "Part: {name}; {} threads; best of {repeats}; times in ms.\n",
        rayon::current_num_threads()
    );
    println!("| triangles | nodes | load | centre | grid | rays | select | parting | total |");
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    // More triangles, same grid.
    let mut mesh = base.mesh.clone();
    for level in 0..3 {
        if level > 0 {
            mesh = mesh.subdivided();
        }
        let mut stl = Vec::new();
        mesh.write_stl(&mut stl).unwrap();
        row(&stl, direction, Spacing::Mm(auto), repeats);
    }
    // More nodes, same triangles.
    for halvings in 1..4 {
        let h = auto / f64::from(1u32 << halvings);
        row(&bytes, direction, Spacing::Mm(h), repeats);
    }
}

fn row(stl: &[u8], direction: Direction, spacing: Spacing, repeats: usize) {
    let mut best = [f64::INFINITY; 7];
    let (mut triangles, mut nodes) = (0, 0);
    for _ in 0..repeats {
        let t = Instant::now();
        let part = mesh::read_stl(stl, stl.len() as u64, Units::Mm).expect("load");
        let load = t.elapsed().as_secs_f64();
        let options = LocateOptions {
            direction,
            spacing,
            ..LocateOptions::default()
        };
        let analysis = locate(&part, &options).expect("locate");
        let s = analysis.times;
        let stages = [
            load,
            s.centre_s,
            s.grid_s,
            s.projection_s,
            s.select_s,
            s.parting_s,
        ];
        // The parting line runs alongside the rays: the total is the wall time, not a sum.
        let total = load + s.total_s;
        for (b, v) in best.iter_mut().zip(stages.iter().chain([&total])) {
            *b = b.min(*v);
        }
        triangles = part.mesh.triangles.len();
        nodes = analysis.grid.len();
    }
    let ms = best.map(|s| s * 1e3);
    println!(
        "| {triangles} | {nodes} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} |",
        ms[0], ms[1], ms[2], ms[3], ms[4], ms[5], ms[6]
    );
}
