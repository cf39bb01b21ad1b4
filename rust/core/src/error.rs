//! The one error type of the core. Every fallible entry point returns [`Result`]; the Python
//! crate maps each variant to one exception class in a single place (`rust/py/src/error.rs`).

use std::fmt;

/// Why a core call refused its input or could not run.
#[derive(Debug, Clone, PartialEq)]
pub enum Error {
    /// Bad input: `arg` names the offending argument, `message` says what was expected and found.
    InvalidInput { arg: String, message: String },
    /// Valid input that this method (or backend) cannot serve: a light kind, an emission texture,
    /// a light among the receivers, an option on the GPU. `arg` names what it refuses; `message`
    /// says why and which methods or options can. An evaluation records it as the method's
    /// refusal of the setup, where a bad input stays an error.
    Unsupported { arg: String, message: String },
    /// The request would need more memory than the configured limit; nothing was allocated.
    TooLarge {
        what: String,
        bytes: u64,
        limit: u64,
    },
    /// A resource outside the input is missing (no GPU adapter, ...).
    Unavailable(String),
    /// The request's estimated work is above the configured limit; nothing was computed.
    TooMuchWork {
        what: String,
        operations: u64,
        limit: u64,
    },
    /// The call was stopped through its [`crate::interrupt::Cancel`] token.
    Interrupted,
}

/// `Result` with the core [`Error`].
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// A bad-input error naming `arg`.
    pub fn invalid(arg: impl Into<String>, message: impl Into<String>) -> Self {
        Error::InvalidInput {
            arg: arg.into(),
            message: message.into(),
        }
    }

    /// A refusal of a valid setup by a method that cannot serve it, naming `arg`.
    pub fn unsupported(arg: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Unsupported {
            arg: arg.into(),
            message: message.into(),
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::InvalidInput { arg, message } | Error::Unsupported { arg, message } => {
                write!(f, "{arg}: {message}")
            }
            Error::TooLarge { what, bytes, limit } => write!(
                f,
                "{what} needs about {} ({bytes} bytes), above the memory limit of {} \
                 (lower the resolution or sample count, or raise softshadows.set_memory_limit)",
                human_bytes(*bytes),
                human_bytes(*limit)
            ),
            Error::Unavailable(message) => write!(f, "{message}"),
            Error::TooMuchWork { what, operations, limit } => write!(
                f,
                "{what} needs about {operations:.3e} operations, above the work limit of {limit:.3e} \
                 (lower the resolution, sample count or view count, or raise softshadows.set_work_limit)",
                operations = *operations as f64,
                limit = *limit as f64
            ),
            Error::Interrupted => write!(f, "interrupted"),
        }
    }
}

impl std::error::Error for Error {}

/// `bytes` in the largest binary unit that keeps the number at least 1, two decimals.
fn human_bytes(bytes: u64) -> String {
    let units = ["bytes", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < units.len() {
        value /= 1024.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{bytes} bytes")
    } else {
        format!("{value:.2} {}", units[unit])
    }
}
