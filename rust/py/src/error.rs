//! The one mapping from core errors to Python exceptions: bad input → ValueError, a setup a method
//! cannot serve → UnsupportedSetup (a ValueError), a request too
//! large → MemoryError, too much work → WorkLimitError (a RuntimeError), a missing resource →
//! RuntimeError, an interrupted call → KeyboardInterrupt.

use pyo3::exceptions::{PyKeyboardInterrupt, PyMemoryError, PyRuntimeError, PyValueError};
use pyo3::PyErr;
use softshadows_core::Error;

pyo3::create_exception!(
    _core,
    WorkLimitError,
    PyRuntimeError,
    "A call's estimated work is above softshadows.work_limit(); raise it with softshadows.set_work_limit."
);

pyo3::create_exception!(
    _core,
    UnsupportedSetup,
    PyValueError,
    "A method refuses a valid setup it cannot serve (a light kind, an emission texture, a light among the receivers, an option on the GPU); the message names the methods or options that can."
);

/// Turns a core [`Error`] into the matching Python exception.
pub fn to_py(err: Error) -> PyErr {
    let message = err.to_string();
    match err {
        Error::InvalidInput { .. } => PyValueError::new_err(message),
        Error::Unsupported { .. } => UnsupportedSetup::new_err(message),
        Error::TooLarge { .. } => PyMemoryError::new_err(message),
        Error::Unavailable(_) => PyRuntimeError::new_err(message),
        Error::TooMuchWork { .. } => WorkLimitError::new_err(message),
        Error::Interrupted => PyKeyboardInterrupt::new_err(message),
    }
}

/// `?`-friendly conversion of core results.
pub trait OrRaise<T> {
    fn or_raise(self) -> pyo3::PyResult<T>;
}

impl<T> OrRaise<T> for softshadows_core::Result<T> {
    fn or_raise(self) -> pyo3::PyResult<T> {
        self.map_err(to_py)
    }
}
