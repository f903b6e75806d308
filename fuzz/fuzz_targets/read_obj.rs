//! The OBJ reader on arbitrary bytes: an error or a mesh, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use moldgate::mesh::{read_obj, Units};

fuzz_target!(|data: &[u8]| {
    let _ = read_obj(data, Units::Mm);
});
