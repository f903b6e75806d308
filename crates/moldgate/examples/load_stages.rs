//! Times the stages of loading and of plain `locate` one by one, on one part, repeated,
//! and prints the best time of each: what the whole command is made of, stage by stage
//! (run with `RAYON_NUM_THREADS=1` for each stage's CPU time).
//!
//! ```text
//! cargo build --release -p moldgate --example load_stages
//! target/release/examples/load_stages PART.stl [DEMOLD] [REPEATS]
//! ```

use std::fs::File;
use std::io::BufReader;
use std::time::Instant;

use moldgate::centre::Centres;
use moldgate::frame::Frame;
use moldgate::mesh::{self, stl, Topology, Units};
use moldgate::parting::PartingLine;
use moldgate::{locate, Direction, LocateOptions};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: load_stages PART.stl [DEMOLD] [REPEATS]");
        std::process::exit(2);
    };
    let direction: Direction = args
        .get(1)
        .map_or("+y", String::as_str)
        .parse()
        .expect("demold");
    let repeats: usize = args.get(2).map_or(15, |s| s.parse().expect("repeats"));
    let len = std::fs::metadata(path).expect("the part").len();
    let open = || File::open(path).map(|f| BufReader::with_capacity(1 << 16, f));
    let names = [
        "weld+join",
        "topology",
        "whole load",
        "centre",
        "outline",
        "rays",
        "locate",
    ];
    let mut best = [f64::INFINITY; 7];
    for _ in 0..repeats {
        let t = Instant::now();
        let raw = stl::read_reopen(open, len, Units::Mm).expect("load");
        let weld = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let topology = Topology::new(&raw.mesh);
        let topo = t.elapsed().as_secs_f64();
        drop((raw, topology));
        let t = Instant::now();
        let part = mesh::read_stl_reopen(open, len, Units::Mm).expect("load");
        let load = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let centres = Centres::of(&part.mesh);
        let centre = t.elapsed().as_secs_f64();
        std::hint::black_box(centres);
        let frame = Frame::new(direction);
        let t = Instant::now();
        let line = PartingLine::outline(&part.mesh, &part.topology, &frame);
        let outline = t.elapsed().as_secs_f64();
        std::hint::black_box(line);
        let options = LocateOptions {
            direction,
            ..LocateOptions::default()
        };
        let t = Instant::now();
        let analysis = locate(&part, &options).expect("locate");
        let whole = t.elapsed().as_secs_f64();
        let now = [
            weld,
            topo,
            load,
            centre,
            outline,
            analysis.times.projection_s,
            whole,
        ];
        for (b, n) in best.iter_mut().zip(now) {
            *b = b.min(n);
        }
    }
    let line: Vec<String> = names
        .iter()
        .zip(best)
        .map(|(n, b)| format!("{n} {:.1}", b * 1e3))
        .collect();
    println!(
        "best of {repeats}, ms, {} threads: {}",
        rayon::current_num_threads(),
        line.join(", ")
    );
}
