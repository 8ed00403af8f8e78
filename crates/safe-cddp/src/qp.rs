//! The per-step QP of the forward pass, eq. (15):
//!
//! ```text
//! min_du  1/2 du^T H du + q^T du     s.t.   a_i^T du <= b_i  (i < m),   |du_j| <= Delta
//! ```
//!
//! with `H = Q_uu + mu I`, `q = alpha Q_u + Q_ux dx`, and one row per linearised constraint
//! `g_i + C_i du + D_i dx <= 0` (`a_i = C_i`, `b_i = -(g_i + D_i dx)`), control bound and
//! trust-region side.
//!
//! [`StepQp::solve`] tries, in order (see [`QpMethod`]):
//! 1. the unconstrained minimiser `-H^{-1} q`: when it satisfies every row it is the optimum;
//! 2. a small primal active-set method started from the backward pass's working set: it ends only
//!    with a point that satisfies the KKT conditions (stationarity by construction, every row
//!    feasible, multipliers `>= 0`), so its answer is the optimum too; it gives up after a few
//!    changes of the working set, or on a degenerate one;
//! 3. a closed-form certificate of infeasibility (`box_infeasible`: a row that cannot be met in
//!    the box of the control bounds and the trust region), which answers the common infeasible
//!    QP of the forward pass without an interior-point solve that would only certify it;
//! 4. every working set of at most `nu` rows (`enumerate`), when there are few of them (2
//!    controls and up to 20 rows): the one that gives a KKT point is the optimum;
//! 5. Clarabel, an interior-point solver set up once (dense `H` and `A` patterns, presolve and
//!    equilibration off) and updated in place with `update_P/q/A/b` for every QP; its answer is
//!    polished by one exact solve on the rows it found active.
//!
//! [`StepQp::solve_elastic`] (the QP with its constraint rows relaxed by a penalised slack) tries
//! an active-set method on the KKT system in `(du, s)` first, then the working sets of at most
//! `nu + 1` rows in `(du, s)`, and Clarabel only when both give up;
//! [`StepQp::solve_fast`] is steps 1-2 alone, for a knot whose QP was infeasible in the previous
//! forward pass.
//!
//! Clarabel allocates a little inside `solve` (its timers); everything else here is allocated in
//! [`StepQp::new`].

use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus};
use ddp_core::dims::{Alloc, DefaultAllocator, Dim, MatrixN, VectorN, U1};
use ddp_core::{Error, Result};
use nalgebra::Cholesky;

/// Which solvers [`StepQp::solve`] may use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum QpMethod {
    /// Unconstrained minimiser, then the active-set method, then the enumeration of working sets,
    /// then Clarabel (the default).
    #[default]
    Fast,
    /// Clarabel for every QP (the paper's design; for comparisons and tests).
    Clarabel,
}

/// Which path answered a QP.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum QpPath {
    /// The unconstrained minimiser was feasible.
    Unconstrained,
    /// The active-set method found the KKT point.
    ActiveSet,
    /// Clarabel solved it.
    Clarabel,
}

/// The answer of [`StepQp::solve`].
#[derive(Debug, Clone, PartialEq)]
pub enum QpOutcome<NU: Dim>
where
    DefaultAllocator: Alloc<NU, NU>,
{
    /// The optimal `du` and the path that found it.
    Solved(VectorN<NU>, QpPath),
    /// No `du` satisfies the rows (certified by Clarabel).
    Infeasible,
    /// Clarabel stopped without a solution or a certificate (iteration limit, numerical trouble).
    Failed,
}

/// Counters of [`StepQp`] since the last [`StepQp::reset_stats`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct QpStats {
    /// QPs posed.
    pub solved: usize,
    /// Answered by the unconstrained minimiser.
    pub unconstrained: usize,
    /// Answered by the active-set method.
    pub active_set: usize,
    /// Answered by enumerating the working sets (after the active-set method gave up).
    pub enumerated: usize,
    /// Handed to Clarabel.
    pub clarabel: usize,
    /// Interior-point iterations of Clarabel, summed.
    pub clarabel_iterations: usize,
    /// Certified infeasible.
    pub infeasible: usize,
    /// Clarabel failures (neither a solution nor a certificate).
    pub failed: usize,
    /// Elastic QPs (infeasible rows relaxed by a penalised slack).
    pub elastic: usize,
    /// Of `infeasible`, certified by the closed-form box test ([`StepQp::solve`]) without Clarabel.
    pub box_certified: usize,
    /// Elastic QPs posed without first certifying the QP infeasible (the knot's QP was
    /// infeasible before; see [`StepQp::solve_fast`]).
    pub elastic_direct: usize,
    /// Of `elastic`, answered by the elastic active-set method.
    pub elastic_active_set: usize,
    /// Of `elastic`, answered by enumerating the working sets (after the active-set method
    /// gave up; the rest went to Clarabel).
    pub elastic_enumerated: usize,
}

impl QpStats {
    /// Solves handed to Clarabel: QPs (`clarabel`) and elastic QPs that neither the elastic
    /// active-set method nor the enumeration answered.
    pub fn clarabel_solves(&self) -> usize {
        self.clarabel + self.elastic - self.elastic_active_set - self.elastic_enumerated
    }
}

impl std::ops::AddAssign for QpStats {
    fn add_assign(&mut self, o: Self) {
        self.solved += o.solved;
        self.unconstrained += o.unconstrained;
        self.active_set += o.active_set;
        self.enumerated += o.enumerated;
        self.clarabel += o.clarabel;
        self.clarabel_iterations += o.clarabel_iterations;
        self.infeasible += o.infeasible;
        self.failed += o.failed;
        self.elastic += o.elastic;
        self.box_certified += o.box_certified;
        self.elastic_direct += o.elastic_direct;
        self.elastic_active_set += o.elastic_active_set;
        self.elastic_enumerated += o.elastic_enumerated;
    }
}

/// Feasibility tolerance of a row, relative to `1 + |b_i|`.
const FEAS_TOL: f64 = 1e-10;
/// Working-set changes the active-set method may make before handing over to Clarabel.
const ACTIVE_SET_ITERATIONS: usize = 8;
/// Most working sets [`StepQp::solve`] enumerates before handing a QP to Clarabel (2 controls and
/// 20 rows: 210).
const ENUMERATION_LIMIT: usize = 256;

/// Working-set changes the elastic active-set method may make before handing over to Clarabel.
const ELASTIC_ITERATIONS: usize = 12;

/// The most controls a per-step QP takes (its polish step keeps a stack list of 64 rows).
pub const MAX_QP_CONTROLS: usize = 63;

/// A Clarabel instance for `n` variables and `m` rows with dense patterns (upper triangle of `P`,
/// all of `A`), set up once and updated in place.
struct ClarabelQp {
    n: usize,
    m: usize,
    solver: DefaultSolver<f64>,
    p_vals: Vec<f64>,
    q_vals: Vec<f64>,
    a_vals: Vec<f64>,
    b_vals: Vec<f64>,
}

impl ClarabelQp {
    fn new(n: usize, m: usize) -> Result<Self> {
        let mut colptr = Vec::with_capacity(n + 1);
        let mut rowval = Vec::new();
        colptr.push(0);
        for j in 0..n {
            for i in 0..=j {
                rowval.push(i);
            }
            colptr.push(rowval.len());
        }
        let p_vals = vec![0.0; rowval.len()];
        let mut p_init = p_vals.clone();
        for j in 0..n {
            p_init[colptr[j + 1] - 1] = 1.0; // the diagonal entry is the last of each column
        }
        let p = CscMatrix::new(n, n, colptr, rowval, p_init);
        // The entries of A are kept even when zero (`input_sparse_dropzeros = false`).
        let a_colptr: Vec<usize> = (0..=n).map(|j| j * m).collect();
        let a_rowval: Vec<usize> = (0..n).flat_map(|_| 0..m).collect();
        let a_vals = vec![0.0; m * n];
        let a = CscMatrix::new(m, n, a_colptr, a_rowval, a_vals.clone());
        let q_vals = vec![0.0; n];
        let b_vals = vec![1.0; m];
        let settings = DefaultSettings::<f64> {
            verbose: false,
            presolve_enable: false,
            equilibrate_enable: false,
            input_sparse_dropzeros: false,
            max_iter: 100,
            tol_gap_abs: 1e-11,
            tol_gap_rel: 1e-11,
            tol_feas: 1e-11,
            tol_infeas_abs: 1e-10,
            tol_infeas_rel: 1e-10,
            tol_ktratio: 1e-8,
            ..DefaultSettings::default()
        };
        let solver = DefaultSolver::new(&p, &q_vals, &a, &b_vals, &[NonnegativeConeT(m)], settings)
            .map_err(|e| Error::invalid("qp", format!("Clarabel setup failed: {e}")))?;
        Ok(Self {
            n,
            m,
            solver,
            p_vals,
            q_vals,
            a_vals,
            b_vals,
        })
    }

    /// Writes `P` (symmetrised upper triangle of the `n x n` matrix `p(i, j)`), `q`, and row `i`
    /// of `A, b` from `row(i)` (rows past the data are padding `0 <= 1`), then solves.
    fn solve(
        &mut self,
        p: impl Fn(usize, usize) -> f64,
        q: impl Fn(usize) -> f64,
        row: impl Fn(usize, &mut [f64]) -> f64,
    ) -> std::result::Result<SolverStatus, ()> {
        let (n, m) = (self.n, self.m);
        let mut idx = 0;
        for j in 0..n {
            for i in 0..=j {
                self.p_vals[idx] = 0.5 * (p(i, j) + p(j, i));
                idx += 1;
            }
            self.q_vals[j] = q(j);
        }
        let mut buf = [0.0; 64];
        let buf = &mut buf[..n];
        for i in 0..m {
            buf.fill(0.0);
            let mut bi = row(i, buf);
            if !bi.is_finite() {
                buf.fill(0.0);
                bi = 1.0;
            }
            for j in 0..n {
                self.a_vals[j * m + i] = buf[j];
            }
            self.b_vals[i] = bi;
        }
        self.solver
            .update_P(&self.p_vals)
            .and_then(|_| self.solver.update_q(&self.q_vals))
            .and_then(|_| self.solver.update_A(&self.a_vals))
            .and_then(|_| self.solver.update_b(&self.b_vals))
            .map_err(|_| ())?;
        self.solver.solve();
        Ok(self.solver.solution.status)
    }
}

/// The per-step QP solver and its buffers, for `NU` controls and up to `max_rows` rows (the
/// trust region adds `2 NU` more internally).
pub struct StepQp<NU: Dim>
where
    DefaultAllocator: Alloc<NU, NU>,
{
    nu: NU,
    max_rows: usize,
    method: QpMethod,
    clarabel: ClarabelQp,
    elastic: ClarabelQp,
    working: Vec<usize>,
    /// The elastic active-set method's working set, KKT matrix (row-major, `(2 nu + 2)^2`) and
    /// right-hand side / solution.
    e_working: Vec<usize>,
    e_kkt: Vec<f64>,
    e_rhs: Vec<f64>,
    stats: QpStats,
}

impl<NU: Dim> std::fmt::Debug for StepQp<NU>
where
    DefaultAllocator: Alloc<NU, NU>,
{
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StepQp")
            .field("max_rows", &self.max_rows)
            .field("method", &self.method)
            .field("stats", &self.stats)
            .finish()
    }
}

impl<NU: Dim> StepQp<NU>
where
    DefaultAllocator: Alloc<NU, NU>,
{
    /// Sets up two Clarabel instances once (the QP: `nu` variables, `max_rows + 2 nu` rows; its
    /// elastic form: one slack more) with dense patterns, and allocates every buffer.
    pub fn new(nu: NU, max_rows: usize, method: QpMethod) -> Result<Self> {
        let n = nu.value();
        if n > MAX_QP_CONTROLS {
            return Err(Error::invalid(
                "nu",
                format!("{n} exceeds the per-step QP's limit of {MAX_QP_CONTROLS} controls"),
            ));
        }
        let m = max_rows + 2 * n;
        Ok(Self {
            nu,
            max_rows,
            method,
            clarabel: ClarabelQp::new(n, m)?,
            elastic: ClarabelQp::new(n + 1, m + 1)?,
            working: Vec::with_capacity(n),
            e_working: Vec::with_capacity(n + 1),
            e_kkt: vec![0.0; (2 * n + 2) * (2 * n + 2)],
            e_rhs: vec![0.0; 2 * n + 2],
            stats: QpStats::default(),
        })
    }

    /// The largest number of rows a QP may have.
    pub fn max_rows(&self) -> usize {
        self.max_rows
    }

    /// The method in use.
    pub fn method(&self) -> QpMethod {
        self.method
    }

    /// Changes the method.
    pub fn set_method(&mut self, method: QpMethod) {
        self.method = method;
    }

    /// Counters since the last reset.
    pub fn stats(&self) -> &QpStats {
        &self.stats
    }

    /// Counts an elastic QP posed without certifying the QP infeasible first.
    pub fn count_elastic_direct(&mut self) {
        self.stats.elastic_direct += 1;
    }

    /// Zeros the counters.
    pub fn reset_stats(&mut self) {
        self.stats = QpStats::default();
    }

    /// Solves `min 1/2 du^T h du + q^T du` s.t. `a[i]^T du <= b[i]` and `|du_j| <= trust` (no
    /// trust region when `trust` is infinite). `h` must be symmetric positive definite (the caller
    /// regularises it). `guess` lists rows likely to be active (the backward pass's working set);
    /// it only affects speed. Panics if `a.len() > max_rows` or `a.len() != b.len()`.
    pub fn solve(
        &mut self,
        h: &MatrixN<NU, NU>,
        q: &VectorN<NU>,
        a: &[VectorN<NU>],
        b: &[f64],
        trust: f64,
        guess: &[usize],
    ) -> QpOutcome<NU> {
        assert!(
            a.len() <= self.max_rows && a.len() == b.len(),
            "QP rows exceed the capacity"
        );
        self.stats.solved += 1;
        let Some(chol) = h.clone().cholesky() else {
            self.stats.failed += 1;
            return QpOutcome::Failed;
        };
        if self.method == QpMethod::Fast {
            if let Some(solved) = self.fast_paths(&chol, q, a, b, trust, guess) {
                return solved;
            }
            if box_infeasible(a, b, trust) {
                self.stats.infeasible += 1;
                self.stats.box_certified += 1;
                return QpOutcome::Infeasible;
            }
            if let Some(du) = self.enumerate(&chol, q, a, b, trust) {
                self.stats.enumerated += 1;
                return QpOutcome::Solved(du, QpPath::ActiveSet);
            }
        }
        self.clarabel_solve(&chol, h, q, a, b, trust)
    }

    /// [`StepQp::solve`] without Clarabel: the unconstrained minimiser and the active-set method
    /// (their answers are optimal). `None` when neither finds the KKT point, or `h` is not
    /// positive definite; the caller then poses the QP in elastic form right away (a knot whose
    /// QP was infeasible in the previous forward pass, where certifying it again would cost an
    /// interior-point solve that only reports infeasibility).
    pub fn solve_fast(
        &mut self,
        h: &MatrixN<NU, NU>,
        q: &VectorN<NU>,
        a: &[VectorN<NU>],
        b: &[f64],
        trust: f64,
        guess: &[usize],
    ) -> Option<VectorN<NU>> {
        assert!(
            a.len() <= self.max_rows && a.len() == b.len(),
            "QP rows exceed the capacity"
        );
        self.stats.solved += 1;
        let chol = h.clone().cholesky()?;
        match self.fast_paths(&chol, q, a, b, trust, guess)? {
            QpOutcome::Solved(du, _) => Some(du),
            _ => None,
        }
    }

    /// The unconstrained minimiser, then the active-set method (counted in the stats).
    fn fast_paths(
        &mut self,
        chol: &Cholesky<f64, NU>,
        q: &VectorN<NU>,
        a: &[VectorN<NU>],
        b: &[f64],
        trust: f64,
        guess: &[usize],
    ) -> Option<QpOutcome<NU>> {
        let du = -chol.solve(q);
        if max_violation(&du, a, b, trust) <= 0.0 {
            self.stats.unconstrained += 1;
            return Some(QpOutcome::Solved(du, QpPath::Unconstrained));
        }
        if let Some(du) = self.active_set(chol, q, a, b, trust, guess) {
            self.stats.active_set += 1;
            return Some(QpOutcome::Solved(du, QpPath::ActiveSet));
        }
        None
    }

    /// Row `i` of the combined system: constraint rows first, then the trust region
    /// (`+du_j <= trust`, `-du_j <= trust`).
    #[inline]
    fn row(nu: NU, a: &[VectorN<NU>], b: &[f64], trust: f64, i: usize) -> (VectorN<NU>, f64) {
        if i < a.len() {
            (a[i].clone(), b[i])
        } else {
            let j = (i - a.len()) / 2;
            let sign = if (i - a.len()).is_multiple_of(2) { 1.0 } else { -1.0 };
            let mut e = VectorN::<NU>::zeros_generic(nu, U1);
            e[j] = sign;
            (e, trust)
        }
    }

    fn n_rows(&self, a: &[VectorN<NU>], trust: f64) -> usize {
        a.len() + if trust.is_finite() { 2 * self.nu.value() } else { 0 }
    }

    /// Exact solve with the rows of `self.working` held as equalities: returns `du` and writes the
    /// multipliers into `lambda` (entries beyond the working set are zero). `None` when the
    /// working rows are (nearly) dependent.
    fn equality_qp(
        &self,
        chol: &Cholesky<f64, NU>,
        q: &VectorN<NU>,
        a: &[VectorN<NU>],
        b: &[f64],
        trust: f64,
        lambda: &mut VectorN<NU>,
    ) -> Option<VectorN<NU>> {
        let hq = chol.solve(q);
        let m = self.working.len();
        let nu = self.nu;
        let mut hw = MatrixN::<NU, NU>::zeros_generic(nu, nu); // columns H^{-1} a_w
        let mut s = MatrixN::<NU, NU>::identity_generic(nu, nu);
        let mut rhs = VectorN::<NU>::zeros_generic(nu, U1);
        for (c, &i) in self.working.iter().enumerate() {
            let (ai, _) = Self::row(self.nu, a, b, trust, i);
            hw.set_column(c, &chol.solve(&ai));
        }
        for (r, &i) in self.working.iter().enumerate() {
            let (ai, bi) = Self::row(self.nu, a, b, trust, i);
            for c in 0..m {
                s[(r, c)] = ai.dot(&hw.column(c));
            }
            rhs[r] = -(bi + ai.dot(&hq));
        }
        // S = A_W H^-1 A_W^T (identity beyond the working set); a tiny pivot means dependent rows.
        let scale = (0..m).map(|r| s[(r, r)]).fold(0.0, f64::max);
        let s_chol = s.cholesky()?;
        let l = s_chol.l_dirty();
        for r in 0..m {
            if l[(r, r)] * l[(r, r)] <= 1e-12 * scale {
                return None;
            }
        }
        *lambda = s_chol.solve(&rhs);
        for r in m..nu.value() {
            lambda[r] = 0.0;
        }
        Some(-hq - hw * &*lambda)
    }

    /// A primal active-set method from the working set `guess`. Returns the KKT point or `None`.
    fn active_set(
        &mut self,
        chol: &Cholesky<f64, NU>,
        q: &VectorN<NU>,
        a: &[VectorN<NU>],
        b: &[f64],
        trust: f64,
        guess: &[usize],
    ) -> Option<VectorN<NU>> {
        self.working.clear();
        for &i in guess.iter().take(self.nu.value()) {
            if i < a.len() {
                self.working.push(i);
            }
        }
        let n_rows = self.n_rows(a, trust);
        let mut lambda = VectorN::<NU>::zeros_generic(self.nu, U1);
        for _ in 0..ACTIVE_SET_ITERATIONS {
            let du = self.equality_qp(chol, q, a, b, trust, &mut lambda)?;
            // Drop the most negative multiplier first.
            let mut worst = (usize::MAX, -1e-12);
            for r in 0..self.working.len() {
                if lambda[r] < worst.1 {
                    worst = (r, lambda[r]);
                }
            }
            if worst.0 != usize::MAX {
                self.working.remove(worst.0);
                continue;
            }
            // Add the most violated row.
            let mut add = (usize::MAX, 0.0);
            for i in 0..n_rows {
                if self.working.contains(&i) {
                    continue;
                }
                let (ai, bi) = Self::row(self.nu, a, b, trust, i);
                let v = (ai.dot(&du) - bi) / (1.0 + bi.abs());
                if v > FEAS_TOL && v > add.1 {
                    add = (i, v);
                }
            }
            if add.0 == usize::MAX {
                return Some(du);
            }
            if self.working.len() == self.nu.value() {
                return None;
            }
            self.working.push(add.0);
        }
        None
    }

    /// The KKT point found by trying every working set of at most `nu` rows (the trust region's
    /// sides included), in order of size, or `None` when there are more than
    /// [`ENUMERATION_LIMIT`] of them or none gives a KKT point (then Clarabel decides, and
    /// certifies infeasibility). With `H` positive definite the optimum of a feasible QP is
    /// unique, and its multipliers can be carried by linearly independent active rows, at most
    /// `nu` of them (Caratheodory's theorem on the cone of active gradients), so some such
    /// working set gives it: the equality-constrained solve on that set is stationary, feasible
    /// for every row and has multipliers `>= 0`, the same tests as [`Self::active_set`]. For the
    /// few controls of a mobile robot (2) and a dozen rows this is ~100 tiny solves, far cheaper
    /// than an interior-point solve, and it answers exactly the degenerate QPs (more rows
    /// binding than controls, working sets the active-set method cannot grow) that reach here.
    fn enumerate(
        &mut self,
        chol: &Cholesky<f64, NU>,
        q: &VectorN<NU>,
        a: &[VectorN<NU>],
        b: &[f64],
        trust: f64,
    ) -> Option<VectorN<NU>> {
        let nu = self.nu.value();
        let n_rows = self.n_rows(a, trust);
        let max_k = nu.min(n_rows);
        if subsets_up_to(n_rows, max_k) > ENUMERATION_LIMIT {
            return None;
        }
        let mut lambda = VectorN::<NU>::zeros_generic(self.nu, U1);
        first_subset(n_rows, max_k, |set| {
            self.working.clear();
            self.working.extend_from_slice(set);
            let du = self.equality_qp(chol, q, a, b, trust, &mut lambda)?;
            let dual_ok = (0..set.len()).all(|r| lambda[r] >= -1e-12);
            (dual_ok && self.primal_feasible(&du, a, b, trust)).then_some(du)
        })
    }

    /// Every row outside the working set holds at `du`, within [`FEAS_TOL`] (the rows of the
    /// working set hold as equalities).
    fn primal_feasible(&self, du: &VectorN<NU>, a: &[VectorN<NU>], b: &[f64], trust: f64) -> bool {
        (0..self.n_rows(a, trust)).all(|i| {
            self.working.contains(&i) || {
                let (ai, bi) = Self::row(self.nu, a, b, trust, i);
                (ai.dot(du) - bi) / (1.0 + bi.abs()) <= FEAS_TOL
            }
        })
    }

    /// Solves the KKT system of the elastic QP on the working set `e_working`, in the variables
    /// `z = (du, s)`,
    ///
    /// ```text
    /// [ H  0  A_u^T ] [du]   [-q]
    /// [ 0  0  A_s^T ] [s ] = [-p]      (A_s = -1 on soft rows and on -s <= 0, else 0),
    /// [A_u A_s  0   ] [l ]   [ b]
    /// ```
    ///
    /// leaving `(du, s, l)` in `e_rhs`; `false` on a dependent working set (a pivot below
    /// `tiny`). Row `n_rows` of the working set is `-s <= 0`.
    fn elastic_kkt(&mut self, e: &ElasticQp<NU>, tiny: f64) -> bool {
        let ElasticQp {
            h,
            q,
            a,
            b,
            soft,
            trust,
            penalty,
        } = *e;
        let nu = self.nu.value();
        let s_row = self.n_rows(a, trust);
        let m = self.e_working.len();
        let dim = nu + 1 + m;
        let kkt = &mut self.e_kkt[..dim * dim];
        let rhs = &mut self.e_rhs[..dim];
        kkt.fill(0.0);
        for r in 0..nu {
            for c in 0..nu {
                kkt[r * dim + c] = h[(r, c)];
            }
            rhs[r] = -q[r];
        }
        rhs[nu] = -penalty;
        for (w, &i) in self.e_working.iter().enumerate() {
            let row = nu + 1 + w;
            let (ai, bi, si) = if i == s_row {
                (None, 0.0, -1.0)
            } else {
                let (ai, bi) = Self::row(self.nu, a, b, trust, i);
                (Some(ai), bi, if i < soft { -1.0 } else { 0.0 })
            };
            if let Some(ai) = ai {
                for j in 0..nu {
                    kkt[row * dim + j] = ai[j];
                    kkt[j * dim + row] = ai[j];
                }
            }
            kkt[row * dim + nu] = si;
            kkt[nu * dim + row] = si;
            rhs[row] = bi;
        }
        solve_dense(kkt, rhs, dim, tiny)
    }

    /// The most violated row of the elastic QP at `(du, s)` outside the working set (rows
    /// `0 .. n_rows`, then `-s <= 0` as row `n_rows`), by more than [`FEAS_TOL`] relative to
    /// `1 + |b_i|`; `None` when every row holds.
    fn elastic_most_violated(&self, e: &ElasticQp<NU>, du: &VectorN<NU>, s: f64) -> Option<usize> {
        let ElasticQp { a, b, soft, trust, .. } = *e;
        let n_rows = self.n_rows(a, trust);
        let mut add = (usize::MAX, 0.0);
        for i in 0..=n_rows {
            if self.e_working.contains(&i) {
                continue;
            }
            let v = if i == n_rows {
                -s
            } else {
                let (ai, bi) = Self::row(self.nu, a, b, trust, i);
                let lhs = ai.dot(du) - if i < soft { s } else { 0.0 };
                (lhs - bi) / (1.0 + bi.abs())
            };
            if v > FEAS_TOL && v > add.1 {
                add = (i, v);
            }
        }
        (add.0 != usize::MAX).then_some(add.0)
    }

    /// A primal active-set method for the elastic QP of [`StepQp::solve_elastic`]: each step
    /// solves the KKT system of the working set exactly ([`Self::elastic_kkt`]), drops the most
    /// negative multiplier, or adds the most violated row; it returns only a KKT point
    /// (stationary, primal feasible, multipliers `>= 0`), which is the optimum of this convex
    /// QP. `None` (hand over to the enumeration) on a dependent working set or after a few
    /// changes of it. Starts from the most violated soft row at the unconstrained minimiser.
    fn elastic_active_set(&mut self, e: &ElasticQp<NU>, chol: &Cholesky<f64, NU>) -> Option<(VectorN<NU>, f64)> {
        let ElasticQp {
            h,
            q,
            a,
            b,
            soft,
            penalty,
            ..
        } = *e;
        let nu = self.nu.value();
        let du0 = -chol.solve(q);
        let mut first = (usize::MAX, f64::NEG_INFINITY);
        for i in 0..soft {
            let v = (a[i].dot(&du0) - b[i]) / (1.0 + b[i].abs());
            if v > first.1 {
                first = (i, v);
            }
        }
        if first.0 == usize::MAX {
            return None;
        }
        self.e_working.clear();
        self.e_working.push(first.0);
        // Every working row has a unit entry (soft rows in `s`, bounds and trust region in
        // `du`), so pivots are measured against `H`'s scale.
        let tiny = 1e-14 * h.amax().max(1.0);
        for _ in 0..ELASTIC_ITERATIONS {
            if !self.elastic_kkt(e, tiny) {
                return None;
            }
            let m = self.e_working.len();
            let rhs = &self.e_rhs;
            let du = VectorN::<NU>::from_fn_generic(self.nu, U1, |j, _| rhs[j]);
            let s = rhs[nu];
            // Drop the most negative multiplier first.
            let mut worst = (usize::MAX, -1e-12 * (1.0 + penalty));
            for w in 0..m {
                if rhs[nu + 1 + w] < worst.1 {
                    worst = (w, rhs[nu + 1 + w]);
                }
            }
            if worst.0 != usize::MAX {
                self.e_working.remove(worst.0);
                if self.e_working.is_empty() {
                    return None;
                }
                continue;
            }
            // Add the most violated row.
            let Some(add) = self.elastic_most_violated(e, &du, s) else {
                return Some((du, s.max(0.0)));
            };
            if m == nu + 1 {
                return None;
            }
            self.e_working.push(add);
        }
        None
    }

    /// The elastic QP's KKT point found by trying every working set of at most `nu + 1` rows
    /// (in `z = (du, s)`; the trust region's sides and `-s <= 0` included) that holds a row in
    /// `s`, in order of size, or `None` when there are more than [`ENUMERATION_LIMIT`] of them
    /// or none gives a KKT point (then Clarabel decides). As for [`Self::enumerate`]: the optimal
    /// `du` is unique (`H` positive definite) and some optimal multipliers are carried by at most
    /// `nu + 1` independent active rows (Caratheodory); a set without a row in `s` leaves the
    /// slack's stationarity `p = sum l_i` unmet. It answers the degenerate elastic QPs (ties
    /// between soft rows, a soft row parallel to a bound) on which the active-set method gives up.
    fn elastic_enumerate(&mut self, e: &ElasticQp<NU>) -> Option<(VectorN<NU>, f64)> {
        let (soft, penalty) = (e.soft, e.penalty);
        let nu = self.nu.value();
        let n_all = self.n_rows(e.a, e.trust) + 1;
        let s_row = n_all - 1;
        let max_k = (nu + 1).min(n_all);
        if subsets_up_to(n_all, max_k) > ENUMERATION_LIMIT {
            return None;
        }
        let tiny = 1e-14 * e.h.amax().max(1.0);
        first_subset(n_all, max_k, |set| {
            // Only sets with a row in `s` (the indices increase: a soft row is first, `-s <= 0`
            // last).
            if set[0] >= soft && set[set.len() - 1] != s_row {
                return None;
            }
            self.e_working.clear();
            self.e_working.extend_from_slice(set);
            if !self.elastic_kkt(e, tiny) {
                return None;
            }
            let rhs = &self.e_rhs;
            let dual_ok = (0..set.len()).all(|w| rhs[nu + 1 + w] >= -1e-12 * (1.0 + penalty));
            let du = VectorN::<NU>::from_fn_generic(self.nu, U1, |j, _| rhs[j]);
            let s = rhs[nu];
            (dual_ok && self.elastic_most_violated(e, &du, s).is_none()).then(|| (du, s.max(0.0)))
        })
    }

    fn clarabel_solve(
        &mut self,
        chol: &Cholesky<f64, NU>,
        h: &MatrixN<NU, NU>,
        q: &VectorN<NU>,
        a: &[VectorN<NU>],
        b: &[f64],
        trust: f64,
    ) -> QpOutcome<NU> {
        self.stats.clarabel += 1;
        let n_rows = self.n_rows(a, trust);
        let status = self.clarabel.solve(
            |i, j| h[(i, j)],
            |j| q[j],
            |i, out| {
                if i < n_rows {
                    let (ai, bi) = Self::row(self.nu, a, b, trust, i);
                    out.copy_from_slice(ai.as_slice());
                    bi
                } else {
                    1.0
                }
            },
        );
        let Ok(status) = status else {
            self.stats.failed += 1;
            return QpOutcome::Failed;
        };
        self.stats.clarabel_iterations += self.clarabel.solver.solution.iterations as usize;
        match status {
            SolverStatus::Solved | SolverStatus::AlmostSolved => {
                let sol = &self.clarabel.solver.solution;
                let du = VectorN::<NU>::from_fn_generic(self.nu, U1, |j, _| sol.x[j]);
                // Polish: an exact solve on the rows Clarabel found active, kept if it is a KKT point.
                self.working.clear();
                let mut order: [(f64, usize); 64] = [(0.0, usize::MAX); 64];
                let mut count = 0;
                for i in 0..n_rows {
                    if sol.z[i] > 1e-9 && count < 64 {
                        order[count] = (sol.z[i], i);
                        count += 1;
                    }
                }
                order[..count].sort_unstable_by(|x, y| y.0.total_cmp(&x.0));
                for &(_, i) in order[..count].iter().take(self.nu.value()) {
                    self.working.push(i);
                }
                let mut lambda = VectorN::<NU>::zeros_generic(self.nu, U1);
                if let Some(polished) = self.equality_qp(chol, q, a, b, trust, &mut lambda) {
                    let dual_ok = (0..self.working.len()).all(|r| lambda[r] >= -1e-9);
                    if dual_ok && max_violation(&polished, a, b, trust) <= 1e-9 {
                        return QpOutcome::Solved(polished, QpPath::Clarabel);
                    }
                }
                QpOutcome::Solved(du, QpPath::Clarabel)
            }
            SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => {
                self.stats.infeasible += 1;
                QpOutcome::Infeasible
            }
            _ => {
                self.stats.failed += 1;
                QpOutcome::Failed
            }
        }
    }

    /// The elastic form of the QP, for a knot whose QP is infeasible: the first `soft` rows may
    /// be violated by a common slack `s >= 0` that costs `penalty * s`; the other rows (control
    /// bounds) and the trust region stay hard. Always feasible when the hard rows are. Returns
    /// `du` and `s`.
    pub fn solve_elastic(
        &mut self,
        h: &MatrixN<NU, NU>,
        q: &VectorN<NU>,
        a: &[VectorN<NU>],
        b: &[f64],
        soft: usize,
        trust: f64,
        penalty: f64,
    ) -> Option<(VectorN<NU>, f64)> {
        assert!(a.len() <= self.max_rows && a.len() == b.len() && soft <= a.len());
        self.stats.elastic += 1;
        if self.method == QpMethod::Fast {
            let e = ElasticQp {
                h,
                q,
                a,
                b,
                soft,
                trust,
                penalty,
            };
            if let Some(solved) = h.clone().cholesky().and_then(|chol| self.elastic_active_set(&e, &chol)) {
                self.stats.elastic_active_set += 1;
                return Some(solved);
            }
            if let Some(solved) = self.elastic_enumerate(&e) {
                self.stats.elastic_enumerated += 1;
                return Some(solved);
            }
        }
        let n_rows = self.n_rows(a, trust);
        let nu = self.nu.value();
        let status = self.elastic.solve(
            |i, j| if i < nu && j < nu { h[(i, j)] } else { 0.0 },
            |j| if j < nu { q[j] } else { penalty },
            |i, out| {
                if i < n_rows {
                    let (ai, bi) = Self::row(self.nu, a, b, trust, i);
                    out[..nu].copy_from_slice(ai.as_slice());
                    if i < soft {
                        out[nu] = -1.0;
                    }
                    bi
                } else if i == n_rows {
                    out[nu] = -1.0; // -s <= 0
                    0.0
                } else {
                    1.0
                }
            },
        );
        self.stats.clarabel_iterations += self.elastic.solver.solution.iterations as usize;
        match status {
            Ok(SolverStatus::Solved | SolverStatus::AlmostSolved) => {
                let x = &self.elastic.solver.solution.x;
                Some((VectorN::<NU>::from_fn_generic(self.nu, U1, |j, _| x[j]), x[nu].max(0.0)))
            }
            _ => {
                self.stats.failed += 1;
                None
            }
        }
    }
}

/// Calls `visit` with the subsets of `0..n` of 1 to `max_k` elements (indices increasing), by
/// size and then lexicographically, until it returns `Some`; `max_k <= MAX_QP_CONTROLS + 1`.
fn first_subset<T>(n: usize, max_k: usize, mut visit: impl FnMut(&[usize]) -> Option<T>) -> Option<T> {
    let mut idx = [0usize; MAX_QP_CONTROLS + 1];
    for k in 1..=max_k.min(n) {
        for (j, slot) in idx[..k].iter_mut().enumerate() {
            *slot = j;
        }
        loop {
            if let Some(found) = visit(&idx[..k]) {
                return Some(found);
            }
            // Next subset: the rightmost index that can move, then its successors after it.
            let Some(j) = (0..k).rev().find(|&j| idx[j] < n - k + j) else {
                break;
            };
            idx[j] += 1;
            for t in j + 1..k {
                idx[t] = idx[t - 1] + 1;
            }
        }
    }
    None
}

/// An elastic QP of [`StepQp::solve_elastic`]: `min 1/2 du' H du + q' du + penalty s` over
/// `(du, s)` with the first `soft` rows relaxed by `s >= 0` (`a_i' du - s <= b_i`) and the others
/// and the trust region hard.
struct ElasticQp<'a, NU: Dim>
where
    DefaultAllocator: Alloc<NU, NU>,
{
    h: &'a MatrixN<NU, NU>,
    q: &'a VectorN<NU>,
    a: &'a [VectorN<NU>],
    b: &'a [f64],
    soft: usize,
    trust: f64,
    penalty: f64,
}

/// `sum_{k=1..=max_k} C(n, k)`, the number of non-empty subsets of at most `max_k` of `n` items,
/// stopping (saturated) once it passes [`ENUMERATION_LIMIT`].
fn subsets_up_to(n: usize, max_k: usize) -> usize {
    let mut count = 0usize;
    let mut c = 1usize;
    for k in 1..=max_k {
        c = c.saturating_mul(n + 1 - k) / k;
        count = count.saturating_add(c);
        if count > ENUMERATION_LIMIT {
            break;
        }
    }
    count
}

/// Solves the `dim x dim` system `m x = rhs` (row-major `m`, overwritten) in place by Gaussian
/// elimination with partial pivoting; `false` when a pivot is below `tiny` (a dependent working
/// set).
fn solve_dense(m: &mut [f64], rhs: &mut [f64], dim: usize, tiny: f64) -> bool {
    for col in 0..dim {
        let mut piv = col;
        for r in col + 1..dim {
            if m[r * dim + col].abs() > m[piv * dim + col].abs() {
                piv = r;
            }
        }
        let p = m[piv * dim + col];
        if p.is_nan() || p.abs() <= tiny {
            return false;
        }
        if piv != col {
            for c in 0..dim {
                m.swap(piv * dim + c, col * dim + c);
            }
            rhs.swap(piv, col);
        }
        for r in col + 1..dim {
            let f = m[r * dim + col] / p;
            if f != 0.0 {
                for c in col..dim {
                    m[r * dim + c] -= f * m[col * dim + c];
                }
                rhs[r] -= f * rhs[col];
            }
        }
    }
    for r in (0..dim).rev() {
        let mut v = rhs[r];
        for c in r + 1..dim {
            v -= m[r * dim + c] * rhs[c];
        }
        rhs[r] = v / m[r * dim + r];
    }
    true
}

/// A closed-form certificate of infeasibility: the box `lo <= du <= hi` that the trust region
/// and the rows with a single nonzero entry (the control-bound sides) define is empty, or some
/// other row cannot be met anywhere in it (`min_box a_i^T du > b_i`, by a margin well above the
/// QP's feasibility tolerance). A `false` proves nothing. Catches the common infeasible QP of the
/// forward pass (a state row of relative degree `r`, whose `C_i` is `O(dt^r)`, asking for more
/// than the control bounds allow) without an interior-point solve.
fn box_infeasible<NU: Dim>(a: &[VectorN<NU>], b: &[f64], trust: f64) -> bool
where
    DefaultAllocator: Alloc<NU, NU>,
{
    const MARGIN: f64 = 1e-8;
    let n = a.first().map_or(0, |ai| ai.len());
    if n == 0 || n > MAX_QP_CONTROLS {
        return false;
    }
    let (mut lo, mut hi) = ([-trust; MAX_QP_CONTROLS], [trust; MAX_QP_CONTROLS]);
    let single = |ai: &VectorN<NU>| {
        let mut at = usize::MAX;
        for (j, &v) in ai.iter().enumerate() {
            if v != 0.0 {
                if at != usize::MAX {
                    return None;
                }
                at = j;
            }
        }
        (at != usize::MAX).then_some(at)
    };
    for (ai, &bi) in a.iter().zip(b) {
        if let Some(j) = single(ai) {
            // a_ij du_j <= b_i
            let bound = bi / ai[j];
            if ai[j] > 0.0 {
                hi[j] = hi[j].min(bound);
            } else {
                lo[j] = lo[j].max(bound);
            }
        }
    }
    for j in 0..n {
        if lo[j] > hi[j] + MARGIN * (1.0 + lo[j].abs().max(hi[j].abs())) {
            return true;
        }
    }
    for (ai, &bi) in a.iter().zip(b) {
        if single(ai).is_some() {
            continue;
        }
        let mut least = 0.0;
        for (j, &v) in ai.iter().enumerate() {
            least += if v > 0.0 {
                v * lo[j]
            } else if v < 0.0 {
                v * hi[j]
            } else {
                0.0
            };
        }
        // An unbounded side gives -inf (never a certificate); NaN compares false.
        if least - bi > MARGIN * (1.0 + bi.abs()) {
            return true;
        }
    }
    false
}

/// Largest scaled violation `(a_i^T du - b_i) / (1 + |b_i|)` minus the tolerance, over the rows
/// and the trust region (`<= 0` means feasible).
fn max_violation<NU: Dim>(du: &VectorN<NU>, a: &[VectorN<NU>], b: &[f64], trust: f64) -> f64
where
    DefaultAllocator: Alloc<NU, NU>,
{
    let mut worst = f64::NEG_INFINITY;
    for (ai, &bi) in a.iter().zip(b) {
        worst = worst.max((ai.dot(du) - bi) / (1.0 + bi.abs()) - FEAS_TOL);
    }
    if trust.is_finite() {
        worst = worst.max((du.amax() - trust) / (1.0 + trust) - FEAS_TOL);
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;
    use ddp_core::dims::U2;
    use ddp_core::{Matrix, Vector};

    /// Seeded uniform numbers in [-1, 1) (xorshift64).
    fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        }
    }

    /// The default QP solver and the Clarabel-only one, for 2 controls and 8 rows.
    fn fast_and_clarabel() -> (StepQp<U2>, StepQp<U2>) {
        (
            StepQp::new(U2, 8, QpMethod::Fast).unwrap(),
            StepQp::new(U2, 8, QpMethod::Clarabel).unwrap(),
        )
    }

    /// A random symmetric positive definite 2x2 `H = L L^T`.
    /// Solves one elastic QP (penalty `1e3`) with the fast paths and with Clarabel alone, asserts
    /// the same `(du, s)`, and returns the fast solver's counters.
    fn elastic_against_clarabel(
        case: usize,
        h: &Matrix<2, 2>,
        q: &Vector<2>,
        a: &[Vector<2>],
        b: &[f64],
        soft: usize,
        trust: f64,
    ) -> QpStats {
        let (mut fast, mut exact) = fast_and_clarabel();
        let (du, s) = fast.solve_elastic(h, q, a, b, soft, trust, 1e3).unwrap();
        let (du_c, s_c) = exact.solve_elastic(h, q, a, b, soft, trust, 1e3).unwrap();
        assert!(
            (du - du_c).amax() < 1e-6 && (s - s_c).abs() < 1e-6,
            "case {case}: {du} {s} against Clarabel's {du_c} {s_c}"
        );
        *fast.stats()
    }

    /// The hard rows of the forward pass's elastic QPs: `|du_0| <= 1`, `|du_1| <= 0.5`.
    fn push_control_bounds(a: &mut Vec<Vector<2>>, b: &mut Vec<f64>) {
        for (row, bound) in [
            (Vector::<2>::new(1.0, 0.0), 1.0),
            (Vector::<2>::new(-1.0, 0.0), 1.0),
            (Vector::<2>::new(0.0, 1.0), 0.5),
            (Vector::<2>::new(0.0, -1.0), 0.5),
        ] {
            a.push(row);
            b.push(bound);
        }
    }

    fn spd(rand: &mut impl FnMut() -> f64) -> Matrix<2, 2> {
        let l = Matrix::<2, 2>::new(1.0 + rand().abs(), 0.0, rand(), 0.5 + rand().abs());
        l * l.transpose()
    }

    /// min 1/2 |du|^2 - du_0 - du_1  s.t. du_0 + du_1 <= 1: the optimum is (1/2, 1/2) with
    /// multiplier 1/2 (by symmetry and stationarity `du - (1, 1) + lambda (1, 1) = 0`).
    fn hand_qp() -> (Matrix<2, 2>, Vector<2>, Vec<Vector<2>>, Vec<f64>) {
        (
            Matrix::<2, 2>::identity(),
            Vector::<2>::new(-1.0, -1.0),
            vec![Vector::<2>::new(1.0, 1.0)],
            vec![1.0],
        )
    }

    #[test]
    fn every_method_finds_the_hand_optimum() {
        let (h, q, a, b) = hand_qp();
        for method in [QpMethod::Fast, QpMethod::Clarabel] {
            let mut qp = StepQp::new(U2, 4, method).unwrap();
            for guess in [&[][..], &[0][..]] {
                match qp.solve(&h, &q, &a, &b, f64::INFINITY, guess) {
                    QpOutcome::Solved(du, _) => assert!((du - Vector::<2>::new(0.5, 0.5)).amax() < 1e-9, "{du}"),
                    other => panic!("{method:?}: {other:?}"),
                }
            }
        }
    }

    #[test]
    fn trust_region_binds() {
        // Unconstrained optimum (1, 1); a trust region of 0.25 clips both components.
        let (h, q, _, _) = hand_qp();
        for method in [QpMethod::Fast, QpMethod::Clarabel] {
            let mut qp = StepQp::new(U2, 2, method).unwrap();
            match qp.solve(&h, &q, &[], &[], 0.25, &[]) {
                QpOutcome::Solved(du, _) => assert!((du - Vector::<2>::new(0.25, 0.25)).amax() < 1e-9),
                other => panic!("{other:?}"),
            }
        }
    }

    #[test]
    fn box_certificate_skips_clarabel_only_when_infeasible() {
        // Control bounds |du_j| <= 1 as single-entry rows, and a row 0.01 du_0 + 0.01 du_1 <= -0.03
        // that needs du_0 + du_1 <= -3: impossible in the box, certified without Clarabel.
        let h = Matrix::<2, 2>::identity();
        let q = Vector::<2>::new(1.0, -1.0);
        let mut a = vec![
            Vector::<2>::new(0.01, 0.01),
            Vector::<2>::new(1.0, 0.0),
            Vector::<2>::new(-1.0, 0.0),
            Vector::<2>::new(0.0, 1.0),
            Vector::<2>::new(0.0, -1.0),
        ];
        let mut b = vec![-0.03, 1.0, 1.0, 1.0, 1.0];
        let mut qp = StepQp::new(U2, 5, QpMethod::Fast).unwrap();
        assert_eq!(qp.solve(&h, &q, &a, &b, f64::INFINITY, &[]), QpOutcome::Infeasible);
        assert_eq!((qp.stats().box_certified, qp.stats().clarabel), (1, 0));
        // Just inside the box (du = (-1, -1) meets it with room): not certified, and solved.
        b[0] = -0.019;
        match qp.solve(&h, &q, &a, &b, f64::INFINITY, &[]) {
            QpOutcome::Solved(du, _) => assert!(0.01 * (du[0] + du[1]) <= -0.019 + 1e-12 && du.amax() <= 1.0 + 1e-12),
            other => panic!("{other:?}"),
        }
        assert_eq!(qp.stats().box_certified, 1);
        // Contradictory single-entry rows (du_0 <= -2 and du_0 >= -1) with a trust region.
        a.truncate(3);
        b.truncate(3);
        b[0] = 1.0;
        a[1] = Vector::<2>::new(2.0, 0.0);
        b[1] = -4.0;
        assert_eq!(qp.solve(&h, &q, &a, &b, 5.0, &[]), QpOutcome::Infeasible);
        assert_eq!(qp.stats().box_certified, 2);
        // Clarabel agrees that the last QP is infeasible.
        let mut exact = StepQp::new(U2, 5, QpMethod::Clarabel).unwrap();
        assert_eq!(exact.solve(&h, &q, &a, &b, 5.0, &[]), QpOutcome::Infeasible);
        assert_eq!(exact.stats().box_certified, 0);
    }

    #[test]
    fn solve_fast_answers_without_clarabel_or_declines() {
        let (h, q, a, b) = hand_qp();
        let mut qp = StepQp::new(U2, 2, QpMethod::Fast).unwrap();
        let du = qp.solve_fast(&h, &q, &a, &b, f64::INFINITY, &[]).unwrap();
        assert!((du - Vector::<2>::new(0.5, 0.5)).amax() < 1e-9);
        // Infeasible rows: no answer, and no Clarabel call.
        let rows = [Vector::<2>::new(1.0, 0.0), Vector::<2>::new(-1.0, 0.0)];
        assert!(qp
            .solve_fast(&h, &q, &rows, &[-1.0, -1.0], f64::INFINITY, &[])
            .is_none());
        assert_eq!(qp.stats().clarabel, 0);
    }

    #[test]
    fn elastic_active_set_matches_clarabel() {
        // Seeded QPs in the forward pass's shape: soft rows with small `C` (relative degree 2),
        // hard control-bound sides, sometimes a trust region; the elastic optimum of the
        // active-set method (`Fast`) against Clarabel's.
        let mut rand = uniform(0x2545_f491_4f6c_dd1d);
        let mut answered = 0;
        for case in 0..200 {
            let h = spd(&mut rand);
            let q = Vector::<2>::new(rand(), rand());
            let soft = 1 + case % 3;
            let mut a = Vec::new();
            let mut b = Vec::new();
            for _ in 0..soft {
                a.push(Vector::<2>::new(1e-2 * rand(), 1e-2 * rand()));
                b.push(0.05 * rand());
            }
            push_control_bounds(&mut a, &mut b);
            let trust = if case % 4 == 0 { 0.7 } else { f64::INFINITY };
            answered += elastic_against_clarabel(case, &h, &q, &a, &b, soft, trust).elastic_active_set;
        }
        assert!(answered >= 120, "the active-set method answered only {answered} of 200");
    }

    #[test]
    fn elastic_enumeration_matches_clarabel_on_degenerate_elastic_qps() {
        // Seeded infeasible QPs in the forward pass's shape whose elastic optimum is degenerate:
        // soft rows that a point `v` violates by one common amount (ties in the slack), hard
        // control-bound sides, sometimes `v` on a bound, the unconstrained minimiser pushed
        // away. Where the active-set method gives up, the enumeration must find Clarabel's
        // elastic optimum, and no such QP may reach Clarabel.
        let mut rand = uniform(0x51_7cc1_b727_220a);
        let (mut enumerated, mut active_set) = (0, 0);
        for case in 0..300 {
            let h = spd(&mut rand);
            let mut v = Vector::<2>::new(0.5 * rand(), 0.25 * rand());
            if case % 3 == 0 {
                v[0] = 1.0; // on the bound du_0 <= 1
            }
            let q = -(h * v) + Vector::<2>::new(rand(), rand());
            let (mut a, mut b) = (Vec::new(), Vec::new());
            let soft = 2 + case % 3;
            let excess = 0.01 + 0.05 * rand().abs();
            for _ in 0..soft {
                let ai = Vector::<2>::new(0.1 * rand(), 0.1 * rand());
                b.push(ai.dot(&v) - excess);
                a.push(ai);
            }
            push_control_bounds(&mut a, &mut b);
            let stats = elastic_against_clarabel(case, &h, &q, &a, &b, soft, f64::INFINITY);
            assert_eq!(stats.clarabel_solves(), 0, "case {case}: handed to Clarabel");
            enumerated += stats.elastic_enumerated;
            active_set += stats.elastic_active_set;
        }
        // The active-set method answers 14 of these, the enumeration the other 286.
        assert!(
            enumerated >= 200,
            "the enumeration answered only {enumerated} of 300 (the active-set method {active_set})"
        );
    }

    #[test]
    fn enumeration_matches_clarabel_on_degenerate_qps() {
        // Seeded feasible QPs whose optimum often has more binding rows than controls: three
        // rows through one point `v` (b = a^T v), a few more that `v` satisfies strictly, and an
        // unconstrained minimiser pushed outside. Where the active-set method gives up, the
        // enumeration must find Clarabel's optimum.
        let mut rand = uniform(0x9e37_79b9_7f4a_7c15);
        let mut enumerated = 0;
        for case in 0..300 {
            let h = spd(&mut rand);
            let v = Vector::<2>::new(0.3 * rand(), 0.3 * rand());
            let q = -(h * v) + Vector::<2>::new(2.0 * rand(), 2.0 * rand());
            let (mut a, mut b) = (Vec::new(), Vec::new());
            for i in 0..3 + case % 5 {
                let ai = Vector::<2>::new(rand(), rand());
                let slack = if i < 3 { 0.0 } else { 0.2 * rand().abs() };
                b.push(ai.dot(&v) + slack);
                a.push(ai);
            }
            let trust = if case % 3 == 0 { 1.5 } else { f64::INFINITY };
            let (mut fast, mut exact) = fast_and_clarabel();
            let QpOutcome::Solved(du, _) = fast.solve(&h, &q, &a, &b, trust, &[]) else {
                panic!("case {case}: a feasible QP was not solved by the fast paths");
            };
            let QpOutcome::Solved(du_c, _) = exact.solve(&h, &q, &a, &b, trust, &[]) else {
                panic!("case {case}: Clarabel did not solve a feasible QP");
            };
            assert!((du - du_c).amax() < 1e-6, "case {case}: {du} against Clarabel's {du_c}");
            assert_eq!(fast.stats().clarabel, 0, "case {case}: handed to Clarabel");
            enumerated += fast.stats().enumerated;
        }
        assert!(enumerated >= 30, "the enumeration answered only {enumerated} of 300");
    }

    #[test]
    fn infeasible_rows_are_reported() {
        // du_0 <= -1 and -du_0 <= -1 (du_0 >= 1) cannot both hold.
        let h = Matrix::<2, 2>::identity();
        let a = [Vector::<2>::new(1.0, 0.0), Vector::<2>::new(-1.0, 0.0)];
        let b = [-1.0, -1.0];
        let mut qp = StepQp::new(U2, 2, QpMethod::Fast).unwrap();
        assert_eq!(
            qp.solve(&h, &Vector::zeros(), &a, &b, f64::INFINITY, &[]),
            QpOutcome::Infeasible
        );
        assert_eq!(qp.stats().infeasible, 1);
    }
}
