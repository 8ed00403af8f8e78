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
//! 3. Clarabel, an interior-point solver set up once (dense `H` and `A` patterns, presolve and
//!    equilibration off) and updated in place with `update_P/q/A/b` for every QP; its answer is
//!    polished by one exact solve on the rows it found active.
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
    /// Unconstrained minimiser, then the active-set method, then Clarabel (the default).
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
}

impl std::ops::AddAssign for QpStats {
    fn add_assign(&mut self, o: Self) {
        self.solved += o.solved;
        self.unconstrained += o.unconstrained;
        self.active_set += o.active_set;
        self.clarabel += o.clarabel;
        self.clarabel_iterations += o.clarabel_iterations;
        self.infeasible += o.infeasible;
        self.failed += o.failed;
        self.elastic += o.elastic;
    }
}

/// Feasibility tolerance of a row, relative to `1 + |b_i|`.
const FEAS_TOL: f64 = 1e-10;
/// Working-set changes the active-set method may make before handing over to Clarabel.
const ACTIVE_SET_ITERATIONS: usize = 8;

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
            let du = -chol.solve(q);
            if max_violation(&du, a, b, trust) <= 0.0 {
                self.stats.unconstrained += 1;
                return QpOutcome::Solved(du, QpPath::Unconstrained);
            }
            if let Some(du) = self.active_set(&chol, q, a, b, trust, guess) {
                self.stats.active_set += 1;
                return QpOutcome::Solved(du, QpPath::ActiveSet);
            }
        }
        self.clarabel_solve(&chol, h, q, a, b, trust)
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
