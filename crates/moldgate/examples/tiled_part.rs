//! Writes a large binary STL for scaling measurements: COPIES copies of a binary STL part
//! side by side along x (each moved by 1.25 times the part's width), so that triangles,
//! vertices and the file grow in proportion while the part's detail stays the same.
//!
//! ```text
//! cargo run --release -p moldgate --example tiled_part -- PART.stl OUT.stl COPIES
//! ```
//!
//! The records are copied as they are but for the corners' x, which is moved in f64 and
//! rounded to f32 again; rounding may weld a few corners that lay within one f32 step of
//! each other (moldgate's load counts them as collapsed facets). `scripts/scaling_table.py`
//! uses it.

use std::fs::File;
use std::io::{BufWriter, Read, Write};

const RECORD: usize = 50;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [part, out, copies] = &args[..] else {
        eprintln!("usage: tiled_part PART.stl OUT.stl COPIES");
        std::process::exit(2);
    };
    let copies: u32 = copies.parse().expect("COPIES is a whole number");
    let mut bytes = Vec::new();
    File::open(part)
        .and_then(|mut f| f.read_to_end(&mut bytes))
        .expect("read the part");
    let n = u32::from_le_bytes(bytes[80..84].try_into().unwrap()) as usize;
    assert_eq!(
        bytes.len(),
        84 + RECORD * n,
        "a binary STL of 84 + 50 n bytes"
    );
    let records = &bytes[84..];
    let x_of = |rec: &[u8], k: usize| {
        let at = 12 + 12 * k;
        f32::from_le_bytes(rec[at..at + 4].try_into().unwrap())
    };
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for rec in records.chunks_exact(RECORD) {
        for k in 0..3 {
            lo = lo.min(x_of(rec, k));
            hi = hi.max(x_of(rec, k));
        }
    }
    let pitch = 1.25 * f64::from(hi - lo);
    let total = u32::try_from(n as u64 * u64::from(copies)).expect("at most 2^32 - 1 facets");
    let mut w = BufWriter::with_capacity(1 << 20, File::create(out).expect("create OUT"));
    let mut header = [b' '; 80];
    header[..27].copy_from_slice(b"moldgate tiled scaling part");
    w.write_all(&header).unwrap();
    w.write_all(&total.to_le_bytes()).unwrap();
    let mut rec = [0u8; RECORD];
    for c in 0..copies {
        let offset = pitch * f64::from(c);
        for src in records.chunks_exact(RECORD) {
            rec.copy_from_slice(src);
            for k in 0..3 {
                let at = 12 + 12 * k;
                let x = (f64::from(x_of(src, k)) + offset) as f32;
                rec[at..at + 4].copy_from_slice(&x.to_le_bytes());
            }
            w.write_all(&rec).unwrap();
        }
    }
    w.flush().expect("write OUT");
}
