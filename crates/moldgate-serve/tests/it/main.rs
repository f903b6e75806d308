//! The service's integration tests, one test binary (`cargo test -p moldgate-serve --test it`):
//! each file of this folder is a module, named for what it tests.

mod openapi;
mod web_dir;
