//! Which side of each state constraint a trajectory passes, for the portfolio's third start
//! where the first two agree ([`crate::Settings::portfolio_new_side`]).
//!
//! The local optima of an obstacle problem differ first by the side of each obstacle the path
//! takes (its homotopy class), and the barrier homotopy decides the sides while it keeps the
//! trajectory away from every boundary (Pavlov, Shames and Manzie 2021). The side is read from
//! the constraint itself, so that every state constraint has one (a circle, a traced or imported
//! function): the unit gradient `g_x / |g_x|` of each row at the state where the row is largest,
//! its most active point. Two trajectories that pass a disc on the same side have gradients
//! there within 90 degrees of each other (outward normals of the same half of the disc); on
//! opposite sides they point apart.

use std::sync::Arc;

use ddp_core::dims::{Alloc, DefaultAllocator, Dim, Dims, VectorN};

use super::rows::Slot;
use crate::Constraint;

/// Scratch and results of [`Sides::measure`], all sized at construction (a solve allocates
/// nothing for them).
#[derive(Debug, Clone)]
pub(crate) struct Sides<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    g: Vec<f64>,
    gx: Vec<VectorN<NX>>,
    gu: Vec<VectorN<NU>>,
    /// `(largest value, its time)` per row of the constraint being measured.
    worst: Vec<(f64, usize)>,
    /// The kept solution's unit gradients (`nx` per state row), valid when `kept_valid`.
    pub kept: Vec<f64>,
    /// The kept solution's `(largest value, its time)` per state row, with `kept`.
    pub kept_at: Vec<(f64, usize)>,
    pub kept_valid: bool,
    /// The unit gradients of the last measurement of the running start.
    pub now: Vec<f64>,
}

impl<NX: Dim, NU: Dim> Sides<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// For constraints of at most `max_dim` rows, `state_rows` rows of state-only constraints.
    pub fn new(dims: Dims<NX, NU>, max_dim: usize, state_rows: usize) -> Self {
        let len = state_rows * dims.nx();
        Self {
            g: vec![0.0; max_dim],
            gx: vec![dims.x_zeros(); max_dim],
            gu: vec![dims.u_zeros(); max_dim],
            worst: vec![(f64::NEG_INFINITY, 1); max_dim],
            kept: Vec::with_capacity(len),
            kept_at: Vec::with_capacity(state_rows),
            kept_valid: false,
            now: Vec::with_capacity(len),
        }
    }

    /// Writes the sides of `xs` (`n + 1` states) to `kept` (or `now`): for every row of every
    /// state-only constraint (in the order of `slots`), the unit gradient at the state of
    /// `x_1 .. x_N` where the row is largest (zeros where the gradient is zero or not finite);
    /// into `kept`, also that largest value and its time (`kept_at`).
    pub fn measure(
        &mut self,
        constraints: &[Arc<dyn Constraint<NX, NU>>],
        slots: &[Slot],
        xs: &[VectorN<NX>],
        zero_u: &VectorN<NU>,
        n: usize,
        into_kept: bool,
    ) {
        let mut out = std::mem::take(if into_kept { &mut self.kept } else { &mut self.now });
        out.clear();
        if into_kept {
            self.kept_at.clear();
        }
        let states = n > 0 && xs.len() > n;
        for (c, slot) in constraints.iter().zip(slots).filter(|_| states) {
            if slot.mixed || slot.dim == 0 {
                continue;
            }
            let d = slot.dim;
            self.worst[..d].fill((f64::NEG_INFINITY, 1));
            for (t, x) in xs.iter().enumerate().take(n + 1).skip(1) {
                c.evaluate(t, x, zero_u, &mut self.g[..d]);
                for (w, &v) in self.worst[..d].iter_mut().zip(&self.g[..d]) {
                    if v > w.0 {
                        *w = (v, t);
                    }
                }
            }
            for r in 0..d {
                let t = self.worst[r].1;
                if into_kept {
                    self.kept_at.push(self.worst[r]);
                }
                let (g, gx, gu) = (&mut self.g[..d], &mut self.gx[..d], &mut self.gu[..d]);
                c.jacobians(t, &xs[t], zero_u, g, gx, gu);
                let norm = gx[r].norm();
                let unit = norm > 0.0 && norm.is_finite();
                out.extend(gx[r].iter().map(|&e| if unit { e / norm } else { 0.0 }));
            }
        }
        if into_kept {
            self.kept = out;
            self.kept_valid = true;
        } else {
            self.now = out;
        }
    }

    /// Whether the last measurement of the running start passes every state row on the kept
    /// solution's side: each row's two unit gradients within 90 degrees (`false` when the kept
    /// solution's sides are not measured).
    pub fn same_as_kept(&self, nx: usize) -> bool {
        self.kept_valid
            && self.kept.len() == self.now.len()
            && nx > 0
            && self
                .kept
                .chunks(nx)
                .zip(self.now.chunks(nx))
                .all(|(a, b)| a.iter().zip(b).map(|(p, q)| p * q).sum::<f64>() > 0.0)
    }
}
