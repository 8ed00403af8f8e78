//! The widest x86-64 vector instructions the CPU has, read once (x86-64 only), as `pulp` tokens:
//! code run through a token's `vectorize` is compiled for those instructions and called only
//! where the CPU has them, without unsafe code in ddpkit.
//!
//! The environment variable `DDPKIT_SIMD` narrows the choice for comparisons: `off` runs the
//! portable code everywhere, `avx2` stops at AVX2 and FMA.

use std::sync::OnceLock;

pub use pulp::x86::{V3, V4};

/// The instructions a kernel can use.
#[derive(Clone, Copy, Debug)]
pub enum Simd {
    /// AVX2 and FMA.
    V3(V3),
    /// AVX-512 (F, VL, BW, DQ, CD) besides.
    V4(V4),
}

/// The widest [`Simd`] the CPU has (within `DDPKIT_SIMD`), read once; `None`: portable code.
#[inline(always)]
pub fn available() -> Option<Simd> {
    static TOKEN: OnceLock<Option<Simd>> = OnceLock::new();
    *TOKEN.get_or_init(|| {
        let limit = std::env::var("DDPKIT_SIMD").unwrap_or_default().to_ascii_lowercase();
        match limit.as_str() {
            "off" => None,
            "avx2" => V3::try_new().map(Simd::V3),
            _ => V4::try_new().map(Simd::V4).or_else(|| V3::try_new().map(Simd::V3)),
        }
    })
}
