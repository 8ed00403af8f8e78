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

pub(crate) fn positive(field: &str, v: f64) -> Result<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(Error::invalid(field, format!("must be finite and > 0, got {v}")))
    }
}

pub(crate) fn nonnegative(field: &str, v: f64) -> Result<f64> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(Error::invalid(field, format!("must be finite and >= 0, got {v}")))
    }
}

pub(crate) fn finite2(field: &str, v: [f64; 2]) -> Result<[f64; 2]> {
    for (i, x) in v.iter().enumerate() {
        if !x.is_finite() {
            return Err(Error::invalid(
                format!("{field}[{i}]"),
                format!("must be finite, got {x}"),
            ));
        }
    }
    Ok(v)
}
