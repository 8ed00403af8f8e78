//! A direct optimiser of a spline's free control points: minimises jerk plus curvature of the
//! time-parametrised trajectory while the waypoints and the continuity class stay fixed.
//!
//! ```text
//! min_d  w_j J(d) + w_k K(d),    J = int |x'''(T)|^2 dT (or the paper's discrete form),
//!                                K = sum_k |kappa(T_k)|  (the paper's curvature sum)
//! ```
//!
//! The free variables are the waypoint tangents `d_i` of the Hermite form (C1: all of them;
//! C2: only the two end tangents, the interior ones following from the C2 conditions), so
//! continuity holds by construction. BFGS with central-difference gradients and an Armijo
//! backtracking line search, starting from Catmull-Rom (C1) or the natural spline (C2).
//!
//! ```
//! use bezier::{optimize_spline, OptimizeSettings, OptimizeStatus, Point, Spline, SplineCost};
//! let w = [Point::new(0.0, 0.0), Point::new(1.0, 1.0), Point::new(2.0, 0.0)];
//! let settings = OptimizeSettings { max_iterations: 15, ..OptimizeSettings::default() };
//! let report = optimize_spline(&w, &settings).unwrap();
//! assert!(report.cost <= report.initial_cost);
//! assert_eq!(report.spline.waypoints(), w.to_vec());
//! ```

use crate::error::{check_finite, Error, Result};
use crate::point::{Point, Vec2};
use crate::profile::Trajectory;
use crate::spline::{Continuity, Spline};

/// Which jerk measure the cost uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JerkMeasure {
    /// `int |x'''|^2 dT` of the full 2D jerk ([`Trajectory::jerk_cost_integral`]).
    Integral,
    /// The paper's discrete tangential jerk ([`Trajectory::jerk_cost_discrete`]); it sees the
    /// path's shape only through its length.
    Discrete,
}

/// The objective: weights, the motion profile and the sampling.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplineCost {
    /// Weight of the jerk term (default 1).
    pub jerk_weight: f64,
    /// Weight of the curvature sum (default 0.01).
    pub curvature_weight: f64,
    /// Sigmoid steepness `m` (default 10).
    pub m: f64,
    /// Sigmoid midpoint `k` (default 0.5).
    pub k: f64,
    /// Peak speed (default 1).
    pub max_speed: f64,
    /// Reference points for the curvature sum and the discrete jerk (default 100).
    pub samples: usize,
    /// Jerk measure (default [`JerkMeasure::Integral`]).
    pub jerk: JerkMeasure,
}

impl Default for SplineCost {
    fn default() -> SplineCost {
        SplineCost {
            jerk_weight: 1.0,
            curvature_weight: 0.01,
            m: 10.0,
            k: 0.5,
            max_speed: 1.0,
            samples: 100,
            jerk: JerkMeasure::Integral,
        }
    }
}

impl SplineCost {
    fn validate(&self) -> Result<()> {
        check_finite("cost.jerk_weight", 0, self.jerk_weight)?;
        check_finite("cost.curvature_weight", 0, self.curvature_weight)?;
        if self.jerk_weight < 0.0 || self.curvature_weight < 0.0 {
            return Err(Error::InvalidParameter {
                field: "cost.jerk_weight / cost.curvature_weight",
                value: self.jerk_weight.min(self.curvature_weight),
                reason: "weights must be >= 0",
            });
        }
        if self.samples < 4 {
            return Err(Error::InvalidParameter {
                field: "cost.samples",
                value: self.samples as f64,
                reason: "must be >= 4",
            });
        }
        Ok(())
    }

    /// The cost of `spline` traversed with this cost's sigmoid profile.
    pub fn evaluate(&self, spline: &Spline) -> Result<f64> {
        self.validate()?;
        let traj = Trajectory::with_sigmoid(spline.clone(), self.m, self.k, self.max_speed)?;
        let j = match self.jerk {
            JerkMeasure::Integral => traj.jerk_cost_integral(1e-8),
            JerkMeasure::Discrete => traj.jerk_cost_discrete(self.samples),
        };
        Ok(self.jerk_weight * j + self.curvature_weight * traj.curvature_sum(self.samples))
    }
}

/// Optimiser settings (validated by [`optimize_spline`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OptimizeSettings {
    /// Continuity kept: `C1` (all tangents free) or `C2` (end tangents free). Default `C1`.
    pub continuity: Continuity,
    /// The objective.
    pub cost: SplineCost,
    /// Iteration limit (default 100).
    pub max_iterations: usize,
    /// Stop when the gradient's largest component is below `gradient_tolerance * (1 + |cost|)`
    /// (default `1e-6`).
    pub gradient_tolerance: f64,
}

impl Default for OptimizeSettings {
    fn default() -> OptimizeSettings {
        OptimizeSettings {
            continuity: Continuity::C1,
            cost: SplineCost::default(),
            max_iterations: 100,
            gradient_tolerance: 1e-6,
        }
    }
}

/// How the optimisation ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OptimizeStatus {
    /// The gradient (or the cost decrease) fell below tolerance.
    Converged,
    /// `max_iterations` reached.
    MaxIterations,
    /// No step along the search direction decreased the cost.
    LineSearchFailed,
}

/// Result of [`optimize_spline`].
#[derive(Clone, Debug)]
pub struct OptimizeReport {
    /// The optimised spline (through the same waypoints).
    pub spline: Spline,
    /// Cost of the starting spline.
    pub initial_cost: f64,
    /// Final cost.
    pub cost: f64,
    /// BFGS iterations done.
    pub iterations: usize,
    /// Cost evaluations done.
    pub evaluations: usize,
    /// How it ended.
    pub status: OptimizeStatus,
}

fn build(waypoints: &[Point], x: &[f64], continuity: Continuity) -> Spline {
    let d: Vec<Vec2> = x.chunks(2).map(|c| Vec2::new(c[0], c[1])).collect();
    match continuity {
        Continuity::C2 => {
            let t = Spline::c2_tangents(waypoints, Some((d[0], d[1])));
            Spline::hermite_unchecked(waypoints, &t)
        }
        _ => Spline::hermite_unchecked(waypoints, &d),
    }
}

/// Optimises the free control points of a spline through `waypoints` (see the module docs).
/// Errors: bad waypoints (`TooFew`, `NonFinite`), bad settings (naming the field).
pub fn optimize_spline(waypoints: &[Point], settings: &OptimizeSettings) -> Result<OptimizeReport> {
    settings.cost.validate()?;
    check_finite("gradient_tolerance", 0, settings.gradient_tolerance)?;
    if settings.continuity == Continuity::C0 {
        return Err(Error::InvalidParameter {
            field: "continuity",
            value: 0.0,
            reason: "must be C1 or C2",
        });
    }
    let start = match settings.continuity {
        Continuity::C2 => Spline::c2_natural(waypoints)?,
        _ => Spline::catmull_rom(waypoints)?,
    };
    let tangents = start.tangents();
    let mut x: Vec<f64> = match settings.continuity {
        Continuity::C2 => vec![
            tangents[0].x,
            tangents[0].y,
            tangents[tangents.len() - 1].x,
            tangents[tangents.len() - 1].y,
        ],
        _ => tangents.iter().flat_map(|d| [d.x, d.y]).collect(),
    };
    let n = x.len();
    let scale = waypoints
        .windows(2)
        .map(|w| w[0].distance(w[1]))
        .fold(0.0, f64::max)
        .max(1e-12);
    let mut evaluations = 0usize;
    let mut f = |x: &[f64]| -> f64 {
        evaluations += 1;
        settings
            .cost
            .evaluate(&build(waypoints, x, settings.continuity))
            .unwrap_or(f64::INFINITY)
    };
    let h = 6e-6 * scale;
    let grad = |f: &mut dyn FnMut(&[f64]) -> f64, x: &[f64]| -> Vec<f64> {
        let mut xp = x.to_vec();
        (0..x.len())
            .map(|i| {
                xp[i] = x[i] + h;
                let fp = f(&xp);
                xp[i] = x[i] - h;
                let fm = f(&xp);
                xp[i] = x[i];
                (fp - fm) / (2.0 * h)
            })
            .collect()
    };
    let mut fx = f(&x);
    let initial_cost = fx;
    let mut g = grad(&mut f, &x);
    // Inverse-Hessian approximation, initially scaled identity.
    let mut hinv = vec![0.0; n * n];
    for i in 0..n {
        hinv[i * n + i] = 1.0;
    }
    let mut status = OptimizeStatus::MaxIterations;
    let mut iterations = 0;
    let mut first = true;
    while iterations < settings.max_iterations {
        let gmax = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if !(gmax > settings.gradient_tolerance * (1.0 + fx.abs())) {
            status = OptimizeStatus::Converged;
            break;
        }
        iterations += 1;
        let mut p: Vec<f64> = (0..n)
            .map(|i| -(0..n).map(|j| hinv[i * n + j] * g[j]).sum::<f64>())
            .collect();
        let mut slope: f64 = p.iter().zip(&g).map(|(a, b)| a * b).sum();
        if !(slope < 0.0) {
            // Not a descent direction: restart from steepest descent.
            for i in 0..n {
                for j in 0..n {
                    hinv[i * n + j] = if i == j { 1.0 } else { 0.0 };
                }
            }
            p = g.iter().map(|v| -v).collect();
            slope = -g.iter().map(|v| v * v).sum::<f64>();
        }
        if first {
            // First step: move at most a tenth of the waypoint spacing.
            let pn = p.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            if pn > 0.1 * scale {
                let s = 0.1 * scale / pn;
                p.iter_mut().for_each(|v| *v *= s);
                slope *= s;
            }
            first = false;
        }
        let mut alpha = 1.0;
        let mut accepted = None;
        for _ in 0..40 {
            let xn: Vec<f64> = x.iter().zip(&p).map(|(a, b)| a + alpha * b).collect();
            let fnew = f(&xn);
            if fnew <= fx + 1e-4 * alpha * slope {
                accepted = Some((xn, fnew));
                break;
            }
            alpha *= 0.5;
        }
        let Some((xn, fnew)) = accepted else {
            status = OptimizeStatus::LineSearchFailed;
            break;
        };
        let gn = grad(&mut f, &xn);
        let s: Vec<f64> = xn.iter().zip(&x).map(|(a, b)| a - b).collect();
        let y: Vec<f64> = gn.iter().zip(&g).map(|(a, b)| a - b).collect();
        let sy: f64 = s.iter().zip(&y).map(|(a, b)| a * b).sum();
        if sy > 1e-300 {
            // BFGS inverse update: H <- (I - rho s y^T) H (I - rho y s^T) + rho s s^T.
            let rho = 1.0 / sy;
            let hy: Vec<f64> = (0..n).map(|i| (0..n).map(|j| hinv[i * n + j] * y[j]).sum()).collect();
            let yhy: f64 = y.iter().zip(&hy).map(|(a, b)| a * b).sum();
            for i in 0..n {
                for j in 0..n {
                    hinv[i * n + j] += -rho * (hy[i] * s[j] + s[i] * hy[j]) + (rho * rho * yhy + rho) * s[i] * s[j];
                }
            }
        }
        let decrease = fx - fnew;
        x = xn;
        g = gn;
        fx = fnew;
        if decrease <= 1e-12 * (1.0 + fx.abs()) {
            status = OptimizeStatus::Converged;
            break;
        }
    }
    Ok(OptimizeReport {
        spline: build(waypoints, &x, settings.continuity),
        initial_cost,
        cost: fx,
        iterations,
        evaluations,
        status,
    })
}
