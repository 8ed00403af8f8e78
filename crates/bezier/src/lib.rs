//! # bezier
//!
//! Bézier curves and splines for robot trajectories (after Queen Elizabeth's School (2022),
//! *Developing a Minimum-Error Trajectory Generation Framework*): evaluation, derivatives,
//! curvature, exact bounding boxes, subdivision, degree elevation, arc length (a-priori adaptive
//! Gauss-Legendre to `1e-10` and beyond, with AVX-512 or AVX2 sums chosen at run time and a batch
//! form, [`CubicBez::arclen_batch`]; and Simpson's rule as in the paper), inverse arc length,
//! uniform resampling; C1/C2 splines through waypoints with the paper's jerk and curvature costs
//! and a direct optimiser; the sigmoid motion profile and the time-parametrised trajectory, sampled
//! as states and controls for the unicycle and car models of `ddp-core`.
//!
//! ```
//! use bezier::{CubicBez, Point, ParamCurve, ParamCurveArclen, ParamCurveCurvature, DEFAULT_ACCURACY};
//! use bezier::{Spline, SigmoidProfile, Trajectory};
//!
//! // One segment: length, the parameter at half the length, curvature there.
//! let c = CubicBez::new((0.0, 0.0), (1.0, 1.0), (2.0, 1.0), (3.0, 0.0));
//! let len = c.arclen(1e-10);
//! let t_half = c.inv_arclen(0.5 * len, 1e-10);
//! assert!((c.arclen_range(0.0, t_half, 1e-12) - 0.5 * len).abs() < 1e-9);
//! assert!(c.curvature(t_half) < 0.0); // turning right at the top
//!
//! // A spline through waypoints, a sigmoid profile capped at 1 m/s, DDP reference for a unicycle.
//! let waypoints = [Point::new(0.0, 0.0), Point::new(2.0, 1.0), Point::new(4.0, 0.0)];
//! let spline = Spline::catmull_rom(&waypoints).unwrap();
//! let profile = SigmoidProfile::with_max_speed(spline.arclen(DEFAULT_ACCURACY), 10.0, 0.5, 1.0).unwrap();
//! let traj = Trajectory::new(spline, profile).unwrap();
//! let (x, u) = traj.unicycle(0.1, 50).unwrap();
//! assert_eq!((x.len(), u.len()), (51, 50));
//! assert!(u.iter().all(|u| u[0] <= 1.0 + 1e-6)); // speed bound respected
//! ```
//!
//! ## Symbols
//!
//! | paper | here |
//! |---|---|
//! | `B(t)`, control points `P_i` | [`ParamCurve::eval`], `points` |
//! | `K(t)` curvature | [`ParamCurveCurvature::curvature`] (signed) |
//! | jerk functional `int x'''(t)^2 dt` | [`Trajectory::jerk_cost_integral`], [`Trajectory::jerk_cost_discrete`] (the paper's) |
//! | sum of `|K|` at the reference points | [`Trajectory::curvature_sum`] |
//! | sigmoid steepness `m`, midpoint `k` | [`SigmoidProfile`] `m`, `k` |

// `!(x > 0.0)` is deliberate throughout: it is true for NaN, which must take the defined path.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod accuracy;
pub mod bernstein;
mod bezier;
mod branch_tables;
mod cubic;
pub mod error;
mod gauss_legendre;
#[cfg(target_arch = "x86_64")]
mod gauss_simd;
pub mod optimize;
pub mod point;
pub mod profile;
mod quad;
pub mod quadrature;
pub mod spline;
pub mod traits;

pub use crate::bezier::{Bezier, BezierDyn};
pub use cubic::{CubicArclen, CubicBez};
pub use error::{Error, Result};
pub use optimize::{optimize_spline, JerkMeasure, OptimizeReport, OptimizeSettings, OptimizeStatus, SplineCost};
pub use point::{Point, Rect, Vec2};
pub use profile::{SigmoidProfile, StatesControls, Trajectory, TrajectorySample};
pub use quad::QuadBez;
pub use spline::{Continuity, Spline};
pub use traits::{
    curvature_deriv_from, curvature_from, ParamCurve, ParamCurveArclen, ParamCurveCurvature, ParamCurveDeriv,
    ParamCurveExtrema, DEFAULT_ACCURACY, RELATIVE_ACCURACY_FLOOR,
};

/// The instructions the arc-length sums run with on this CPU: `"avx512"`, `"avx2+fma"` or
/// `"portable"`, chosen at run time (the environment variable `DDPKIT_SIMD` narrows the choice:
/// `avx2` or `off`). Results agree to an ulp or two across them; speed does not.
pub fn simd_level() -> &'static str {
    #[cfg(target_arch = "x86_64")]
    match gauss_simd::available() {
        Some(gauss_simd::Simd::V4(_)) => return "avx512",
        Some(gauss_simd::Simd::V3(_)) => return "avx2+fma",
        None => {}
    }
    "portable"
}
