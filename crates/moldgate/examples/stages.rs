//! Times each stage of `locate` on one part, repeated, and prints the best time of each.
//!
//! ```text
//! cargo run --release -p moldgate --example stages -- PART.stl [+z] [repeats] [spacing_mm]
//! ```

use std::time::Instant;

use moldgate::gate::quadrature::Spacing;
use moldgate::mesh::{self, Units};
use moldgate::{locate, LocateOptions};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: stages PART.stl [DEMOLD] [REPEATS] [SPACING_MM]");
        std::process::exit(2);
    };
    let direction = args
        .get(1)
        .map_or("+z", String::as_str)
        .parse()
        .expect("demold");
    let repeats: usize = args.get(2).map_or(10, |s| s.parse().expect("repeats"));
    let spacing = args
        .get(3)
        .map_or(Spacing::Auto, |s| Spacing::Mm(s.parse().expect("spacing")));
    let bytes = std::fs::read(path).expect("read the part");
    let mut best = [f64::INFINITY; 7];
    let mut nodes = 0;
    let mut triangles = 0;
    for _ in 0..repeats {
        let t = Instant::now();
        let part = mesh::read_stl(&bytes[..], bytes.len() as u64, Units::Mm).expect("load");
        let load = t.elapsed().as_secs_f64();
        let options = LocateOptions {
            direction,
            spacing,
            ..LocateOptions::default()
        };
        let t = Instant::now();
        let analysis = locate(&part, &options).expect("locate");
        let total = t.elapsed().as_secs_f64() + load;
        let s = analysis.times;
        let now = [
            load,
            s.centre_s,
            s.grid_s,
            s.projection_s,
            s.select_s,
            s.parting_s,
            total,
        ];
        for (b, n) in best.iter_mut().zip(now) {
            *b = b.min(n);
        }
        nodes = analysis.grid.len();
        triangles = part.mesh.triangles.len();
    }
    let ms = best.map(|s| s * 1e3);
    println!(
        "triangles {triangles} nodes {nodes} | best of {repeats}, ms: load {:.1} centre {:.1} grid {:.1} rays {:.1} select {:.1} parting {:.1} total {:.1}",
        ms[0], ms[1], ms[2], ms[3], ms[4], ms[5], ms[6]
    );
}
