//! moldgate in the browser: the library compiled to `wasm32-unknown-unknown` behind a few
//! plain `extern "C"` exports ([`ffi`]), so the page's own few dozen lines of JavaScript
//! (`web/src/moldgate.js`) load it without generated bindings. The part is read from the
//! bytes the page hands over and studied on the user's machine; nothing leaves it.
//!
//! [`session`] holds the work in plain Rust (read by extension, study, report, GLB, PNG,
//! HTML) and is tested natively; [`ffi`] only moves bytes in and out.
//!
//! Build: `cargo build -p moldgate-web --release --target wasm32-unknown-unknown`
//! (`scripts/build-web.sh` does it and builds the page).
#![deny(missing_docs)]

pub mod ffi;
pub mod session;
