//! The `moldgate._moldgate` native module: thin glue between Python and the moldgate
//! library. Parts are loaded or built from arrays ([`part`]), studied with the library's
//! [`moldgate::study`] from options that Python hands over as JSON ([`study`]), and every
//! error becomes a Python exception with the library's message. The Python package
//! (`python/moldgate/__init__.py`) gives the user-facing signatures and docstrings.
//!
//! Every call that does real work releases the GIL (`Python::detach`) and runs under
//! `catch_unwind`, so Python threads run parts in parallel and no Rust panic reaches Python.

mod part;
mod study;

use std::panic::{catch_unwind, AssertUnwindSafe};

use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

create_exception!(
    moldgate,
    LoadError,
    PyValueError,
    "A part that cannot be read or built: the message names the file and the place (line, byte, vertex or triangle)."
);
create_exception!(
    moldgate,
    OptionsError,
    PyValueError,
    "An option that is unknown or out of range, or a material that cannot be used."
);
create_exception!(
    moldgate,
    NoGateError,
    PyValueError,
    "The part was studied but no position qualifies for a gate (the message says which rule removed the last ones)."
);
create_exception!(
    moldgate,
    InternalError,
    PyRuntimeError,
    "A defect of moldgate (a panic caught at the boundary); please report it with the message."
);

/// The message of a caught panic.
fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into())
}

/// Runs `f` without the GIL, turning a panic into [`InternalError`].
pub(crate) fn detached<T: Send>(
    py: Python<'_>,
    f: impl FnOnce() -> Result<T, PyErrBox> + Send,
) -> PyResult<T> {
    py.detach(|| catch_unwind(AssertUnwindSafe(f)))
        .map_err(|p| panicked(&*p))?
        .map_err(PyErrBox::into_py_err)
}

/// The `InternalError` of a caught panic.
pub(crate) fn panicked(payload: &(dyn std::any::Any + Send)) -> PyErr {
    InternalError::new_err(format!(
        "internal error in moldgate, please report it: {}",
        panic_message(payload)
    ))
}

/// Runs `f` with the GIL held, turning a panic into [`InternalError`].
pub(crate) fn guarded<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|p| Err(panicked(&*p)))
}

/// An error made without the GIL: which exception, and its message.
#[derive(Debug)]
pub(crate) enum PyErrBox {
    Load(String),
    Options(String),
    NoGate(String),
    Internal(String),
}

impl PyErrBox {
    pub(crate) fn into_py_err(self) -> PyErr {
        match self {
            PyErrBox::Load(m) => LoadError::new_err(m),
            PyErrBox::Options(m) => OptionsError::new_err(m),
            PyErrBox::NoGate(m) => NoGateError::new_err(m),
            PyErrBox::Internal(m) => InternalError::new_err(m),
        }
    }
}

/// keyword_words(text)
/// --
///
/// A message of the library with the command line's flags named as this package's
/// keywords (`--max-nodes` as `max_nodes`, `--aesthetic` as `aesthetic=True`).
#[pyfunction]
fn keyword_words(text: &str) -> String {
    moldgate::study::keyword_words(text, "True")
}

#[pymodule]
fn _moldgate(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("LoadError", py.get_type::<LoadError>())?;
    m.add("OptionsError", py.get_type::<OptionsError>())?;
    m.add("NoGateError", py.get_type::<NoGateError>())?;
    m.add("InternalError", py.get_type::<InternalError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<part::Part>()?;
    m.add_class::<study::Study>()?;
    m.add_class::<study::Gate>()?;
    m.add_class::<study::Suitability>()?;
    m.add_function(wrap_pyfunction!(part::load, m)?)?;
    m.add_function(wrap_pyfunction!(part::sample, m)?)?;
    m.add_function(wrap_pyfunction!(part::check_units, m)?)?;
    m.add_function(wrap_pyfunction!(study::study, m)?)?;
    m.add_function(wrap_pyfunction!(study::batch_row, m)?)?;
    m.add_function(wrap_pyfunction!(study::materials, m)?)?;
    m.add_function(wrap_pyfunction!(study::default_options, m)?)?;
    m.add_function(wrap_pyfunction!(study::check_options, m)?)?;
    m.add_function(wrap_pyfunction!(study::panic_for_test, m)?)?;
    m.add_function(wrap_pyfunction!(keyword_words, m)?)?;
    Ok(())
}
