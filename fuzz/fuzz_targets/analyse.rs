//! A whole analysis of a small part from arbitrary bytes: load (the first byte picks the
//! reader and the next three the options), `locate` with a small grid, then the fill
//! analysis with a small voxel grid, then the report as JSON. Errors are fine; a panic is not.
//! The body is `moldgate_fuzz::analyse`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| moldgate_fuzz::analyse(data));
