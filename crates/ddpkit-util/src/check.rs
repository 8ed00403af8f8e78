//! Validators of numeric input. Each returns the value when it passes and otherwise a
//! [`CheckError`] naming the field, what was required and the value, which a crate's own error
//! type turns into its "invalid field" variant through `From`:
//!
//! ```
//! use ddpkit_util::check::{self, CheckError};
//!
//! #[derive(Debug)]
//! enum Error {
//!     Invalid { field: String, reason: String },
//! }
//!
//! impl From<CheckError> for Error {
//!     fn from(e: CheckError) -> Self {
//!         Error::Invalid { reason: e.reason(), field: e.field }
//!     }
//! }
//!
//! fn dt(v: f64) -> Result<f64, Error> {
//!     Ok(check::positive("dt", v)?)
//! }
//! let Err(Error::Invalid { field, reason }) = dt(f64::NAN) else { panic!() };
//! assert_eq!((field.as_str(), reason.as_str()), ("dt", "must be finite and > 0, got NaN"));
//! ```
//!
//! The reasons read `must be finite, got {v}`, `must be finite and > 0, got {v}` and
//! `must be finite and >= 0, got {v}`, with the value printed in its own type (`f32` or `f64`).

use std::fmt;

/// A floating-point type the validators accept (`f32`, `f64`).
pub trait Real: Copy + PartialOrd + fmt::Display + fmt::Debug + private::Sealed {
    /// Zero.
    const ZERO: Self;
    /// Neither infinite nor NaN.
    fn is_finite(self) -> bool;
}

impl Real for f64 {
    const ZERO: Self = 0.0;
    fn is_finite(self) -> bool {
        f64::is_finite(self)
    }
}

impl Real for f32 {
    const ZERO: Self = 0.0;
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
}

mod private {
    pub trait Sealed {}
    impl Sealed for f64 {}
    impl Sealed for f32 {}
}

/// What a value had to be.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Requirement {
    /// Neither infinite nor NaN.
    Finite,
    /// Finite and `> 0`.
    Positive,
    /// Finite and `>= 0`.
    Nonnegative,
}

impl Requirement {
    /// The condition in words: `finite`, `finite and > 0`, `finite and >= 0`.
    pub fn describe(self) -> &'static str {
        match self {
            Requirement::Finite => "finite",
            Requirement::Positive => "finite and > 0",
            Requirement::Nonnegative => "finite and >= 0",
        }
    }

    /// Whether `v` meets the requirement.
    pub fn holds<T: Real>(self, v: T) -> bool {
        v.is_finite()
            && match self {
                Requirement::Finite => true,
                Requirement::Positive => v > T::ZERO,
                Requirement::Nonnegative => v >= T::ZERO,
            }
    }
}

/// A value that failed a check: the field (with its index where there is one, `subgoals[1]`),
/// the requirement and the value.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckError<T = f64> {
    /// The field, e.g. `"dt"` or `"position[1]"`.
    pub field: String,
    /// What the value had to be.
    pub requirement: Requirement,
    /// The rejected value.
    pub value: T,
}

impl<T: Real> CheckError<T> {
    /// The reason without the field: `must be finite and > 0, got -1`.
    pub fn reason(&self) -> String {
        format!("must be {}, got {}", self.requirement.describe(), self.value)
    }
}

impl<T: Real> fmt::Display for CheckError<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}", self.field, self.reason())
    }
}

impl<T: Real> std::error::Error for CheckError<T> {}

/// `v` if it meets `requirement`, else a [`CheckError`] naming `field`.
pub fn require<T: Real>(field: &str, requirement: Requirement, v: T) -> Result<T, CheckError<T>> {
    if requirement.holds(v) {
        Ok(v)
    } else {
        Err(CheckError {
            field: field.to_string(),
            requirement,
            value: v,
        })
    }
}

/// `v` if it is finite.
pub fn finite<T: Real>(field: &str, v: T) -> Result<T, CheckError<T>> {
    require(field, Requirement::Finite, v)
}

/// `v` if it is finite and `> 0`.
pub fn positive<T: Real>(field: &str, v: T) -> Result<T, CheckError<T>> {
    require(field, Requirement::Positive, v)
}

/// `v` if it is finite and `>= 0`.
pub fn nonnegative<T: Real>(field: &str, v: T) -> Result<T, CheckError<T>> {
    require(field, Requirement::Nonnegative, v)
}

/// `values` if every element is finite; the error names the first offender as `field[i]`.
pub fn finite_each<T: Real, V: AsRef<[T]>>(field: &str, values: V) -> Result<V, CheckError<T>> {
    if let Some((i, &v)) = values.as_ref().iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(CheckError {
            field: format!("{field}[{i}]"),
            requirement: Requirement::Finite,
            value: v,
        });
    }
    Ok(values)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_pass_or_name_field_requirement_and_value() {
        assert_eq!(finite("x", -3.0), Ok(-3.0));
        assert_eq!(positive("x", 1e-300), Ok(1e-300));
        assert_eq!(nonnegative("x", 0.0), Ok(0.0));
        assert_eq!(nonnegative("x", -0.0), Ok(-0.0));
        let e = positive("dt", 0.0).unwrap_err();
        assert_eq!(
            e,
            CheckError {
                field: "dt".into(),
                requirement: Requirement::Positive,
                value: 0.0
            }
        );
        assert_eq!(e.reason(), "must be finite and > 0, got 0");
        assert_eq!(e.to_string(), "dt must be finite and > 0, got 0");
        assert_eq!(
            nonnegative("w", -2.5).unwrap_err().reason(),
            "must be finite and >= 0, got -2.5"
        );
        assert_eq!(
            finite("q", f64::NEG_INFINITY).unwrap_err().reason(),
            "must be finite, got -inf"
        );
    }

    #[test]
    fn nan_and_infinity_fail_every_check() {
        for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            for r in [Requirement::Finite, Requirement::Positive, Requirement::Nonnegative] {
                let e = require("v", r, v).unwrap_err();
                assert_eq!(e.requirement, r);
                assert!(e.reason().starts_with(&format!("must be {}, got ", r.describe())));
            }
        }
        assert_eq!(
            positive("v", f64::INFINITY).unwrap_err().reason(),
            "must be finite and > 0, got inf"
        );
        assert_eq!(
            positive("v", f64::NAN).unwrap_err().reason(),
            "must be finite and > 0, got NaN"
        );
    }

    #[test]
    fn f32_values_print_in_their_own_type() {
        assert_eq!(positive("lr", 0.1f32), Ok(0.1f32));
        let e = positive("lr", -0.1f32).unwrap_err();
        // Not -0.10000000149011612, as the value widened to f64 would print.
        assert_eq!(e.reason(), "must be finite and > 0, got -0.1");
    }

    #[test]
    fn finite_each_names_the_first_bad_index() {
        assert_eq!(finite_each("p", [1.0, 2.0]), Ok([1.0, 2.0]));
        assert_eq!(finite_each("p", vec![0.0; 0]), Ok(vec![]));
        let e = finite_each("goal", [0.0, f64::NAN, f64::INFINITY]).unwrap_err();
        assert_eq!((e.field.as_str(), e.requirement), ("goal[1]", Requirement::Finite));
        assert_eq!(e.reason(), "must be finite, got NaN");
        let e = finite_each("xs", &[1.0f64, 2.0, f64::NEG_INFINITY][..]).unwrap_err();
        assert_eq!(e.to_string(), "xs[2] must be finite, got -inf");
    }
}
