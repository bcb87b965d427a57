//! Errors raised to Python: the CLI's one-line message (an error and its causes joined with
//! `": "`, as `femto` prints after `femto: error: `), as `femto.FemtoError` (a `ValueError`),
//! or, when the cause is a file the system could not open, read or write, as
//! `femto.FemtoOSError` (also an `OSError`; `femto.FemtoFileNotFoundError`, also a
//! `FileNotFoundError`, when it is missing). The classes live in `femto/_errors.py`.

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::PyType;
use std::error::Error;

/// The error as the CLI prints it: the message, then each cause not already in it.
pub fn error_line(e: &(dyn Error + 'static)) -> String {
    let mut line = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        let text = c.to_string();
        if !line.contains(&text) {
            line.push_str(": ");
            line.push_str(&text);
        }
        cause = c.source();
    }
    line.replace('\n', " ")
}

/// The first I/O error in `e`'s chain of causes.
fn io_cause<'a>(e: &'a (dyn Error + 'static)) -> Option<&'a std::io::Error> {
    let mut cause: Option<&(dyn Error + 'static)> = Some(e);
    while let Some(c) = cause {
        if let Some(io) = c.downcast_ref::<std::io::Error>() {
            return Some(io);
        }
        cause = c.source();
    }
    None
}

/// The OS error number of an I/O error that a library error carries only as text (some
/// wrap their cause into their message): std writes it as `(os error N)`.
fn errno_in_text(message: &str) -> Option<i32> {
    let (_, rest) = message.rsplit_once("(os error ")?;
    rest.split_once(')')?.0.parse().ok()
}

/// The class named `name` of `femto._errors`.
fn class<'py>(py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyType>> {
    Ok(py
        .import("femto._errors")?
        .getattr(name)?
        .cast_into::<PyType>()?)
}

/// `message` as a `femto.FemtoError` (a `ValueError`): a bad argument or bad input.
pub fn value_error(message: impl Into<String>) -> PyErr {
    let message = message.into();
    Python::attach(|py| match class(py, "FemtoError") {
        Ok(cls) => PyErr::from_type(cls, message),
        Err(e) => PyRuntimeError::new_err(format!("{message} (femto._errors: {e})")),
    })
}

/// A library error as the Python exception that fits it, with the CLI's message.
pub fn to_py(e: &(dyn Error + 'static)) -> PyErr {
    let message = error_line(e);
    let not_found = io_cause(e).map(|io| io.kind() == std::io::ErrorKind::NotFound);
    // A `NotFound` error made by the library (no OS error number) is ENOENT all the same.
    let errno = io_cause(e)
        .and_then(|io| io.raw_os_error())
        .or_else(|| errno_in_text(&message))
        .or_else(|| (not_found == Some(true)).then(libc_enoent));
    let is_os = io_cause(e).is_some() || errno.is_some();
    Python::attach(|py| {
        let raised = if is_os {
            let missing = not_found.unwrap_or(errno == Some(libc_enoent()));
            let name = if missing {
                "FemtoFileNotFoundError"
            } else {
                "FemtoOSError"
            };
            // str() stays the CLI's line (one argument); `.errno` is set afterwards.
            class(py, name).map(|cls| {
                let err = PyErr::from_type(cls, message.clone());
                if let Some(n) = errno {
                    let _ = err.value(py).setattr("errno", n);
                }
                err
            })
        } else {
            class(py, "FemtoError").map(|cls| PyErr::from_type(cls, message.clone()))
        };
        raised
            .unwrap_or_else(|e| PyRuntimeError::new_err(format!("{message} (femto._errors: {e})")))
    })
}

/// ENOENT: the OS error number of a missing file (2 on Linux, macOS and Windows' CRT).
const fn libc_enoent() -> i32 {
    2
}

/// Convert a library `Result` into a Python one.
pub trait IntoPy<T> {
    fn py_err(self) -> PyResult<T>;
}

impl<T, E: Error + 'static> IntoPy<T> for Result<T, E> {
    fn py_err(self) -> PyResult<T> {
        self.map_err(|e| to_py(&e))
    }
}
