//! The shared peer-benchmark problems (`bench/problems.md`): JSON files with a model (`"car"`,
//! `"point"`, `"unicycle"`), `dt`, `N`, `x0`, a cost, an optional control box and optional
//! circular obstacles `[ox, oy, r]` imposed as `(px - ox)^2 + (py - oy)^2 >= r^2` on
//! `x_1 .. x_N` ([`Circle`] in squared form).
//!
//! ```no_run
//! use safe_cddp::benchmark::BenchmarkProblem;
//! let p = BenchmarkProblem::from_file("p2_car4.json")?;
//! let (problem, constraints) = p.car_or_point()?;
//! # Ok::<(), ddp_core::Error>(())
//! ```

use ddp_core::dims::{Const, U2, U3, U4};
use std::path::Path;
use std::sync::Arc;

use ddp_core::costs::{QuadraticCost, QuadraticTerminal};
use ddp_core::models::{Car, DoubleIntegrator2D, Unicycle};
use ddp_core::{ControlBounds, Dynamics, Error, Problem, Result, Vector};
use serde::Deserialize;

use crate::constraints::Circle;
use crate::{Constraint, Constraints};

/// Longest horizon `N` a problem file may ask for (the benchmark problems use 100 to 120).
pub const MAX_HORIZON: usize = 100_000;

/// The cost of a benchmark problem.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum BenchmarkCost {
    /// Crocoddyl's unicycle cost `1/2 (w_x^2 |x|^2 + w_u^2 |u|^2)`, terminal `1/2 w_x^2 |x_N|^2`.
    Unicycle {
        /// `w_x`
        w_x: f64,
        /// `w_u`
        w_u: f64,
    },
    /// `1/2 u^T diag(R) u` per knot and `1/2 (x_N - x_goal)^T diag(Qf) (x_N - x_goal)`.
    QuadGoal {
        /// `x_goal`
        x_goal: Vec<f64>,
        /// Diagonal of `R`.
        #[serde(rename = "R")]
        r: Vec<f64>,
        /// Diagonal of `Qf`.
        #[serde(rename = "Qf")]
        qf: Vec<f64>,
    },
}

/// One problem file of `bench/problems.md`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BenchmarkProblem {
    /// Free text.
    pub name: String,
    /// `"unicycle"`, `"car"` or `"point"`.
    pub model: String,
    /// Time step.
    pub dt: f64,
    /// Horizon.
    #[serde(rename = "N")]
    pub horizon: usize,
    /// Initial state.
    pub x0: Vec<f64>,
    /// The cost.
    pub cost: BenchmarkCost,
    /// Optional lower control bounds.
    #[serde(default)]
    pub u_min: Option<Vec<f64>>,
    /// Optional upper control bounds.
    #[serde(default)]
    pub u_max: Option<Vec<f64>>,
    /// Optional obstacles `[ox, oy, r]`.
    #[serde(default)]
    pub obstacles: Vec<[f64; 3]>,
}

fn vector<const N: usize>(field: &str, v: &[f64]) -> Result<Vector<N>> {
    if v.len() != N {
        return Err(Error::Shape {
            field: field.into(),
            got: format!("({},)", v.len()),
            expected: format!("({N},)"),
        });
    }
    let out = Vector::<N>::from_column_slice(v);
    ddp_core::error::check_finite(field, out.iter())?;
    Ok(out)
}

impl BenchmarkProblem {
    /// Parses a problem from JSON text; a malformed file gets an error naming the field.
    pub fn from_json(text: &str) -> Result<Self> {
        let p: Self = serde_json::from_str(text).map_err(|e| Error::invalid("problem file", e.to_string()))?;
        if !(p.dt.is_finite() && p.dt > 0.0) {
            return Err(Error::invalid("dt", format!("must be finite and > 0, got {}", p.dt)));
        }
        if p.horizon == 0 {
            return Err(Error::EmptyHorizon);
        }
        // Checked before `Problem::new` allocates a knot per step.
        if p.horizon > MAX_HORIZON {
            return Err(Error::invalid(
                "N",
                format!("must be at most {MAX_HORIZON}, got {}", p.horizon),
            ));
        }
        for (k, o) in p.obstacles.iter().enumerate() {
            ddp_core::error::check_finite(&format!("obstacles[{k}]"), o.iter())?;
        }
        Ok(p)
    }

    /// Reads and parses a problem file.
    pub fn from_file(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path)
            .map_err(|e| Error::invalid("problem file", format!("cannot read {}: {e}", path.display())))?;
        Self::from_json(&text)
    }

    fn bounds<const NU: usize>(&self) -> Result<Option<ControlBounds<Const<NU>>>> {
        match (&self.u_min, &self.u_max) {
            (None, None) => Ok(None),
            (lo, hi) => {
                let lo = match lo {
                    Some(v) => vector::<NU>("u_min", v)?,
                    None => Vector::repeat(f64::NEG_INFINITY),
                };
                let hi = match hi {
                    Some(v) => vector::<NU>("u_max", v)?,
                    None => Vector::repeat(f64::INFINITY),
                };
                Ok(Some(ControlBounds::new(lo, hi)?))
            }
        }
    }

    fn build<const NX: usize, const NU: usize>(
        &self,
        dynamics: Arc<dyn Dynamics<Const<NX>, Const<NU>>>,
    ) -> Result<Problem<Const<NX>, Const<NU>>> {
        let x0 = vector::<NX>("x0", &self.x0)?;
        let (running, terminal): (
            Arc<QuadraticCost<Const<NX>, Const<NU>>>,
            Arc<QuadraticTerminal<Const<NX>>>,
        ) = match &self.cost {
            BenchmarkCost::Unicycle { w_x, w_u } => (
                Arc::new(QuadraticCost::weighted_norms(*w_x, *w_u)?),
                Arc::new(QuadraticTerminal::diagonal(&[w_x * w_x; NX], Vector::zeros())?),
            ),
            BenchmarkCost::QuadGoal { x_goal, r, qf } => {
                let goal = vector::<NX>("cost.x_goal", x_goal)?;
                let r = vector::<NU>("cost.R", r)?;
                let qf = vector::<NX>("cost.Qf", qf)?;
                (
                    Arc::new(QuadraticCost::diagonal(
                        &[0.0; NX],
                        r.as_slice(),
                        Vector::zeros(),
                        Vector::zeros(),
                    )?),
                    Arc::new(QuadraticTerminal::diagonal(qf.as_slice(), goal)?),
                )
            }
        };
        let mut problem = Problem::new(x0, dynamics, running, terminal, self.horizon)?;
        problem.set_control_bounds(self.bounds::<NU>()?)?;
        Ok(problem)
    }

    /// The problem and its obstacle constraints for the 4-state models (`"car"`, `"point"`).
    pub fn car_or_point(&self) -> Result<(Problem<U4, U2>, Constraints<U4, U2>)> {
        let dynamics: Arc<dyn Dynamics<U4, U2>> = match self.model.as_str() {
            "car" => Arc::new(Car::new(self.dt)?),
            "point" => Arc::new(DoubleIntegrator2D::new(self.dt)?),
            other => {
                return Err(Error::invalid(
                    "model",
                    format!("expected \"car\" or \"point\" for a 4-state problem, got {other:?}"),
                ))
            }
        };
        let problem = self.build(dynamics)?;
        Ok((problem, self.circles()?))
    }

    /// The problem and its obstacle constraints for `"unicycle"`.
    pub fn unicycle(&self) -> Result<(Problem<U3, U2>, Constraints<U3, U2>)> {
        if self.model != "unicycle" {
            return Err(Error::invalid(
                "model",
                format!("expected \"unicycle\", got {:?}", self.model),
            ));
        }
        let problem = self.build(Arc::new(Unicycle::new(self.dt)?))?;
        Ok((problem, self.circles()?))
    }

    fn circles<const NX: usize, const NU: usize>(&self) -> Result<Vec<Arc<dyn Constraint<Const<NX>, Const<NU>>>>> {
        self.obstacles
            .iter()
            .map(|o| {
                Ok(Arc::new(Circle::<Const<NX>>::squared([o[0], o[1]], o[2], [0, 1])?)
                    as Arc<dyn Constraint<Const<NX>, Const<NU>>>)
            })
            .collect()
    }
}
