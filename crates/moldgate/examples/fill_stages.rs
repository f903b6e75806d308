//! Best-of-N time of each stage of the fill analysis on one part, and of one march:
//! `fill_stages PART.stl DEMOLD [REPEATS]`. Run with `RAYON_NUM_THREADS=1` for the work of
//! one thread.
use std::time::Instant;

use moldgate::flow::{self, FillOptions, Strategy, Walls};
use moldgate::raycast::Bvh;
use moldgate::thickness::{wall_thickness_of, CrossCheck, ThicknessOptions};
use moldgate::{locate, LocateOptions, Material};

fn best<T>(repeats: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut out = None;
    let mut best = f64::INFINITY;
    for _ in 0..repeats {
        let t = Instant::now();
        let r = f();
        best = best.min(t.elapsed().as_secs_f64() * 1e3);
        out = Some(r);
    }
    (best, out.expect("one run"))
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        eprintln!("usage: fill_stages PART.stl DEMOLD [REPEATS]");
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
    let repeats: usize = args.get(3).map_or(5, |s| s.parse().expect("repeats"));
    let options = LocateOptions {
        direction: args[2].parse().expect("demold"),
        ..LocateOptions::default()
    };
    let analysis = locate(&part, &options).expect("locate");
    let pp = Material::builtin("PP").expect("PP");
    // The fill alone takes the Morton tree, as the study builds it for a fill without the
    // wall of every facet.
    let (tree_ms, bvh) = best(repeats, || Bvh::new_morton(&part.mesh));
    println!("Morton tree {tree_ms:.1} ms");
    for (name, gates, strategy) in [
        ("fill", 1, Strategy::Paper),
        ("balanced", 1, Strategy::Balanced),
        ("gates 3", 3, Strategy::Paper),
    ] {
        let o = FillOptions {
            gates,
            strategy,
            ..FillOptions::default()
        };
        let (ms, f) = best(repeats, || {
            flow::analyse(&part.mesh, &analysis, &pp, Walls::Measure(&bvh), &o).expect("fill")
        });
        let t = f.times;
        println!(
            "{name}: {ms:.1} ms (voxels {:.1}, wall {:.1}, paper {:.1}, balanced {:.1}, several {:.1}); cells {}, runs {} + {}",
            t.voxels_s * 1e3,
            t.wall_s * 1e3,
            t.paper_s * 1e3,
            t.balanced_s * 1e3,
            t.several_s * 1e3,
            f.cells,
            f.balanced.as_ref().map_or(0, |b| b.search.runs),
            f.several.as_ref().map_or(0, |s| s.runs),
        );
    }
    let nominal = 1.5;
    let limits = flow::FlowOptions::default();
    let (bodies_ms, bodies) = best(repeats, || flow::Bodies::of(&part.mesh));
    // The study passes the count of bodies the load found: one body needs no union.
    let (counted_ms, _) = best(repeats, || {
        flow::Bodies::of_counted(&part.mesh, Some(part.topology.bodies))
    });
    let (size_ms, h) = best(repeats, || {
        flow::cell_size(&part.mesh, nominal, &limits)
            .expect("cell")
            .0
    });
    let (build_ms, voxels) = best(repeats, || {
        flow::Voxels::bounded(&part.mesh, h, &bodies.of_triangle, &limits).expect("cells")
    });
    let (costs_ms, _) = best(repeats, || {
        flow::Domain::from_voxels(voxels.clone(), None, nominal, &pp)
    });
    println!(
        "cells at {h:.4} mm: bodies {bodies_ms:.1} ms ({counted_ms:.1} ms with their count known), cell size and limits {size_ms:.1} ms, voxelising {build_ms:.1} ms, costs {costs_ms:.1} ms (with a copy of the cells)"
    );
    let domain = flow::Domain::new(&part.mesh, h, None, nominal, &pp);
    let src = domain
        .source(analysis.gate().expect("gate").point())
        .expect("source");
    let (ms, f) = best(repeats * 4, || flow::march(&domain.voxels, &[src], None));
    println!(
        "one march {ms:.2} ms on {} cells, L_max {:.4}",
        domain.voxels.len(),
        flow::argmax(&f.t).1
    );
    let (ms, _) = best(repeats * 4, || {
        flow::march(&domain.voxels, &[src], Some(&domain.fill_cost))
    });
    println!("one march with a cost {ms:.2} ms");
    // The walls the fill measures: one facet per surface cell.
    let mut owners: Vec<u32> = voxels
        .triangle
        .iter()
        .zip(&voxels.surface)
        .filter(|(_, &s)| s)
        .map(|(&t, _)| t)
        .collect();
    let listed = owners.len();
    owners.sort_unstable();
    owners.dedup();
    for check in [CrossCheck::Off, CrossCheck::On] {
        let o = ThicknessOptions {
            cross_check: check,
            ..ThicknessOptions::default()
        };
        let (ms, _) = best(repeats, || wall_thickness_of(&part.mesh, &bvh, &o, &owners));
        println!(
            "walls of the cells' facets ({listed} listed, {} distinct), cross check {check:?}: {ms:.1} ms",
            owners.len()
        );
    }
}
