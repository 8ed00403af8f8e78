//! The accuracy conventions every approximate method shares: the default request, the floor
//! relative to a curve's size, and what NaN, zero and negative requests mean. Both the
//! capability traits ([`crate::traits`]) and the integrators ([`crate::quadrature`]) build on it.

/// The accuracy (absolute, in length units) the examples use and the methods suggest: `1e-9`.
pub const DEFAULT_ACCURACY: f64 = 1e-9;

/// Smallest accuracy the adaptive methods try for, relative to the curve's size: requests below
/// `RELATIVE_ACCURACY_FLOOR * size` are raised to it (round-off makes them meaningless).
pub const RELATIVE_ACCURACY_FLOOR: f64 = 1e-15;

/// NaN becomes [`DEFAULT_ACCURACY`]; zero or negative becomes the smallest positive accuracy
/// (the integrators then raise it to [`RELATIVE_ACCURACY_FLOOR`] times the integral's size).
#[inline]
pub(crate) fn sanitize_accuracy(accuracy: f64) -> f64 {
    if accuracy.is_nan() {
        DEFAULT_ACCURACY
    } else if accuracy <= 0.0 {
        f64::MIN_POSITIVE
    } else {
        accuracy
    }
}
