//! The PLY reader on arbitrary bytes: an error or a mesh, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use moldgate::mesh::{read_ply, Units};

fuzz_target!(|data: &[u8]| {
    let _ = read_ply(data, Units::Mm);
});
