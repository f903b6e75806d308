//! Wall thickness of one part, with and without the cross-width check, the time of each
//! step, and the rays alone as Embree's call in `scripts/speed_table.py` casts them (best of
//! N runs in one process).
//!
//! `cargo run --release -p moldgate --example thickness -- PART.stl [UNITS] [RUNS]`

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
        eprintln!("usage: thickness PART.stl [UNITS] [RUNS]");
        std::process::exit(2);
    };
    let units: Units = args
        .get(2)
        .map_or(Ok(Units::Mm), |u| u.parse())
        .unwrap_or_else(|e| {
            eprintln!("{e}");
            std::process::exit(2)
        });
    let runs: usize = args.get(3).and_then(|r| r.parse().ok()).unwrap_or(5);
    let bytes = std::fs::read(path).expect("read the part");
    let part = mesh::read_stl(&bytes[..], bytes.len() as u64, units).expect("a valid STL");
    let m = &part.mesh;
    println!("{path}: {} triangles", m.triangles.len());
    let (bvh, build) = best_of(runs, || Bvh::new(m));
    println!("bvh build               {build:8.1} ms");
    // One ray per facet from its centroid along the inverted normal, first hit only: what
    // the reference's Embree call (trimesh `intersects_first`) casts.
    let rays: Vec<Ray> = (0..m.triangles.len())
        .map(|t| {
            let [a, b, c] = m.corners(t);
            Ray::new((a + b + c) / 3.0, -m.normal(t)).skipping(t as u32)
        })
        .collect();
    let leaf_rays: Vec<Ray> = bvh.leaf_order().iter().map(|&t| rays[t as usize]).collect();
    for (name, rays) in [("mesh order", &rays), ("leaf order", &leaf_rays)] {
        let (hits, ms) = best_of(runs, || {
            rays.par_iter()
                .with_min_len(256)
                .filter(|r| bvh.first_hit(r).is_some())
                .count()
        });
        println!(
            "first hits, {name}      {ms:8.1} ms: {hits} of {} rays hit, {:.2} M rays/s",
            rays.len(),
            rays.len() as f64 / ms / 1e3
        );
    }
    for (name, cross_check) in [
        ("rays + cross check", CrossCheck::On),
        ("rays only", CrossCheck::Off),
    ] {
        let options = ThicknessOptions {
            cross_check,
            ..ThicknessOptions::default()
        };
        let (w, ms) = best_of(runs, || wall_thickness_with(m, &bvh, &options));
        println!(
            "thickness, {name:<18} {ms:8.1} ms: min {:.3} nominal {:.3} max {:.3} mm, unknown {:.2} %",
            w.min_mm.unwrap_or(f64::NAN),
            w.nominal_mm.unwrap_or(f64::NAN),
            w.max_mm.unwrap_or(f64::NAN),
            100.0 * w.unknown_area_share
        );
    }
}
