//! The `(nx, nu)` pairs this wheel is compiled for.
//!
//! Python sees runtime dimensions; ddp-core's models, problems and solvers are const-generic
//! (`Problem<NX, NU>`). [`define_pairs!`] turns one list of pairs into
//!
//! - the enums [`AnyDynamics`], [`AnyProblem`] and [`AnySolver`], one variant per pair;
//! - [`Pair<NX, NU>`] for [`Dims`]: generic code reaches the variant of its own pair;
//! - `with_dims!(nx, nu, f(args))`: calls `f::<NX, NU>(args)` for a runtime pair, or returns
//!   a `ShapeError` naming the supported pairs.
//!
//! Adding a pair is one line in the `define_pairs!` invocation at the bottom.

use std::sync::Arc;

use ddp_core::{Dynamics, Problem, Solver};

use crate::errors::{shape, CoreError};

/// Access to the variant of each `Any*` enum that holds `(NX, NU)`; implemented for [`Dims`] for
/// every compiled pair, so generic code states `where Dims: Pair<NX, NU>`.
pub trait Pair<const NX: usize, const NU: usize> {
    /// The dynamics if `d` has this pair.
    fn dynamics(d: &AnyDynamics) -> Option<&Arc<dyn Dynamics<NX, NU>>>;
    /// Wraps dynamics of this pair.
    fn wrap_dynamics(d: Arc<dyn Dynamics<NX, NU>>) -> AnyDynamics;
    /// The problem if `p` has this pair.
    fn problem(p: &AnyProblem) -> Option<&Problem<NX, NU>>;
    /// The problem if `p` has this pair, mutably.
    fn problem_mut(p: &mut AnyProblem) -> Option<&mut Problem<NX, NU>>;
    /// Wraps a problem of this pair.
    fn wrap_problem(p: Problem<NX, NU>) -> AnyProblem;
    /// The solver if `s` has this pair, mutably.
    fn solver_mut(s: &mut AnySolver) -> Option<&mut Solver<NX, NU>>;
    /// The solver if `s` has this pair.
    fn solver(s: &AnySolver) -> Option<&Solver<NX, NU>>;
    /// Wraps a solver of this pair.
    fn wrap_solver(s: Solver<NX, NU>) -> AnySolver;
}

/// The implementor of [`Pair`] for every compiled `(nx, nu)`.
pub struct Dims;

/// The error for a pair this build does not support.
pub fn unsupported(nx: usize, nu: usize) -> CoreError {
    let list: Vec<String> = PAIRS.iter().map(|(a, b)| format!("({a}, {b})")).collect();
    shape(
        "(nx, nu)",
        format!("({nx}, {nu})"),
        format!("one of the compiled pairs {}", list.join(", ")),
    )
}

/// The control dimension of the first compiled pair with `nx` states (for state-only costs).
pub fn nu_for(nx: usize) -> Option<usize> {
    PAIRS.iter().find(|p| p.0 == nx).map(|p| p.1)
}

/// A mismatch between an `Any*` value and the pair a generic function was instantiated for. The
/// bindings construct values and their pair together, so this is a bug, reported, never a panic.
pub fn internal_mismatch(what: &str) -> CoreError {
    crate::errors::invalid("internal", format!("{what} has unexpected dimensions (a ddpkit bug)"))
}

macro_rules! define_pairs {
    ($d:tt $( $var:ident = ($nx:literal, $nu:literal) ),+ $(,)?) => {
        /// Dynamics of any compiled pair (shared, immutable).
        #[derive(Clone)]
        pub enum AnyDynamics { $( #[doc = concat!("`(", $nx, ", ", $nu, ")`")] $var(Arc<dyn Dynamics<$nx, $nu>>) ),+ }
        /// A problem of any compiled pair.
        #[derive(Clone)]
        pub enum AnyProblem { $( #[doc = concat!("`(", $nx, ", ", $nu, ")`")] $var(Problem<$nx, $nu>) ),+ }
        /// A solver workspace of any compiled pair (boxed: the fixed-size parts differ a lot in size).
        #[derive(Clone)]
        pub enum AnySolver { $( #[doc = concat!("`(", $nx, ", ", $nu, ")`")] $var(Box<Solver<$nx, $nu>>) ),+ }

        /// The compiled `(nx, nu)` pairs.
        pub const PAIRS: &[(usize, usize)] = &[ $( ($nx, $nu) ),+ ];

        $(
            #[allow(unreachable_patterns)]
            impl Pair<$nx, $nu> for Dims {
                fn dynamics(d: &AnyDynamics) -> Option<&Arc<dyn Dynamics<$nx, $nu>>> {
                    match d { AnyDynamics::$var(x) => Some(x), _ => None }
                }
                fn wrap_dynamics(d: Arc<dyn Dynamics<$nx, $nu>>) -> AnyDynamics {
                    AnyDynamics::$var(d)
                }
                fn problem(p: &AnyProblem) -> Option<&Problem<$nx, $nu>> {
                    match p { AnyProblem::$var(x) => Some(x), _ => None }
                }
                fn problem_mut(p: &mut AnyProblem) -> Option<&mut Problem<$nx, $nu>> {
                    match p { AnyProblem::$var(x) => Some(x), _ => None }
                }
                fn wrap_problem(p: Problem<$nx, $nu>) -> AnyProblem {
                    AnyProblem::$var(p)
                }
                fn solver_mut(s: &mut AnySolver) -> Option<&mut Solver<$nx, $nu>> {
                    match s { AnySolver::$var(x) => Some(&mut **x), _ => None }
                }
                fn solver(s: &AnySolver) -> Option<&Solver<$nx, $nu>> {
                    match s { AnySolver::$var(x) => Some(&**x), _ => None }
                }
                fn wrap_solver(s: Solver<$nx, $nu>) -> AnySolver {
                    AnySolver::$var(Box::new(s))
                }
            }
        )+

        /// Calls the generic function `f::<NX, NU>(args)` for the runtime pair `(nx, nu)`; an
        /// unsupported pair gives `Err(unsupported(nx, nu).into())`.
        macro_rules! with_dims {
            ($d nx:expr, $d nu:expr, $d f:ident ( $d ( $d arg:expr ),* $d (,)? )) => {
                match ($d nx, $d nu) {
                    $( ($nx, $nu) => $d f::<$nx, $nu>( $d ( $d arg ),* ), )+
                    (nx, nu) => Err(::core::convert::Into::into($crate::dims::unsupported(nx, nu))),
                }
            };
        }
    };
}

// One line per compiled (nx, nu) pair: the built-in models' dimensions.
define_pairs!($
    D3x2 = (3, 2),   // Unicycle, DifferentialDrive
    D4x2 = (4, 2),   // DoubleIntegrator2D, Car
    D12x4 = (12, 4), // Quadrotor
    D10x5 = (10, 5), // ArmBase
);
