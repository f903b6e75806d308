//! Times the parting line by both rules on the same part, paired and interleaved (old rule,
//! new rule, old, new, ...), and prints each rule's median, the median of the per-round
//! ratios and the load average, with the line each rule gives:
//!
//! ```text
//! cargo run --release -p moldgate --example parting_time -- PART.stl [+z] [rounds] [units]
//! ```
//!
//! The stage timed is what `locate` runs for the parting line (the topology is built by the
//! loader, as in `locate`; the aesthetic gate on the line is not included).

#[path = "../tests/it/common/outline.rs"]
mod outline;

use std::time::Instant;

use moldgate::mesh::{self, Units};
use moldgate::parting::PartingLine;
use moldgate::{Direction, Frame};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: parting_time PART.stl [DEMOLD] [ROUNDS] [mm|in|m]");
        std::process::exit(2);
    };
    let direction: Direction = args
        .get(1)
        .map_or("+z", String::as_str)
        .parse()
        .expect("demold");
    let rounds: usize = args.get(2).map_or(21, |s| s.parse().expect("rounds"));
    let units = match args.get(3).map(String::as_str) {
        Some("in") => Units::In,
        Some("m") => Units::M,
        _ => Units::Mm,
    };
    let bytes = std::fs::read(path).expect("read the part");
    let part = mesh::read_stl(&bytes[..], bytes.len() as u64, units).expect("load");
    let frame = Frame::new(direction);
    let (mut old, mut new, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
    let (mut longest, mut outline) = (PartingLine::default(), PartingLine::default());
    for _ in 0..rounds {
        let t = Instant::now();
        longest = PartingLine::new(&part.mesh, &part.topology, &frame);
        let a = t.elapsed().as_secs_f64();
        let t = Instant::now();
        outline = PartingLine::outline(&part.mesh, &part.topology, &frame);
        let b = t.elapsed().as_secs_f64();
        old.push(a);
        new.push(b);
        ratio.push(b / a);
    }
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "{path} {direction:?}: {} triangles, {rounds} paired rounds, load average {}",
        part.mesh.triangles.len(),
        load.split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );
    println!(
        "  longest: median {:.2} ms, {:.1} mm, closed {}",
        1e3 * median(old),
        longest.length_mm,
        longest.closed
    );
    println!(
        "  outline: median {:.2} ms, {:.1} mm, closed {}, {} rims {:?}",
        1e3 * median(new),
        outline.length_mm,
        outline.closed,
        outline.rims.len(),
        outline
            .rims
            .iter()
            .map(|r| (r.edges, (r.length_mm * 10.0).round() / 10.0, r.closed))
            .collect::<Vec<_>>()
    );
    let projected: f64 = outline
        .edges
        .iter()
        .map(|&[a, b]| {
            let (p, q) = (
                part.mesh.vertices[a as usize],
                part.mesh.vertices[b as usize],
            );
            frame.project(p).distance(frame.project(q))
        })
        .sum();
    println!("  outline rule projected on the plane: {projected:.1} mm");
    println!("  outline / longest: median ratio {:.2}", median(ratio));
    let perimeter = outline::outline_perimeter(&part.mesh, &frame, 1500);
    println!(
        "  outline perimeter (raster) {perimeter:.1} mm: outline rule / perimeter {:.3}",
        outline.length_mm / perimeter
    );
}
