//! The one DDP core that every solver of ddpkit is built from.
//!
//! It owns the steps that do not depend on how a variant treats constraints: rolling out, the
//! linearisation along a trajectory, the Q blocks of Tassa et al. (2012) with the full-DDP
//! second-order terms, the regularisation and its schedule, the value-function update, the
//! expected improvement and the line search. A variant supplies its gains through [`Gains`]
//! (as Crocoddyl's BoxDDP overrides `computeGains`): [`FreeGains`] (iLQR / DDP), [`BoxGains`]
//! (box-DDP, Tassa, Mansard and Todorov 2014), [`ClampedGains`] (a fixed active set of control
//! bounds), and Safe-CDDP's active-set KKT gains (Xie et al. 2017) in the `safe-cddp` crate.
//!
//! | symbol | field | equation (Tassa et al. 2012) |
//! |---|---|---|
//! | `Q_x, Q_u, Q_xx, Q_uu, Q_ux` | [`QBlocks`] `q_x, q_u, q_xx, q_uu, q_ux` | (5) |
//! | `Q_uu + mu I`, `Q_ux` (regularised) | `q_uu_r`, `q_ux_r` | (10) |
//! | `k, K` | [`Policy`] `k_ff`, `k_fb` | (6) |
//! | `V_x, V_xx` | [`ValueFunction`] `v_x`, `v_xx` | (11) |
//! | `Delta V(alpha)` | [`Expected`] `dv1`, `dv2` | (13) |
//! | `mu, Delta` | [`MuSchedule`] `mu`, `dmu` | §II-F |
//!
//! Every buffer is allocated by the constructors; the steps allocate nothing, at compile-time
//! and run-time sizes alike.

use crate::boxqp::{box_qp, BoxQp};
use crate::dims::{Alloc, DefaultAllocator, Dim, Dims, MatrixN, VectorN};
use crate::error::{check_finite, Error};
use crate::kernels::{
    add_to, cholesky_in_place, cholesky_solve_in_place, copy, ldl_from, ldl_solve_in_place, mul_to, mul_vec_add,
    negate, sym_tr_mul2_add, sym_tr_mul_add, tr_mul_add, tr_mul_vec_add,
};
use crate::solver::settings::{LineSearchSettings, Method, Regularization, RegularizationSettings, Shooting};
use crate::solver::shooting::MultipleShooting;
use crate::{ControlBounds, CostDerivatives, Problem, TerminalDerivatives};
#[cfg(target_arch = "x86_64")]
use ddpkit_util::simd::Simd;

/// A backward pass met a `Q_uu` (or KKT matrix) that is not positive definite.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NotPositiveDefinite;

/// The nominal trajectory `(xs, us)` and the trial of the line search.
#[derive(Debug, Clone)]
pub struct Trajectory<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// `x_0 .. x_N`
    pub xs: Vec<VectorN<NX>>,
    /// `u_0 .. u_{N-1}`
    pub us: Vec<VectorN<NU>>,
    /// Trial states.
    pub xs_try: Vec<VectorN<NX>>,
    /// Trial controls.
    pub us_try: Vec<VectorN<NU>>,
    /// Each knot's dynamics data from the rollout ([`crate::Dynamics::step_keep`]), for the
    /// Jacobians at the same point ([`crate::Dynamics::jacobians_kept`]); empty until a model
    /// keeps some, and possibly of another point (the model checks).
    pub data: Vec<Vec<f64>>,
    /// The trial's.
    pub data_try: Vec<Vec<f64>>,
}

impl<NX: Dim, NU: Dim> Trajectory<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// Zero trajectories of `n` knots.
    pub fn new(dims: Dims<NX, NU>, n: usize) -> Self {
        Self {
            xs: vec![dims.x_zeros(); n + 1],
            us: vec![dims.u_zeros(); n],
            xs_try: vec![dims.x_zeros(); n + 1],
            us_try: vec![dims.u_zeros(); n],
            data: vec![Vec::new(); n],
            data_try: vec![Vec::new(); n],
        }
    }
    /// Makes the trial the nominal trajectory (a swap, no copy).
    pub fn accept_trial(&mut self) {
        std::mem::swap(&mut self.xs, &mut self.xs_try);
        std::mem::swap(&mut self.us, &mut self.us_try);
        std::mem::swap(&mut self.data, &mut self.data_try);
    }
}

/// Derivatives of dynamics and costs along a trajectory.
#[derive(Debug, Clone)]
pub struct Linearization<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// `f_x` per knot.
    pub fx: Vec<MatrixN<NX, NX>>,
    /// `f_u` per knot.
    pub fu: Vec<MatrixN<NX, NU>>,
    /// Running-cost derivatives per knot.
    pub l: Vec<CostDerivatives<NX, NU>>,
    /// Terminal-cost derivatives.
    pub l_n: TerminalDerivatives<NX>,
    /// Whether the dynamics keep per-knot data for the second-order terms of full DDP
    /// ([`crate::Dynamics::jacobians_keep`]); set by the solver from its method.
    pub keep_second_order: bool,
    /// Each knot's dynamics data ([`crate::Dynamics::jacobians_keep`]), empty until a model keeps some.
    pub data: Vec<Vec<f64>>,
}

impl<NX: Dim, NU: Dim> Linearization<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// Zero derivatives for `n` knots. The dynamics' data starts empty (no allocation); a model
    /// that keeps some grows its knot's once, at the first full-DDP linearisation.
    pub fn new(dims: Dims<NX, NU>, n: usize) -> Self {
        Self {
            fx: vec![dims.xx_zeros(); n],
            fu: vec![dims.xu_zeros(); n],
            l: vec![CostDerivatives::zeros(dims); n],
            l_n: TerminalDerivatives::zeros(dims.nx),
            keep_second_order: false,
            data: vec![Vec::new(); n],
        }
    }

    /// Derivatives of the first `n` knots' dynamics and costs and of the terminal cost along
    /// `(xs, us)`, with the dynamics' data of their rollout (`kept`, [`Trajectory::data`]; empty
    /// for none).
    #[inline(never)]
    pub fn compute(
        &mut self,
        problem: &Problem<NX, NU>,
        xs: &[VectorN<NX>],
        us: &[VectorN<NU>],
        kept: &[Vec<f64>],
        n: usize,
    ) {
        let data = if self.keep_second_order {
            &mut self.data[..n]
        } else {
            &mut []
        };
        knots_derivatives(
            &problem.knots()[..n],
            &xs[..n],
            &us[..n],
            kept,
            &mut self.fx[..n],
            &mut self.fu[..n],
            &mut self.l[..n],
            data,
        );
        self.cost_terminal(problem, &xs[n]);
    }

    /// [`Linearization::compute`] with the knots split over `threads` (contiguous chunks, one
    /// per thread; the calling thread takes the first chunk and the terminal cost, the pool's
    /// `threads - 1` workers the others). Each knot's derivatives are computed by the same code
    /// as in the sequential pass and written to the same place, so the result is bit-identical
    /// to [`Linearization::compute`] for any thread count.
    pub fn compute_with(
        &mut self,
        threads: &DerivativeThreads,
        problem: &Problem<NX, NU>,
        xs: &[VectorN<NX>],
        us: &[VectorN<NU>],
        kept: &[Vec<f64>],
        n: usize,
    ) {
        #[cfg(feature = "parallel")]
        if let Some(pool) = threads.pool.as_deref() {
            if n >= 2 {
                let chunk = n.div_ceil(threads.threads);
                let knots = &problem.knots()[..n];
                let (fx, fu, l) = (&mut self.fx[..n], &mut self.fu[..n], &mut self.l[..n]);
                let (data, keep) = (&mut self.data[..n], self.keep_second_order);
                // The caller works too rather than blocking while `threads` workers run: a
                // blocked caller must be woken when they finish, and afterwards they spin for
                // more work on the cores the rest of the iteration runs on.
                let run = |c: usize,
                           fx: &mut [MatrixN<NX, NX>],
                           fu: &mut [MatrixN<NX, NU>],
                           l: &mut [CostDerivatives<NX, NU>],
                           data: &mut [Vec<f64>]| {
                    let r = c * chunk..c * chunk + fx.len();
                    let data = if keep { data } else { &mut [] };
                    let kept = kept.get(r.clone()).unwrap_or(&[]);
                    knots_derivatives(&knots[r.clone()], &xs[r.clone()], &us[r], kept, fx, fu, l, data);
                };
                pool.in_place_scope(|scope| {
                    let mut parts = fx
                        .chunks_mut(chunk)
                        .zip(fu.chunks_mut(chunk))
                        .zip(l.chunks_mut(chunk))
                        .zip(data.chunks_mut(chunk))
                        .enumerate();
                    let first = parts.next();
                    for (c, (((fx, fu), l), data)) in parts {
                        scope.spawn(move |_| run(c, fx, fu, l, data));
                    }
                    if let Some((c, (((fx, fu), l), data))) = first {
                        run(c, fx, fu, l, data);
                    }
                });
                self.cost_terminal(problem, &xs[n]);
                return;
            }
        }
        let _ = threads;
        self.compute(problem, xs, us, kept, n);
    }

    /// Only the running and terminal cost derivatives (the dynamics' are kept).
    pub fn compute_costs(&mut self, problem: &Problem<NX, NU>, xs: &[VectorN<NX>], us: &[VectorN<NU>], n: usize) {
        for (k, knot) in problem.knots()[..n].iter().enumerate() {
            knot.cost.set_derivatives(&xs[k], &us[k], &mut self.l[k]);
        }
        self.cost_terminal(problem, &xs[n]);
    }

    fn cost_terminal(&mut self, problem: &Problem<NX, NU>, x_n: &VectorN<NX>) {
        self.l_n.clear();
        problem.terminal().add_derivatives(x_n, 1.0, &mut self.l_n);
    }
}

/// The dynamics Jacobians and running-cost derivatives of `knots` at `(xs, us)` (equal lengths),
/// into `fx`, `fu`, `l`, keeping the dynamics' second-order data in `data` where it is not
/// empty (full DDP), else reading their rollout's `kept` data (where it is not empty): the one
/// text of the derivative phase, sequential or per thread chunk.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn knots_derivatives<NX: Dim, NU: Dim>(
    knots: &[crate::Knot<NX, NU>],
    xs: &[VectorN<NX>],
    us: &[VectorN<NU>],
    kept: &[Vec<f64>],
    fx: &mut [MatrixN<NX, NX>],
    fu: &mut [MatrixN<NX, NU>],
    l: &mut [CostDerivatives<NX, NU>],
    data: &mut [Vec<f64>],
) where
    DefaultAllocator: Alloc<NX, NU>,
{
    for (k, knot) in knots.iter().enumerate() {
        let (x, u) = (&xs[k], &us[k]);
        match data.get_mut(k) {
            Some(d) => knot.dynamics.jacobians_keep(x, u, &mut fx[k], &mut fu[k], d),
            None => match kept.get(k) {
                Some(kept) => knot.dynamics.jacobians_kept(x, u, &mut fx[k], &mut fu[k], kept),
                None => knot.dynamics.jacobians(x, u, &mut fx[k], &mut fu[k]),
            },
        }
        knot.cost.set_derivatives(x, u, &mut l[k]);
    }
}

/// The threads of the derivative phase ([`crate::Settings::derivative_threads`]): none (the
/// calling thread) or a rayon pool of its own, created once (with the `parallel` feature).
/// Clones share the pool.
#[derive(Debug, Clone)]
pub struct DerivativeThreads {
    threads: usize,
    #[cfg(feature = "parallel")]
    pool: Option<std::sync::Arc<rayon::ThreadPool>>,
}

impl Default for DerivativeThreads {
    fn default() -> Self {
        Self {
            threads: 1,
            #[cfg(feature = "parallel")]
            pool: None,
        }
    }
}

impl DerivativeThreads {
    /// `threads` workers (1: none, the calling thread). Above 1 it starts a rayon pool of
    /// `threads - 1` threads, the calling thread being the last (an allocation and the OS
    /// threads, once); errors name
    /// `settings.derivative_threads` (0, too many, no `parallel` feature, or the OS refused).
    pub fn new(threads: usize) -> crate::Result<Self> {
        let probe = crate::Settings {
            derivative_threads: threads,
            ..crate::Settings::default()
        };
        probe.validate()?;
        if threads == 1 {
            return Ok(Self::default());
        }
        #[cfg(feature = "parallel")]
        {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads - 1)
                .thread_name(|i| format!("ddp-derivatives-{i}"))
                .build()
                .map_err(|e| Error::invalid("settings.derivative_threads", format!("no thread pool: {e}")))?;
            Ok(Self {
                threads,
                pool: Some(std::sync::Arc::new(pool)),
            })
        }
        #[cfg(not(feature = "parallel"))]
        unreachable!("Settings::validate rejects derivative_threads > 1 without the parallel feature")
    }

    /// The number of threads (1: the calling thread).
    pub fn threads(&self) -> usize {
        self.threads
    }
}

/// The affine policy `du = k + K dx` of a backward pass.
#[derive(Debug, Clone)]
pub struct Policy<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// Feed-forward terms `k`.
    pub k_ff: Vec<VectorN<NU>>,
    /// Feedback gains `K`.
    pub k_fb: Vec<MatrixN<NU, NX>>,
}

impl<NX: Dim, NU: Dim> Policy<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// Zero policy of `n` knots.
    pub fn new(dims: Dims<NX, NU>, n: usize) -> Self {
        Self {
            k_ff: vec![dims.u_zeros(); n],
            k_fb: vec![dims.ux_zeros(); n],
        }
    }
    /// Zeros every term.
    pub fn clear(&mut self) {
        self.k_ff.iter_mut().for_each(|k| k.fill(0.0));
        self.k_fb.iter_mut().for_each(|k| k.fill(0.0));
    }
}

/// `V_x`, `V_xx` along the trajectory (`N + 1` entries).
#[derive(Debug, Clone)]
pub struct ValueFunction<NX: Dim>
where
    DefaultAllocator: Alloc<NX, NX>,
{
    /// `V_x`
    pub v_x: Vec<VectorN<NX>>,
    /// `V_xx`
    pub v_xx: Vec<MatrixN<NX, NX>>,
}

impl<NX: Dim> ValueFunction<NX>
where
    DefaultAllocator: Alloc<NX, NX>,
{
    /// Zero value function of `n` knots.
    pub fn new(nx: NX, n: usize) -> Self {
        Self {
            v_x: vec![VectorN::zeros_generic(nx, nalgebra::U1); n + 1],
            v_xx: vec![MatrixN::zeros_generic(nx, nx); n + 1],
        }
    }
}

/// The Q blocks of the knot being processed, and the scratch of the backward pass.
#[derive(Debug, Clone)]
pub struct QBlocks<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// `Q_x`
    pub q_x: VectorN<NX>,
    /// `Q_u`
    pub q_u: VectorN<NU>,
    /// `Q_xx`
    pub q_xx: MatrixN<NX, NX>,
    /// `Q_uu`
    pub q_uu: MatrixN<NU, NU>,
    /// `Q_ux`
    pub q_ux: MatrixN<NU, NX>,
    /// Regularised `Q_uu` (symmetrised).
    pub q_uu_r: MatrixN<NU, NU>,
    /// Regularised `Q_ux`.
    pub q_ux_r: MatrixN<NU, NX>,
    /// Scratch for a gains step: the `L D L^T` factors of `q_uu_r` after [`QBlocks::factor`]
    /// ([`crate::kernels::ldl_from`]; solve with [`QBlocks::solve`]).
    pub ldl: MatrixN<NU, NU>,
    /// Scratch for a gains step (`NU`).
    pub t_u: VectorN<NU>,
    /// Scratch for a gains step (`NU x NX`).
    pub t_ux: MatrixN<NU, NX>,
    t_x: VectorN<NX>,
    v_xx_fx: MatrixN<NX, NX>,
    v_xx_fu: MatrixN<NX, NU>,
    g_xx: MatrixN<NX, NX>,
    g_uu: MatrixN<NU, NU>,
    g_ux: MatrixN<NU, NX>,
    m_k: VectorN<NU>,
    m_kk: MatrixN<NU, NX>,
    /// Buffers of box-DDP's QP ([`BoxGains`]).
    boxqp: BoxQp<NU>,
    /// Scratch of the definiteness test of full DDP's blocks.
    d_uu: MatrixN<NU, NU>,
    d_ux: MatrixN<NU, NX>,
    d_uxs: MatrixN<NU, NX>,
    d_xx: MatrixN<NX, NX>,
}

impl<NX: Dim, NU: Dim> QBlocks<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// Zero blocks.
    pub fn new(dims: Dims<NX, NU>) -> Self {
        Self {
            q_x: dims.x_zeros(),
            q_u: dims.u_zeros(),
            q_xx: dims.xx_zeros(),
            q_uu: dims.uu_zeros(),
            q_ux: dims.ux_zeros(),
            q_uu_r: dims.uu_zeros(),
            q_ux_r: dims.ux_zeros(),
            ldl: dims.uu_zeros(),
            t_u: dims.u_zeros(),
            t_ux: dims.ux_zeros(),
            t_x: dims.x_zeros(),
            v_xx_fx: dims.xx_zeros(),
            v_xx_fu: dims.xu_zeros(),
            g_xx: dims.xx_zeros(),
            g_uu: dims.uu_zeros(),
            g_ux: dims.ux_zeros(),
            m_k: dims.u_zeros(),
            m_kk: dims.ux_zeros(),
            boxqp: BoxQp::new(dims.nu),
            d_uu: dims.uu_zeros(),
            d_ux: dims.ux_zeros(),
            d_uxs: dims.ux_zeros(),
            d_xx: dims.xx_zeros(),
        }
    }

    /// Factors `q_uu_r` into `ldl` (`L D L^T`); `Err` when not positive definite.
    #[inline(always)]
    pub fn factor(&mut self) -> Result<(), NotPositiveDefinite> {
        if ldl_from(&self.q_uu_r, &mut self.ldl) {
            Ok(())
        } else {
            Err(NotPositiveDefinite)
        }
    }

    /// `b <- Q_uu^-1 b` (regularised) after [`QBlocks::factor`], for every column of `b`.
    #[inline(always)]
    pub fn solve<C: Dim>(&self, b: &mut MatrixN<NU, C>)
    where
        DefaultAllocator: nalgebra::allocator::Allocator<NU, C>,
    {
        ldl_solve_in_place(&self.ldl, b);
    }

    /// The unconstrained Newton step after [`QBlocks::factor`]: `k = -Q_uu^-1 Q_u`,
    /// `K = -Q_uu^-1 Q_ux` (regularised).
    #[inline(always)]
    pub fn newton_step(&self, k_ff: &mut VectorN<NU>, k_fb: &mut MatrixN<NU, NX>) {
        copy(k_ff, &self.q_u);
        self.solve(k_ff);
        negate(k_ff);
        copy(k_fb, &self.q_ux_r);
        self.solve(k_fb);
        negate(k_fb);
    }
}

/// What a gains step reports for its knot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GainsInfo {
    /// Contribution to the stationarity measure (`|Q_u|^2` over the free controls, or of the
    /// projected gradient).
    pub gradient: f64,
    /// The gains solve `(Q_uu + mu I) [k K] = -[Q_u Q_ux]` exactly (no active constraint), so the
    /// value update may use its collapsed form.
    pub exact: bool,
}

/// The step a variant solver overrides: its gains at one knot from the Q blocks (Crocoddyl's
/// `computeGains`), and optionally curvature it adds to `Q_xx`.
pub trait Gains<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// Writes `k_ff`, `k_fb` at knot `k` (they hold the previous pass's values, a warm start)
    /// from `q` (`q_uu_r`, `q_ux_r` regularised) and the nominal control `u`.
    fn compute(
        &mut self,
        k: usize,
        q: &mut QBlocks<NX, NU>,
        u: &VectorN<NU>,
        k_ff: &mut VectorN<NU>,
        k_fb: &mut MatrixN<NU, NX>,
    ) -> Result<GainsInfo, NotPositiveDefinite>;

    /// Adds curvature to `Q_xx` of knot `k`, or to `V_xx` at `k = N` (constraint Hessians).
    fn add_curvature(&self, _k: usize, _q_xx: &mut MatrixN<NX, NX>) {}
}

/// Unconstrained gains (iLQR and full DDP): the Newton step of the regularised Q block.
#[derive(Debug, Clone, Copy, Default)]
pub struct FreeGains;

impl<NX: Dim, NU: Dim> Gains<NX, NU> for FreeGains
where
    DefaultAllocator: Alloc<NX, NU>,
{
    #[inline(always)]
    fn compute(
        &mut self,
        _k: usize,
        q: &mut QBlocks<NX, NU>,
        _u: &VectorN<NU>,
        k_ff: &mut VectorN<NU>,
        k_fb: &mut MatrixN<NU, NX>,
    ) -> Result<GainsInfo, NotPositiveDefinite> {
        q.factor()?;
        q.newton_step(k_ff, k_fb);
        Ok(GainsInfo {
            gradient: q.q_u.norm_squared(),
            exact: true,
        })
    }
}

/// Box-DDP gains (Tassa, Mansard and Todorov 2014): `k` from the box QP on `u + k`, `K` on the
/// free controls only (clamped rows zero).
#[derive(Debug, Clone, Copy)]
pub struct BoxGains<'a, NU: Dim>
where
    DefaultAllocator: Alloc<NU, NU>,
{
    /// The control bounds.
    pub bounds: &'a ControlBounds<NU>,
    /// Iteration limit of the QP.
    pub iterations: usize,
}

impl<NX: Dim, NU: Dim> Gains<NX, NU> for BoxGains<'_, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn compute(
        &mut self,
        _k: usize,
        q: &mut QBlocks<NX, NU>,
        u: &VectorN<NU>,
        k_ff: &mut VectorN<NU>,
        k_fb: &mut MatrixN<NU, NX>,
    ) -> Result<GainsInfo, NotPositiveDefinite> {
        let b = self.bounds;
        let qp = &mut q.boxqp;
        for i in 0..u.len() {
            qp.lower[i] = b.lower[i] - u[i];
            qp.upper[i] = b.upper[i] - u[i];
        }
        let report = box_qp(qp, &q.q_uu_r, &q.q_u, k_ff, self.iterations);
        if !report.factored {
            return Err(NotPositiveDefinite);
        }
        let qp = &q.boxqp;
        k_fb.fill(0.0);
        let mut grad = 0.0;
        if qp.free.iter().any(|&f| f) {
            for i in 0..u.len() {
                for j in 0..q.q_ux_r.ncols() {
                    k_fb[(i, j)] = if qp.free[i] { -q.q_ux_r[(i, j)] } else { 0.0 };
                }
            }
            cholesky_solve_in_place(&qp.chol, k_fb);
        }
        // Stationarity is measured on the free controls only: a clamped one may keep a gradient
        // that pushes into its bound.
        for i in 0..u.len() {
            if qp.free[i] {
                grad += q.q_u[i] * q.q_u[i];
            }
        }
        k_ff.copy_from(&qp.x);
        Ok(GainsInfo {
            gradient: grad,
            exact: false,
        })
    }
}

/// Gains with a fixed active set of control bounds: the controls that sit at a bound get no
/// feedback (zero rows of `K`), the others the Newton step of the free block; `k = 0`. Used by
/// Safe-CDDP's closed-loop covariance propagation (the bounds-only Riccati recursion).
#[derive(Debug, Clone, Copy)]
pub struct ClampedGains<'a, NU: Dim>
where
    DefaultAllocator: Alloc<NU, NU>,
{
    /// The control bounds (`None`: every control free).
    pub bounds: Option<&'a ControlBounds<NU>>,
}

impl<NX: Dim, NU: Dim> Gains<NX, NU> for ClampedGains<'_, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn compute(
        &mut self,
        _k: usize,
        q: &mut QBlocks<NX, NU>,
        u: &VectorN<NU>,
        k_ff: &mut VectorN<NU>,
        k_fb: &mut MatrixN<NU, NX>,
    ) -> Result<GainsInfo, NotPositiveDefinite> {
        if let Some(b) = self.bounds {
            for i in 0..u.len() {
                let tol = 1e-9 * (1.0 + u[i].abs());
                if u[i] >= b.upper[i] - tol || u[i] <= b.lower[i] + tol {
                    // Clamped: no feedback through this control.
                    for j in 0..u.len() {
                        q.q_uu_r[(i, j)] = 0.0;
                        q.q_uu_r[(j, i)] = 0.0;
                    }
                    q.q_uu_r[(i, i)] = 1.0;
                    for j in 0..q.q_ux_r.ncols() {
                        q.q_ux_r[(i, j)] = 0.0;
                    }
                }
            }
        }
        q.factor()?;
        k_fb.copy_from(&q.q_ux_r);
        q.solve(k_fb);
        k_fb.neg_mut();
        k_ff.fill(0.0);
        Ok(GainsInfo {
            gradient: 0.0,
            exact: false,
        })
    }
}

/// Options of one backward pass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BackwardOptions {
    /// Regularisation `mu`.
    pub mu: f64,
    /// Where `mu` enters.
    pub placement: Regularization,
    /// iLQR or full DDP.
    pub method: Method,
    /// Full DDP: keep the second-order terms only at knots where they leave the Q block
    /// definite (the retry after a failed plain pass).
    pub gated: bool,
}

/// Expected improvement and stationarity of a backward pass.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Expected {
    /// `sum k^T Q_u`
    pub dv1: f64,
    /// `sum 1/2 k^T Q_uu k`
    pub dv2: f64,
    /// Stationarity measure (sum of the gains steps' `gradient`).
    pub gradient: f64,
    /// Full DDP knots that fell back to the Gauss-Newton blocks.
    pub gauss_newton_knots: usize,
}

impl Expected {
    /// Expected cost decrease of a step `alpha`: `-(alpha dv1 + alpha^2 dv2)`.
    #[inline]
    pub fn decrease(&self, alpha: f64) -> f64 {
        -(alpha * self.dv1 + alpha * alpha * self.dv2)
    }
}

/// Tassa's regularisation state: raised after a failure, lowered after a success.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MuSchedule {
    /// Current `mu`.
    pub mu: f64,
    /// Current factor `Delta`.
    pub dmu: f64,
}

impl MuSchedule {
    /// The start of a solve.
    pub fn new(s: &RegularizationSettings) -> Self {
        Self {
            mu: s.mu_init,
            dmu: 1.0,
        }
    }
    /// Back to the start.
    pub fn reset(&mut self, s: &RegularizationSettings) {
        *self = Self::new(s);
    }
    /// `Delta <- max(Delta_0, Delta Delta_0)`, `mu <- max(mu_min, mu Delta)`; `false` past `mu_max`.
    pub fn raise(&mut self, s: &RegularizationSettings) -> bool {
        self.dmu = f64::max(s.mu_factor, self.dmu * s.mu_factor);
        self.mu = f64::max(s.mu_min, self.mu * self.dmu);
        self.mu <= s.mu_max
    }
    /// Runs `pass` (one backward pass, counted in `passes`) with `mu` raised along the schedule
    /// until it succeeds; `false` past `mu_max`. Full DDP retries each failed plain pass with
    /// the second-order terms gated ([`backward_pass`]) until a gated pass has failed too: that
    /// failure came from the Gauss-Newton blocks themselves, which only a larger `mu` mends, so
    /// the larger values get the plain pass alone (a gated retry there fails as well where the
    /// plain one does, in all but rare cases, and would double every retry's cost; the first
    /// plain pass that succeeds is the one the full retries would have taken).
    pub fn until_definite(
        &mut self,
        s: &RegularizationSettings,
        method: Method,
        passes: &mut usize,
        mut pass: impl FnMut(BackwardOptions) -> Result<(), NotPositiveDefinite>,
    ) -> bool {
        let mut gate = method == Method::Ddp;
        loop {
            let mut opts = BackwardOptions {
                mu: self.mu,
                placement: s.placement,
                method,
                gated: false,
            };
            *passes += 1;
            let mut result = pass(opts);
            if result.is_err() && gate {
                opts.gated = true;
                *passes += 1;
                result = pass(opts);
                gate = result.is_ok();
            }
            if result.is_ok() {
                return true;
            }
            if !self.raise(s) {
                return false;
            }
        }
    }
    /// `Delta <- min(Delta / Delta_0, 1 / Delta_0)`, `mu <- mu Delta` (0 below `mu_min`).
    pub fn lower(&mut self, s: &RegularizationSettings) {
        self.dmu = f64::min(self.dmu / s.mu_factor, 1.0 / s.mu_factor);
        self.mu = if self.mu * self.dmu > s.mu_min {
            self.mu * self.dmu
        } else {
            0.0
        };
    }
}

/// The Armijo test of the line search on the expected improvement: a decrease of at least
/// `armijo` times the expected one (or no increase where none is expected).
#[inline]
pub fn armijo_accepts(ls: &LineSearchSettings, expected: f64, actual: f64) -> bool {
    (expected > 0.0 && actual >= ls.armijo * expected) || (expected <= 0.0 && actual >= 0.0)
}

/// One trial of a line search, as the solver's forward pass judges it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Trial {
    /// Accept this step.
    Accept,
    /// Reject it and try a shorter one.
    Shorter,
    /// Try the same length again (the forward pass changed its own state, e.g. a trust region).
    Again,
    /// Give up this line search.
    Stop,
}

/// Backtracking from `alpha = 1` by `step_factor` down to `step_min`: returns the accepted step.
pub fn line_search(ls: &LineSearchSettings, mut trial: impl FnMut(f64) -> Trial) -> Option<f64> {
    let mut alpha = 1.0;
    while alpha >= ls.step_min {
        match trial(alpha) {
            Trial::Accept => return Some(alpha),
            Trial::Shorter => alpha *= ls.step_factor,
            Trial::Again => {}
            Trial::Stop => return None,
        }
    }
    None
}

/// The shared workspace of a DDP solver over at most `capacity` knots: trajectory,
/// linearisation, policy, value function, Q blocks and the regularisation state.
#[derive(Debug, Clone)]
pub struct Core<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// The sizes.
    pub dims: Dims<NX, NU>,
    /// Knots in use (at most the capacity the buffers were made for).
    pub n: usize,
    /// Nominal and trial trajectories.
    pub traj: Trajectory<NX, NU>,
    /// Derivatives along the nominal trajectory.
    pub lin: Linearization<NX, NU>,
    /// The policy of the last backward pass.
    pub policy: Policy<NX, NU>,
    /// The value function of the last backward pass.
    pub value: ValueFunction<NX>,
    /// Q blocks and scratch.
    pub q: QBlocks<NX, NU>,
    /// Regularisation state.
    pub reg: MuSchedule,
    /// Expected improvement of the last backward pass.
    pub expected: Expected,
    /// Cost of the nominal trajectory.
    pub cost: f64,
    /// The threads of the derivative phase ([`Core::set_derivative_threads`]).
    pub derivative_threads: DerivativeThreads,
    /// Multiple shooting's defects, multipliers, step and filter ([`Core::set_shooting`]);
    /// `None` under single shooting.
    pub ms: Option<MultipleShooting<NX, NU>>,
    pub(crate) dx: VectorN<NX>,
    du: VectorN<NU>,
}

impl<NX: Dim, NU: Dim> Core<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// Allocates every buffer for `capacity` knots.
    pub fn new(dims: Dims<NX, NU>, capacity: usize, reg: &RegularizationSettings) -> Self {
        Self {
            dims,
            n: capacity,
            traj: Trajectory::new(dims, capacity),
            lin: Linearization::new(dims, capacity),
            policy: Policy::new(dims, capacity),
            value: ValueFunction::new(dims.nx, capacity),
            q: QBlocks::new(dims),
            reg: MuSchedule::new(reg),
            expected: Expected::default(),
            cost: f64::NAN,
            derivative_threads: DerivativeThreads::default(),
            ms: None,
            dx: dims.x_zeros(),
            du: dims.u_zeros(),
        }
    }

    /// Sets the nominal controls of the active horizon (length `n`, each of size `nu`, finite);
    /// errors name `us` or `us[k]`.
    pub fn set_controls(&mut self, us: &[VectorN<NU>]) -> crate::Result<()> {
        copy_checked("us", us, &mut self.traj.us[..self.n], self.dims.nu())
    }

    /// Sets the nominal states `x_0 .. x_n` (length `n + 1`, each of size `nx`, finite); errors
    /// name `xs` or `xs[k]`.
    pub fn set_states(&mut self, xs: &[VectorN<NX>]) -> crate::Result<()> {
        copy_checked("xs", xs, &mut self.traj.xs[..=self.n], self.dims.nx())
    }

    /// Rejects a problem of other sizes than this workspace's, naming `problem`.
    pub fn check_dims(&self, problem: &Problem<NX, NU>) -> crate::Result<()> {
        let (d, mine) = (problem.dims(), self.dims);
        if d.nx() != mine.nx() || d.nu() != mine.nu() {
            return Err(Error::Shape {
                field: "problem".into(),
                got: format!("(nx, nu) = ({}, {})", d.nx(), d.nu()),
                expected: format!("({}, {}) (the sizes this solver was created for)", mine.nx(), mine.nu()),
            });
        }
        Ok(())
    }

    /// Projects the nominal controls onto `bounds` (if any).
    pub fn clamp_controls(&mut self, bounds: Option<&ControlBounds<NU>>) {
        if let Some(b) = bounds {
            self.traj.us[..self.n].iter_mut().for_each(|u| b.clamp_mut(u));
        }
    }

    /// Simulates the nominal controls from `x0` into the nominal states; returns the cost.
    #[inline(never)]
    pub fn rollout(&mut self, problem: &Problem<NX, NU>) -> f64 {
        let n = self.n;
        let (xs, us, data) = (&mut self.traj.xs, &self.traj.us, &mut self.traj.data);
        let mut cost = 0.0;
        xs[0].copy_from(problem.x0());
        for (k, knot) in problem.knots()[..n].iter().enumerate() {
            let (head, tail) = xs.split_at_mut(k + 1);
            cost += knot.cost.value(&head[k], &us[k]);
            knot.dynamics.step_keep(&head[k], &us[k], &mut tail[0], &mut data[k]);
        }
        self.cost = cost + problem.terminal().value(&xs[n]);
        self.cost
    }

    /// Rolls out the feedback policy with step `alpha` into the trial trajectory:
    /// `u_k = clamp(u_k + alpha k_k + K_k (x_k_new - x_k))`. Returns the trial's cost.
    #[inline(never)]
    pub fn rollout_policy(&mut self, problem: &Problem<NX, NU>, alpha: f64) -> f64 {
        let n = self.n;
        let bounds = problem.bounds();
        let t = &mut self.traj;
        let mut cost = 0.0;
        t.xs_try[0].copy_from(problem.x0());
        for (k, knot) in problem.knots()[..n].iter().enumerate() {
            let (head, tail) = t.xs_try.split_at_mut(k + 1);
            let x = &head[k];
            for ((d, a), b) in self
                .dx
                .as_mut_slice()
                .iter_mut()
                .zip(x.as_slice())
                .zip(t.xs[k].as_slice())
            {
                *d = a - b;
            }
            mul_vec_add(&mut self.du, None, &self.policy.k_fb[k], &self.dx);
            let u = &mut t.us_try[k];
            let terms = t.us[k].iter().zip(self.policy.k_ff[k].iter()).zip(self.du.iter());
            for (u, ((u_nom, k_ff), du)) in u.iter_mut().zip(terms) {
                *u = u_nom + alpha * k_ff + du;
            }
            if let Some(b) = bounds {
                b.clamp_mut(u);
            }
            cost += knot.cost.value(x, u);
            knot.dynamics.step_keep(x, u, &mut tail[0], &mut t.data_try[k]);
        }
        cost + problem.terminal().value(&t.xs_try[n])
    }

    /// The derivatives along the nominal trajectory (on the derivative threads, if any), with
    /// the dynamics' data for the second-order terms where `method` is full DDP.
    pub fn linearize(&mut self, problem: &Problem<NX, NU>, method: Method) {
        self.lin.keep_second_order = method == Method::Ddp;
        self.lin.compute_with(
            &self.derivative_threads,
            problem,
            &self.traj.xs,
            &self.traj.us,
            &self.traj.data,
            self.n,
        );
    }

    /// Computes the derivatives on `threads` threads from now on (1: the calling thread); keeps
    /// the current pool when the count is unchanged. Errors as [`DerivativeThreads::new`].
    pub fn set_derivative_threads(&mut self, threads: usize) -> crate::Result<()> {
        if threads != self.derivative_threads.threads() {
            self.derivative_threads = DerivativeThreads::new(threads)?;
        }
        Ok(())
    }

    /// Single or multiple shooting from now on: allocates multiple shooting's buffers when it
    /// is switched on (room for `max_iterations` filter entries, at most
    /// [`super::LOG_PREALLOCATED`]), drops them when it is off.
    pub fn set_shooting(&mut self, shooting: Shooting, max_iterations: usize) {
        match shooting {
            Shooting::Single => self.ms = None,
            Shooting::Multiple => {
                let capacity = self.traj.us.len();
                match self.ms.as_mut() {
                    Some(ms) if ms.gaps.len() == capacity => {
                        // At most one filter entry per iteration: room for them all now.
                        let entries = max_iterations.min(super::LOG_PREALLOCATED);
                        ms.filter.reserve(entries.saturating_sub(ms.filter.len()));
                    }
                    _ => {
                        let entries = max_iterations.min(super::LOG_PREALLOCATED);
                        self.ms = Some(MultipleShooting::new(self.dims, capacity, entries))
                    }
                }
            }
        }
    }

    /// The backward pass over the workspace's linearisation, policy and value function with the
    /// variant's `gains`; the expected improvement lands in `self.expected`. Under multiple
    /// shooting the defects enter the value gradient and the multipliers weight the
    /// second-order terms ([`crate::solver::shooting`]).
    pub fn backward(
        &mut self,
        problem: &Problem<NX, NU>,
        gains: &mut impl Gains<NX, NU>,
        opts: BackwardOptions,
    ) -> Result<(), NotPositiveDefinite> {
        self.expected = backward_pass(
            problem,
            &self.traj.xs,
            &self.traj.us,
            &self.lin,
            &mut self.q,
            &mut self.policy,
            &mut self.value,
            gains,
            opts,
            self.ms.as_mut().map(|ms| ShootingTerms {
                gaps: &ms.gaps,
                lambda: &ms.lambda,
                v_x_gap: &mut ms.v_x_gap,
            }),
            self.n,
        )?;
        Ok(())
    }

    /// Receding horizon: drops the first knot of the solution and repeats the last control.
    pub fn shift(&mut self) {
        let n = self.n;
        if n > 1 {
            self.traj.us[..n].rotate_left(1);
            self.traj.us[n - 1] = self.traj.us[n - 2].clone();
            self.traj.xs[..=n].rotate_left(1);
            self.traj.xs[n] = self.traj.xs[n - 1].clone();
            self.traj.data[..n].rotate_left(1);
            self.policy.k_ff[..n].rotate_left(1);
            self.policy.k_ff[n - 1] = self.policy.k_ff[n - 2].clone();
            self.policy.k_fb[..n].rotate_left(1);
            self.policy.k_fb[n - 1] = self.policy.k_fb[n - 2].clone();
        }
    }
}

/// Copies `src` into `dst` after checking that it has `dst.len()` vectors of `dim` finite
/// entries; errors name `field` or `field[k]`.
fn copy_checked<N: Dim>(field: &str, src: &[VectorN<N>], dst: &mut [VectorN<N>], dim: usize) -> crate::Result<()>
where
    DefaultAllocator: Alloc<N, N>,
{
    if src.len() != dst.len() {
        return Err(Error::Shape {
            field: field.into(),
            got: format!("({}, {dim})", src.len()),
            expected: format!("({}, {dim})", dst.len()),
        });
    }
    for (k, v) in src.iter().enumerate() {
        if v.len() != dim {
            return Err(Error::Shape {
                field: format!("{field}[{k}]"),
                got: format!("({},)", v.len()),
                expected: format!("({dim},)"),
            });
        }
        // The field's name is formatted only for an error: a valid guess allocates nothing.
        if !v.iter().all(|e| e.is_finite()) {
            check_finite(&format!("{field}[{k}]"), v.iter())?;
        }
    }
    for (d, v) in dst.iter_mut().zip(src) {
        d.copy_from(v);
    }
    Ok(())
}

/// What multiple shooting adds to a backward pass ([`crate::solver::shooting`]).
pub struct ShootingTerms<'a, NX: Dim>
where
    DefaultAllocator: Alloc<NX, NX>,
{
    /// The defects `d_k = f(x_k, u_k) - x_{k+1}`.
    pub gaps: &'a [VectorN<NX>],
    /// The multipliers `lambda_k` of the defects (entry 0 unused).
    pub lambda: &'a [VectorN<NX>],
    /// Scratch for `V_x' + V_xx' d_k`.
    pub v_x_gap: &'a mut VectorN<NX>,
}

/// The Riccati backward pass of DDP (Tassa et al. 2012, eqs. (5)-(11)) over knots `n-1 .. 0`,
/// with the gains of `gains`:
///
/// ```text
/// Q_x  = l_x + f_x^T V_x'          Q_u  = l_u + f_u^T V_x'
/// Q_xx = l_xx + f_x^T V_xx' f_x    Q_uu = l_uu + f_u^T V_xx' f_u    Q_ux = l_ux + f_u^T V_xx' f_x
/// (full DDP: + V_x' . f_xx, f_ux, f_uu)
/// V_x  = Q_x + K^T (Q_uu k + Q_u) + Q_ux^T k
/// V_xx = Q_xx + K^T (Q_uu K + Q_ux) + Q_ux^T K
/// ```
///
/// Reads the derivatives in `lin`, writes `policy` and `value`; one text for every solver and
/// every size. Returns the expected improvement. With `shooting` (multiple
/// shooting) `V_x'` reads `V_x' + V_xx' d_k` and the second-order terms are weighted by
/// `lambda_{k+1}` ([`crate::solver::shooting`]).
#[inline(never)]
pub fn backward_pass<NX: Dim, NU: Dim>(
    problem: &Problem<NX, NU>,
    xs: &[VectorN<NX>],
    us: &[VectorN<NU>],
    lin: &Linearization<NX, NU>,
    q: &mut QBlocks<NX, NU>,
    policy: &mut Policy<NX, NU>,
    value: &mut ValueFunction<NX>,
    gains: &mut impl Gains<NX, NU>,
    opts: BackwardOptions,
    shooting: Option<ShootingTerms<'_, NX>>,
    n: usize,
) -> Result<Expected, NotPositiveDefinite>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    // Compiled for AVX-512, or AVX2 and FMA, where the CPU has them (wider vectors for the small
    // dense products: about 0.97x the time of a family replay): the same operations in the same
    // order, with no multiply-add fused that the text does not fuse, so the same results bit for
    // bit.
    #[cfg(target_arch = "x86_64")]
    match ddpkit_util::simd::available() {
        Some(Simd::V4(simd)) => {
            return simd
                .vectorize(|| backward_pass_body(problem, xs, us, lin, q, policy, value, gains, opts, shooting, n))
        }
        Some(Simd::V3(simd)) => {
            return simd
                .vectorize(|| backward_pass_body(problem, xs, us, lin, q, policy, value, gains, opts, shooting, n))
        }
        None => {}
    }
    backward_pass_body(problem, xs, us, lin, q, policy, value, gains, opts, shooting, n)
}

#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn backward_pass_body<NX: Dim, NU: Dim>(
    problem: &Problem<NX, NU>,
    xs: &[VectorN<NX>],
    us: &[VectorN<NU>],
    lin: &Linearization<NX, NU>,
    q: &mut QBlocks<NX, NU>,
    policy: &mut Policy<NX, NU>,
    value: &mut ValueFunction<NX>,
    gains: &mut impl Gains<NX, NU>,
    opts: BackwardOptions,
    mut shooting: Option<ShootingTerms<'_, NX>>,
    n: usize,
) -> Result<Expected, NotPositiveDefinite>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    let ddp = opts.method == Method::Ddp;
    let mu = opts.mu;
    let control_reg = opts.placement == Regularization::Control;
    copy(&mut value.v_x[n], &lin.l_n.lx);
    copy(&mut value.v_xx[n], &lin.l_n.lxx);
    gains.add_curvature(n, &mut value.v_xx[n]);
    let mut e = Expected::default();
    for k in (0..n).rev() {
        let (fx, fu, l) = (&lin.fx[k], &lin.fu[k], &lin.l[k]);
        let (v_x_k, v_x_next) = value.v_x.split_at_mut(k + 1);
        let (v_xx_k, v_xx_next) = value.v_xx.split_at_mut(k + 1);
        let (mut v_x, v_xx) = (&v_x_next[0], &v_xx_next[0]);
        // The weights of the dynamics' second derivatives: V_x' (single shooting) or the
        // multiplier lambda_{k+1} (multiple shooting).
        let mut weights = v_x;
        if let Some(ms) = shooting.as_mut() {
            mul_vec_add(ms.v_x_gap, Some(v_x), v_xx, &ms.gaps[k]);
            v_x = ms.v_x_gap;
            weights = &ms.lambda[k + 1];
        }
        q_blocks(q, l, fx, fu, v_x, v_xx);
        gains.add_curvature(k, &mut q.q_xx);
        let knot = &problem.knots()[k];
        if ddp && knot.dynamics.has_second_order() {
            // Full DDP adds V_x' . f_xx etc. Far from a minimum that can make the Q block
            // indefinite, and through Q_xx the indefiniteness would flow into every V_xx
            // upstream. So after a failed plain pass (`gated`) this knot keeps the second-order
            // terms only when the whole block is positive (semi)definite: Q_uu > 0 and its Schur
            // complement Q_xx - Q_ux^T Q_uu^-1 Q_ux >= 0 (the V_xx this knot passes on).
            // Otherwise it uses the Gauss-Newton blocks, and V_xx stays PSD by induction. The
            // plain pass adds the terms straight into the blocks; the gated one into copies, so
            // that the Gauss-Newton blocks remain as the fallback.
            let (h_xx, h_ux, h_uu) = if opts.gated {
                copy(&mut q.g_xx, &q.q_xx);
                copy(&mut q.g_ux, &q.q_ux);
                copy(&mut q.g_uu, &q.q_uu);
                (&mut q.g_xx, &mut q.g_ux, &mut q.g_uu)
            } else {
                (&mut q.q_xx, &mut q.q_ux, &mut q.q_uu)
            };
            let data = lin.data.get(k).map_or(&[][..], Vec::as_slice);
            knot.dynamics
                .add_second_order_kept(&xs[k], &us[k], weights, data, h_xx, h_ux, h_uu);
            if opts.gated {
                if second_order_definite(q, fu, fx, mu, opts.placement) {
                    std::mem::swap(&mut q.q_xx, &mut q.g_xx);
                    std::mem::swap(&mut q.q_ux, &mut q.g_ux);
                    std::mem::swap(&mut q.q_uu, &mut q.g_uu);
                } else {
                    e.gauss_newton_knots += 1;
                }
            }
        }
        regularize(q, fx, fu, mu, opts.placement);
        let (k_ff, k_fb) = (&mut policy.k_ff[k], &mut policy.k_fb[k]);
        let info = gains.compute(k, q, &us[k], k_ff, k_fb)?;
        e.gradient += info.gradient;
        mul_vec_add(&mut q.m_k, None, &q.q_uu, k_ff);
        e.dv1 += k_ff.dot(&q.q_u);
        e.dv2 += 0.5 * k_ff.dot(&q.m_k);
        if info.exact && control_reg {
            // (Q_uu + mu I) K = -Q_ux and likewise for k, so the brackets of the update are
            // -mu K and -mu k and both collapse to one product with G = Q_ux - mu K:
            //   V_x = Q_x + G^T k,   V_xx = Q_xx + G^T K.
            let (g, a, b) = (q.t_ux.as_mut_slice(), q.q_ux.as_slice(), k_fb.as_slice());
            for i in 0..g.len() {
                g[i] = a[i] - mu * b[i];
            }
            tr_mul_vec_add(&mut v_x_k[k], Some(&q.q_x), &q.t_ux, k_ff);
            sym_tr_mul_add(&mut v_xx_k[k], &q.q_xx, &q.t_ux, k_fb);
        } else {
            // Valid for any affine policy du = k + K dx (Xie et al. 2017, eq. (14)).
            add_to(&mut q.m_k, &q.q_u);
            mul_to(&mut q.m_kk, &q.q_uu, k_fb);
            add_to(&mut q.m_kk, &q.q_ux);
            tr_mul_vec_add(&mut v_x_k[k], Some(&q.q_x), k_fb, &q.m_k);
            tr_mul_vec_add(&mut q.t_x, None, &q.q_ux, k_ff);
            add_to(&mut v_x_k[k], &q.t_x);
            sym_tr_mul2_add(&mut v_xx_k[k], &q.q_xx, k_fb, &q.m_kk, &q.q_ux, k_fb);
        }
    }
    Ok(e)
}

/// The Gauss-Newton Q blocks of one knot (eq. (5) without the second-order dynamics terms).
#[inline(always)]
fn q_blocks<NX: Dim, NU: Dim>(
    q: &mut QBlocks<NX, NU>,
    l: &CostDerivatives<NX, NU>,
    fx: &MatrixN<NX, NX>,
    fu: &MatrixN<NX, NU>,
    v_x: &VectorN<NX>,
    v_xx: &MatrixN<NX, NX>,
) where
    DefaultAllocator: Alloc<NX, NU>,
{
    tr_mul_vec_add(&mut q.q_x, Some(&l.lx), fx, v_x);
    tr_mul_vec_add(&mut q.q_u, Some(&l.lu), fu, v_x);
    mul_to(&mut q.v_xx_fx, v_xx, fx);
    mul_to(&mut q.v_xx_fu, v_xx, fu);
    sym_tr_mul_add(&mut q.q_xx, &l.lxx, fx, &q.v_xx_fx);
    tr_mul_add(&mut q.q_uu, Some(&l.luu), fu, &q.v_xx_fu);
    tr_mul_add(&mut q.q_ux, Some(&l.lux), fu, &q.v_xx_fx);
}

/// `q_uu_r`, `q_ux_r` from `q_uu`, `q_ux`: `Q_uu + mu I` (control) or `Q_uu + mu f_u^T f_u`,
/// `Q_ux + mu f_u^T f_x` (state, Tassa et al. 2012 eq. (10)); `q_uu_r` symmetrised.
#[inline(always)]
fn regularize<NX: Dim, NU: Dim>(
    q: &mut QBlocks<NX, NU>,
    fx: &MatrixN<NX, NX>,
    fu: &MatrixN<NX, NU>,
    mu: f64,
    placement: Regularization,
) where
    DefaultAllocator: Alloc<NX, NU>,
{
    match placement {
        Regularization::Control => {
            // Symmetrised and shifted in one pass that reads `q_uu` and only writes `q_uu_r`:
            // re-reading entries just written as scalars with wider loads stalls on store
            // forwarding (about 2 % of a family solve when done in place).
            let m = q.q_uu.nrows();
            let (a, r) = (q.q_uu.as_slice(), q.q_uu_r.as_mut_slice());
            for j in 0..m {
                for i in 0..m {
                    r[j * m + i] = 0.5 * (a[j * m + i] + a[i * m + j]);
                }
                r[j * m + j] += mu;
            }
            copy(&mut q.q_ux_r, &q.q_ux);
        }
        Regularization::State => {
            tr_mul_add(&mut q.q_uu_r, None, fu, fu);
            q.q_uu_r *= mu;
            q.q_uu_r += &q.q_uu;
            tr_mul_add(&mut q.q_ux_r, None, fu, fx);
            q.q_ux_r *= mu;
            q.q_ux_r += &q.q_ux;
            let m = q.q_uu_r.nrows();
            let r = q.q_uu_r.as_mut_slice();
            for j in 0..m {
                for i in 0..j {
                    let s = 0.5 * (r[j * m + i] + r[i * m + j]);
                    r[j * m + i] = s;
                    r[i * m + j] = s;
                }
            }
        }
    }
}

/// Whether the full-DDP blocks `g_*` are positive (semi)definite after regularisation:
/// `Q_uu > 0` and `Q_xx - Q_ux^T Q_uu^-1 Q_ux >= 0` (up to a relative tolerance).
fn second_order_definite<NX: Dim, NU: Dim>(
    q: &mut QBlocks<NX, NU>,
    fu: &MatrixN<NX, NU>,
    fx: &MatrixN<NX, NX>,
    mu: f64,
    placement: Regularization,
) -> bool
where
    DefaultAllocator: Alloc<NX, NU>,
{
    // In the blocks' own scratch (no allocation at run-time sizes): `R_uu` into `d_uu`, `R_ux`
    // into `d_ux`.
    let QBlocks {
        g_xx,
        g_uu,
        g_ux,
        d_uu,
        d_ux,
        d_uxs,
        d_xx,
        ..
    } = q;
    match placement {
        Regularization::Control => {
            copy(d_uu, g_uu);
            for i in 0..d_uu.nrows() {
                d_uu[(i, i)] += mu;
            }
            copy(d_ux, g_ux);
        }
        Regularization::State => {
            tr_mul_add(d_uu, None, fu, fu);
            *d_uu *= mu;
            *d_uu += &*g_uu;
            tr_mul_add(d_ux, None, fu, fx);
            *d_ux *= mu;
            *d_ux += &*g_ux;
        }
    }
    // Q_uu > 0: the Cholesky factor of its symmetric part (read from the lower triangle).
    symmetrize_lower(d_uu);
    if !cholesky_in_place(d_uu) {
        return false;
    }
    // The Schur complement Q_xx - Q_ux^T Q_uu^-1 Q_ux, symmetrised, >= 0 up to the tolerance.
    copy(d_uxs, d_ux);
    cholesky_solve_in_place(d_uu, d_uxs);
    tr_mul_add(d_xx, None, d_ux, d_uxs);
    let n = d_xx.nrows();
    for j in 0..n {
        for i in 0..n {
            d_xx[(i, j)] = g_xx[(i, j)] - d_xx[(i, j)];
        }
    }
    symmetrize_lower(d_xx);
    let tol = 1e-9 * (1.0 + g_xx.amax());
    for i in 0..n {
        d_xx[(i, i)] += tol;
    }
    cholesky_in_place(d_xx)
}

/// Replaces the lower triangle of `m` by that of `(M + M^T) / 2` (what [`cholesky_in_place`]
/// reads).
fn symmetrize_lower<N: Dim>(m: &mut MatrixN<N, N>)
where
    DefaultAllocator: nalgebra::allocator::Allocator<N, N>,
{
    let n = m.nrows();
    for j in 0..n {
        for i in j + 1..n {
            m[(i, j)] = 0.5 * (m[(i, j)] + m[(j, i)]);
        }
    }
}
