//! The layers of the sub-goal network, for one sample, `f32`, channel-major (`C x H x W`) images
//! and row-major `(tokens x features)` matrices.
//!
//! Dense convolutions are `im2col` + GEMM; the GEMM is nalgebra's, which hands matrices larger
//! than 5 x 5 to `matrixmultiply::sgemm` (cache-blocked, SIMD kernels) through a safe,
//! strided-view API. Depthwise convolutions, squeeze-excitation, attention scores and layer norms
//! are plain loops: they are a small share of the work.

use nalgebra::{DMatrixView, DMatrixViewMut, Dyn};

/// `c = op(a) op(b) + beta c` with row-major `c` (`m x n`), `op(a)` `m x k` and `op(b)` `k x n`.
/// `a_t`: `a` is stored row-major as `k x m` (so `op(a) = a^T`); same for `b_t` (`b` is `n x k`).
#[allow(clippy::too_many_arguments)]
pub(crate) fn gemm(m: usize, n: usize, k: usize, a: &[f32], a_t: bool, b: &[f32], b_t: bool, beta: f32, c: &mut [f32]) {
    debug_assert!(a.len() >= m * k && b.len() >= k * n && c.len() >= m * n);
    if m == 0 || n == 0 {
        return;
    }
    if k == 0 {
        c[..m * n].iter_mut().for_each(|v| *v *= beta);
        return;
    }
    // Element (i, j) of a strided view lives at `i * rstride + j * cstride`.
    let (ars, acs) = if a_t { (1, m) } else { (k, 1) };
    let (brs, bcs) = if b_t { (1, k) } else { (n, 1) };
    // nalgebra calls matrixmultiply only when every dimension exceeds 5; its own fallback loop
    // mishandles row-strided views, so small products (attention over 3 queries) are done here.
    if m <= 5 || n <= 5 || k <= 5 {
        for i in 0..m {
            for j in 0..n {
                let dot: f32 = (0..k).map(|l| a[i * ars + l * acs] * b[l * brs + j * bcs]).sum();
                let cij = &mut c[i * n + j];
                *cij = if beta == 0.0 { dot } else { beta * *cij + dot };
            }
        }
        return;
    }
    let av = DMatrixView::<f32, Dyn, Dyn>::from_slice_with_strides(&a[..m * k], m, k, ars, acs);
    let bv = DMatrixView::<f32, Dyn, Dyn>::from_slice_with_strides(&b[..k * n], k, n, brs, bcs);
    let mut cv = DMatrixViewMut::<f32, Dyn, Dyn>::from_slice_with_strides_mut(&mut c[..m * n], m, n, n, 1);
    cv.gemm(1.0, &av, &bv, beta);
}

/// Activation functions of the two encoders and the decoder's feed-forward block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Act {
    /// Identity.
    None,
    /// `max(0, x)`.
    Relu,
    /// `x sigmoid(x)` (EfficientNet).
    Silu,
    /// `x Phi(x)` with the exact normal CDF (torch's default `gelu`).
    Gelu,
}

impl Act {
    pub(crate) fn apply(self, x: &mut [f32]) {
        match self {
            Act::None => {}
            Act::Relu => x.iter_mut().for_each(|v| *v = v.max(0.0)),
            Act::Silu => x.iter_mut().for_each(|v| *v /= 1.0 + exp_f32(-*v)),
            Act::Gelu => x.iter_mut().for_each(|v| *v = gelu(*v)),
        }
    }
}

#[inline]
pub(crate) fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + exp_f32(-x))
}

/// `e^x` in `f32` to about 1 ulp, without branches so that loops over slices vectorise (the
/// libm call does not; SiLU's exponentials were a quarter of EfficientNet's time). Cephes'
/// `expf`: `x = n ln 2 + r`, `|r| <= ln 2 / 2`, a degree-7 polynomial for `e^r`, `2^n` through the
/// exponent bits. Inputs are clamped to `[-87, 88]` (results stay normal and finite).
#[inline(always)]
pub(crate) fn exp_f32(x: f32) -> f32 {
    const LN2_HI: f32 = 0.693_359_4;
    const LN2_LO: f32 = -2.121_944_4e-4;
    // 1.5 * 2^23: adding and subtracting it rounds to the nearest integer (no `roundps` needed).
    const ROUND: f32 = 12_582_912.0;
    let x = x.clamp(-87.0, 88.0);
    let n = (x * std::f32::consts::LOG2_E + ROUND) - ROUND;
    let r = x - n * LN2_HI - n * LN2_LO;
    let mut p = 1.987_569_1e-4f32;
    p = p * r + 1.398_199_9e-3;
    p = p * r + 8.333_452e-3;
    p = p * r + 4.166_579_6e-2;
    p = p * r + 1.666_666_5e-1;
    p = p * r + 5.0e-1;
    let e = p * r * r + r + 1.0;
    e * f32::from_bits(((n as i32 + 127) << 23) as u32)
}

/// `x Phi(x) = x (1 + erf(x / sqrt 2)) / 2`, evaluated in `f64`.
pub(crate) fn gelu(x: f32) -> f32 {
    let x = x as f64;
    (0.5 * x * (1.0 + erf(x * std::f64::consts::FRAC_1_SQRT_2))) as f32
}

/// The error function to about 1e-12 (W. J. Cody's rational approximations are overkill here:
/// Taylor series for `|x| < 2.5`, the continued fraction of `erfc` beyond).
pub(crate) fn erf(x: f64) -> f64 {
    let ax = x.abs();
    let r = if ax < 2.5 {
        // erf(x) = 2/sqrt(pi) sum_n (-1)^n x^(2n+1) / (n! (2n+1))
        let x2 = ax * ax;
        let mut term = ax;
        let mut sum = ax;
        let mut n = 0.0;
        while term.abs() > 1e-17 * sum.abs() {
            n += 1.0;
            term *= -x2 / n;
            sum += term / (2.0 * n + 1.0);
            if n > 200.0 {
                break;
            }
        }
        sum * std::f64::consts::FRAC_2_SQRT_PI
    } else if ax < 30.0 {
        // erfc(x) = exp(-x^2)/sqrt(pi) * 1/(x + 1/2/(x + 1/(x + 3/2/(x + ...)))), evaluated backwards.
        let mut f = ax;
        for n in (1..60).rev() {
            f = ax + (n as f64 / 2.0) / f;
        }
        1.0 - (-ax * ax).exp() / (std::f64::consts::PI.sqrt() * f)
    } else {
        1.0
    };
    r.copysign(x)
}

/// A dense 2D convolution with bias (batch norm folded in), `groups = 1`.
#[derive(Debug, Clone)]
pub(crate) struct Conv2d {
    pub cin: usize,
    pub cout: usize,
    pub k: usize,
    pub stride: usize,
    pub pad: usize,
    /// `cout x (cin k k)`, row-major (torch's `[cout, cin, k, k]`).
    pub weight: Vec<f32>,
    pub bias: Vec<f32>,
    pub act: Act,
}

/// Output side of a convolution: `floor((n + 2 pad - k) / stride) + 1` (torch's rule).
pub(crate) fn conv_out(n: usize, k: usize, stride: usize, pad: usize) -> usize {
    (n + 2 * pad).saturating_sub(k) / stride + 1
}

impl Conv2d {
    /// `input`: `cin x h x w`; writes `cout x ho x wo` to `out`, returns `(ho, wo)`; `col` is scratch.
    pub(crate) fn forward(
        &self,
        input: &[f32],
        h: usize,
        w: usize,
        out: &mut Vec<f32>,
        col: &mut Vec<f32>,
    ) -> (usize, usize) {
        let (k, s, p) = (self.k, self.stride, self.pad);
        let ho = conv_out(h, k, s, p);
        let wo = conv_out(w, k, s, p);
        let n = ho * wo;
        let kk = self.cin * k * k;
        out.clear();
        out.resize(self.cout * n, 0.0);
        for (o, b) in self.bias.iter().enumerate() {
            out[o * n..(o + 1) * n].fill(*b);
        }
        if k == 1 && s == 1 && p == 0 {
            gemm(self.cout, n, kk, &self.weight, false, input, false, 1.0, out);
        } else {
            im2col(input, self.cin, h, w, k, s, p, ho, wo, col);
            gemm(self.cout, n, kk, &self.weight, false, col, false, 1.0, out);
        }
        self.act.apply(out);
        (ho, wo)
    }
}

/// Unfolds `c x h x w` into `(c k k) x (ho wo)`, zero padding, row `(ci, ky, kx)`.
#[allow(clippy::too_many_arguments)]
fn im2col(
    input: &[f32],
    c: usize,
    h: usize,
    w: usize,
    k: usize,
    s: usize,
    p: usize,
    ho: usize,
    wo: usize,
    col: &mut Vec<f32>,
) {
    let n = ho * wo;
    col.clear();
    col.resize(c * k * k * n, 0.0);
    for ci in 0..c {
        let plane = &input[ci * h * w..(ci + 1) * h * w];
        for ky in 0..k {
            for kx in 0..k {
                let row = &mut col[((ci * k + ky) * k + kx) * n..][..n];
                for oy in 0..ho {
                    let iy = (oy * s + ky) as isize - p as isize;
                    if iy < 0 || iy >= h as isize {
                        continue;
                    }
                    let src = &plane[iy as usize * w..][..w];
                    let dst = &mut row[oy * wo..][..wo];
                    for (ox, d) in dst.iter_mut().enumerate() {
                        let ix = (ox * s + kx) as isize - p as isize;
                        if ix >= 0 && ix < w as isize {
                            *d = src[ix as usize];
                        }
                    }
                }
            }
        }
    }
}

/// A depthwise convolution (`groups = channels`) with bias (batch norm folded in).
#[derive(Debug, Clone)]
pub(crate) struct DepthwiseConv {
    pub channels: usize,
    pub k: usize,
    pub stride: usize,
    pub pad: usize,
    /// `channels x k x k`.
    pub weight: Vec<f32>,
    pub bias: Vec<f32>,
    pub act: Act,
}

impl DepthwiseConv {
    /// `input`: `channels x h x w` -> `out`: `channels x ho x wo`; `padded` is scratch.
    ///
    /// Each channel is copied once into a zero-padded plane split into `stride` column phases
    /// (even / odd columns for stride 2), so every kernel tap is a contiguous multiply-add over an
    /// output row, which the compiler vectorises.
    pub(crate) fn forward(
        &self,
        input: &[f32],
        h: usize,
        w: usize,
        out: &mut Vec<f32>,
        padded: &mut Vec<f32>,
    ) -> (usize, usize) {
        let (k, s, p) = (self.k, self.stride, self.pad);
        let ho = conv_out(h, k, s, p);
        let wo = conv_out(w, k, s, p);
        let (hp, wp) = (h + 2 * p, w + 2 * p);
        // Phase `ph` holds padded columns `ph, ph + s, ...`: `pw` slots each.
        let pw = wp.div_ceil(s);
        let plane_len = hp * pw;
        out.clear();
        out.resize(self.channels * ho * wo, 0.0);
        padded.clear();
        padded.resize(s * plane_len, 0.0);
        for c in 0..self.channels {
            let plane = &input[c * h * w..(c + 1) * h * w];
            // Borders stay zero from the resize; the interior is overwritten for every channel.
            for y in 0..h {
                let src = &plane[y * w..(y + 1) * w];
                let yp = y + p;
                if s == 1 {
                    padded[yp * pw + p..yp * pw + p + w].copy_from_slice(src);
                } else {
                    for (x, v) in src.iter().enumerate() {
                        let xp = x + p;
                        padded[(xp % s) * plane_len + yp * pw + xp / s] = *v;
                    }
                }
            }
            let wk = &self.weight[c * k * k..(c + 1) * k * k];
            let dst = &mut out[c * ho * wo..(c + 1) * ho * wo];
            dst.fill(self.bias[c]);
            for oy in 0..ho {
                let row = &mut dst[oy * wo..(oy + 1) * wo];
                for ky in 0..k {
                    let yp = oy * s + ky;
                    for kx in 0..k {
                        let wv = wk[ky * k + kx];
                        let src = &padded[(kx % s) * plane_len + yp * pw + kx / s..][..wo];
                        for (d, x) in row.iter_mut().zip(src) {
                            *d += wv * x;
                        }
                    }
                }
            }
        }
        self.act.apply(out);
        (ho, wo)
    }
}

/// `y = x W^T + b` on the rows of `x`.
#[derive(Debug, Clone)]
pub(crate) struct Linear {
    pub din: usize,
    pub dout: usize,
    /// `dout x din` (torch's layout).
    pub weight: Vec<f32>,
    pub bias: Vec<f32>,
}

impl Linear {
    /// `x`: `rows x din` -> `out`: `rows x dout`.
    pub(crate) fn forward(&self, x: &[f32], rows: usize, out: &mut Vec<f32>) {
        out.clear();
        out.reserve(rows * self.dout);
        for _ in 0..rows {
            out.extend_from_slice(&self.bias);
        }
        gemm(rows, self.dout, self.din, x, false, &self.weight, true, 1.0, out);
    }
}

/// Layer norm over the last dimension.
#[derive(Debug, Clone)]
pub(crate) struct LayerNorm {
    pub weight: Vec<f32>,
    pub bias: Vec<f32>,
    pub eps: f32,
}

impl LayerNorm {
    pub(crate) fn forward(&self, x: &mut [f32]) {
        let d = self.weight.len();
        for row in x.chunks_exact_mut(d) {
            let mean = row.iter().map(|v| *v as f64).sum::<f64>() / d as f64;
            let var = row.iter().map(|v| (*v as f64 - mean).powi(2)).sum::<f64>() / d as f64;
            let inv = 1.0 / (var + self.eps as f64).sqrt();
            for ((v, g), b) in row.iter_mut().zip(&self.weight).zip(&self.bias) {
                *v = ((*v as f64 - mean) * inv) as f32 * g + b;
            }
        }
    }
}

/// `torch.nn.MultiheadAttention` without masks: packed input projection, `heads` heads, output projection.
#[derive(Debug, Clone)]
pub(crate) struct Attention {
    pub d: usize,
    pub heads: usize,
    pub q: Linear,
    pub k: Linear,
    pub v: Linear,
    pub out: Linear,
}

/// Scratch buffers of one attention call.
#[derive(Debug, Default)]
pub(crate) struct AttnScratch {
    q: Vec<f32>,
    k: Vec<f32>,
    v: Vec<f32>,
    ctx: Vec<f32>,
    scores: Vec<f32>,
}

impl Attention {
    /// Keys and values of `memory` (`t x d`), computed once per call for cross-attention.
    pub(crate) fn project_kv(&self, memory: &[f32], t: usize, k: &mut Vec<f32>, v: &mut Vec<f32>) {
        self.k.forward(memory, t, k);
        self.v.forward(memory, t, v);
    }

    /// Attention of the queries `x` (`s x d`) over projected keys/values (`t x d`), into `out` (`s x d`).
    pub(crate) fn attend(
        &self,
        x: &[f32],
        s: usize,
        k: &[f32],
        v: &[f32],
        t: usize,
        scratch: &mut AttnScratch,
        out: &mut Vec<f32>,
    ) {
        let d = self.d;
        let hd = d / self.heads;
        let scale = 1.0 / (hd as f32).sqrt();
        self.q.forward(x, s, &mut scratch.q);
        scratch.ctx.clear();
        scratch.ctx.resize(s * d, 0.0);
        scratch.scores.resize(t, 0.0);
        for h in 0..self.heads {
            let cols = h * hd..(h + 1) * hd;
            for i in 0..s {
                let qi = &scratch.q[i * d..][cols.clone()];
                let mut max = f32::NEG_INFINITY;
                for j in 0..t {
                    let kj = &k[j * d..][cols.clone()];
                    let dot: f32 = qi.iter().zip(kj).map(|(a, b)| a * b).sum::<f32>() * scale;
                    scratch.scores[j] = dot;
                    max = max.max(dot);
                }
                let mut sum = 0.0;
                for sc in scratch.scores[..t].iter_mut() {
                    *sc = (*sc - max).exp();
                    sum += *sc;
                }
                let ctx = &mut scratch.ctx[i * d..][cols.clone()];
                for j in 0..t {
                    let a = scratch.scores[j] / sum;
                    for (c, vv) in ctx.iter_mut().zip(&v[j * d..][cols.clone()]) {
                        *c += a * vv;
                    }
                }
            }
        }
        self.out.forward(&scratch.ctx, s, out);
    }

    /// Self-attention of `x` (`s x d`).
    pub(crate) fn self_attend(&self, x: &[f32], s: usize, scratch: &mut AttnScratch, out: &mut Vec<f32>) {
        let (mut k, mut v) = (std::mem::take(&mut scratch.k), std::mem::take(&mut scratch.v));
        self.project_kv(x, s, &mut k, &mut v);
        self.attend(x, s, &k, &v, s, scratch, out);
        scratch.k = k;
        scratch.v = v;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn erf_matches_known_values() {
        // erf values from Abramowitz & Stegun, Table 7.1.
        for (x, e) in [
            (0.0, 0.0),
            (0.5, 0.520_499_877_813_046_5),
            (1.0, 0.842_700_792_949_714_9),
            (2.0, 0.995_322_265_018_952_7),
            (2.5, 0.999_593_047_982_555),
            (3.0, 0.999_977_909_503_001_4),
            (-1.5, -0.966_105_146_475_310_7),
        ] {
            assert!((erf(x) - e).abs() < 1e-12, "erf({x}) = {} != {e}", erf(x));
        }
    }

    #[test]
    fn exp_f32_is_within_two_ulp_of_std() {
        let mut worst = 0.0f64;
        for i in 0..=200_000 {
            let x = -87.0 + 175.0 * i as f32 / 200_000.0;
            let (a, b) = (exp_f32(x) as f64, (x as f64).exp());
            worst = worst.max(((a - b) / b).abs());
        }
        assert!(worst < 2.5e-7, "relative error {worst:e}");
        assert!(exp_f32(-1000.0) > 0.0 && exp_f32(1000.0).is_finite());
        assert_eq!(exp_f32(0.0), 1.0);
    }

    #[test]
    fn gemm_matches_naive_products_in_all_layouts() {
        for (m, n, k) in [(7, 9, 11), (3, 9, 11), (7, 2, 11), (7, 9, 4), (1, 1, 1)] {
            gemm_case(m, n, k);
        }
    }

    fn gemm_case(m: usize, n: usize, k: usize) {
        let a: Vec<f32> = (0..m * k).map(|i| ((i * 7 % 13) as f32 - 6.0) / 5.0).collect();
        let b: Vec<f32> = (0..k * n).map(|i| ((i * 5 % 11) as f32 - 5.0) / 3.0).collect();
        let at: Vec<f32> = (0..k * m).map(|i| a[(i % m) * k + i / m]).collect();
        let bt: Vec<f32> = (0..n * k).map(|i| b[(i % k) * n + i / k]).collect();
        let mut want = vec![0.0f32; m * n];
        for i in 0..m {
            for j in 0..n {
                want[i * n + j] = (0..k).map(|l| a[i * k + l] * b[l * n + j]).sum::<f32>() + 0.5;
            }
        }
        for (aa, a_t) in [(&a, false), (&at, true)] {
            for (bb, b_t) in [(&b, false), (&bt, true)] {
                let mut c = vec![1.0f32; m * n];
                gemm(m, n, k, aa, a_t, bb, b_t, 0.5, &mut c);
                for (x, y) in c.iter().zip(&want) {
                    assert!((x - y).abs() < 1e-4, "a_t {a_t} b_t {b_t}: {x} != {y}");
                }
            }
        }
    }

    #[test]
    fn depthwise_equals_dense_convolution_with_block_diagonal_weights() {
        let (c, h, w) = (3, 9, 8);
        let input: Vec<f32> = (0..c * h * w).map(|i| ((i * 31 % 17) as f32 - 8.0) / 4.0).collect();
        for (k, s) in [(3, 1), (3, 2), (5, 1), (5, 2)] {
            let p = (k - 1) / 2;
            let dw_w: Vec<f32> = (0..c * k * k).map(|i| ((i * 13 % 7) as f32 - 3.0) / 2.0).collect();
            let bias = vec![0.1, -0.2, 0.3];
            let dw = DepthwiseConv {
                channels: c,
                k,
                stride: s,
                pad: p,
                weight: dw_w.clone(),
                bias: bias.clone(),
                act: Act::None,
            };
            let mut dense_w = vec![0.0; c * c * k * k];
            for ci in 0..c {
                dense_w[(ci * c + ci) * k * k..][..k * k].copy_from_slice(&dw_w[ci * k * k..][..k * k]);
            }
            let conv = Conv2d {
                cin: c,
                cout: c,
                k,
                stride: s,
                pad: p,
                weight: dense_w,
                bias,
                act: Act::None,
            };
            let (mut a, mut b, mut col) = (Vec::new(), Vec::new(), Vec::new());
            let sa = dw.forward(&input, h, w, &mut a, &mut col);
            let sb = conv.forward(&input, h, w, &mut b, &mut col);
            assert_eq!(sa, sb);
            for (x, y) in a.iter().zip(&b) {
                assert!((x - y).abs() < 1e-5, "k {k} s {s}: {x} != {y}");
            }
        }
    }
}
