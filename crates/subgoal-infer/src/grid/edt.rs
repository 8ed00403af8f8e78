//! Exact Euclidean distance transform of a binary grid (Felzenszwalb and Huttenlocher, "Distance
//! Transforms of Sampled Functions", Theory of Computing 8, 2012).
//!
//! For every cell `q` the transform is `D(q) = min_{p in obstacles} |q - p|^2` in cell units.
//! It is separable: a 1D transform along every column, then along every row of the result, each
//! the lower envelope of the parabolas `(q - p)^2 + f(p)`, found in `O(n)`:
//!
//! ```text
//! s = ((f(q) + q^2) - (f(v_k) + v_k^2)) / (2 q - 2 v_k)   intersection of parabolas q and v_k
//! ```
//!
//! ```
//! use subgoal_infer::grid::Edt;
//! // 5 x 1 grid with one obstacle in the middle.
//! let mut edt = Edt::new(5, 1);
//! let mut out = vec![0.0; 5];
//! edt.squared(5, 1, |i| i == 2, &mut out);
//! assert_eq!(out, vec![4.0, 1.0, 0.0, 1.0, 4.0]);
//! ```

/// Scratch buffers of the transform, sized for grids up to `width x height` (allocated once).
#[derive(Debug, Clone, Default)]
pub struct Edt {
    f: Vec<f64>,
    v: Vec<usize>,
    z: Vec<f64>,
    column: Vec<f64>,
}

impl Edt {
    /// Allocates the scratch for grids of up to `width x height` cells (`O(width * height)`).
    pub fn new(width: usize, height: usize) -> Self {
        let n = width.max(height);
        Self {
            f: vec![0.0; n],
            v: vec![0; n],
            z: vec![0.0; n + 1],
            column: vec![0.0; width * height],
        }
    }

    fn reserve(&mut self, width: usize, height: usize) {
        let n = width.max(height);
        if self.f.len() < n {
            self.f.resize(n, 0.0);
            self.v.resize(n, 0);
            self.z.resize(n + 1, 0.0);
        }
        if self.column.len() < width * height {
            self.column.resize(width * height, 0.0);
        }
    }

    /// Writes the squared distance (in cells) from every cell of a row-major `width x height`
    /// grid to the nearest cell for which `obstacle(flat_index)` holds; `f64::INFINITY`
    /// everywhere when there is no obstacle. `out.len()` must be `width * height` (panics
    /// otherwise). No allocation once the scratch is large enough.
    pub fn squared(&mut self, width: usize, height: usize, obstacle: impl Fn(usize) -> bool, out: &mut [f64]) {
        assert_eq!(out.len(), width * height, "out must hold width * height cells");
        self.reserve(width, height);
        // Pass 1: along every column (fixed x, varying y), into `column`. For a binary input the
        // 1D transform is the squared distance to the nearest obstacle of the column: two sweeps
        // over whole rows (Meijster et al.'s first phase), cache-friendly and branch-light.
        let col = &mut self.column[..width * height];
        for x in 0..width {
            col[x] = if obstacle(x) { 0.0 } else { f64::INFINITY };
        }
        for y in 1..height {
            let (prev, cur) = col[(y - 1) * width..(y + 1) * width].split_at_mut(width);
            for x in 0..width {
                cur[x] = if obstacle(y * width + x) { 0.0 } else { prev[x] + 1.0 };
            }
        }
        for y in (0..height.saturating_sub(1)).rev() {
            let (cur, next) = col[y * width..(y + 2) * width].split_at_mut(width);
            for x in 0..width {
                cur[x] = cur[x].min(next[x] + 1.0);
            }
        }
        for c in col.iter_mut() {
            *c *= *c;
        }
        // Pass 2: along every row of the column result.
        for y in 0..height {
            let row = y * width;
            let src = &self.column[row..row + width];
            // Rows entirely on obstacles (0) or entirely without one in their columns (inf)
            // transform to themselves: common in sparse maps and in the inside transform of a
            // signed field.
            if src.iter().all(|&c| c == 0.0) || src.iter().all(|&c| c == f64::INFINITY) {
                out[row..row + width].copy_from_slice(src);
                continue;
            }
            self.f[..width].copy_from_slice(src);
            lower_envelope(&self.f[..width], &mut out[row..row + width], &mut self.v, &mut self.z);
        }
    }
}

/// 1D squared distance transform `d(q) = min_p (q - p)^2 + f(p)` over the finite `f(p)`;
/// `INFINITY` everywhere when every `f(p)` is infinite.
fn lower_envelope(f: &[f64], d: &mut [f64], v: &mut [usize], z: &mut [f64]) {
    let n = f.len();
    // k: index of the rightmost parabola of the envelope; None while no parabola is finite.
    let mut k: Option<usize> = None;
    for q in 0..n {
        if f[q] == f64::INFINITY {
            continue;
        }
        let fq = f[q] + (q * q) as f64;
        match k {
            None => {
                k = Some(0);
                v[0] = q;
                z[0] = f64::NEG_INFINITY;
                z[1] = f64::INFINITY;
            }
            Some(mut kk) => loop {
                let p = v[kk];
                let s = (fq - (f[p] + (p * p) as f64)) / (2.0 * (q - p) as f64);
                if s <= z[kk] {
                    // z[0] = -inf, so this never runs past kk = 0.
                    kk -= 1;
                    continue;
                }
                kk += 1;
                v[kk] = q;
                z[kk] = s;
                z[kk + 1] = f64::INFINITY;
                k = Some(kk);
                break;
            },
        }
    }
    if k.is_none() {
        d.fill(f64::INFINITY);
        return;
    }
    let mut kk = 0;
    for (q, dq) in d.iter_mut().enumerate() {
        while z[kk + 1] < q as f64 {
            kk += 1;
        }
        let p = v[kk];
        let e = q as f64 - p as f64;
        *dq = e * e + f[p];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn brute(width: usize, height: usize, obs: &[bool]) -> Vec<f64> {
        let pts: Vec<(usize, usize)> = (0..width * height)
            .filter(|&i| obs[i])
            .map(|i| (i % width, i / width))
            .collect();
        (0..width * height)
            .map(|i| {
                let (x, y) = ((i % width) as f64, (i / width) as f64);
                pts.iter()
                    .map(|&(px, py)| (x - px as f64).powi(2) + (y - py as f64).powi(2))
                    .fold(f64::INFINITY, f64::min)
            })
            .collect()
    }

    #[test]
    fn equals_brute_force_on_random_grids() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut edt = Edt::new(1, 1);
        for case in 0..60 {
            let w = rng.random_range(1..40);
            let h = rng.random_range(1..40);
            let density = [0.0, 0.002, 0.02, 0.2, 0.7, 1.0][case % 6];
            let obs: Vec<bool> = (0..w * h).map(|_| rng.random::<f64>() < density).collect();
            let mut out = vec![0.0; w * h];
            edt.squared(w, h, |i| obs[i], &mut out);
            assert_eq!(out, brute(w, h, &obs), "case {case}: {w} x {h}, density {density}");
        }
    }

    #[test]
    fn empty_grid_is_infinite() {
        let mut edt = Edt::new(3, 3);
        let mut out = vec![0.0; 12];
        edt.squared(4, 3, |_| false, &mut out);
        assert!(out.iter().all(|d| d.is_infinite()));
    }
}
