//! The command line's integration tests, one test binary (`cargo test -p moldgate-cli --test
//! it`): each file of this folder is a module, named for what it tests (`cargo test -p
//! moldgate-cli --test it serve::` runs one). One binary links once instead of once per file.

mod batch;
mod cli;
mod common;
mod fill_cli;
mod glb_cli;
mod hostile_cli;
mod obj_ply_cli;
mod pictures;
mod scripts;
mod serve;
mod special_files;
mod study_cli;
