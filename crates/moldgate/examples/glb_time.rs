//! Best-of-N time to write the GLB of one part, and a digest of its bytes so that two
//! builds can be checked to write the same file.
//!
//! `cargo run --release -p moldgate --example glb_time -- PART.stl [+y] [runs]`
//! (or a sample name instead of a file). Run with `RAYON_NUM_THREADS=1` for the work of
//! one thread, which is what the browser app's single-threaded module does. The digest
//! (the standard library's hasher) compares builds made with one Rust toolchain.

use std::hash::{Hash, Hasher};
use std::time::Instant;

use moldgate::scene::Scene;

mod common;

fn main() {
    let common::Located {
        name: part,
        loaded,
        analysis,
        runs,
    } = common::located_from_args();
    let scene = Scene::new(&loaded.mesh, &analysis, part.clone()).with_topology(&loaded.topology);
    let (mut best, mut times) = (f64::MAX, Vec::new());
    let mut bytes = Vec::new();
    for _ in 0..runs {
        let t = Instant::now();
        bytes = moldgate::gltf::glb(&scene).expect("the GLB writes");
        let s = t.elapsed().as_secs_f64();
        best = best.min(s);
        times.push(s);
    }
    times.sort_by(f64::total_cmp);
    let mut h = std::collections::hash_map::DefaultHasher::new();
    bytes.hash(&mut h);
    println!(
        "{part}: {} triangles, GLB {} bytes, best {:.1} ms, median {:.1} ms (of {runs}); digest {:016x}",
        loaded.mesh.triangles.len(),
        bytes.len(),
        best * 1e3,
        times[times.len() / 2] * 1e3,
        h.finish()
    );
}
