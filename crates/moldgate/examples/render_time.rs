//! Best-of-N time to draw and encode the picture of one part.
//!
//! `cargo run --release -p moldgate --example render_time -- PART.stl [+y] [runs]`
//! (or a sample name instead of a file; any format the command line reads).

use std::time::Instant;

use moldgate::render::{render, RenderOptions};
use moldgate::scene::Scene;

mod common;

fn main() {
    let common::Located {
        name: part,
        loaded,
        analysis,
        runs,
    } = common::located_from_args();
    let t = Instant::now();
    let scene = Scene::new(&loaded.mesh, &analysis, part.clone()).with_topology(&loaded.topology);
    let scene_s = t.elapsed().as_secs_f64();
    // The same scene without the topology draws both sides of every facet: the runs
    // alternate between the two, so that their times are paired.
    let both_sides = Scene {
        topology: None,
        ..scene.clone()
    };
    let (mut draw, mut draw_both, mut encode) = (f64::MAX, f64::MAX, f64::MAX);
    let mut bytes = 0;
    for _ in 0..runs {
        let t = Instant::now();
        render(&both_sides, &RenderOptions::default()).expect("the picture draws");
        draw_both = draw_both.min(t.elapsed().as_secs_f64());
        let t = Instant::now();
        let picture = render(&scene, &RenderOptions::default()).expect("the picture draws");
        draw = draw.min(t.elapsed().as_secs_f64());
        let t = Instant::now();
        bytes = picture.png().expect("the PNG encodes").len();
        encode = encode.min(t.elapsed().as_secs_f64());
    }
    println!(
        "{part}: {} triangles, scene {:.1} ms, draw {:.1} ms (both sides of every facet {:.1} ms), \
         encode {:.1} ms, {} bytes (best of {runs})",
        loaded.mesh.triangles.len(),
        scene_s * 1e3,
        draw * 1e3,
        draw_both * 1e3,
        encode * 1e3,
        bytes
    );
}
