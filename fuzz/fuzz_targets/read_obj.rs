//! The OBJ reader on arbitrary bytes: an error or a mesh, never a panic (`moldgate_fuzz::read_obj`).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| moldgate_fuzz::read_obj(data));
