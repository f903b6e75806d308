//! The floor for the speed of loading: a streaming parse of a binary STL and nothing else.
//!
//! Reads the file in chunks of whole facets, decodes every corner's three `f32` and sums
//! them, so that the work cannot be optimised away; no welding, no topology, no analysis,
//! one thread. `scripts/speed_table.py` times this whole process beside `moldgate locate`
//! on the same file: the ratio says how far the command is from merely reading its input.
//!
//! ```text
//! cargo build --release -p moldgate --example parse_floor
//! target/release/examples/parse_floor PART.stl
//! ```

use std::fs::File;
use std::io::Read;

/// Bytes of one binary STL facet: normal, three corners, attribute count.
const FACET: usize = 50;
/// Facets per read: 1 MB chunks, the size at which a read costs about the copy.
const CHUNK_FACETS: usize = 20_000;

fn main() {
    let Some(path) = std::env::args().nth(1) else {
        eprintln!("usage: parse_floor PART.stl");
        std::process::exit(2);
    };
    let mut file = File::open(&path).unwrap_or_else(|e| {
        eprintln!("parse_floor: {path}: {e}");
        std::process::exit(1);
    });
    let mut header = [0u8; 84];
    if let Err(e) = file.read_exact(&mut header) {
        eprintln!("parse_floor: {path}: not a binary STL ({e})");
        std::process::exit(1);
    }
    let declared = u32::from_le_bytes([header[80], header[81], header[82], header[83]]) as usize;
    let mut buffer = vec![0u8; CHUNK_FACETS * FACET];
    let mut left = declared;
    let mut sum = [0f64; 3];
    while left > 0 {
        let n = left.min(CHUNK_FACETS);
        let chunk = &mut buffer[..n * FACET];
        if let Err(e) = file.read_exact(chunk) {
            eprintln!("parse_floor: {path}: file ends before its {declared} facets ({e})");
            std::process::exit(1);
        }
        for facet in chunk.chunks_exact(FACET) {
            // Corners start after the 12-byte normal.
            for (i, c) in facet[12..48].chunks_exact(4).enumerate() {
                sum[i % 3] += f32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f64;
            }
        }
        left -= n;
    }
    println!(
        "{declared} facets, corner sums {:.6e} {:.6e} {:.6e}",
        sum[0], sum[1], sum[2]
    );
}
