//! The optimal control problem: `x_0`, one running model (dynamics + cost) per knot, a terminal
//! cost, and optional control bounds.
//!
//! ```text
//! min_{u_0..u_{N-1}}  sum_{k<N} l_k(x_k, u_k) + l_N(x_N)
//! s.t.                x_{k+1} = f_k(x_k, u_k),  x_0 given,  u_min <= u_k <= u_max
//! ```
//!
//! The sizes come from `x0` (`nx`) and from the pieces (`nu`: the dynamics, else the running
//! cost, else the compile-time `NU`); a piece built for other sizes is an error naming it.

use std::sync::Arc;

use crate::dims::{Alloc, DefaultAllocator, Dim, Dims, VectorN};
use crate::error::{check_finite, Error, Result};
use crate::{Cost, Dynamics, TerminalCost};

/// One running knot: dynamics and running cost. Cloning shares the models.
pub struct Knot<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// `f_k`
    pub dynamics: Arc<dyn Dynamics<NX, NU>>,
    /// `l_k`
    pub cost: Arc<dyn Cost<NX, NU>>,
}

impl<NX: Dim, NU: Dim> Clone for Knot<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn clone(&self) -> Self {
        Self {
            dynamics: self.dynamics.clone(),
            cost: self.cost.clone(),
        }
    }
}

/// Element-wise control bounds `lower <= u <= upper`.
#[derive(Debug, Clone, PartialEq)]
pub struct ControlBounds<NU: Dim>
where
    DefaultAllocator: Alloc<NU, NU>,
{
    /// Lower bounds (may be `-inf`).
    pub lower: VectorN<NU>,
    /// Upper bounds (may be `+inf`).
    pub upper: VectorN<NU>,
}

impl<NU: Dim> ControlBounds<NU>
where
    DefaultAllocator: Alloc<NU, NU>,
{
    /// Rejects NaN, lengths that differ and `lower > upper`, naming the index.
    pub fn new(lower: VectorN<NU>, upper: VectorN<NU>) -> Result<Self> {
        if lower.len() != upper.len() {
            return Err(Error::Shape {
                field: "u_max".into(),
                got: format!("({},)", upper.len()),
                expected: format!("({},) like u_min", lower.len()),
            });
        }
        for i in 0..lower.len() {
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

    /// Projects `u` onto the box (a new vector).
    #[inline]
    pub fn clamp(&self, u: &VectorN<NU>) -> VectorN<NU> {
        let mut v = u.clone();
        self.clamp_mut(&mut v);
        v
    }

    /// Projects `u` onto the box in place.
    #[inline]
    pub fn clamp_mut(&self, u: &mut VectorN<NU>) {
        for i in 0..u.len() {
            u[i] = u[i].clamp(self.lower[i], self.upper[i]);
        }
    }
}

/// An optimal control problem with `NX` states and `NU` controls (compile-time or run-time
/// sizes, see [`crate::dims`]). Cloning shares the models.
pub struct Problem<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    dims: Dims<NX, NU>,
    x0: VectorN<NX>,
    knots: Vec<Knot<NX, NU>>,
    terminal: Arc<dyn TerminalCost<NX>>,
    bounds: Option<ControlBounds<NU>>,
}

impl<NX: Dim, NU: Dim> Clone for Problem<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn clone(&self) -> Self {
        Self {
            dims: self.dims,
            x0: self.x0.clone(),
            knots: self.knots.clone(),
            terminal: self.terminal.clone(),
            bounds: self.bounds.clone(),
        }
    }
}

/// Checks that a piece's declared size matches, naming the piece.
fn check_piece(field: &str, what: &str, declared: Option<usize>, expected: usize) -> Result<()> {
    match declared {
        Some(d) if d != expected => Err(Error::Shape {
            field: field.to_string(),
            got: format!("{what} = {d}"),
            expected: format!("{what} = {expected} (from x0 and the dynamics)"),
        }),
        _ => Ok(()),
    }
}

impl<NX: Dim, NU: Dim> Problem<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// A problem with the same model at every knot. Rejects `horizon == 0`, a non-finite `x0`
    /// and pieces whose sizes disagree.
    pub fn new(
        x0: VectorN<NX>,
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

    /// A problem with one model per knot (time-varying). The control size comes from the first
    /// knot's dynamics (else its cost, else the compile-time `NU`).
    pub fn from_knots(x0: VectorN<NX>, knots: Vec<Knot<NX, NU>>, terminal: Arc<dyn TerminalCost<NX>>) -> Result<Self> {
        if knots.is_empty() {
            return Err(Error::EmptyHorizon);
        }
        check_finite("x0", x0.iter())?;
        let nx = x0.len();
        let nu = knots[0]
            .dynamics
            .sizes()
            .1
            .or(knots[0].cost.sizes().1)
            .or(NU::try_to_usize())
            .ok_or_else(|| {
                Error::invalid(
                    "knots[0].dynamics",
                    "reports no control size (a run-time-size model must state its sizes)",
                )
            })?;
        let dims = Dims::new("problem", nx, nu)?;
        let many = knots.len() > 1;
        for (k, knot) in knots.iter().enumerate() {
            let name = |piece: &str| {
                if many {
                    format!("knots[{k}].{piece}")
                } else {
                    piece.to_string()
                }
            };
            let (dx, du) = knot.dynamics.sizes();
            check_piece(&name("dynamics"), "nx", dx, nx)?;
            check_piece(&name("dynamics"), "nu", du, nu)?;
            let (cx, cu) = knot.cost.sizes();
            check_piece(&name("running_cost"), "nx", cx, nx)?;
            check_piece(&name("running_cost"), "nu", cu, nu)?;
        }
        check_piece("terminal_cost", "nx", terminal.state_size(), nx)?;
        Ok(Self {
            dims,
            x0,
            knots,
            terminal,
            bounds: None,
        })
    }

    fn check_bounds(&self, bounds: &ControlBounds<NU>) -> Result<()> {
        if bounds.lower.len() != self.dims.nu() {
            return Err(Error::Shape {
                field: "control_bounds".into(),
                got: format!("({},)", bounds.lower.len()),
                expected: format!("({},)", self.dims.nu()),
            });
        }
        Ok(())
    }

    /// Adds control bounds (box-DDP); bounds of another size are an error.
    pub fn with_control_bounds(mut self, bounds: ControlBounds<NU>) -> Result<Self> {
        self.check_bounds(&bounds)?;
        self.bounds = Some(bounds);
        Ok(self)
    }

    /// Replaces the control bounds; bounds of another size are an error.
    pub fn set_control_bounds(&mut self, bounds: Option<ControlBounds<NU>>) -> Result<()> {
        if let Some(b) = &bounds {
            self.check_bounds(b)?;
        }
        self.bounds = bounds;
        Ok(())
    }

    /// Replaces the initial state (receding horizon). Rejects NaN/inf and another size.
    pub fn set_x0(&mut self, x0: VectorN<NX>) -> Result<()> {
        if x0.len() != self.dims.nx() {
            return Err(Error::Shape {
                field: "x0".into(),
                got: format!("({},)", x0.len()),
                expected: format!("({},)", self.dims.nx()),
            });
        }
        check_finite("x0", x0.iter())?;
        self.x0 = x0;
        Ok(())
    }

    /// Replaces the model at knot `k`; pieces of other sizes are an error.
    pub fn set_knot(&mut self, k: usize, knot: Knot<NX, NU>) -> Result<()> {
        let n = self.knots.len();
        let (nx, nu) = (self.dims.nx(), self.dims.nu());
        let (dx, du) = knot.dynamics.sizes();
        check_piece(&format!("knots[{k}].dynamics"), "nx", dx, nx)?;
        check_piece(&format!("knots[{k}].dynamics"), "nu", du, nu)?;
        let (cx, cu) = knot.cost.sizes();
        check_piece(&format!("knots[{k}].running_cost"), "nx", cx, nx)?;
        check_piece(&format!("knots[{k}].running_cost"), "nu", cu, nu)?;
        let slot = self
            .knots
            .get_mut(k)
            .ok_or_else(|| Error::invalid("knot", format!("index {k} out of range for horizon {n}")))?;
        *slot = knot;
        Ok(())
    }

    /// Replaces the terminal cost; one of another size is an error.
    pub fn set_terminal(&mut self, terminal: Arc<dyn TerminalCost<NX>>) -> Result<()> {
        check_piece("terminal_cost", "nx", terminal.state_size(), self.dims.nx())?;
        self.terminal = terminal;
        Ok(())
    }

    /// The sizes.
    pub fn dims(&self) -> Dims<NX, NU> {
        self.dims
    }
    /// The initial state.
    pub fn x0(&self) -> &VectorN<NX> {
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

    /// Simulates `us` from `x0` into `xs` (lengths `N` and `N + 1`).
    pub fn rollout(&self, us: &[VectorN<NU>], xs: &mut [VectorN<NX>]) -> Result<()> {
        self.check_lengths(us.len(), xs.len())?;
        self.check_sizes(us, xs)?;
        xs[0].copy_from(&self.x0);
        for (k, knot) in self.knots.iter().enumerate() {
            let (head, tail) = xs.split_at_mut(k + 1);
            knot.dynamics.step_into(&head[k], &us[k], &mut tail[0]);
        }
        Ok(())
    }

    /// The total cost of a trajectory.
    pub fn cost(&self, xs: &[VectorN<NX>], us: &[VectorN<NU>]) -> Result<f64> {
        self.check_lengths(us.len(), xs.len())?;
        self.check_sizes(us, xs)?;
        let running: f64 = self
            .knots
            .iter()
            .enumerate()
            .map(|(k, m)| m.cost.value(&xs[k], &us[k]))
            .sum();
        Ok(running + self.terminal.value(&xs[self.knots.len()]))
    }

    /// Every state and control of the problem's size (run-time sizes can differ per vector).
    fn check_sizes(&self, us: &[VectorN<NU>], xs: &[VectorN<NX>]) -> Result<()> {
        let (nx, nu) = (self.dims.nx(), self.dims.nu());
        if let Some(k) = us.iter().position(|u| u.len() != nu) {
            return Err(Error::Shape {
                field: format!("us[{k}]"),
                got: format!("({},)", us[k].len()),
                expected: format!("({nu},)"),
            });
        }
        if let Some(k) = xs.iter().position(|x| x.len() != nx) {
            return Err(Error::Shape {
                field: format!("xs[{k}]"),
                got: format!("({},)", xs[k].len()),
                expected: format!("({nx},)"),
            });
        }
        Ok(())
    }

    fn check_lengths(&self, nu: usize, nx: usize) -> Result<()> {
        let n = self.knots.len();
        let (sx, su) = (self.dims.nx(), self.dims.nu());
        if nu != n {
            return Err(Error::Shape {
                field: "us".into(),
                got: format!("({nu}, {su})"),
                expected: format!("({n}, {su})"),
            });
        }
        if nx != n + 1 {
            return Err(Error::Shape {
                field: "xs".into(),
                got: format!("({nx}, {sx})"),
                expected: format!("({}, {sx})", n + 1),
            });
        }
        Ok(())
    }
}
