//! The module's exports: plain `extern "C"` functions over integers and byte ranges of the
//! module's memory, so the page needs no generated bindings (`web/src/moldgate.js` is the
//! glue).
//!
//! Protocol: the page allocates a range with [`mg_alloc`], writes bytes into it and passes
//! `(pointer, length)`; every call that produces something returns a status (non-zero for
//! success: a handle, or 1) and leaves its output, or the error message in UTF-8 when it
//! failed, in one output buffer read through [`mg_out_ptr`] and [`mg_out_len`] until the
//! next call. A study lives under its handle until [`mg_drop`].
//!
//! The module imports three functions from the page (module `moldgate`): `now_ms() -> f64`
//! (the clock of the report's timings), `progress(stage_ptr, stage_len, fraction)` and
//! `panicked(message_ptr, message_len)`. A panic aborts a `wasm32-unknown-unknown` module
//! (the call traps): the hook set by [`mg_init`] hands the message to the page first, and
//! the page makes a new instance, since the old one's memory may be half-written.

use std::sync::{Mutex, MutexGuard};

use moldgate::study::Progress;

use crate::session::{self, Colouring, Request, Session};

#[cfg(target_arch = "wasm32")]
mod page {
    #[link(wasm_import_module = "moldgate")]
    extern "C" {
        pub fn now_ms() -> f64;
        pub fn progress(stage: *const u8, stage_len: usize, fraction: f64);
        pub fn panicked(message: *const u8, message_len: usize);
    }
}

/// The sessions and the output buffer. The module runs on one thread; the lock only makes
/// the statics safe to name.
struct State {
    sessions: Vec<Option<Session>>,
    out: Vec<u8>,
    /// Whether the last study refused was refused for its file ([`session::Failure`]).
    file_error: bool,
}

static STATE: Mutex<State> = Mutex::new(State {
    sessions: Vec::new(),
    out: Vec::new(),
    file_error: false,
});

fn state() -> MutexGuard<'static, State> {
    // A panic while the lock was held ends the instance in the browser; natively (tests)
    // the state is still whole enough to read.
    STATE.lock().unwrap_or_else(|e| e.into_inner())
}

/// Puts `result` in the output buffer: the bytes and `ok`, or the message and 0.
fn finish(result: Result<Vec<u8>, String>, ok: u32) -> u32 {
    let mut s = state();
    match result {
        Ok(bytes) => {
            s.out = bytes;
            ok
        }
        Err(message) => {
            s.out = message.into_bytes();
            0
        }
    }
}

/// The bytes at `(ptr, len)`.
///
/// # Safety
/// `ptr` must point to `len` readable bytes (any pointer when `len` is 0).
unsafe fn bytes<'a>(ptr: *const u8, len: usize) -> &'a [u8] {
    if len == 0 || ptr.is_null() {
        &[]
    } else {
        // SAFETY: the caller gives `len` readable bytes at `ptr`.
        unsafe { std::slice::from_raw_parts(ptr, len) }
    }
}

/// Sets the panic hook and the clock. Call once after instantiating.
#[no_mangle]
pub extern "C" fn mg_init() {
    #[cfg(target_arch = "wasm32")]
    {
        std::panic::set_hook(Box::new(|info| {
            let message = info.to_string();
            // SAFETY: the page copies the message out before the module traps.
            unsafe { page::panicked(message.as_ptr(), message.len()) };
        }));
        // SAFETY: `now_ms` takes nothing and returns a number.
        moldgate::clock::set_millisecond_clock(|| unsafe { page::now_ms() });
    }
}

/// Allocates `len` bytes for the page to write into; null when memory is exhausted.
#[no_mangle]
pub extern "C" fn mg_alloc(len: usize) -> *mut u8 {
    if len == 0 {
        return std::ptr::NonNull::<u8>::dangling().as_ptr();
    }
    match std::alloc::Layout::array::<u8>(len) {
        // SAFETY: the layout has a non-zero size.
        Ok(layout) => unsafe { std::alloc::alloc(layout) },
        Err(_) => std::ptr::null_mut(),
    }
}

/// Frees a range from [`mg_alloc`].
///
/// # Safety
/// `(ptr, len)` must be a range [`mg_alloc`] returned and not yet freed.
#[no_mangle]
pub unsafe extern "C" fn mg_free(ptr: *mut u8, len: usize) {
    if len == 0 || ptr.is_null() {
        return;
    }
    if let Ok(layout) = std::alloc::Layout::array::<u8>(len) {
        // SAFETY: allocated by `mg_alloc` with this layout.
        unsafe { std::alloc::dealloc(ptr, layout) };
    }
}

/// The output of the last call.
#[no_mangle]
pub extern "C" fn mg_out_ptr() -> *const u8 {
    state().out.as_ptr()
}

/// The length of the output of the last call.
#[no_mangle]
pub extern "C" fn mg_out_len() -> usize {
    state().out.len()
}

/// The largest file accepted, in bytes.
#[no_mangle]
pub extern "C" fn mg_max_file_bytes() -> usize {
    session::MAX_FILE_BYTES
}

fn report_progress(p: Progress) {
    #[cfg(target_arch = "wasm32")]
    {
        let name = p.stage.name();
        // SAFETY: the page copies the name out during the call.
        unsafe { page::progress(name.as_ptr(), name.len(), p.fraction) };
    }
    #[cfg(not(target_arch = "wasm32"))]
    let _ = p;
}

/// Reads the file at `(file_ptr, file_len)` and studies it as the request at
/// `(request_ptr, request_len)` asks (JSON of [`Request`]). Returns the study's handle
/// (non-zero), or 0 with the message in the output.
///
/// # Safety
/// Both ranges must be readable.
#[no_mangle]
pub unsafe extern "C" fn mg_study(
    file_ptr: *const u8,
    file_len: usize,
    request_ptr: *const u8,
    request_len: usize,
) -> u32 {
    // SAFETY: the caller gives readable ranges.
    let (file, request) = unsafe { (bytes(file_ptr, file_len), bytes(request_ptr, request_len)) };
    let result = request_of(request)
        .map_err(session::Failure::from)
        .and_then(|r| Session::new(file, &r, &report_progress));
    match result {
        Ok(session) => {
            let mut s = state();
            s.sessions.push(Some(session));
            s.out.clear();
            s.file_error = false;
            s.sessions.len() as u32
        }
        Err(failure) => {
            state().file_error = failure.file;
            finish(Err(failure.message), 0)
        }
    }
}

/// Checks the request at `(request_ptr, request_len)` (JSON of [`Request`]) as [`mg_study`]
/// would before it reads the file: 1 when its options are sound, else 0 with the message in
/// the output. The page asks it before it lets the results shown go.
///
/// # Safety
/// The range must be readable.
#[no_mangle]
pub unsafe extern "C" fn mg_check(request_ptr: *const u8, request_len: usize) -> u32 {
    // SAFETY: the caller gives a readable range.
    let request = unsafe { bytes(request_ptr, request_len) };
    let result = request_of(request)
        .map_err(session::Failure::from)
        .and_then(|r| Session::settings(&r).map(drop));
    match result {
        Ok(()) => finish(Ok(Vec::new()), 1),
        Err(failure) => finish(Err(failure.message), 1),
    }
}

/// 1 when the last study refused ([`mg_study`] returned 0) was refused for its file, which
/// cannot be read as a mesh (no option mends it), else 0.
#[no_mangle]
pub extern "C" fn mg_error_is_file() -> u32 {
    u32::from(state().file_error)
}

/// The page's request; its options read as the service's and the Python package's are, so
/// that an error names the option at fault in plain words (`material.n: ...`).
fn request_of(bytes: &[u8]) -> Result<Request, String> {
    let mut value: serde_json::Value =
        serde_json::from_slice(bytes).map_err(|e| format!("the request is not JSON: {e}"))?;
    let options = match value.as_object_mut().and_then(|o| o.remove("options")) {
        None => moldgate::StudyOptions::default(),
        Some(serde_json::Value::Object(object)) => {
            moldgate::StudyOptions::from_json_object(object).map_err(|e| format!("options: {e}"))?
        }
        Some(other) => return Err(format!("options must be an object, got {other}")),
    };
    let mut request: Request =
        serde_json::from_value(value).map_err(|e| format!("request: {e}"))?;
    request.options = options;
    Ok(request)
}

/// Runs `f` on the study under `handle`.
fn with_session(handle: u32, f: impl FnOnce(&Session) -> Result<Vec<u8>, String>) -> u32 {
    let result = {
        let s = state();
        match handle
            .checked_sub(1)
            .and_then(|i| s.sessions.get(i as usize))
        {
            Some(Some(session)) => f(session),
            _ => Err(format!("no study {handle}")),
        }
    };
    finish(result, 1)
}

/// The report JSON of a study (as `moldgate locate --json` prints it).
#[no_mangle]
pub extern "C" fn mg_report(handle: u32) -> u32 {
    with_session(handle, |s| s.report_json().map(String::into_bytes))
}

/// The GLB of a study, the part coloured by `colouring` (0 as the study shows it, 1 height,
/// 2 wall thickness, 3 fill order).
#[no_mangle]
pub extern "C" fn mg_glb(handle: u32, colouring: u32) -> u32 {
    with_session(handle, |s| s.glb(colouring_of(colouring)?))
}

/// The PNG picture of a study, the part coloured by `colouring` (as [`mg_glb`]).
#[no_mangle]
pub extern "C" fn mg_png(handle: u32, colouring: u32) -> u32 {
    with_session(handle, |s| s.png(colouring_of(colouring)?))
}

/// The HTML report of a study, its picture coloured by `colouring` (as [`mg_glb`]).
#[no_mangle]
pub extern "C" fn mg_html(handle: u32, colouring: u32) -> u32 {
    with_session(handle, |s| {
        s.html(colouring_of(colouring)?).map(String::into_bytes)
    })
}

/// The colouring of an export's code, or the message for a code of none.
fn colouring_of(code: u32) -> Result<Colouring, String> {
    Colouring::from_code(code).ok_or(format!("no colouring {code}"))
}

/// Forgets a study.
#[no_mangle]
pub extern "C" fn mg_drop(handle: u32) {
    let mut s = state();
    if let Some(slot) = handle
        .checked_sub(1)
        .and_then(|i| s.sessions.get_mut(i as usize))
    {
        *slot = None;
    }
}

/// The built-in samples as JSON.
#[no_mangle]
pub extern "C" fn mg_samples() -> u32 {
    finish(Ok(session::samples_json().into_bytes()), 1)
}

/// The built-in materials as JSON.
#[no_mangle]
pub extern "C" fn mg_materials() -> u32 {
    finish(Ok(session::materials_json().into_bytes()), 1)
}

/// The materials with a user's materials file, `{"name": ..., "text": ...}` as JSON at
/// `(ptr, len)`, as JSON (see [`session::materials_with_json`]); 0 with the message in the
/// output when the file is refused.
///
/// # Safety
/// The range must be readable.
#[no_mangle]
pub unsafe extern "C" fn mg_materials_with(ptr: *const u8, len: usize) -> u32 {
    // SAFETY: the caller gives a readable range.
    let file = unsafe { bytes(ptr, len) };
    let result = std::str::from_utf8(file)
        .map_err(|e| format!("the materials file's request is not UTF-8: {e}"))
        .and_then(session::materials_with_json);
    finish(result.map(String::into_bytes), 1)
}

/// The default options (the command line's) as JSON.
#[no_mangle]
pub extern "C" fn mg_defaults() -> u32 {
    finish(Ok(session::defaults_json().into_bytes()), 1)
}

/// Panics with the message at `(ptr, len)`: the test of the page's recovery from a trap
/// (`web/tests/glue.test.mjs`), since the library itself has no panic to offer.
///
/// # Safety
/// The range must be readable.
#[no_mangle]
pub unsafe extern "C" fn mg_panic(ptr: *const u8, len: usize) {
    // SAFETY: the caller gives a readable range.
    let message = String::from_utf8_lossy(unsafe { bytes(ptr, len) }).into_owned();
    panic!("{message}");
}

/// The threads the study runs on: 1 in the browser, where rayon falls back to the calling
/// thread because `wasm32-unknown-unknown` cannot start threads.
#[no_mangle]
pub extern "C" fn mg_threads() -> usize {
    // Builds rayon's global pool if no study has yet, as a study's first parallel loop does.
    rayon::current_num_threads()
}

/// The version of moldgate.
#[no_mangle]
pub extern "C" fn mg_version() -> u32 {
    finish(Ok(env!("CARGO_PKG_VERSION").as_bytes().to_vec()), 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn out() -> Vec<u8> {
        // SAFETY: the output buffer is readable until the next call.
        unsafe { bytes(mg_out_ptr(), mg_out_len()).to_vec() }
    }

    fn study(file: &[u8], request: &str) -> u32 {
        // SAFETY: both are live slices.
        unsafe { mg_study(file.as_ptr(), file.len(), request.as_ptr(), request.len()) }
    }

    // One test: the exports share one state, and tests run on several threads.
    #[test]
    fn the_protocol_round_trips() {
        let p = mg_alloc(10);
        assert!(!p.is_null());
        // SAFETY: allocated above.
        unsafe { mg_free(p, 10) };

        let h = study(b"", r#"{ "sample": "cap", "options": { "demold": "-z" } }"#);
        assert!(h > 0, "{}", String::from_utf8_lossy(&out()));
        assert_eq!(mg_report(h), 1);
        let report: serde_json::Value = serde_json::from_slice(&out()).unwrap();
        assert_eq!(report["input"]["sample"], "cap");
        assert_eq!(mg_glb(h, 0), 1);
        assert!(out().starts_with(b"glTF"));
        assert_eq!(mg_glb(h, 9), 0);
        assert_eq!(out(), b"no colouring 9");

        assert_eq!(study(b"solid x\nfacet", r#"{ "file_name": "x.stl" }"#), 0);
        assert!(String::from_utf8(out()).unwrap().starts_with("x.stl: "));
        assert_eq!(study(b"", "{ not json"), 0);
        assert!(String::from_utf8(out())
            .unwrap()
            .starts_with("the request is not JSON: "));
        // A material of the page's own parameters with one left empty: the parameter is
        // named in plain words, not by the Rust type that did not match.
        let r = r#"{ "sample": "cap", "options": { "material": { "n": null, "t_melt": 230, "t_wall": 50, "gamma_opt": 1000, "mu_opt": 100, "k": 0.2 } } }"#;
        assert_eq!(study(b"", r), 0);
        let said = String::from_utf8(out()).unwrap();
        assert_eq!(
            said,
            "options: material.n: got no value (null), expected a number"
        );

        mg_drop(h);
        assert_eq!(mg_report(h), 0);
        assert_eq!(out(), format!("no study {h}").as_bytes());
        assert_eq!(mg_report(0), 0);
        assert_eq!(mg_samples(), 1);
        assert!(out().starts_with(b"["));
    }
}
