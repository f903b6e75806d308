//! The walls of every facet through the surface-area tree and through the Morton tree,
//! compared facet by facet; with the cross-width check off and on.
//!
//! `cargo run --release -p moldgate --example morton_walls -- PART.stl`

use moldgate::mesh::{self, Units};
use moldgate::raycast::Bvh;
use moldgate::thickness::{wall_thickness_of, CrossCheck, ThicknessOptions};

fn main() {
    let path = std::env::args()
        .nth(1)
        .expect("usage: morton_walls PART.stl");
    let bytes = std::fs::read(&path).expect("read the part");
    let part = mesh::read_stl(&bytes[..], bytes.len() as u64, Units::Mm).expect("a valid STL");
    let mesh = &part.mesh;
    let all: Vec<u32> = (0..mesh.triangles.len() as u32).collect();
    let (sah, morton) = (Bvh::new(mesh), Bvh::new_morton(mesh));
    for check in [CrossCheck::Off, CrossCheck::On] {
        let o = ThicknessOptions {
            cross_check: check,
            ..ThicknessOptions::default()
        };
        let a = wall_thickness_of(mesh, &sah, &o, &all);
        let b = wall_thickness_of(mesh, &morton, &o, &all);
        let differ: Vec<usize> = (0..a.len())
            .filter(|&t| a[t].to_bits() != b[t].to_bits())
            .collect();
        println!("{check:?}: {} of {} facets differ", differ.len(), a.len());
        let mut ties = 0;
        for &t in &differ {
            // The nearest surface to the points of the chord, through each tree.
            let [p, q, r] = mesh.corners(t);
            let n = (q - p).cross(r - p).normalize();
            let c = (p + q + r) / 3.0;
            let chord = a[t].max(b[t]) as f64;
            let tie = [0.25, 0.5, 0.75].iter().any(|&at| {
                let m = c - n * (at * chord);
                let (x, y) = (
                    sah.nearest_within(m, chord),
                    morton.nearest_within(m, chord),
                );
                x.map(|h| h.distance) == y.map(|h| h.distance)
                    && x.map(|h| h.triangle) != y.map(|h| h.triangle)
            });
            ties += tie as usize;
            if differ.len() < 200 && t == differ[0] {
                println!("  facet {t}: {} vs {}", a[t], b[t]);
            }
        }
        println!(
            "  of which a point of the chord has two nearest triangles at one distance: {ties}"
        );
    }
}
