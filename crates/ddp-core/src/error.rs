//! Errors for bad input. The outcome of a solve is a [`crate::Status`], never an error.

/// Bad input, rejected before any work is done. Every variant names the offending field (and the
/// index where there is one) and the reason.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Error {
    /// A number that must be finite is NaN or infinite.
    #[error("{field}[{index}] is not finite ({value})")]
    NotFinite {
        /// The field holding the value, e.g. `"x0"` or `"running_cost.q"`.
        field: String,
        /// Flat index of the value inside the field.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// An array has the wrong number of elements or the wrong shape.
    #[error("{field} has shape {got}, expected {expected}")]
    Shape {
        /// The field with the wrong shape.
        field: String,
        /// Shape that was given, e.g. `"(3,)"`.
        got: String,
        /// Shape that was expected.
        expected: String,
    },
    /// A value is outside its allowed range.
    #[error("{field} is invalid: {reason}")]
    Invalid {
        /// The field with the invalid value.
        field: String,
        /// Why the value is rejected.
        reason: String,
    },
    /// A weight matrix is not symmetric positive semidefinite.
    #[error("{field} is not symmetric positive semidefinite: {reason}")]
    NotPsd {
        /// The weight matrix, e.g. `"q"`.
        field: String,
        /// What failed (asymmetry or a negative eigenvalue).
        reason: String,
    },
    /// The problem has no knots.
    #[error("horizon must have at least one knot (got N = 0)")]
    EmptyHorizon,
}

/// Result alias for ddpkit.
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
/// `dt is invalid: must be finite and > 0, got 0`.
impl From<ddpkit_util::check::CheckError> for Error {
    fn from(e: ddpkit_util::check::CheckError) -> Self {
        Error::Invalid {
            reason: e.reason(),
            field: e.field,
        }
    }
}

/// Rejects NaN and infinities in `values`, naming `field` and the flat index.
pub fn check_finite<'a>(field: &str, values: impl IntoIterator<Item = &'a f64>) -> Result<()> {
    for (index, &value) in values.into_iter().enumerate() {
        if !value.is_finite() {
            return Err(Error::NotFinite {
                field: field.to_string(),
                index,
                value,
            });
        }
    }
    Ok(())
}

/// Rejects negative or non-finite weights, naming `field` and the index.
pub fn check_nonnegative<'a>(field: &str, values: impl IntoIterator<Item = &'a f64>) -> Result<()> {
    for (index, &value) in values.into_iter().enumerate() {
        if !value.is_finite() {
            return Err(Error::NotFinite {
                field: field.to_string(),
                index,
                value,
            });
        }
        if value < 0.0 {
            return Err(Error::invalid(
                format!("{field}[{index}]"),
                format!("weight must be non-negative, got {value}"),
            ));
        }
    }
    Ok(())
}
