//! Tape-backed models: [`TapeDynamics`], [`TapeCost`], [`TapeTerminal`] and [`TapeConstraint`]
//! implement ddp-core's [`Dynamics`], [`Cost`], [`TerminalCost`] and Safe-CDDP's [`Constraint`]
//! at every dimension type (`Const<N>` or `Dyn`), with exact first and second derivatives.
//!
//! A model is immutable and `Send + Sync` (the tape is shared behind an `Arc`); evaluation
//! scratch is a per-thread [`ProgramWorkspace`] that grows once to the largest tape a thread
//! evaluates, so repeated evaluations allocate nothing and many threads may evaluate one model at
//! once. Each model compiles its tape into a [`Program`] when built (see [`crate::program`]) and
//! resolves where every Jacobian and Hessian entry goes in the solver's matrices then, so an
//! evaluation only runs flat lists. For full DDP, [`TapeDynamics`] keeps each knot's forward
//! sweep in the solver's data ([`Dynamics::jacobians_keep`]) so that the backward passes at that
//! linearisation run only the reverse sweep.
//! Inputs of the wrong length (a bug of the caller; problems check sizes when built) give NaN
//! outputs, never a panic.

use std::cell::RefCell;
use std::sync::Arc;

use ddp_core::dims::{check_size, Alloc, DefaultAllocator, Dim, MatrixN, VectorN, MAX_CONTROLS, MAX_STATES};
use ddp_core::{Cost, CostDerivatives, Dynamics, Error, Result, TerminalCost, TerminalDerivatives};
use safe_cddp::Constraint;

use crate::program::{Needs, Program, ProgramWorkspace};
use crate::tape::Tape;

thread_local! {
    static WORKSPACE: RefCell<ProgramWorkspace> = RefCell::new(ProgramWorkspace::default());
}

/// Runs `f` with this thread's workspace.
#[inline]
fn with_ws<R>(f: impl FnOnce(&mut ProgramWorkspace) -> R) -> R {
    WORKSPACE.with(|cell| match cell.try_borrow_mut() {
        Ok(mut ws) => f(&mut ws),
        // Only re-entered if a model is evaluated from inside another's evaluation.
        Err(_) => f(&mut ProgramWorkspace::default()),
    })
}

/// Where a lower-triangle Hessian entry `hess[h]` goes: `block` 0, 1, 2 for the `xx`, `ux`,
/// `uu` blocks (column-major offsets), and the mirrored offset of an off-diagonal entry of a
/// symmetric block (`u32::MAX` for none).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct HessianSlot {
    h: u32,
    block: u8,
    off: u32,
    mirror: u32,
}

/// The destinations of a program's Hessian entries in `(xx, ux, uu)` blocks of a model with
/// `nx` states and `nu` controls (`ux` is `nu x nx`).
fn hessian_slots(prog: &Program, nx: usize, nu: usize) -> Vec<HessianSlot> {
    let mut out = Vec::new();
    for (h, &(r, c)) in prog.hessian_pattern().iter().enumerate() {
        let (r, c) = (r as usize, c as usize);
        let (block, off, mirror) = if r < nx {
            (0, c * nx + r, (r != c).then_some(r * nx + c))
        } else if c < nx {
            (1, c * nu + (r - nx), None)
        } else {
            let (r, c) = (r - nx, c - nx);
            (2, c * nu + r, (r != c).then_some(r * nu + c))
        };
        out.push(HessianSlot {
            h: h as u32,
            block,
            off: off as u32,
            mirror: mirror.map_or(u32::MAX, |m| m as u32),
        });
    }
    out
}

/// Adds `scale` times the Hessian entries to the blocks (`hess` from [`Program::second_order`],
/// or a quadratic cost's constant entries; a scale of 1 adds them exactly).
#[inline]
fn add_hessian(slots: &[HessianSlot], hess: &[f64], scale: f64, blocks: [&mut [f64]; 3]) {
    let [xx, ux, uu] = blocks;
    for s in slots {
        let v = scale * hess[s.h as usize];
        let m = match s.block {
            0 => &mut *xx,
            1 => &mut *ux,
            _ => &mut *uu,
        };
        m[s.off as usize] += v;
        if s.mirror != u32::MAX {
            m[s.mirror as usize] += v;
        }
    }
}

/// Adds `scale` times the gradient `g` (of `(x, u)`) to `lx` and `lu`.
#[inline]
fn add_gradient(g: &[f64], scale: f64, lx: &mut [f64], lu: &mut [f64]) {
    let (gx, gu) = g.split_at(lx.len());
    for (l, g) in lx.iter_mut().zip(gx).chain(lu.iter_mut().zip(gu)) {
        *l += scale * g;
    }
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

/// A tape's program and where its derivative entries go (built with the model).
#[derive(Debug, Clone, PartialEq)]
struct Compiled {
    prog: Program,
    /// `(dot slot, offset)` of the Jacobian entries in `f_x` and in `f_u` (dynamics; unused
    /// by costs).
    jac_x: Vec<(u32, u32)>,
    jac_u: Vec<(u32, u32)>,
    hess: Vec<HessianSlot>,
    /// A cost whose tape is at most quadratic ([`Tape::is_at_most_quadratic`]): its gradient at
    /// `z = 0` and its Hessian entries (at [`Program::hessian_pattern`]), the same at every
    /// point, so that [`Compiled::cost_derivatives`] runs only the forward sweep for the value.
    quadratic: Option<(Vec<f64>, Vec<f64>)>,
}

impl Compiled {
    /// A dynamics program and where its Jacobian and Hessian entries go.
    fn dynamics(prog: Program, nx: usize, nu: usize) -> Self {
        let (mut jac_x, mut jac_u) = (Vec::new(), Vec::new());
        for &(i, c, slot) in prog.jacobian_entries() {
            let (i, c) = (i as usize, c as usize);
            if c < nx {
                jac_x.push((slot, (c * nx + i) as u32));
            } else {
                jac_u.push((slot, ((c - nx) * nx + i) as u32));
            }
        }
        let hess = hessian_slots(&prog, nx, nu);
        Self {
            prog,
            jac_x,
            jac_u,
            hess,
            quadratic: None,
        }
    }

    /// A cost's program (value, gradient and Hessian in all `nx + nu` inputs) and, for a tape
    /// of degree at most 2, its gradient at the origin and its constant Hessian.
    fn cost(tape: &Tape, nx: usize, nu: usize) -> Self {
        let prog = Program::with_needs(
            tape,
            Needs {
                hessian_rows: nx + nu,
                jacobian_values: false,
                gradient: true,
                one_sweep: false,
            },
        );
        let hess = hessian_slots(&prog, nx, nu);
        let quadratic = tape
            .is_at_most_quadratic()
            .then(|| {
                with_ws(|ws| {
                    prog.second_order(ws, &vec![0.0; nx], &vec![0.0; nu], &[1.0]);
                    (
                        ws.bar[..nx + nu].to_vec(),
                        ws.hess[..prog.hessian_pattern().len()].to_vec(),
                    )
                })
            })
            // Not finite at the origin (a division by a constant zero): the general path, which
            // reports it where it is evaluated.
            .filter(|(g, h)| g.iter().chain(h).all(|v| v.is_finite()));
        Self {
            prog,
            jac_x: Vec::new(),
            jac_u: Vec::new(),
            hess,
            quadratic,
        }
    }

    /// Adds `w` times the cost's gradient at `z = (x, u)` to `(lx, lu)` and its Hessian to the
    /// `(xx, ux, uu)` blocks; returns `w` times its value. At most quadratic: the value from the
    /// forward sweep, the gradient `g_0 + H z` and the constant `H`.
    fn cost_derivatives(
        &self,
        x: &[f64],
        u: &[f64],
        w: f64,
        lx: &mut [f64],
        lu: &mut [f64],
        blocks: [&mut [f64]; 3],
    ) -> f64 {
        let nx = x.len();
        let Some((g0, h)) = &self.quadratic else {
            return with_ws(|ws| {
                self.prog.second_order(ws, x, u, &[w]);
                add_gradient(&ws.bar[..nx + u.len()], 1.0, lx, lu);
                add_hessian(&self.hess, &ws.hess, 1.0, blocks);
                w * self.prog.output(ws, 0)
            });
        };
        let mut v = [0.0];
        with_ws(|ws| self.prog.values(ws, x, u, &mut v));
        add_gradient(g0, w, lx, lu);
        let z = |k: usize| if k < nx { x[k] } else { u[k - nx] };
        let mut grad = |k: usize, d: f64| {
            if k < nx {
                lx[k] += d;
            } else {
                lu[k - nx] += d;
            }
        };
        for (&(r, c), &hv) in self.prog.hessian_pattern().iter().zip(h) {
            let (r, c, hv) = (r as usize, c as usize, w * hv);
            grad(r, hv * z(c));
            if r != c {
                grad(c, hv * z(r));
            }
        }
        add_hessian(&self.hess, h, w, blocks);
        w * v[0]
    }

    /// Writes the Jacobian entries from `dot` into `f_x` and `f_u` (column-major).
    #[inline]
    fn write_jacobians(&self, dot: &[f64], fx: &mut [f64], fu: &mut [f64]) {
        for (m, entries) in [(fx, &self.jac_x), (fu, &self.jac_u)] {
            m.fill(0.0);
            for &(slot, off) in entries {
                m[off as usize] = dot[slot as usize];
            }
        }
    }
}

/// Discrete dynamics `x+ = F(x, u)` given by a tape with inputs `(x, u)` and `nx` outputs.
#[derive(Debug, Clone, PartialEq)]
pub struct TapeDynamics {
    tape: Arc<Tape>,
    nx: usize,
    nu: usize,
    compiled: Arc<Compiled>,
    /// The program of [`Dynamics::jacobians_keep`] ([`Needs::one_sweep`]).
    kept: Arc<Compiled>,
}

impl TapeDynamics {
    /// Checks that `tape` has `nx + nu` inputs and `nx` outputs, and compiles it.
    pub fn new(tape: Tape, nx: usize, nu: usize) -> Result<Self> {
        check_dims("dynamics", nx, Some(nu))?;
        check_tape(&tape, "dynamics", nx + nu, Some(nx))?;
        // The solver reads Jacobians without values and `V_x`-weighted Hessians without gradients.
        let prog = Program::with_needs(
            &tape,
            Needs {
                hessian_rows: nx + nu,
                jacobian_values: false,
                gradient: false,
                one_sweep: false,
            },
        );
        // Full DDP's: one forward sweep per knot and linearisation, kept for the backward
        // passes.
        let kept = Program::with_needs(
            &tape,
            Needs {
                hessian_rows: nx + nu,
                jacobian_values: false,
                gradient: false,
                one_sweep: true,
            },
        );
        Ok(Self {
            tape: Arc::new(tape),
            nx,
            nu,
            compiled: Arc::new(Compiled::dynamics(prog, nx, nu)),
            kept: Arc::new(Compiled::dynamics(kept, nx, nu)),
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
        let prog = &self.compiled.prog;
        with_ws(|ws| prog.values(ws, x.as_slice(), u.as_slice(), out.as_mut_slice()));
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
        let c = &*self.compiled;
        with_ws(|ws| {
            c.prog.jacobian(ws, x.as_slice(), u.as_slice());
            c.write_jacobians(&ws.dot, fx.as_mut_slice(), fu.as_mut_slice());
        });
    }
    fn jacobians_keep(
        &self,
        x: &VectorN<NX>,
        u: &VectorN<NU>,
        fx: &mut MatrixN<NX, NX>,
        fu: &mut MatrixN<NX, NU>,
        data: &mut Vec<f64>,
    ) {
        let nx = self.nx;
        if !self.fits(x.len(), u.len()) || fx.len() != nx * nx || fu.len() != nx * self.nu {
            fx.fill(f64::NAN);
            fu.fill(f64::NAN);
            return;
        }
        let c = &*self.kept;
        c.prog.jacobian_keep(data, x.as_slice(), u.as_slice());
        c.write_jacobians(c.prog.kept_dot(data), fx.as_mut_slice(), fu.as_mut_slice());
    }
    fn add_second_order_kept(
        &self,
        x: &VectorN<NX>,
        u: &VectorN<NU>,
        lambda: &VectorN<NX>,
        data: &[f64],
        h_xx: &mut MatrixN<NX, NX>,
        h_ux: &mut MatrixN<NU, NX>,
        h_uu: &mut MatrixN<NU, NU>,
    ) {
        if !self.fits(x.len(), u.len()) || lambda.len() != self.nx {
            h_xx.fill(f64::NAN);
            return;
        }
        let c = &*self.kept;
        let done = with_ws(|ws| {
            let kept = c
                .prog
                .second_order_kept(ws, data, x.as_slice(), u.as_slice(), lambda.as_slice());
            if kept {
                let blocks = [h_xx.as_mut_slice(), h_ux.as_mut_slice(), h_uu.as_mut_slice()];
                add_hessian(&c.hess, &ws.hess, 1.0, blocks);
            }
            kept
        });
        if !done {
            // No sweep kept at this point (another caller's data, or a changed trajectory).
            Dynamics::<NX, NU>::add_second_order(self, x, u, lambda, h_xx, h_ux, h_uu);
        }
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
        let c = &*self.compiled;
        with_ws(|ws| {
            c.prog.second_order(ws, x.as_slice(), u.as_slice(), lambda.as_slice());
            let blocks = [h_xx.as_mut_slice(), h_ux.as_mut_slice(), h_uu.as_mut_slice()];
            add_hessian(&c.hess, &ws.hess, 1.0, blocks);
        });
    }
}

/// A running cost `l(x, u)` given by a tape with inputs `(x, u)` and one output.
#[derive(Debug, Clone, PartialEq)]
pub struct TapeCost {
    tape: Arc<Tape>,
    nx: usize,
    nu: usize,
    compiled: Arc<Compiled>,
}

impl TapeCost {
    /// Checks that `tape` has `nx + nu` inputs and one output, and compiles it (a tape of
    /// degree at most 2 keeps its constant Hessian: see [`Tape::is_at_most_quadratic`]).
    pub fn new(tape: Tape, nx: usize, nu: usize) -> Result<Self> {
        check_dims("cost", nx, Some(nu))?;
        check_tape(&tape, "cost", nx + nu, Some(1))?;
        let compiled = Arc::new(Compiled::cost(&tape, nx, nu));
        Ok(Self {
            tape: Arc::new(tape),
            nx,
            nu,
            compiled,
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
        let prog = &self.compiled.prog;
        with_ws(|ws| prog.values(ws, x.as_slice(), u.as_slice(), &mut v));
        v[0]
    }
    fn add_derivatives(&self, x: &VectorN<NX>, u: &VectorN<NU>, w: f64, d: &mut CostDerivatives<NX, NU>) -> f64 {
        if x.len() != self.nx || u.len() != self.nu {
            return f64::NAN;
        }
        let blocks = [d.lxx.as_mut_slice(), d.lux.as_mut_slice(), d.luu.as_mut_slice()];
        let (lx, lu) = (d.lx.as_mut_slice(), d.lu.as_mut_slice());
        self.compiled
            .cost_derivatives(x.as_slice(), u.as_slice(), w, lx, lu, blocks)
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
    compiled: Arc<Compiled>,
}

impl TapeTerminal {
    /// Checks that `tape` has `nx` inputs and one output, and compiles it (as [`TapeCost::new`]).
    pub fn new(tape: Tape, nx: usize) -> Result<Self> {
        check_dims("terminal_cost", nx, None)?;
        check_tape(&tape, "terminal_cost", nx, Some(1))?;
        let compiled = Arc::new(Compiled::cost(&tape, nx, 0));
        Ok(Self {
            tape: Arc::new(tape),
            nx,
            compiled,
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
        let prog = &self.compiled.prog;
        with_ws(|ws| prog.values(ws, x.as_slice(), &[], &mut v));
        v[0]
    }
    fn add_derivatives(&self, x: &VectorN<NX>, w: f64, d: &mut TerminalDerivatives<NX>) -> f64 {
        if x.len() != self.nx {
            return f64::NAN;
        }
        let blocks = [d.lxx.as_mut_slice(), &mut [], &mut []];
        self.compiled
            .cost_derivatives(x.as_slice(), &[], w, d.lx.as_mut_slice(), &mut [], blocks)
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
    compiled: Arc<Compiled>,
}

impl TapeConstraint {
    /// Checks that `tape` has `nx + nu` inputs (`nx` where `nu` is `None`) and at least one output.
    pub fn new(tape: Tape, nx: usize, nu: Option<usize>) -> Result<Self> {
        check_dims("constraint", nx, nu)?;
        check_tape(&tape, "constraint", nx + nu.unwrap_or(0), None)?;
        let uses_control = (nx..tape.n_inputs()).any(|k| tape.uses_input(k));
        // Constraint Jacobians come with values; only the `xx` block of the curvature is read.
        let prog = Program::with_needs(
            &tape,
            Needs {
                hessian_rows: nx,
                jacobian_values: true,
                gradient: false,
                one_sweep: false,
            },
        );
        let hess = hessian_slots(&prog, nx, 0);
        Ok(Self {
            tape: Arc::new(tape),
            nx,
            nu,
            uses_control,
            compiled: Arc::new(Compiled {
                prog,
                jac_x: Vec::new(),
                jac_u: Vec::new(),
                hess,
                quadratic: None,
            }),
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
    fn control<'a>(&self, u: &'a [f64]) -> &'a [f64] {
        if self.nu.is_some() {
            u
        } else {
            &[]
        }
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
        let prog = &self.compiled.prog;
        with_ws(|ws| prog.values(ws, x.as_slice(), self.control(u.as_slice()), g));
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
        let prog = &self.compiled.prog;
        with_ws(|ws| {
            prog.jacobian(ws, x.as_slice(), self.control(u.as_slice()));
            for i in 0..m {
                g[i] = prog.output(ws, i);
                g_x[i].fill(0.0);
                g_u[i].fill(0.0);
            }
            for &(i, c, slot) in prog.jacobian_entries() {
                let (i, c, v) = (i as usize, c as usize, ws.dot[slot as usize]);
                if c < nx {
                    g_x[i][c] = v;
                } else {
                    g_u[i][c - nx] = v;
                }
            }
        });
    }
    fn add_hessian(&self, _t: usize, x: &VectorN<NX>, u: &VectorN<NU>, w: &[f64], h_xx: &mut MatrixN<NX, NX>) {
        if !self.fits(x.len(), u.len()) || w.len() != self.tape.n_outputs() {
            h_xx.fill(f64::NAN);
            return;
        }
        let c = &*self.compiled;
        with_ws(|ws| {
            c.prog.second_order(ws, x.as_slice(), self.control(u.as_slice()), w);
            add_hessian(&c.hess, &ws.hess, 1.0, [h_xx.as_mut_slice(), &mut [], &mut []]);
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
