//! The obstacle hinge of DDPEN eq. (7) on a distance field:
//!
//! ```text
//! c_o(x) = w * ReLU(d - dist(p)),   p = (x[i0], x[i1]),   dc_o/dp = -w * grad dist(p) where active
//! ```
//!
//! `dist` is the bilinear interpolant of a [`DistanceField`], so the term is cheap (four cell
//! reads) and its gradient exact for that interpolant. Eq. (7) sums the hinge over obstacle
//! points; near one obstacle the nearest point dominates, and the field gives it in `O(1)`
//! instead of `O(points)` (for the point-set form see `ddp_core::costs::ObstacleHinge`).
//!
//! Like `ObstacleHinge`, only the gradient is added: the hinge's Hessian (the curvature of
//! `-dist`) is not positive semidefinite, and DDP wants a PSD `l_xx` (a Gauss-Newton model).
//!
//! [`DistanceFieldHinge::squared`] is the quadratic hinge `w * ReLU(d - dist(p))^2`, a stiff
//! wall for keeping a footprint out of contact: its pull grows with the penetration, so it can
//! outweigh the cost-to-go a plan saves by cutting a corner (the linear hinge's constant pull
//! `w` cannot, whatever the depth). It adds the Gauss-Newton Hessian `2 w grad dist grad dist^T`
//! (PSD) with its gradient `-2 w ReLU(d - dist) grad dist`.

use nalgebra::Const;
use std::sync::Arc;

use ddp_core::{Error, Result, TerminalCost, TerminalDerivatives, Vector};

use crate::grid::DistanceField;

/// `w * ReLU(margin - dist(p))` over a shared [`DistanceField`] (see the module docs).
#[derive(Debug, Clone)]
pub struct DistanceFieldHinge<const NX: usize> {
    field: Arc<DistanceField>,
    margin: f64,
    indices: [usize; 2],
    weight: f64,
    squared: bool,
}

impl<const NX: usize> DistanceFieldHinge<NX> {
    /// `margin`: the distance `d` (m) below which the hinge is active; `indices`: the state
    /// indices of the planar position; `weight >= 0`. Errors name the field.
    pub fn new(field: Arc<DistanceField>, margin: f64, indices: [usize; 2], weight: f64) -> Result<Self> {
        if !(margin.is_finite() && margin >= 0.0) {
            return Err(Error::invalid(
                "margin",
                format!("must be finite and >= 0, got {margin}"),
            ));
        }
        if !(weight.is_finite() && weight >= 0.0) {
            return Err(Error::invalid(
                "weight",
                format!("must be finite and >= 0, got {weight}"),
            ));
        }
        for (k, &i) in indices.iter().enumerate() {
            if i >= NX {
                return Err(Error::invalid(
                    format!("indices[{k}]"),
                    format!("state index {i} out of range for a {NX}-dimensional state"),
                ));
            }
        }
        if indices[0] == indices[1] {
            return Err(Error::invalid("indices", "the two position indices must differ"));
        }
        Ok(Self {
            field,
            margin,
            indices,
            weight,
            squared: false,
        })
    }

    /// The quadratic hinge `weight * ReLU(margin - dist(p))^2` (see the module docs); the same
    /// arguments and errors as [`new`](Self::new).
    pub fn squared(field: Arc<DistanceField>, margin: f64, indices: [usize; 2], weight: f64) -> Result<Self> {
        Ok(Self {
            squared: true,
            ..Self::new(field, margin, indices, weight)?
        })
    }

    /// The distance field.
    pub fn field(&self) -> &Arc<DistanceField> {
        &self.field
    }
    /// The activation distance `d` (m).
    pub fn margin(&self) -> f64 {
        self.margin
    }
}

impl<const NX: usize> TerminalCost<Const<NX>> for DistanceFieldHinge<NX> {
    #[inline]
    fn value(&self, x: &Vector<NX>) -> f64 {
        let [i, j] = self.indices;
        let (d, _) = self.field.sample([x[i], x[j]]);
        let depth = (self.margin - d).max(0.0);
        self.weight * if self.squared { depth * depth } else { depth }
    }

    #[inline]
    fn add_derivatives(&self, x: &Vector<NX>, w: f64, der: &mut TerminalDerivatives<Const<NX>>) -> f64 {
        let [i, j] = self.indices;
        let (d, g) = self.field.sample([x[i], x[j]]);
        if d >= self.margin {
            return 0.0;
        }
        let c = w * self.weight;
        let depth = self.margin - d;
        if self.squared {
            let s = 2.0 * c * depth;
            der.lx[i] -= s * g[0];
            der.lx[j] -= s * g[1];
            let h = 2.0 * c;
            der.lxx[(i, i)] += h * g[0] * g[0];
            der.lxx[(i, j)] += h * g[0] * g[1];
            der.lxx[(j, i)] += h * g[1] * g[0];
            der.lxx[(j, j)] += h * g[1] * g[1];
            return c * depth * depth;
        }
        der.lx[i] -= c * g[0];
        der.lx[j] -= c * g[1];
        c * depth
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{Costmap, GridGeometry, LETHAL};
    use rand::{Rng, SeedableRng};

    fn setup() -> (Arc<DistanceField>, Vec<[f64; 2]>) {
        let g = GridGeometry::centered([0.0, 0.0], 80, 80, 0.05).unwrap();
        let mut m = Costmap::new(g);
        let mut pts = Vec::new();
        for k in 0..20 {
            let p = [-0.5 + 0.05 * k as f64, 0.6];
            m.mark(p, LETHAL);
            pts.push(g.cell_to_world(g.world_to_cell(p).unwrap().0, g.world_to_cell(p).unwrap().1));
        }
        let mut f = DistanceField::new(g);
        f.compute(&m, LETHAL).unwrap();
        (Arc::new(f), pts)
    }

    #[test]
    fn value_equals_brute_force_at_cell_centres() {
        let (f, pts) = setup();
        let hinge = DistanceFieldHinge::<3>::new(f.clone(), 0.8, [0, 1], 2.0).unwrap();
        let g = *f.geometry();
        for iy in (0..80).step_by(3) {
            for ix in (0..80).step_by(3) {
                let p = g.cell_to_world(ix, iy);
                let brute = pts
                    .iter()
                    .map(|o| (p[0] - o[0]).hypot(p[1] - o[1]))
                    .fold(f64::INFINITY, f64::min);
                let want = 2.0 * (0.8 - brute).max(0.0);
                let got = hinge.value(&Vector::<3>::new(p[0], p[1], 0.3));
                assert!((got - want).abs() < 1e-5, "({ix}, {iy}): {got} vs {want}");
            }
        }
    }

    #[test]
    fn gradient_matches_finite_differences() {
        let (f, _) = setup();
        let hinge = DistanceFieldHinge::<3>::new(f, 0.8, [0, 1], 2.0).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let h = 1e-6;
        for _ in 0..200 {
            let x = Vector::<3>::new(rng.random_range(-1.5..1.5), rng.random_range(-0.5..1.5), 0.0);
            let mut d = TerminalDerivatives::<Const<3>>::default();
            let v = hinge.add_derivatives(&x, 1.5, &mut d);
            assert!((v - 1.5 * hinge.value(&x)).abs() < 1e-12);
            for k in 0..2 {
                let mut e = Vector::<3>::zeros();
                e[k] = h;
                let fd = 1.5 * (hinge.value(&(x + e)) - hinge.value(&(x - e))) / (2.0 * h);
                // Kinks of the bilinear interpolant and of the ReLU: allow a rare mismatch there.
                if (fd - d.lx[k]).abs() > 1e-4 {
                    let near_kink = (hinge.value(&(x + e)) == 0.0) != (hinge.value(&(x - e)) == 0.0);
                    let g = hinge.field().geometry().world_to_grid([x[0], x[1]]);
                    let on_line = g.iter().any(|c| ((c - 0.5) - (c - 0.5).round()).abs() < 1e-4);
                    assert!(near_kink || on_line, "d/dx{k} at {x:?}: {} vs {fd}", d.lx[k]);
                }
            }
            assert_eq!(d.lx[2], 0.0);
            assert_eq!(d.lxx, ddp_core::Matrix::<3, 3>::zeros());
        }
    }

    #[test]
    fn squared_hinge_is_the_square_with_gauss_newton_curvature() {
        let (f, _) = setup();
        let lin = DistanceFieldHinge::<3>::new(f.clone(), 0.8, [0, 1], 1.0).unwrap();
        let sq = DistanceFieldHinge::<3>::squared(f, 0.8, [0, 1], 3.0).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let h = 1e-6;
        let mut active = 0;
        for _ in 0..200 {
            let x = Vector::<3>::new(rng.random_range(-1.5..1.5), rng.random_range(-0.5..1.5), 0.2);
            let depth = lin.value(&x);
            assert!((sq.value(&x) - 3.0 * depth * depth).abs() < 1e-12);
            let mut d = TerminalDerivatives::<Const<3>>::default();
            let v = sq.add_derivatives(&x, 0.5, &mut d);
            assert!((v - 0.5 * sq.value(&x)).abs() < 1e-12);
            if depth == 0.0 {
                assert_eq!(d.lx, Vector::<3>::zeros());
                assert_eq!(d.lxx, ddp_core::Matrix::<3, 3>::zeros());
                continue;
            }
            active += 1;
            // Gradient: -2 w depth grad dist; Hessian: 2 w grad grad^T (PSD, rank one).
            let (_, g) = sq.field().sample([x[0], x[1]]);
            for k in 0..2 {
                let mut e = Vector::<3>::zeros();
                e[k] = h;
                let fd = 0.5 * (sq.value(&(x + e)) - sq.value(&(x - e))) / (2.0 * h);
                let gp = sq.field().geometry().world_to_grid([x[0], x[1]]);
                let on_line = gp.iter().any(|c| ((c - 0.5) - (c - 0.5).round()).abs() < 1e-4);
                assert!((fd - d.lx[k]).abs() < 1e-4 || on_line, "d/dx{k}: {} vs {fd}", d.lx[k]);
                for j in 0..2 {
                    assert!((d.lxx[(k, j)] - 2.0 * 0.5 * 3.0 * g[k] * g[j]).abs() < 1e-12);
                }
            }
            assert!(d.lxx[(0, 0)] >= 0.0 && d.lxx[(1, 1)] >= 0.0);
            assert_eq!(d.lx[2], 0.0);
        }
        assert!(active > 20, "{active}");
    }

    #[test]
    fn bad_input_names_the_field() {
        let (f, _) = setup();
        let e = DistanceFieldHinge::<3>::new(f.clone(), -1.0, [0, 1], 1.0).unwrap_err();
        assert!(e.to_string().starts_with("margin"), "{e}");
        let e = DistanceFieldHinge::<3>::new(f.clone(), 1.0, [0, 3], 1.0).unwrap_err();
        assert!(e.to_string().starts_with("indices[1]"), "{e}");
        let e = DistanceFieldHinge::<3>::new(f.clone(), 1.0, [0, 1], f64::NAN).unwrap_err();
        assert!(e.to_string().starts_with("weight"), "{e}");
        let e = DistanceFieldHinge::<3>::squared(f, f64::INFINITY, [0, 1], 1.0).unwrap_err();
        assert!(e.to_string().starts_with("margin"), "{e}");
    }
}
