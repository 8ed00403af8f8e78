//! From Python's run-time `(nx, nu)` to ddp-core's dimension types.
//!
//! ddp-core is generic over nalgebra dimensions: `Const<N>` for compiled sizes (stack matrices,
//! unrolled loops) and `Dyn` for sizes known only at run time. The bindings keep one `Any*` enum
//! variant per compiled pair (the built-in robots' sizes and those of the textbook robots users
//! bring most, a cart-pole or acrobot and a planar quadrotor: the fixed-size fast path, 0.82x the
//! time of run-time sizes on the traced planar quadrotor's obstacle solve) plus one
//! variant `Dyn` for every other size. Binding code is written once, as generic functions
//! `f::<NX, NU>` bounded by [`Pair`]; [`with_dims!`] calls `f::<Const<a>, Const<b>>` for a
//! compiled pair and `f::<Dyn, Dyn>` for any other valid pair, so one text serves both.
//!
//! The compiled pairs are written once, in [`compiled_pairs!`]; [`define_pairs!`] turns them into
//!
//! - the enums [`AnyDynamics`], [`AnyProblem`] and [`AnySolver`];
//! - the [`Pair`] impls of [`Dispatch`]: generic code reaches the variant of its own dimensions;
//! - `with_dims!(nx, nu, f(args))`: `f::<Const<a>, Const<b>>(args)` or `f::<Dyn, Dyn>(args)`
//!   (sizes of 0 or past [`ddp_core::dims::MAX_STATES`] / [`ddp_core::dims::MAX_CONTROLS`] are an
//!   error naming `nx` or `nu`);
//!
//! Adding a pair is one line in [`compiled_pairs!`].

use std::sync::Arc;

use ddp_core::dims::{check_size, Alloc, Const, DefaultAllocator, Dim, Dyn, MAX_CONTROLS, MAX_STATES};
use ddp_core::{Dynamics, Problem, Solver};

use crate::errors::{shape, CoreError, CoreResult};

/// Calls `$m!(D3x2 = (3, 2), ...)` with the compiled `(nx, nu)` pairs: the one list of them.
/// A `$` after the macro name is passed first, for macros that define macros.
macro_rules! compiled_pairs {
    ($m:ident $($d:tt)?) => {
        $m!($($d)?
            D3x2 = (3, 2),   // Unicycle, DifferentialDrive
            D4x2 = (4, 2),   // DoubleIntegrator2D, Car
            D12x4 = (12, 4), // Quadrotor
            D10x5 = (10, 5), // ArmBase
            D4x1 = (4, 1),   // a cart-pole, an acrobot (models users bring)
            D6x2 = (6, 2),   // a planar quadrotor (models users bring)
        );
    };
}

/// Access to the variant of each `Any*` enum that holds `(NX, NU)`; implemented for [`Dispatch`]
/// for every compiled pair (`Const`, `Const`) and for (`Dyn`, `Dyn`), so generic code states
/// `where DefaultAllocator: Alloc<NX, NU>, Dispatch: Pair<NX, NU>`.
pub trait Pair<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// The dynamics if `d` has these dimensions.
    fn dynamics(d: &AnyDynamics) -> Option<&Arc<dyn Dynamics<NX, NU>>>;
    /// Wraps dynamics of these dimensions.
    fn wrap_dynamics(d: Arc<dyn Dynamics<NX, NU>>) -> AnyDynamics;
    /// The problem if `p` has these dimensions.
    fn problem(p: &AnyProblem) -> Option<&Problem<NX, NU>>;
    /// The problem if `p` has these dimensions, mutably.
    fn problem_mut(p: &mut AnyProblem) -> Option<&mut Problem<NX, NU>>;
    /// Wraps a problem of these dimensions.
    fn wrap_problem(p: Problem<NX, NU>) -> AnyProblem;
    /// The solver if `s` has these dimensions.
    fn solver(s: &AnySolver) -> Option<&Solver<NX, NU>>;
    /// The solver if `s` has these dimensions, mutably.
    fn solver_mut(s: &mut AnySolver) -> Option<&mut Solver<NX, NU>>;
    /// Wraps a solver of these dimensions.
    fn wrap_solver(s: Solver<NX, NU>) -> AnySolver;
}

/// The implementor of [`Pair`].
pub struct Dispatch;

/// A mismatch between an `Any*` value and the dimensions a generic function was instantiated
/// for. The bindings construct values and their dimensions together, so this is a bug, reported,
/// never a panic.
pub fn internal_mismatch(what: &str) -> CoreError {
    crate::errors::invalid("internal", format!("{what} has unexpected dimensions (a ddpkit bug)"))
}

/// The dynamics of `d` as `(NX, NU)` dynamics.
pub fn dynamics_of<NX: Dim, NU: Dim>(d: &AnyDynamics) -> CoreResult<&Arc<dyn Dynamics<NX, NU>>>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    <Dispatch as Pair<NX, NU>>::dynamics(d).ok_or_else(|| internal_mismatch("model"))
}

/// The problem of `p` as a `(NX, NU)` problem.
pub fn problem_of<NX: Dim, NU: Dim>(p: &AnyProblem) -> CoreResult<&Problem<NX, NU>>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    <Dispatch as Pair<NX, NU>>::problem(p).ok_or_else(|| internal_mismatch("problem"))
}

/// The problem of `p` as a `(NX, NU)` problem, mutably.
pub fn problem_mut_of<NX: Dim, NU: Dim>(p: &mut AnyProblem) -> CoreResult<&mut Problem<NX, NU>>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    <Dispatch as Pair<NX, NU>>::problem_mut(p).ok_or_else(|| internal_mismatch("problem"))
}

/// The solver of `s` as a `(NX, NU)` solver.
pub fn solver_of<NX: Dim, NU: Dim>(s: &AnySolver) -> CoreResult<&Solver<NX, NU>>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    <Dispatch as Pair<NX, NU>>::solver(s).ok_or_else(|| internal_mismatch("solver"))
}

/// The solver of `s` as a `(NX, NU)` solver, mutably.
pub fn solver_mut_of<NX: Dim, NU: Dim>(s: &mut AnySolver) -> CoreResult<&mut Solver<NX, NU>>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    <Dispatch as Pair<NX, NU>>::solver_mut(s).ok_or_else(|| internal_mismatch("solver"))
}

/// The dimension values of `(nx, nu)` for the types `(NX, NU)` that [`with_dims!`] chose for them
/// (checked again: a `Const` of another size is an error, never nalgebra's panic).
pub fn dims<NX: Dim, NU: Dim>(nx: usize, nu: usize) -> CoreResult<ddp_core::Dims<NX, NU>> {
    ddp_core::Dims::new("dims", nx, nu).map_err(|e| internal_mismatch(&e.to_string()))
}

/// Checks a run-time pair before it is sent to `(Dyn, Dyn)`: at least 1, at most the limits of
/// [`ddp_core::dims`].
pub fn check_run_time(nx: usize, nu: usize) -> CoreResult<()> {
    check_size("nx", nx, None, MAX_STATES)?;
    check_size("nu", nu, None, MAX_CONTROLS)?;
    Ok(())
}

/// A size given from Python for a model the user brings (`nx`, `nu`, constraint `rows`):
/// at least 1 and at most the run-time limits of [`ddp_core::dims`] (`rows` shares the state
/// limit), checked before anything of that size is traced or allocated.
pub fn model_size(v: i64, field: &str) -> CoreResult<usize> {
    let limit = if field == "nu" { MAX_CONTROLS } else { MAX_STATES };
    let n = usize::try_from(v).map_err(|_| crate::errors::invalid(field, format!("must be at least 1, got {v}")))?;
    check_size(field, n, None, limit)?;
    Ok(n)
}

/// The error for a pair that const-generic code (Safe-CDDP) is not compiled for.
pub fn unsupported(what: &str, nx: usize, nu: usize) -> CoreError {
    let list: Vec<String> = PAIRS.iter().map(|(a, b)| format!("({a}, {b})")).collect();
    shape(
        "(nx, nu)",
        format!("({nx}, {nu})"),
        format!("one of the pairs {what} is compiled for: {}", list.join(", ")),
    )
}

/// The control dimension of the first compiled pair with `nx` states, else 1 (for evaluating a
/// state-only cost, where `nu` does not matter).
pub fn nu_for(nx: usize) -> usize {
    PAIRS.iter().find(|p| p.0 == nx).map_or(1, |p| p.1)
}

/// The `Pair` impl of one variant.
macro_rules! impl_pair {
    ($var:ident, $nx:ty, $nu:ty) => {
        #[allow(unreachable_patterns)]
        impl Pair<$nx, $nu> for Dispatch {
            fn dynamics(d: &AnyDynamics) -> Option<&Arc<dyn Dynamics<$nx, $nu>>> {
                match d {
                    AnyDynamics::$var(x) => Some(x),
                    _ => None,
                }
            }
            fn wrap_dynamics(d: Arc<dyn Dynamics<$nx, $nu>>) -> AnyDynamics {
                AnyDynamics::$var(d)
            }
            fn problem(p: &AnyProblem) -> Option<&Problem<$nx, $nu>> {
                match p {
                    AnyProblem::$var(x) => Some(x),
                    _ => None,
                }
            }
            fn problem_mut(p: &mut AnyProblem) -> Option<&mut Problem<$nx, $nu>> {
                match p {
                    AnyProblem::$var(x) => Some(x),
                    _ => None,
                }
            }
            fn wrap_problem(p: Problem<$nx, $nu>) -> AnyProblem {
                AnyProblem::$var(p)
            }
            fn solver(s: &AnySolver) -> Option<&Solver<$nx, $nu>> {
                match s {
                    AnySolver::$var(x) => Some(&**x),
                    _ => None,
                }
            }
            fn solver_mut(s: &mut AnySolver) -> Option<&mut Solver<$nx, $nu>> {
                match s {
                    AnySolver::$var(x) => Some(&mut **x),
                    _ => None,
                }
            }
            fn wrap_solver(s: Solver<$nx, $nu>) -> AnySolver {
                AnySolver::$var(Box::new(s))
            }
        }
    };
}

macro_rules! define_pairs {
    ($d:tt $( $var:ident = ($nx:literal, $nu:literal) ),+ $(,)?) => {
        /// Dynamics of a compiled pair or of run-time sizes (shared, immutable).
        #[derive(Clone)]
        pub enum AnyDynamics {
            $( #[doc = concat!("`(", $nx, ", ", $nu, ")`")] $var(Arc<dyn Dynamics<Const<$nx>, Const<$nu>>>), )+
            /// Any other `(nx, nu)`.
            Dyn(Arc<dyn Dynamics<Dyn, Dyn>>),
        }
        /// A problem of a compiled pair or of run-time sizes.
        #[derive(Clone)]
        pub enum AnyProblem {
            $( #[doc = concat!("`(", $nx, ", ", $nu, ")`")] $var(Problem<Const<$nx>, Const<$nu>>), )+
            /// Any other `(nx, nu)`.
            Dyn(Problem<Dyn, Dyn>),
        }
        /// A solver workspace of a compiled pair or of run-time sizes (boxed: the fixed-size
        /// parts differ a lot in size).
        #[derive(Clone)]
        pub enum AnySolver {
            $( #[doc = concat!("`(", $nx, ", ", $nu, ")`")] $var(Box<Solver<Const<$nx>, Const<$nu>>>), )+
            /// Any other `(nx, nu)`.
            Dyn(Box<Solver<Dyn, Dyn>>),
        }

        /// The compiled `(nx, nu)` pairs (the fixed-size fast path).
        pub const PAIRS: &[(usize, usize)] = &[ $( ($nx, $nu) ),+ ];

        $( impl_pair!($var, Const<$nx>, Const<$nu>); )+
        impl_pair!(Dyn, Dyn, Dyn);

        /// Calls the generic function `f::<NX, NU>(args)` for the run-time pair `(nx, nu)`:
        /// `Const` dimensions for a compiled pair, `Dyn` for any other; a size of 0 or past the
        /// limits gives `Err(error.into())`.
        macro_rules! with_dims {
            ($d nx:expr, $d nu:expr, $d f:ident ( $d ( $d arg:expr ),* $d (,)? )) => {
                match ($d nx, $d nu) {
                    $( ($nx, $nu) => $d f::<::ddp_core::dims::Const<$nx>, ::ddp_core::dims::Const<$nu>>( $d ( $d arg ),* ), )+
                    (nx, nu) => match $crate::dims::check_run_time(nx, nu) {
                        Ok(()) => $d f::<::ddp_core::dims::Dyn, ::ddp_core::dims::Dyn>( $d ( $d arg ),* ),
                        Err(e) => Err(::core::convert::Into::into(e)),
                    },
                }
            };
        }
    };
}

compiled_pairs!(define_pairs $);
