//! The swing-ups of `py/examples/cartpole_swingup.py` (cart-pole, N = 80, the traced fixture) and
//! `py/examples/acrobot.py` (acrobot, N = 100, traced here with [`TapeBuilder`] from the same
//! equations), in pure Rust, with the line-search and regularisation settings on the command line
//! for scans: prints the iteration table and the counts of passes.
//!
//! ```text
//! cargo run --release -p ddp-tape --example swingups [cartpole|acrobot] [ilqr|ddp] [step_factor] [mu_init] [armijo] [single|multiple]
//! ```
//!
//! The costs are the quadratic built-ins equal to the traced ones (`QuadraticCost` is
//! `1/2 x^T Q x + 1/2 u^T R u`), so iteration counts can differ by one from the Python examples.
use std::sync::Arc;

use ddp_core::costs::{QuadraticCost, QuadraticTerminal};
use ddp_core::dims::{U1, U4};
use ddp_core::{Method, Problem, Settings, Shooting, Solver, Vector};
use ddp_tape::{discretize, Binary, Integrator, TapeBuilder, TapeDynamics, TapeModel, Unary};

fn cartpole() -> Problem<U4, U1> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/cartpole.json");
    let Ok(TapeModel::Dynamics(model)) = TapeModel::load(path) else {
        panic!("{path}")
    };
    // 0.05 (p^2 + pdot^2 + thetadot^2) + 0.05 u^2, 50 |x - (0, pi, 0, 0)|^2
    Problem::new(
        Vector::<4>::zeros(),
        Arc::new(model),
        Arc::new(QuadraticCost::diagonal(&[0.1, 0.0, 0.1, 0.1], &[0.1], Vector::zeros(), Vector::zeros()).unwrap()),
        Arc::new(
            QuadraticTerminal::diagonal(&[100.0; 4], Vector::<4>::new(0.0, std::f64::consts::PI, 0.0, 0.0)).unwrap(),
        ),
        80,
    )
    .unwrap()
}

/// Spong's acrobot as `py/examples/acrobot.py` writes it, RK4, dt = 0.05.
fn acrobot_dynamics() -> TapeDynamics {
    let (m2, l1, lc1, lc2, i1, i2, g) = (1.0, 1.0, 0.5, 0.5, 1.0 / 3.0, 1.0 / 3.0, 9.81);
    let m1 = 1.0;
    let mut b = TapeBuilder::new(5);
    let x: Vec<u32> = (0..5).map(|k| b.input(k).unwrap()).collect();
    let (q1, q2, w1, w2, u) = (x[0], x[1], x[2], x[3], x[4]);
    macro_rules! c {
        ($v:expr) => {
            b.constant($v).unwrap()
        };
    }
    macro_rules! bin {
        ($op:ident, $a:expr, $bb:expr) => {{
            let (a, bb) = ($a, $bb);
            b.binary(Binary::$op, a, bb).unwrap()
        }};
    }
    let s1 = b.unary(Unary::Sin, q1).unwrap();
    let s2 = b.unary(Unary::Sin, q2).unwrap();
    let c2 = b.unary(Unary::Cos, q2).unwrap();
    let q12 = bin!(Add, q1, q2);
    let s12 = b.unary(Unary::Sin, q12).unwrap();
    let k = c!(2.0 * m2 * l1 * lc2);
    let kc2 = bin!(Mul, k, c2);
    let m11 = {
        let a = c!(i1 + i2 + m2 * l1 * l1);
        bin!(Add, a, kc2)
    };
    let m12 = {
        let a = c!(i2);
        let kk = c!(m2 * l1 * lc2);
        let t = bin!(Mul, kk, c2);
        bin!(Add, a, t)
    };
    let m22 = c!(i2);
    let h = {
        let kk = c!(m2 * l1 * lc2);
        bin!(Mul, kk, s2)
    };
    // r1 = -m1 g lc1 s1 - m2 g (l1 s1 + lc2 s12) + 2 h w1 w2 + h w2^2
    let r1 = {
        let a = c!(-m1 * g * lc1 - m2 * g * l1);
        let t1 = bin!(Mul, a, s1);
        let bb = c!(-m2 * g * lc2);
        let t2 = bin!(Mul, bb, s12);
        let two = c!(2.0);
        let hw1 = bin!(Mul, h, w1);
        let hw1w2 = bin!(Mul, hw1, w2);
        let t3 = bin!(Mul, two, hw1w2);
        let w2sq = b.powc(w2, 2.0).unwrap();
        let t4 = bin!(Mul, h, w2sq);
        let s = bin!(Add, t1, t2);
        let s = bin!(Add, s, t3);
        bin!(Add, s, t4)
    };
    // r2 = -m2 g lc2 s12 - h w1^2 + u
    let r2 = {
        let bb = c!(-m2 * g * lc2);
        let t1 = bin!(Mul, bb, s12);
        let w1sq = b.powc(w1, 2.0).unwrap();
        let t2 = bin!(Mul, h, w1sq);
        let s = bin!(Sub, t1, t2);
        bin!(Add, s, u)
    };
    let det = {
        let a = bin!(Mul, m11, m22);
        let bb = bin!(Mul, m12, m12);
        bin!(Sub, a, bb)
    };
    let a1 = {
        let a = bin!(Mul, m22, r1);
        let bb = bin!(Mul, m12, r2);
        let n = bin!(Sub, a, bb);
        bin!(Div, n, det)
    };
    let a2 = {
        let a = bin!(Mul, m11, r2);
        let bb = bin!(Mul, m12, r1);
        let n = bin!(Sub, a, bb);
        bin!(Div, n, det)
    };
    let ode = b.finish(&[w1, w2, a1, a2]).unwrap();
    TapeDynamics::new(discretize(&ode, 4, 1, 0.05, Integrator::Rk4).unwrap(), 4, 1).unwrap()
}

fn acrobot() -> Problem<U4, U1> {
    // 0.01 (w1^2 + w2^2) + 0.01 u^2, 100 ((q1 - pi)^2 + q2^2) + 10 (w1^2 + w2^2)
    Problem::new(
        Vector::<4>::zeros(),
        Arc::new(acrobot_dynamics()),
        Arc::new(QuadraticCost::diagonal(&[0.0, 0.0, 0.02, 0.02], &[0.02], Vector::zeros(), Vector::zeros()).unwrap()),
        Arc::new(
            QuadraticTerminal::diagonal(
                &[200.0, 200.0, 20.0, 20.0],
                Vector::<4>::new(std::f64::consts::PI, 0.0, 0.0, 0.0),
            )
            .unwrap(),
        ),
        100,
    )
    .unwrap()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |i: usize| args.get(i).map(String::as_str);
    let number = |i: usize, default: f64| arg(i).map_or(default, |v| v.parse().expect("a number"));
    let problem = match arg(1).unwrap_or("cartpole") {
        "acrobot" => acrobot(),
        _ => cartpole(),
    };
    let method = match arg(2).unwrap_or("ddp") {
        "ilqr" => Method::Ilqr,
        _ => Method::Ddp,
    };
    let mut settings = Settings {
        method,
        max_iterations: 500,
        ..Settings::default()
    };
    settings.line_search.step_factor = number(3, settings.line_search.step_factor);
    settings.regularization.mu_init = number(4, settings.regularization.mu_init);
    settings.line_search.armijo = number(5, settings.line_search.armijo);
    if arg(6) == Some("multiple") {
        settings.shooting = Shooting::Multiple;
    }
    let mut solver = Solver::new(&problem, settings).expect("valid settings");
    let r = solver.solve(&problem).expect("a problem of the solver's sizes");
    print!("{}", r.table());
    println!(
        "backward passes {}, forward passes {}, Gauss-Newton knots {}, defect {:.1e}",
        r.backward_passes, r.forward_passes, r.gauss_newton_knots, r.defect
    );
}
