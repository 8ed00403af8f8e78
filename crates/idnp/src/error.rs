//! Errors: bad input is rejected early with an [`Error`] naming the field and the reason; the
//! outcome of the algorithm (a failed inverse mapping, a colliding trajectory) is reported in the
//! results, never as an error.

/// What went wrong, naming the field (or file) and the reason.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A setting or argument that cannot work.
    #[error("invalid {field}: {reason}")]
    Invalid {
        /// The field, with its index where there is one (`obstacles[2]`).
        field: String,
        /// Why it was rejected.
        reason: String,
    },
    /// An error of the optimal-control layer (`ddp-core`, `safe-cddp`).
    #[error(transparent)]
    Solver(#[from] ddp_core::Error),
    /// Writing a result file failed.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// Drawing the figure failed.
    #[error("cannot draw {path}: {reason}")]
    Plot {
        /// The file.
        path: String,
        /// The cause.
        reason: String,
    },
}

impl Error {
    /// An [`Error::Invalid`] for `field`.
    pub fn invalid(field: impl Into<String>, reason: impl Into<String>) -> Self {
        Error::Invalid {
            field: field.into(),
            reason: reason.into(),
        }
    }
}

/// `Result` with this crate's [`Error`].
pub type Result<T> = std::result::Result<T, Error>;

/// A failed [`ddpkit_util::check`] validator: an [`Error::Invalid`] naming the field, e.g.
/// `invalid dp.max_step: must be finite and >= 0, got -1`.
impl From<ddpkit_util::check::CheckError> for Error {
    fn from(e: ddpkit_util::check::CheckError) -> Self {
        Error::Invalid {
            reason: e.reason(),
            field: e.field,
        }
    }
}

// The validators the settings use (`?` converts their error).
pub(crate) use ddpkit_util::check::{finite, nonnegative, positive};
