//! Errors for bad input to the grid tools. Every variant names the field and the reason.

/// Bad input, rejected before any work is done.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Error {
    /// A value is outside its allowed range.
    #[error("{field} is invalid: {reason}")]
    Invalid {
        /// The field with the invalid value, e.g. `"resolution"`.
        field: String,
        /// Why the value is rejected.
        reason: String,
    },
    /// Two grids that must share their geometry do not.
    #[error("{field} has geometry {got}, expected {expected}")]
    Geometry {
        /// The argument whose geometry differs.
        field: String,
        /// Its geometry.
        got: String,
        /// The geometry it must have.
        expected: String,
    },
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
}

/// A failed [`ddpkit_util::check`] validator: an [`Error::Invalid`] naming the field, e.g.
/// `resolution is invalid: must be finite and > 0, got 0`.
impl From<ddpkit_util::check::CheckError> for Error {
    fn from(e: ddpkit_util::check::CheckError) -> Self {
        let reason = e.reason();
        Error::invalid(e.field, reason)
    }
}

// The validators the grid tools and the dataset use (`?` converts their error).
pub(crate) use ddpkit_util::check::{finite_each, nonnegative, positive};
