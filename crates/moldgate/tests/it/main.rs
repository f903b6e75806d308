//! The library's integration tests, one test binary (`cargo test -p moldgate --test it`):
//! each file of this folder is a module, named for what it tests (`cargo test -p moldgate
//! --test it flow::` runs one). One binary links once instead of once per file.

mod analysis_properties;
mod closed_forms;
mod common;
mod fill_pictures;
mod flow;
mod fuzz_regressions;
mod glb;
mod hostile_input;
mod obj_ply_reading;
mod placed_gates;
mod render;
mod shared_geometry;
mod shared_parts;
mod stl_reading;
mod study;
mod thickness;
mod undercut;
