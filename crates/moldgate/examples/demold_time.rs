//! Where the time of `--demold auto` goes on one part: the whole choice, then each candidate
//! line's undercut on its own (the rays it casts, best of the repeats).
//!
//! ```text
//! cargo run --release -p moldgate --example demold_time -- PART.stl [repeats]
//! ```

use std::time::Instant;

use moldgate::frame::Direction;
use moldgate::mesh::{self, Units};
use moldgate::raycast::Sampling;
use moldgate::undercut::{auto_direction_checked, undercut, PARALLEL_TOLERANCE};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: demold_time PART.stl [REPEATS]");
        std::process::exit(2);
    };
    let repeats: usize = args.get(1).map_or(5, |s| s.parse().expect("repeats"));
    let bytes = std::fs::read(path).expect("read the part");
    let part = mesh::read_stl(&bytes[..], bytes.len() as u64, Units::Mm).expect("load");
    let mesh = &part.mesh;
    let mut best = f64::INFINITY;
    let mut checks = 0;
    let mut auto = None;
    for _ in 0..repeats {
        let t = Instant::now();
        let mut asked = 0;
        let a = auto_direction_checked(mesh, Sampling::Centroid, |_| {
            asked += 1;
            true
        })
        .expect("auto");
        best = best.min(t.elapsed().as_secs_f64());
        checks = asked;
        auto = Some(a);
    }
    let auto = auto.expect("at least one repeat");
    println!(
        "{} triangles: auto direction best of {repeats} {:.1} ms, {} lines tried, {checks} gate checks asked (answered at once here)",
        mesh.triangles.len(),
        best * 1e3,
        auto.tried.len(),
    );
    for (i, c) in auto.tried.iter().enumerate() {
        let d = Direction::new(moldgate::math::DVec3::from_array(c.direction)).expect("unit");
        let line = d.vector();
        // The rays of this line: one per facet facing a side.
        let rays = (0..mesh.triangles.len())
            .filter(|&t| {
                let [a, b, c] = mesh.corners(t);
                let n = (b - a).cross(c - a).normalize_or_zero();
                n.dot(line).abs() > PARALLEL_TOLERANCE
            })
            .count();
        let mut line_best = f64::INFINITY;
        for _ in 0..repeats {
            let t = Instant::now();
            let u = undercut(mesh, d, Sampling::Centroid);
            line_best = line_best.min(t.elapsed().as_secs_f64());
            if c.evaluated {
                assert_eq!(u.area_mm2.to_bits(), c.undercut.area_mm2.to_bits());
            } else {
                assert!(u.area_mm2 >= c.undercut.area_mm2, "{u:?} {c:?}");
            }
        }
        println!(
            "  {}{} ({:+.3}, {:+.3}, {:+.3}) {:?}: {rays} rays, undercut {}{:.1} mm^2, every ray drawn alone {:.1} ms",
            if i == auto.chosen { "*" } else { " " },
            i,
            c.direction[0],
            c.direction[1],
            c.direction[2],
            c.kind,
            if c.evaluated { "" } else { "at least " },
            c.undercut.area_mm2,
            line_best * 1e3
        );
    }
}
