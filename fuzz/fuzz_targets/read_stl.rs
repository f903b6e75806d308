//! The STL reader on arbitrary bytes: an error or a mesh, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use moldgate::mesh::{read_stl, Units};

fuzz_target!(|data: &[u8]| {
    let _ = read_stl(data, data.len() as u64, Units::Mm);
    // A length that disagrees with the bytes (a file that changed while read).
    let _ = read_stl(data, (data.len() as u64).wrapping_add(50), Units::Mm);
});
