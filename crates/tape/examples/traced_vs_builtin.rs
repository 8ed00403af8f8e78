//! Traced models against the built-in analytic ones, in one process run: P1 (Crocoddyl's
//! unicycle, N = 100) and the 12-state quadrotor reach (N = 50), same costs, same solver; the
//! traced tapes come from `bench/own_robot/make_fixtures.py` (traced in Python from the built-in
//! models' equations). Prints microseconds per iteration and the ratio (target: at most 1.5).
//!
//! ```text
//! cargo run --release -p ddp-tape --example traced_vs_builtin
//! ```
//!
//! `traced_vs_builtin PROBLEM METHOD MODEL REPS` (`unicycle|quadrotor`, `ilqr|ddp`,
//! `builtin|traced`, a count) runs one case only, `REPS` solves, and prints nothing: for
//! instruction counts under `valgrind --tool=callgrind`, which are repeatable on a loaded
//! machine where wall-clock times are not (subtract a `REPS = 0` run for the set-up).
use std::sync::Arc;
use std::time::Instant;

use ddp_core::dims::Dim;
use ddp_core::{reference, Dynamics, Knot, Problem, Settings, Solver};
use ddp_tape::TapeModel;
use nalgebra::allocator::Allocator;

fn load(name: &str) -> ddp_tape::TapeDynamics {
    let path = format!("{}/tests/data/{name}.json", env!("CARGO_MANIFEST_DIR"));
    match TapeModel::load(&path) {
        Ok(TapeModel::Dynamics(d)) => d,
        other => panic!("{path}: {other:?}"),
    }
}

fn with_dynamics<NX: Dim, NU: Dim>(p: &Problem<NX, NU>, d: Arc<dyn Dynamics<NX, NU>>) -> Problem<NX, NU>
where
    nalgebra::DefaultAllocator: ddp_core::dims::Alloc<NX, NU> + Allocator<NX>,
{
    let mut q = p.clone();
    for k in 0..q.horizon() {
        let cost = q.knots()[k].cost.clone();
        q.set_knot(
            k,
            Knot {
                dynamics: d.clone(),
                cost,
            },
        )
        .expect("same sizes");
    }
    q
}

/// Median microseconds per iteration over `reps` solves, and the iterations of one solve.
fn time<NX: Dim, NU: Dim>(p: &Problem<NX, NU>, settings: Settings, reps: usize) -> (f64, usize, f64)
where
    nalgebra::DefaultAllocator: ddp_core::dims::Alloc<NX, NU>,
{
    let mut s = Solver::new(p, settings).expect("solver");
    let mut per_iter = Vec::with_capacity(reps);
    let (mut iters, mut cost) = (0, 0.0);
    for _ in 0..reps {
        s.reset();
        let t = Instant::now();
        let r = s.solve(p).expect("solve");
        let dt = t.elapsed().as_secs_f64();
        iters = r.iterations;
        cost = r.cost;
        per_iter.push(dt * 1e6 / r.iterations.max(1) as f64);
    }
    per_iter.sort_by(f64::total_cmp);
    (per_iter[reps / 2], iters, cost)
}

fn row<NX: Dim, NU: Dim>(name: &str, builtin: &Problem<NX, NU>, traced: &Problem<NX, NU>, method: ddp_core::Method)
where
    nalgebra::DefaultAllocator: ddp_core::dims::Alloc<NX, NU>,
{
    let settings = Settings {
        method,
        ..Settings::default()
    };
    let (tb, ib, cb) = time(builtin, settings, 200);
    let (tt, it, ct) = time(traced, settings, 200);
    println!(
        "{name:<22} {method:<5?} built-in {tb:8.2} us/iter ({ib} it, cost {cb:.6})  traced {tt:8.2} us/iter ({it} it, cost {ct:.6})  ratio {:.2}",
        tt / tb
    );
}

/// One case, `reps` solves, nothing printed (for instruction counts).
fn one(args: &[String]) {
    let reps: usize = args[3].parse().expect("REPS is a count");
    let settings = Settings {
        method: match args[1].as_str() {
            "ilqr" => ddp_core::Method::Ilqr,
            "ddp" => ddp_core::Method::Ddp,
            m => panic!("METHOD is ilqr or ddp, got {m}"),
        },
        ..Settings::default()
    };
    let traced = match args[2].as_str() {
        "builtin" => false,
        "traced" => true,
        m => panic!("MODEL is builtin or traced, got {m}"),
    };
    fn run<NX: Dim, NU: Dim>(p: &Problem<NX, NU>, settings: Settings, reps: usize)
    where
        nalgebra::DefaultAllocator: ddp_core::dims::Alloc<NX, NU>,
    {
        let mut s = Solver::new(p, settings).expect("solver");
        for _ in 0..reps {
            s.reset();
            std::hint::black_box(s.solve(p).expect("solve"));
        }
    }
    match args[0].as_str() {
        "unicycle" => {
            let p = reference::p1_unicycle();
            let p = if traced {
                with_dynamics(&p, Arc::new(load("unicycle")))
            } else {
                p
            };
            run(&p, settings, reps)
        }
        "quadrotor" => {
            let p = reference::quadrotor_reach();
            let p = if traced {
                with_dynamics(&p, Arc::new(load("quadrotor")))
            } else {
                p
            };
            run(&p, settings, reps)
        }
        m => panic!("PROBLEM is unicycle or quadrotor, got {m}"),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() == 4 {
        return one(&args);
    }
    let p1 = reference::p1_unicycle();
    let p1_traced = with_dynamics(&p1, Arc::new(load("unicycle")));
    let quad = reference::quadrotor_reach();
    let quad_traced = with_dynamics(&quad, Arc::new(load("quadrotor")));
    for method in [ddp_core::Method::Ilqr, ddp_core::Method::Ddp] {
        row("P1 unicycle N=100", &p1, &p1_traced, method);
        row("quadrotor reach N=50", &quad, &quad_traced, method);
    }
}
