//! The crate's error type: bad input is rejected with a variant naming the field, index and reason.

/// Rejected input. Every variant names the offending field (and index where there is one).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Error {
    /// A coordinate or parameter is NaN or infinite.
    #[error("{field}[{index}] is not finite")]
    NonFinite {
        /// Name of the argument or field.
        field: &'static str,
        /// Index of the offending element (`0` for scalars).
        index: usize,
    },
    /// Fewer elements than the operation needs.
    #[error("{field} has {got} elements, at least {need} are needed")]
    TooFew {
        /// Name of the argument or field.
        field: &'static str,
        /// Elements given.
        got: usize,
        /// Elements needed.
        need: usize,
    },
    /// A scalar parameter outside its valid range.
    #[error("{field} = {value} is invalid: {reason}")]
    InvalidParameter {
        /// Name of the argument or field.
        field: &'static str,
        /// The value given.
        value: f64,
        /// Why it is rejected.
        reason: &'static str,
    },
    /// An output slice whose length does not match the input's.
    #[error("{field} has {got} elements, {expected} expected")]
    LengthMismatch {
        /// Name of the argument or field.
        field: &'static str,
        /// Elements given.
        got: usize,
        /// Elements expected.
        expected: usize,
    },
    /// Consecutive elements do not meet (a composite curve with a gap).
    #[error("{field}[{index}] does not start where the previous element ends (gap {gap})")]
    Discontinuous {
        /// Name of the argument or field.
        field: &'static str,
        /// Index of the element that does not join its predecessor.
        index: usize,
        /// Distance between the end of element `index - 1` and the start of element `index`.
        gap: f64,
    },
}

/// `Result` with this crate's [`Error`].
pub type Result<T> = core::result::Result<T, Error>;

/// Rejects non-finite scalars.
pub(crate) fn check_finite(field: &'static str, index: usize, v: f64) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(Error::NonFinite { field, index })
    }
}

/// Rejects points with a non-finite coordinate.
pub(crate) fn check_points(field: &'static str, points: &[crate::Point]) -> Result<()> {
    match points.iter().position(|p| !p.is_finite()) {
        Some(index) => Err(Error::NonFinite { field, index }),
        None => Ok(()),
    }
}
