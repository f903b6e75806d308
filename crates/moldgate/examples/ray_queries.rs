//! The ray tree's work on one part, one kind at a time, for timing and for instruction counts
//! (`valgrind --tool=callgrind`, one thread): best of RUNS times in one process.
//!
//! `cargo run --release -p moldgate --example ray_queries -- PART.stl [MODE] [RUNS]`
//!
//! MODE is `build` (the tree), `rays` (one first-hit ray per facet from its centroid along
//! the inverted normal, in the tree's leaf order: the reference's Embree call), `wall` (the
//! wall-thickness stage with the cross-width check), `wall-off` (without it), or `all`
//! (default). Each line prints the time and a checksum of the answers, so two builds of the
//! tree can be compared for equal answers as well as speed.

use std::time::Instant;

use moldgate::mesh::{self, Units};
use moldgate::raycast::{Bvh, Ray};
use moldgate::thickness::{wall_thickness_with, CrossCheck, ThicknessOptions};
use rayon::prelude::*;

fn best_of<T>(runs: usize, mut f: impl FnMut() -> T) -> (T, f64) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..runs {
        let t = Instant::now();
        let v = f();
        best = best.min(t.elapsed().as_secs_f64() * 1e3);
        out = Some(v);
    }
    (out.expect("at least one run"), best)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        eprintln!("usage: ray_queries PART.stl [build|rays|wall|wall-off|all] [RUNS]");
        std::process::exit(2);
    };
    let mode = args.get(2).map_or("all", |m| m.as_str());
    let runs: usize = args.get(3).and_then(|r| r.parse().ok()).unwrap_or(3);
    let bytes = std::fs::read(path).expect("read the part");
    let part = mesh::read_stl(&bytes[..], bytes.len() as u64, Units::Mm).expect("a valid STL");
    let m = &part.mesh;
    let wants = |what: &str| mode == "all" || mode == what;
    let (bvh, build) = best_of(if wants("build") { runs } else { 1 }, || Bvh::new(m));
    if wants("build") {
        println!("build     {build:8.1} ms, {} triangles", bvh.len());
    }
    if wants("rays") {
        let rays: Vec<Ray> = bvh
            .leaf_order()
            .iter()
            .map(|&t| {
                let [a, b, c] = m.corners(t as usize);
                Ray::new((a + b + c) / 3.0, -m.normal(t as usize)).skipping(t)
            })
            .collect();
        let (sum, ms) = best_of(runs, || {
            rays.par_iter()
                .with_min_len(256)
                .map(|r| bvh.first_hit(r).map_or(0.0, |h| h.distance))
                .sum::<f64>()
        });
        println!(
            "rays      {ms:8.1} ms, {:.2} M rays/s, sum of distances {sum:.6}",
            rays.len() as f64 / ms / 1e3
        );
    }
    for (name, cross_check) in [("wall", CrossCheck::On), ("wall-off", CrossCheck::Off)] {
        if !wants(name) {
            continue;
        }
        let options = ThicknessOptions {
            cross_check,
            ..ThicknessOptions::default()
        };
        let (w, ms) = best_of(runs, || wall_thickness_with(m, &bvh, &options));
        let sum: f64 = w
            .per_triangle
            .iter()
            .filter(|v| v.is_finite())
            .map(|&v| v as f64)
            .sum();
        println!(
            "{name:<9} {ms:8.1} ms, nominal {:.6} mm, unknown {:.6} %, sum {sum:.6}",
            w.nominal_mm.unwrap_or(f64::NAN),
            100.0 * w.unknown_area_share
        );
    }
}
