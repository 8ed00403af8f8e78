//! The optimal control problem: `x_0`, one running model (dynamics + cost) per knot, a terminal
//! cost, and optional control bounds.
//!
//! ```text
//! min_{u_0..u_{N-1}}  sum_{k<N} l_k(x_k, u_k) + l_N(x_N)
//! s.t.                x_{k+1} = f_k(x_k, u_k),  x_0 given,  u_min <= u_k <= u_max
//! ```

use std::sync::Arc;

use crate::error::{check_finite, Error, Result};
use crate::{Cost, Dynamics, TerminalCost, Vector};

/// One running knot: dynamics and running cost. Cloning shares the models.
#[derive(Clone)]
pub struct Knot<const NX: usize, const NU: usize> {
    /// `f_k`
    pub dynamics: Arc<dyn Dynamics<NX, NU>>,
    /// `l_k`
    pub cost: Arc<dyn Cost<NX, NU>>,
}

/// Element-wise control bounds `lower <= u <= upper`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlBounds<const NU: usize> {
    /// Lower bounds (may be `-inf`).
    pub lower: Vector<NU>,
    /// Upper bounds (may be `+inf`).
    pub upper: Vector<NU>,
}

impl<const NU: usize> ControlBounds<NU> {
    /// Rejects NaN and `lower > upper`, naming the index.
    pub fn new(lower: Vector<NU>, upper: Vector<NU>) -> Result<Self> {
        for i in 0..NU {
            if lower[i].is_nan() {
                return Err(Error::NotFinite {
                    field: "u_min".into(),
                    index: i,
                    value: lower[i],
                });
            }
            if upper[i].is_nan() {
                return Err(Error::NotFinite {
                    field: "u_max".into(),
                    index: i,
                    value: upper[i],
                });
            }
            if lower[i] > upper[i] {
                return Err(Error::invalid(
                    format!("u_min[{i}]"),
                    format!("lower bound {} exceeds upper bound u_max[{i}] = {}", lower[i], upper[i]),
                ));
            }
        }
        Ok(Self { lower, upper })
    }

    /// Projects `u` onto the box.
    #[inline]
    pub fn clamp(&self, u: &Vector<NU>) -> Vector<NU> {
        Vector::from_fn(|i, _| u[i].clamp(self.lower[i], self.upper[i]))
    }
}

/// An optimal control problem with `NX` states, `NU` controls and `N = knots.len()` steps.
#[derive(Clone)]
pub struct Problem<const NX: usize, const NU: usize> {
    x0: Vector<NX>,
    knots: Vec<Knot<NX, NU>>,
    terminal: Arc<dyn TerminalCost<NX>>,
    bounds: Option<ControlBounds<NU>>,
}

impl<const NX: usize, const NU: usize> Problem<NX, NU> {
    /// The same dynamics and running cost at every one of `horizon` knots (allocates the knot list).
    pub fn new(
        x0: Vector<NX>,
        dynamics: Arc<dyn Dynamics<NX, NU>>,
        running: Arc<dyn Cost<NX, NU>>,
        terminal: Arc<dyn TerminalCost<NX>>,
        horizon: usize,
    ) -> Result<Self> {
        let knot = Knot {
            dynamics,
            cost: running,
        };
        Self::from_knots(x0, vec![knot; horizon], terminal)
    }

    /// One model per knot.
    pub fn from_knots(x0: Vector<NX>, knots: Vec<Knot<NX, NU>>, terminal: Arc<dyn TerminalCost<NX>>) -> Result<Self> {
        if knots.is_empty() {
            return Err(Error::EmptyHorizon);
        }
        check_finite("x0", x0.iter())?;
        Ok(Self {
            x0,
            knots,
            terminal,
            bounds: None,
        })
    }

    /// Adds control bounds (box-DDP).
    pub fn with_control_bounds(mut self, bounds: ControlBounds<NU>) -> Self {
        self.bounds = Some(bounds);
        self
    }

    /// Replaces the control bounds.
    pub fn set_control_bounds(&mut self, bounds: Option<ControlBounds<NU>>) {
        self.bounds = bounds;
    }

    /// Replaces the initial state (receding horizon). Rejects NaN/inf.
    pub fn set_x0(&mut self, x0: Vector<NX>) -> Result<()> {
        check_finite("x0", x0.iter())?;
        self.x0 = x0;
        Ok(())
    }

    /// Replaces the model at knot `k`.
    pub fn set_knot(&mut self, k: usize, knot: Knot<NX, NU>) -> Result<()> {
        let n = self.knots.len();
        let slot = self
            .knots
            .get_mut(k)
            .ok_or_else(|| Error::invalid("knot", format!("index {k} out of range for horizon {n}")))?;
        *slot = knot;
        Ok(())
    }

    /// Replaces the terminal cost.
    pub fn set_terminal(&mut self, terminal: Arc<dyn TerminalCost<NX>>) {
        self.terminal = terminal;
    }

    /// The initial state.
    pub fn x0(&self) -> &Vector<NX> {
        &self.x0
    }
    /// The horizon `N`.
    pub fn horizon(&self) -> usize {
        self.knots.len()
    }
    /// The running knots.
    pub fn knots(&self) -> &[Knot<NX, NU>] {
        &self.knots
    }
    /// The terminal cost.
    pub fn terminal(&self) -> &dyn TerminalCost<NX> {
        &*self.terminal
    }
    /// The control bounds, if any.
    pub fn bounds(&self) -> Option<&ControlBounds<NU>> {
        self.bounds.as_ref()
    }

    /// Simulates `us` from `x0` into `xs` (`xs.len() == us.len() + 1 == N + 1`).
    pub fn rollout(&self, us: &[Vector<NU>], xs: &mut [Vector<NX>]) -> Result<()> {
        self.check_lengths(us.len(), xs.len())?;
        xs[0] = self.x0;
        for (k, knot) in self.knots.iter().enumerate() {
            xs[k + 1] = knot.dynamics.step(&xs[k], &us[k]);
        }
        Ok(())
    }

    /// Total cost of a trajectory.
    pub fn cost(&self, xs: &[Vector<NX>], us: &[Vector<NU>]) -> Result<f64> {
        self.check_lengths(us.len(), xs.len())?;
        let running: f64 = self
            .knots
            .iter()
            .enumerate()
            .map(|(k, m)| m.cost.value(&xs[k], &us[k]))
            .sum();
        Ok(running + self.terminal.value(&xs[self.knots.len()]))
    }

    fn check_lengths(&self, nu: usize, nx: usize) -> Result<()> {
        let n = self.knots.len();
        if nu != n {
            return Err(Error::Shape {
                field: "us".into(),
                got: format!("({nu}, {NU})"),
                expected: format!("({n}, {NU})"),
            });
        }
        if nx != n + 1 {
            return Err(Error::Shape {
                field: "xs".into(),
                got: format!("({nx}, {NX})"),
                expected: format!("({}, {NX})", n + 1),
            });
        }
        Ok(())
    }
}
