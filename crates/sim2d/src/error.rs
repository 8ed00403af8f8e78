//! Errors of the simulator: bad input (scenario files, configurations) and I/O. Every variant
//! names the file or field and the reason. The outcome of a run (completed, stalled) is a
//! status in [`crate::RunResult`], never an error.

use std::path::PathBuf;

/// Everything that can stop a run before it starts, or stop writing its outputs.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A scenario file could not be read.
    #[error("cannot read scenario {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A scenario file is not valid TOML, or a field is missing, unknown or of the wrong type.
    /// The message (from the TOML parser) names the field and shows the line.
    #[error("{source_name}: {message}")]
    Parse {
        /// The file (or `"<string>"`).
        source_name: String,
        /// The parser's message, naming the field.
        message: String,
    },
    /// A value is outside its allowed range, e.g. `obstacles[3].radius`.
    #[error("{field} is invalid: {reason}")]
    Invalid {
        /// The field, with indices.
        field: String,
        /// Why.
        reason: String,
    },
    /// Writing an output (log, figure, JSON) failed.
    #[error("cannot write {path}: {reason}")]
    Write {
        /// The output file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// A solver or cost rejected its input (a bug in the planner setup if it happens).
    #[error(transparent)]
    Ddp(#[from] ddp_core::Error),
    /// A grid tool rejected its input.
    #[error(transparent)]
    Grid(#[from] subgoal_infer::Error),
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// Convenience constructor for [`Error::Invalid`].
    pub fn invalid(field: impl Into<String>, reason: impl Into<String>) -> Self {
        Error::Invalid {
            field: field.into(),
            reason: reason.into(),
        }
    }

    /// Convenience constructor for [`Error::Write`].
    pub fn write(path: impl Into<PathBuf>, reason: impl std::fmt::Display) -> Self {
        Error::Write {
            path: path.into(),
            reason: reason.to_string(),
        }
    }
}

/// A failed [`ddpkit_util::check`] validator: an [`Error::Invalid`] naming the field, e.g.
/// `robot.mass is invalid: must be finite and > 0, got 0`.
impl From<ddpkit_util::check::CheckError> for Error {
    fn from(e: ddpkit_util::check::CheckError) -> Self {
        let reason = e.reason();
        Error::invalid(e.field, reason)
    }
}

// The validators of the configurations and scenario files (`?` converts their error).
pub(crate) use ddpkit_util::check::{finite_each, nonnegative, positive};
