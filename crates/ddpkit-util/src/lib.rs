//! # ddpkit-util
//!
//! Helpers every ddpkit crate needs once, with no dependencies beyond `std` (and `pulp` on x86-64,
//! for the run-time choice of vector instructions):
//!
//! | module | what |
//! |---|---|
//! | [`check`] | validators of numeric input (`finite`, `positive`, `nonnegative`) returning a [`check::CheckError`] that names the field and the reason; each crate's error type converts from it |
//! | [`fs`] | [`fs::write_atomic`]: a file written whole or not at all (temporary file, fsync, rename) |
//! | `simd` | (x86-64) `simd::available()`: AVX-512 or AVX2 + FMA where the CPU has them, as `pulp` tokens (`DDPKIT_SIMD=off` or `avx2` narrows it) |
//!
//! ```
//! use ddpkit_util::check;
//! assert_eq!(check::positive("dt", 0.1), Ok(0.1));
//! let e = check::nonnegative("margin", -1.0).unwrap_err();
//! assert_eq!((e.field.as_str(), e.reason()), ("margin", "must be finite and >= 0, got -1".to_string()));
//! ```

pub mod check;
pub mod fs;
#[cfg(target_arch = "x86_64")]
pub mod simd;
