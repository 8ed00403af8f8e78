//! Tape-backed models: [`TapeDynamics`], [`TapeCost`], [`TapeTerminal`] and [`TapeConstraint`]
//! implement ddp-core's [`Dynamics`], [`Cost`], [`TerminalCost`] and Safe-CDDP's [`Constraint`]
//! at every dimension type (`Const<N>` or `Dyn`), with exact first and second derivatives.
//!
//! A model is immutable and `Send + Sync` (the tape is shared behind an `Arc`); evaluation
//! scratch is a per-thread [`Workspace`] that grows once to the largest tape a thread evaluates,
//! so repeated evaluations allocate nothing and many threads may evaluate one model at once.
//! Inputs of the wrong length (a bug of the caller; problems check sizes when built) give NaN
//! outputs, never a panic.

use std::cell::RefCell;
use std::sync::Arc;

use ddp_core::dims::{check_size, Alloc, DefaultAllocator, Dim, MatrixN, VectorN, MAX_CONTROLS, MAX_STATES};
use ddp_core::{Cost, CostDerivatives, Dynamics, Error, Result, TerminalCost, TerminalDerivatives};
use safe_cddp::Constraint;

use crate::eval::Workspace;
use crate::tape::Tape;

thread_local! {
    static WORKSPACE: RefCell<Workspace> = RefCell::new(Workspace::default());
}

/// Runs `f` with this thread's workspace and the inputs `z = (x, u)` packed into it.
fn with_inputs<R>(x: &[f64], u: Option<&[f64]>, f: impl FnOnce(&[f64], &mut Workspace) -> R) -> R {
    let run = |ws: &mut Workspace| {
        let mut z = std::mem::take(&mut ws.z);
        z.clear();
        z.extend_from_slice(x);
        if let Some(u) = u {
            z.extend_from_slice(u);
        }
        let r = f(&z, ws);
        ws.z = z;
        r
    };
    WORKSPACE.with(|cell| match cell.try_borrow_mut() {
        Ok(mut ws) => run(&mut ws),
        // Only re-entered if a model is evaluated from inside another's evaluation.
        Err(_) => run(&mut Workspace::default()),
    })
}

fn check_tape(tape: &Tape, field: &str, inputs: usize, outputs: Option<usize>) -> Result<()> {
    if tape.n_inputs() != inputs {
        return Err(Error::Shape {
            field: format!("{field}.inputs"),
            got: tape.n_inputs().to_string(),
            expected: inputs.to_string(),
        });
    }
    match outputs {
        Some(m) if tape.n_outputs() != m => Err(Error::Shape {
            field: format!("{field}.outputs"),
            got: format!("({},)", tape.n_outputs()),
            expected: format!("({m},)"),
        }),
        None if tape.n_outputs() == 0 => Err(Error::invalid(format!("{field}.outputs"), "has no rows")),
        _ => Ok(()),
    }
}

fn check_dims(field: &str, nx: usize, nu: Option<usize>) -> Result<()> {
    check_size(&format!("{field}.nx"), nx, None, MAX_STATES)?;
    if let Some(nu) = nu {
        check_size(&format!("{field}.nu"), nu, None, MAX_CONTROLS)?;
    }
    Ok(())
}

/// Adds `row[j]` to `m[(r, j - off)]` for `j` in `cols` (`m` column-major with `rows` rows).
#[inline]
fn add_row<R: Dim, C: Dim>(m: &mut MatrixN<R, C>, r: usize, row: &[f64])
where
    DefaultAllocator: nalgebra::allocator::Allocator<R, C>,
{
    let rows = m.nrows();
    let s = m.as_mut_slice();
    for (j, v) in row.iter().enumerate() {
        s[j * rows + r] += v;
    }
}

/// Discrete dynamics `x+ = F(x, u)` given by a tape with inputs `(x, u)` and `nx` outputs.
#[derive(Debug, Clone, PartialEq)]
pub struct TapeDynamics {
    tape: Arc<Tape>,
    nx: usize,
    nu: usize,
}

impl TapeDynamics {
    /// Checks that `tape` has `nx + nu` inputs and `nx` outputs.
    pub fn new(tape: Tape, nx: usize, nu: usize) -> Result<Self> {
        check_dims("dynamics", nx, Some(nu))?;
        check_tape(&tape, "dynamics", nx + nu, Some(nx))?;
        Ok(Self {
            tape: Arc::new(tape),
            nx,
            nu,
        })
    }
    /// The tape.
    pub fn tape(&self) -> &Tape {
        &self.tape
    }
    /// `(nx, nu)`.
    pub fn dims(&self) -> (usize, usize) {
        (self.nx, self.nu)
    }
    fn fits(&self, x: usize, u: usize) -> bool {
        x == self.nx && u == self.nu
    }
}

impl<NX: Dim, NU: Dim> Dynamics<NX, NU> for TapeDynamics
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn step(&self, x: &VectorN<NX>, u: &VectorN<NU>) -> VectorN<NX> {
        let mut out = VectorN::<NX>::zeros_generic(x.shape_generic().0, nalgebra::U1);
        self.step_into(x, u, &mut out);
        out
    }
    fn step_into(&self, x: &VectorN<NX>, u: &VectorN<NU>, out: &mut VectorN<NX>) {
        if !self.fits(x.len(), u.len()) || out.len() != self.nx {
            out.fill(f64::NAN);
            return;
        }
        with_inputs(x.as_slice(), Some(u.as_slice()), |z, ws| {
            self.tape.values(z, ws, out.as_mut_slice())
        });
    }
    fn sizes(&self) -> (Option<usize>, Option<usize>) {
        (Some(self.nx), Some(self.nu))
    }
    fn jacobians(&self, x: &VectorN<NX>, u: &VectorN<NU>, fx: &mut MatrixN<NX, NX>, fu: &mut MatrixN<NX, NU>) {
        let nx = self.nx;
        if !self.fits(x.len(), u.len()) || fx.len() != nx * nx || fu.len() != nx * self.nu {
            fx.fill(f64::NAN);
            fu.fill(f64::NAN);
            return;
        }
        with_inputs(x.as_slice(), Some(u.as_slice()), |z, ws| {
            self.tape.forward(z, ws, true);
            fx.fill(0.0);
            fu.fill(0.0);
            let cols = self.tape.tangent_columns();
            for (i, &o) in self.tape.outputs().iter().enumerate() {
                let (s, e) = self.tape.tangent_range(o as usize);
                for (&c, &v) in cols[s..e].iter().zip(&ws.dot[s..e]) {
                    let c = c as usize;
                    if c < nx {
                        fx[(i, c)] = v;
                    } else {
                        fu[(i, c - nx)] = v;
                    }
                }
            }
        });
    }
    fn has_second_order(&self) -> bool {
        true
    }
    fn add_second_order(
        &self,
        x: &VectorN<NX>,
        u: &VectorN<NU>,
        lambda: &VectorN<NX>,
        h_xx: &mut MatrixN<NX, NX>,
        h_ux: &mut MatrixN<NU, NX>,
        h_uu: &mut MatrixN<NU, NU>,
    ) {
        let nx = self.nx;
        if !self.fits(x.len(), u.len()) || lambda.len() != nx {
            h_xx.fill(f64::NAN);
            return;
        }
        with_inputs(x.as_slice(), Some(u.as_slice()), |z, ws| {
            self.tape.forward(z, ws, true);
            self.tape.second_order(lambda.as_slice(), ws, |k, _, h| {
                if k < nx {
                    add_row(h_xx, k, &h[..nx]);
                } else {
                    add_row(h_ux, k - nx, &h[..nx]);
                    add_row(h_uu, k - nx, &h[nx..]);
                }
            });
        });
    }
}

/// A running cost `l(x, u)` given by a tape with inputs `(x, u)` and one output.
#[derive(Debug, Clone, PartialEq)]
pub struct TapeCost {
    tape: Arc<Tape>,
    nx: usize,
    nu: usize,
}

impl TapeCost {
    /// Checks that `tape` has `nx + nu` inputs and one output.
    pub fn new(tape: Tape, nx: usize, nu: usize) -> Result<Self> {
        check_dims("cost", nx, Some(nu))?;
        check_tape(&tape, "cost", nx + nu, Some(1))?;
        Ok(Self {
            tape: Arc::new(tape),
            nx,
            nu,
        })
    }
    /// The tape.
    pub fn tape(&self) -> &Tape {
        &self.tape
    }
    /// `(nx, nu)`.
    pub fn dims(&self) -> (usize, usize) {
        (self.nx, self.nu)
    }
}

impl<NX: Dim, NU: Dim> Cost<NX, NU> for TapeCost
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn value(&self, x: &VectorN<NX>, u: &VectorN<NU>) -> f64 {
        if x.len() != self.nx || u.len() != self.nu {
            return f64::NAN;
        }
        let mut v = [0.0];
        with_inputs(x.as_slice(), Some(u.as_slice()), |z, ws| {
            self.tape.values(z, ws, &mut v)
        });
        v[0]
    }
    fn add_derivatives(&self, x: &VectorN<NX>, u: &VectorN<NU>, w: f64, d: &mut CostDerivatives<NX, NU>) -> f64 {
        let nx = self.nx;
        if x.len() != nx || u.len() != self.nu {
            return f64::NAN;
        }
        with_inputs(x.as_slice(), Some(u.as_slice()), |z, ws| {
            self.tape.forward(z, ws, true);
            let v = ws.val[self.tape.outputs()[0] as usize];
            self.tape.second_order(&[w], ws, |k, g, h| {
                if k < nx {
                    d.lx[k] += g;
                    add_row(&mut d.lxx, k, &h[..nx]);
                } else {
                    d.lu[k - nx] += g;
                    add_row(&mut d.lux, k - nx, &h[..nx]);
                    add_row(&mut d.luu, k - nx, &h[nx..]);
                }
            });
            w * v
        })
    }
    fn sizes(&self) -> (Option<usize>, Option<usize>) {
        (Some(self.nx), Some(self.nu))
    }
}

/// A terminal cost `l_N(x)` given by a tape with inputs `x` and one output.
#[derive(Debug, Clone, PartialEq)]
pub struct TapeTerminal {
    tape: Arc<Tape>,
    nx: usize,
}

impl TapeTerminal {
    /// Checks that `tape` has `nx` inputs and one output.
    pub fn new(tape: Tape, nx: usize) -> Result<Self> {
        check_dims("terminal_cost", nx, None)?;
        check_tape(&tape, "terminal_cost", nx, Some(1))?;
        Ok(Self {
            tape: Arc::new(tape),
            nx,
        })
    }
    /// The tape.
    pub fn tape(&self) -> &Tape {
        &self.tape
    }
    /// `nx`.
    pub fn nx(&self) -> usize {
        self.nx
    }
}

impl<NX: Dim> TerminalCost<NX> for TapeTerminal
where
    DefaultAllocator: Alloc<NX, NX>,
{
    fn value(&self, x: &VectorN<NX>) -> f64 {
        if x.len() != self.nx {
            return f64::NAN;
        }
        let mut v = [0.0];
        with_inputs(x.as_slice(), None, |z, ws| self.tape.values(z, ws, &mut v));
        v[0]
    }
    fn add_derivatives(&self, x: &VectorN<NX>, w: f64, d: &mut TerminalDerivatives<NX>) -> f64 {
        if x.len() != self.nx {
            return f64::NAN;
        }
        with_inputs(x.as_slice(), None, |z, ws| {
            self.tape.forward(z, ws, true);
            let v = ws.val[self.tape.outputs()[0] as usize];
            self.tape.second_order(&[w], ws, |k, g, h| {
                d.lx[k] += g;
                add_row(&mut d.lxx, k, h);
            });
            w * v
        })
    }
    fn state_size(&self) -> Option<usize> {
        Some(self.nx)
    }
}

/// Constraints `g(x, u) <= 0` (or `g(x) <= 0`) given by a tape with inputs `(x, u)` (or `x`)
/// and one output per row. A tape whose outputs do not depend on `u` is a state-only
/// constraint, imposed on `x_1 .. x_N` (see [`safe_cddp::constraint`]).
#[derive(Debug, Clone, PartialEq)]
pub struct TapeConstraint {
    tape: Arc<Tape>,
    nx: usize,
    /// `None` for a tape of `x` alone (usable with any control size).
    nu: Option<usize>,
    uses_control: bool,
}

impl TapeConstraint {
    /// Checks that `tape` has `nx + nu` inputs (`nx` where `nu` is `None`) and at least one output.
    pub fn new(tape: Tape, nx: usize, nu: Option<usize>) -> Result<Self> {
        check_dims("constraint", nx, nu)?;
        check_tape(&tape, "constraint", nx + nu.unwrap_or(0), None)?;
        let uses_control = (nx..tape.n_inputs()).any(|k| tape.uses_input(k));
        Ok(Self {
            tape: Arc::new(tape),
            nx,
            nu,
            uses_control,
        })
    }
    /// The tape.
    pub fn tape(&self) -> &Tape {
        &self.tape
    }
    /// `(nx, nu)` (`nu` is `None` for a constraint on `x` alone).
    pub fn dims(&self) -> (usize, Option<usize>) {
        (self.nx, self.nu)
    }
    fn fits(&self, x: usize, u: usize) -> bool {
        x == self.nx && self.nu.is_none_or(|nu| nu == u)
    }
    fn control<'a>(&self, u: &'a [f64]) -> Option<&'a [f64]> {
        self.nu.map(|_| u)
    }
}

impl<NX: Dim, NU: Dim> Constraint<NX, NU> for TapeConstraint
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn dim(&self) -> usize {
        self.tape.n_outputs()
    }
    fn depends_on_control(&self) -> bool {
        self.uses_control
    }
    fn evaluate(&self, _t: usize, x: &VectorN<NX>, u: &VectorN<NU>, g: &mut [f64]) {
        if !self.fits(x.len(), u.len()) || g.len() != self.tape.n_outputs() {
            g.fill(f64::NAN);
            return;
        }
        with_inputs(x.as_slice(), self.control(u.as_slice()), |z, ws| {
            self.tape.values(z, ws, g)
        });
    }
    fn jacobians(
        &self,
        _t: usize,
        x: &VectorN<NX>,
        u: &VectorN<NU>,
        g: &mut [f64],
        g_x: &mut [VectorN<NX>],
        g_u: &mut [VectorN<NU>],
    ) {
        let m = self.tape.n_outputs();
        if !self.fits(x.len(), u.len()) || g.len() != m || g_x.len() != m || g_u.len() != m {
            g.fill(f64::NAN);
            return;
        }
        let nx = self.nx;
        with_inputs(x.as_slice(), self.control(u.as_slice()), |z, ws| {
            self.tape.forward(z, ws, true);
            let cols = self.tape.tangent_columns();
            for (i, &o) in self.tape.outputs().iter().enumerate() {
                g[i] = ws.val[o as usize];
                g_x[i].fill(0.0);
                g_u[i].fill(0.0);
                let (s, e) = self.tape.tangent_range(o as usize);
                for (&c, &v) in cols[s..e].iter().zip(&ws.dot[s..e]) {
                    let c = c as usize;
                    if c < nx {
                        g_x[i][c] = v;
                    } else if self.nu.is_some() {
                        g_u[i][c - nx] = v;
                    }
                }
            }
        });
    }
    fn add_hessian(&self, _t: usize, x: &VectorN<NX>, u: &VectorN<NU>, w: &[f64], h_xx: &mut MatrixN<NX, NX>) {
        if !self.fits(x.len(), u.len()) || w.len() != self.tape.n_outputs() {
            h_xx.fill(f64::NAN);
            return;
        }
        let nx = self.nx;
        with_inputs(x.as_slice(), self.control(u.as_slice()), |z, ws| {
            self.tape.forward(z, ws, true);
            self.tape.second_order(w, ws, |k, _, h| {
                if k < nx {
                    add_row(h_xx, k, &h[..nx]);
                }
            });
        });
    }
    fn check_sizes(&self, nx: usize, nu: usize) -> Result<()> {
        if nx != self.nx {
            return Err(Error::Shape {
                field: "constraint.nx".into(),
                got: self.nx.to_string(),
                expected: format!("{nx} (the problem's state size)"),
            });
        }
        match self.nu {
            Some(n) if n != nu => Err(Error::Shape {
                field: "constraint.nu".into(),
                got: n.to_string(),
                expected: format!("{nu} (the problem's control size)"),
            }),
            _ => Ok(()),
        }
    }
}
