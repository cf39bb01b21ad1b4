//! The one error type of the core. Every fallible entry point returns [`Result`]; the Python
//! crate maps each variant to one exception class in a single place (`rust/py/src/error.rs`).

use std::fmt;

/// Why a core call refused its input or could not run.
#[derive(Debug, Clone, PartialEq)]
pub enum Error {
    /// Bad input: `arg` names the offending argument, `message` says what was expected and found.
    InvalidInput { arg: String, message: String },
    /// The request would need more memory than the configured limit; nothing was allocated.
    TooLarge { what: String, bytes: u64, limit: u64 },
    /// A resource outside the input is missing (no GPU adapter, ...).
    Unavailable(String),
}

/// `Result` with the core [`Error`].
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// A bad-input error naming `arg`.
    pub fn invalid(arg: impl Into<String>, message: impl Into<String>) -> Self {
        Error::InvalidInput { arg: arg.into(), message: message.into() }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::InvalidInput { arg, message } => write!(f, "{arg}: {message}"),
            Error::TooLarge { what, bytes, limit } => write!(
                f,
                "{what} needs about {:.2} GiB, above the memory limit of {:.2} GiB \
                 (lower the resolution or sample count, or raise softshadows.set_memory_limit)",
                *bytes as f64 / (1u64 << 30) as f64,
                *limit as f64 / (1u64 << 30) as f64
            ),
            Error::Unavailable(message) => write!(f, "{message}"),
        }
    }
}

impl std::error::Error for Error {}
