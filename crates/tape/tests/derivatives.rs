//! Tape derivatives against finite differences (every operation) and closed forms (a pendulum
//! with RK4, a quadratic cost), tape models in the solver against the built-in unicycle, sharing
//! of common subexpressions, and the file format (round trip, corrupt files never panic).

use std::sync::Arc;

use ddp_core::costs::{QuadraticCost, QuadraticTerminal};
use ddp_core::dims::{Dyn, VectorN, U1, U2, U3};
use ddp_core::models::Unicycle;
use ddp_core::{Cost, CostDerivatives, Dynamics, Matrix, Problem, Settings, Solver, Vector};
use ddp_tape::{discretize, Binary, Integrator, Node, Tape, TapeBuilder, TapeConstraint, TapeCost, TapeDynamics};
use ddp_tape::{TapeModel, TapeTerminal, Unary, Workspace};
use proptest::prelude::*;
use safe_cddp::Constraint;

/// Jacobian rows of every output (exact, forward tangents).
fn jacobian(t: &Tape, z: &[f64]) -> Vec<Vec<f64>> {
    let mut ws = Workspace::default();
    t.forward(z, &mut ws, true);
    let n = t.n_inputs();
    t.outputs()
        .iter()
        .map(|&o| {
            let mut row = vec![0.0; n];
            t.tangent_row(&ws, o as usize, &mut row);
            row
        })
        .collect()
}

fn values(t: &Tape, z: &[f64]) -> Vec<f64> {
    let mut ws = Workspace::default();
    let mut out = vec![0.0; t.n_outputs()];
    t.values(z, &mut ws, &mut out);
    out
}

/// Gradient and Hessian of `lambda' F` (second-order adjoints).
fn weighted(t: &Tape, z: &[f64], lambda: &[f64]) -> (Vec<f64>, Vec<Vec<f64>>) {
    let n = t.n_inputs();
    let mut ws = Workspace::default();
    t.forward(z, &mut ws, true);
    let (mut g, mut h) = (vec![0.0; n], vec![vec![0.0; n]; n]);
    t.second_order(lambda, &mut ws, |k, gk, hk| {
        g[k] += gk;
        for j in 0..n {
            h[k][j] += hk[j];
        }
    });
    (g, h)
}

/// Largest error of the Jacobian (against central differences of the values) and of the weighted
/// Hessian (against central differences of the exact weighted gradient), relative to `1 + |ref|`.
fn fd_errors(t: &Tape, z: &[f64], lambda: &[f64]) -> (f64, f64) {
    let n = t.n_inputs();
    let h = 1e-6;
    let jac = jacobian(t, z);
    let (g, hess) = weighted(t, z, lambda);
    let (mut ej, mut eh) = (0.0f64, 0.0f64);
    for j in 0..n {
        let (mut zp, mut zm) = (z.to_vec(), z.to_vec());
        zp[j] += h;
        zm[j] -= h;
        let (vp, vm) = (values(t, &zp), values(t, &zm));
        for i in 0..t.n_outputs() {
            let fd = (vp[i] - vm[i]) / (2.0 * h);
            ej = ej.max((fd - jac[i][j]).abs() / (1.0 + fd.abs()));
        }
        let (gp, _) = weighted(t, &zp, lambda);
        let (gm, _) = weighted(t, &zm, lambda);
        for k in 0..n {
            let fd = (gp[k] - gm[k]) / (2.0 * h);
            eh = eh.max((fd - hess[k][j]).abs() / (1.0 + fd.abs()));
        }
    }
    // The weighted gradient is lambda' J.
    for k in 0..n {
        let jl: f64 = (0..t.n_outputs()).map(|i| lambda[i] * jac[i][k]).sum();
        ej = ej.max((jl - g[k]).abs() / (1.0 + jl.abs()));
    }
    (ej, eh)
}

/// A point inside each operation's domain (its argument lands in `(lo, hi)`).
fn domain(op: &str) -> (f64, f64) {
    match op {
        "log" | "sqrt" | "inv" => (0.5, 2.0),
        "acosh" => (1.5, 3.0),
        "asin" | "acos" | "atanh" => (-0.6, 0.6),
        "tan" => (-1.0, 1.0),
        _ => (-1.5, 1.5),
    }
}

#[test]
fn every_unary_operation_matches_finite_differences() {
    for name in Unary::names() {
        let op = Unary::from_name(name).unwrap();
        let (lo, hi) = domain(name);
        // F = [op(a), op(a) * z2 + z1 * z2] with a = lo + (hi - lo) * (0.3 + 0.4 z0 z1), so the
        // argument is a product of inputs (chain rule and cross terms).
        let mut b = TapeBuilder::new(3);
        let (z0, z1, z2) = (b.input(0).unwrap(), b.input(1).unwrap(), b.input(2).unwrap());
        let p = b.binary(Binary::Mul, z0, z1).unwrap();
        let c04 = b.constant(0.4 * (hi - lo)).unwrap();
        let s = b.binary(Binary::Mul, c04, p).unwrap();
        let off = b.constant(lo + 0.3 * (hi - lo)).unwrap();
        let a = b.binary(Binary::Add, off, s).unwrap();
        let v = b.unary(op, a).unwrap();
        let w = b.binary(Binary::Mul, v, z2).unwrap();
        let q = b.binary(Binary::Mul, z1, z2).unwrap();
        let w = b.binary(Binary::Add, w, q).unwrap();
        let t = b.finish(&[v, w]).unwrap();
        for z in [[0.7, 0.9, -0.4], [0.2, 0.5, 1.3], [0.95, 0.35, 0.8]] {
            let (ej, eh) = fd_errors(&t, &z, &[0.7, -1.3]);
            assert!(
                ej < 1e-7 && eh < 1e-6,
                "{name} at {z:?}: jacobian {ej:e}, hessian {eh:e}"
            );
        }
    }
}

#[test]
fn every_binary_operation_matches_finite_differences() {
    for name in Binary::names() {
        let op = Binary::from_name(name).unwrap();
        // F = [op(a, b), op(a, a) + op(b, z0)] with a = z0 z1 + 0.8, b = z2 - 0.3 z0 (positive
        // where pow needs it), covering shared arguments.
        let mut b = TapeBuilder::new(3);
        let (z0, z1, z2) = (b.input(0).unwrap(), b.input(1).unwrap(), b.input(2).unwrap());
        let p = b.binary(Binary::Mul, z0, z1).unwrap();
        let c = b.constant(0.8).unwrap();
        let a = b.binary(Binary::Add, p, c).unwrap();
        let c3 = b.constant(0.3).unwrap();
        let t0 = b.binary(Binary::Mul, c3, z0).unwrap();
        let bb = b.binary(Binary::Sub, z2, t0).unwrap();
        let v = b.binary(op, a, bb).unwrap();
        let aa = b.binary(op, a, a).unwrap();
        let bz = b.binary(op, bb, z0).unwrap();
        let w = b.binary(Binary::Add, aa, bz).unwrap();
        let t = b.finish(&[v, w]).unwrap();
        for z in [[0.7, 0.9, 1.4], [0.4, 0.5, 2.3], [1.1, -0.2, 0.9]] {
            let (ej, eh) = fd_errors(&t, &z, &[0.7, -1.3]);
            assert!(
                ej < 1e-7 && eh < 1e-6,
                "{name} at {z:?}: jacobian {ej:e}, hessian {eh:e}"
            );
        }
    }
}

#[test]
fn constant_powers_match_finite_differences_and_closed_forms() {
    for p in [2.0, 3.0, -1.0, 0.5, 2.5, -2.0] {
        let mut b = TapeBuilder::new(2);
        let (z0, z1) = (b.input(0).unwrap(), b.input(1).unwrap());
        let s = b.binary(Binary::Add, z0, z1).unwrap();
        let v = b.powc(s, p).unwrap();
        let t = b.finish(&[v]).unwrap();
        let z = [0.6, 0.7];
        let (ej, eh) = fd_errors(&t, &z, &[1.0]);
        assert!(ej < 1e-7 && eh < 1e-6, "powc {p}: {ej:e} {eh:e}");
        let (g, h) = weighted(&t, &z, &[1.0]);
        let a: f64 = 1.3;
        assert!((g[0] - p * a.powf(p - 1.0)).abs() < 1e-12);
        assert!((h[0][1] - p * (p - 1.0) * a.powf(p - 2.0)).abs() < 1e-12);
    }
    // x^2 at 0: no 0 * inf in the second derivative.
    let mut b = TapeBuilder::new(1);
    let z = b.input(0).unwrap();
    let v = b.powc(z, 2.0).unwrap();
    let t = b.finish(&[v]).unwrap();
    let (g, h) = weighted(&t, &[0.0], &[1.0]);
    assert_eq!((g[0], h[0][0]), (0.0, 2.0));
}

/// The pendulum `xdot = (w, u - 9.81 sin q - 0.1 w)` as a tape.
fn pendulum_ode() -> Tape {
    let mut b = TapeBuilder::new(3);
    let (q, w, u) = (b.input(0).unwrap(), b.input(1).unwrap(), b.input(2).unwrap());
    let s = b.unary(Unary::Sin, q).unwrap();
    let g = b.constant(9.81).unwrap();
    let gs = b.binary(Binary::Mul, g, s).unwrap();
    let d = b.constant(0.1).unwrap();
    let dw = b.binary(Binary::Mul, d, w).unwrap();
    let a = b.binary(Binary::Sub, u, gs).unwrap();
    let a = b.binary(Binary::Sub, a, dw).unwrap();
    b.finish(&[w, a]).unwrap()
}

/// The same pendulum and RK4 step written by hand for any dual-number scalar.
struct HandPendulum;
impl ddp_core::autodiff::DualDynamics<2, 1> for HandPendulum {
    fn step_generic<T: ddp_core::autodiff::Scalar>(&self, x: &[T; 2], u: &[T; 1]) -> [T; 2] {
        let dt = 0.05;
        let f = |x: [T; 2]| [x[1], u[0] - x[0].sin() * 9.81 - x[1] * 0.1];
        let add = |x: [T; 2], k: [T; 2], h: f64| [x[0] + k[0] * h, x[1] + k[1] * h];
        let k1 = f(*x);
        let k2 = f(add(*x, k1, 0.5 * dt));
        let k3 = f(add(*x, k2, 0.5 * dt));
        let k4 = f(add(*x, k3, dt));
        std::array::from_fn(|i| x[i] + (k1[i] + k2[i] * 2.0 + k3[i] * 2.0 + k4[i]) * (dt / 6.0))
    }
}

#[test]
fn rk4_tape_equals_the_hand_written_model_and_its_dual_number_derivatives() {
    let tape = discretize(&pendulum_ode(), 2, 1, 0.05, Integrator::Rk4).unwrap();
    let m = TapeDynamics::new(tape, 2, 1).unwrap();
    let hand = ddp_core::autodiff::AutoDiff(HandPendulum);
    let (x, u) = (Vector::<2>::new(0.8, -0.4), Vector::<1>::new(0.3));
    let (a, b) = (Dynamics::<U2, U1>::step(&m, &x, &u), hand.step(&x, &u));
    assert!((a - b).amax() < 1e-14, "{a} vs {b}");
    let (mut fx, mut fu, mut gx, mut gu) = (
        Matrix::<2, 2>::zeros(),
        Matrix::<2, 1>::zeros(),
        Matrix::<2, 2>::zeros(),
        Matrix::<2, 1>::zeros(),
    );
    Dynamics::<U2, U1>::jacobians(&m, &x, &u, &mut fx, &mut fu);
    hand.jacobians(&x, &u, &mut gx, &mut gu);
    assert!((fx - gx).amax() < 1e-13 && (fu - gu).amax() < 1e-13);
    let lambda = Vector::<2>::new(1.7, -0.6);
    let (mut h1, mut h2, mut h3) = (
        Matrix::<2, 2>::zeros(),
        Matrix::<1, 2>::zeros(),
        Matrix::<1, 1>::zeros(),
    );
    let (mut k1, mut k2, mut k3) = (
        Matrix::<2, 2>::zeros(),
        Matrix::<1, 2>::zeros(),
        Matrix::<1, 1>::zeros(),
    );
    Dynamics::<U2, U1>::add_second_order(&m, &x, &u, &lambda, &mut h1, &mut h2, &mut h3);
    hand.add_second_order(&x, &u, &lambda, &mut k1, &mut k2, &mut k3);
    assert!((h1 - k1).amax() < 1e-13 && (h2 - k2).amax() < 1e-13 && (h3 - k3).amax() < 1e-13);
    // Euler is x + dt F.
    let euler = discretize(&pendulum_ode(), 2, 1, 0.05, Integrator::Euler).unwrap();
    let v = values(&euler, &[0.8, -0.4, 0.3]);
    assert!((v[1] - (-0.4 + 0.05 * (0.3 - 9.81 * 0.8f64.sin() + 0.04))).abs() < 1e-15);
}

/// Full DDP's path (`jacobians_keep` at the linearisation, `add_second_order_kept` in each
/// backward pass) gives the bits of the plain calls, and falls back to them where the kept
/// sweep is of another point or missing.
#[test]
fn kept_sweep_second_order_equals_the_plain_calls_bit_for_bit() {
    let tape = discretize(&pendulum_ode(), 2, 1, 0.05, Integrator::Rk4).unwrap();
    let m = TapeDynamics::new(tape, 2, 1).unwrap();
    let (x, u) = (Vector::<2>::new(0.8, -0.4), Vector::<1>::new(0.3));
    let lambda = Vector::<2>::new(1.7, -0.6);
    let plain = |x: &Vector<2>, u: &Vector<1>| {
        let (mut fx, mut fu) = (Matrix::<2, 2>::zeros(), Matrix::<2, 1>::zeros());
        Dynamics::<U2, U1>::jacobians(&m, x, u, &mut fx, &mut fu);
        let mut h = (
            Matrix::<2, 2>::zeros(),
            Matrix::<1, 2>::zeros(),
            Matrix::<1, 1>::zeros(),
        );
        Dynamics::<U2, U1>::add_second_order(&m, x, u, &lambda, &mut h.0, &mut h.1, &mut h.2);
        (fx, fu, h)
    };
    let kept = |x: &Vector<2>, u: &Vector<1>, data: &[f64]| {
        let mut h = (
            Matrix::<2, 2>::zeros(),
            Matrix::<1, 2>::zeros(),
            Matrix::<1, 1>::zeros(),
        );
        Dynamics::<U2, U1>::add_second_order_kept(&m, x, u, &lambda, data, &mut h.0, &mut h.1, &mut h.2);
        h
    };
    let (fx, fu, h) = plain(&x, &u);
    let mut data = Vec::new();
    assert_eq!(kept(&x, &u, &data), h, "empty data");
    let (mut gx, mut gu) = (Matrix::<2, 2>::zeros(), Matrix::<2, 1>::zeros());
    Dynamics::<U2, U1>::jacobians_keep(&m, &x, &u, &mut gx, &mut gu, &mut data);
    assert_eq!((gx, gu), (fx, fu));
    assert_eq!(kept(&x, &u, &data), h);
    assert_eq!(kept(&x, &u, &data), h, "a second backward pass");
    let x2 = Vector::<2>::new(0.1, 0.2);
    assert_eq!(kept(&x2, &u, &data), plain(&x2, &u).2, "data of another point");
}

/// `1/2 sum_i w_i (z_i - r_i)^2 + z_0 z_3` over `(x, u)` = 3 + 1.
fn quadratic_tape(w: &[f64; 4], r: &[f64; 4]) -> Tape {
    let mut b = TapeBuilder::new(4);
    let mut acc = b.constant(0.0).unwrap();
    for i in 0..4 {
        let z = b.input(i).unwrap();
        let rc = b.constant(r[i]).unwrap();
        let d = b.binary(Binary::Sub, z, rc).unwrap();
        let d2 = b.powc(d, 2.0).unwrap();
        let wc = b.constant(0.5 * w[i]).unwrap();
        let t = b.binary(Binary::Mul, wc, d2).unwrap();
        acc = b.binary(Binary::Add, acc, t).unwrap();
    }
    let (z0, z3) = (b.input(0).unwrap(), b.input(3).unwrap());
    let c = b.binary(Binary::Mul, z0, z3).unwrap();
    let out = b.binary(Binary::Add, acc, c).unwrap();
    b.finish(&[out]).unwrap()
}

#[test]
fn cost_derivatives_are_the_closed_form_of_a_quadratic() {
    let (w, r) = ([2.0, 3.0, 5.0, 7.0], [0.1, -0.2, 0.3, 0.4]);
    let cost = TapeCost::new(quadratic_tape(&w, &r), 3, 1).unwrap();
    let (x, u) = (Vector::<3>::new(1.0, 2.0, -1.0), Vector::<1>::new(0.5));
    let mut d = CostDerivatives::<U3, U1>::default();
    let v = cost.add_derivatives(&x, &u, 2.0, &mut d);
    let z = [1.0, 2.0, -1.0, 0.5];
    let exact: f64 = (0..4).map(|i| 0.5 * w[i] * (z[i] - r[i]).powi(2)).sum::<f64>() + z[0] * z[3];
    assert!((v - 2.0 * exact).abs() < 1e-13);
    for i in 0..3 {
        let gi = w[i] * (z[i] - r[i]) + if i == 0 { z[3] } else { 0.0 };
        assert!((d.lx[i] - 2.0 * gi).abs() < 1e-13);
        for j in 0..3 {
            assert_eq!(d.lxx[(i, j)], if i == j { 2.0 * w[i] } else { 0.0 });
        }
    }
    assert!((d.lu[0] - 2.0 * (w[3] * (z[3] - r[3]) + z[0])).abs() < 1e-13);
    assert_eq!(d.luu[(0, 0)], 2.0 * w[3]);
    assert_eq!(d.lux[(0, 0)], 2.0);
    assert_eq!((d.lux[(0, 1)], d.lux[(0, 2)]), (0.0, 0.0));
    // The same cost at run-time size (Dyn) gives the same numbers.
    let mut e = CostDerivatives::<Dyn, Dyn>::zeros(ddp_core::Dims::new("t", 3, 1).unwrap());
    let xd = VectorN::<Dyn>::from_column_slice(x.as_slice());
    let ud = VectorN::<Dyn>::from_column_slice(u.as_slice());
    assert_eq!(Cost::<Dyn, Dyn>::add_derivatives(&cost, &xd, &ud, 2.0, &mut e), v);
    assert_eq!(e.lxx.as_slice(), d.lxx.as_slice());
    assert_eq!(e.lux.as_slice(), d.lux.as_slice());
}

#[test]
fn the_degree_analysis_finds_the_quadratic_tapes() {
    assert!(quadratic_tape(&[1.0; 4], &[0.0; 4]).is_at_most_quadratic());
    // (expression of inputs a, b; whether it is at most quadratic)
    type Build = fn(&mut TapeBuilder, u32, u32) -> u32;
    let cases: [(&str, Build, bool); 8] = [
        (
            "a b / 3 - a",
            |b, x, y| {
                let p = b.binary(Binary::Mul, x, y).unwrap();
                let c = b.constant(3.0).unwrap();
                let q = b.binary(Binary::Div, p, c).unwrap();
                b.binary(Binary::Sub, q, x).unwrap()
            },
            true,
        ),
        (
            "sin(2) a^2",
            |b, x, _| {
                let c = b.constant(2.0).unwrap();
                let s = b.unary(Unary::Sin, c).unwrap();
                let p = b.powc(x, 2.0).unwrap();
                b.binary(Binary::Mul, s, p).unwrap()
            },
            true,
        ),
        (
            "-(a^1) + b^0",
            |b, x, y| {
                let p = b.powc(x, 1.0).unwrap();
                let n = b.unary(Unary::Neg, p).unwrap();
                let o = b.powc(y, 0.0).unwrap();
                b.binary(Binary::Add, n, o).unwrap()
            },
            true,
        ),
        (
            "a^2 b",
            |b, x, y| {
                let p = b.powc(x, 2.0).unwrap();
                b.binary(Binary::Mul, p, y).unwrap()
            },
            false,
        ),
        ("a / b", |b, x, y| b.binary(Binary::Div, x, y).unwrap(), false),
        ("sin a", |b, x, _| b.unary(Unary::Sin, x).unwrap(), false),
        ("a^3", |b, x, _| b.powc(x, 3.0).unwrap(), false),
        ("max(a, b)", |b, x, y| b.binary(Binary::Max, x, y).unwrap(), false),
    ];
    for (name, f, quadratic) in cases {
        let mut b = TapeBuilder::new(2);
        let (x, y) = (b.input(0).unwrap(), b.input(1).unwrap());
        let out = f(&mut b, x, y);
        assert_eq!(b.finish(&[out]).unwrap().is_at_most_quadratic(), quadratic, "{name}");
    }
}

#[test]
fn a_quadratic_cost_s_constant_hessian_equals_the_second_order_sweep() {
    // A quadratic cost (its constant Hessian and affine gradient) and a non-quadratic one (the
    // second-order sweep), against the reference interpreter at several points and weights.
    let quad = quadratic_tape(&[2.0, 3.0, 5.0, 7.0], &[0.1, -0.2, 0.3, 0.4]);
    let mut b = TapeBuilder::new(4);
    let (z0, z3) = (b.input(0).unwrap(), b.input(3).unwrap());
    let s = b.unary(Unary::Sin, z0).unwrap();
    let out = b.binary(Binary::Mul, s, z3).unwrap();
    let sine = b.finish(&[out]).unwrap();
    assert!(quad.is_at_most_quadratic() && !sine.is_at_most_quadratic());
    for tape in [quad, sine] {
        let cost = TapeCost::new(tape.clone(), 3, 1).unwrap();
        for (z, w) in [
            ([1.0, 2.0, -1.0, 0.5], 2.0),
            ([-0.3, 0.0, 4.0, -2.5], 0.7),
            ([0.0; 4], 1.0),
        ] {
            let (x, u) = (Vector::<3>::new(z[0], z[1], z[2]), Vector::<1>::new(z[3]));
            let mut d = CostDerivatives::<U3, U1>::default();
            let v = cost.add_derivatives(&x, &u, w, &mut d);
            let (g, h) = weighted(&tape, &z, &[w]);
            let close = |a: f64, e: f64| (a - e).abs() <= 1e-12 * (1.0 + e.abs());
            assert!(close(v, w * values(&tape, &z)[0]));
            for i in 0..4 {
                let gi = if i < 3 { d.lx[i] } else { d.lu[0] };
                assert!(close(gi, g[i]), "gradient {i}: {gi} against {}", g[i]);
                for j in 0..4 {
                    let hij = match (i < 3, j < 3) {
                        (true, true) => d.lxx[(i, j)],
                        (false, true) => d.lux[(0, j)],
                        (true, false) => d.lux[(0, i)],
                        (false, false) => d.luu[(0, 0)],
                    };
                    assert!(close(hij, h[i][j]), "Hessian ({i}, {j}): {hij} against {}", h[i][j]);
                }
            }
        }
    }
}

#[test]
fn common_subexpressions_share_one_node_and_constants_fold() {
    let mut b = TapeBuilder::new(2);
    let (x, y) = (b.input(0).unwrap(), b.input(1).unwrap());
    let p = b.binary(Binary::Mul, x, y).unwrap();
    let q = b.binary(Binary::Mul, y, x).unwrap();
    assert_eq!(p, q);
    let s1 = b.unary(Unary::Sin, p).unwrap();
    let s2 = b.unary(Unary::Sin, q).unwrap();
    assert_eq!(s1, s2);
    let two = b.constant(2.0).unwrap();
    let three = b.constant(3.0).unwrap();
    let six = b.binary(Binary::Mul, two, three).unwrap();
    assert_eq!(b.constant(6.0).unwrap(), six);
    // y * 0 is zero: the output no longer depends on y.
    let zero = b.constant(0.0).unwrap();
    let yz = b.binary(Binary::Mul, y, zero).unwrap();
    let out = b.binary(Binary::Add, x, yz).unwrap();
    let t = b.finish(&[out, s1]).unwrap();
    // input x, input y, x*y, sin: the folded constants and dead nodes are gone.
    assert_eq!(t.nodes().len(), 4);
    let only_x = TapeBuilder::new(2);
    let mut only_x = only_x;
    let xx = only_x.input(0).unwrap();
    let yy = only_x.input(1).unwrap();
    let z = only_x.constant(0.0).unwrap();
    let yz = only_x.binary(Binary::Mul, z, yy).unwrap();
    let o = only_x.binary(Binary::Add, xx, yz).unwrap();
    let t = only_x.finish(&[o]).unwrap();
    assert!(t.uses_input(0) && !t.uses_input(1));
    // Non-finite constants are rejected, also when folding makes them.
    assert!(TapeBuilder::new(1).constant(f64::NAN).is_err());
    let mut b = TapeBuilder::new(1);
    let z = b.constant(0.0).unwrap();
    assert!(b.unary(Unary::Log, z).is_err());
}

#[test]
fn a_constraint_without_the_control_is_state_only() {
    // g = [x0^2 + x1^2 - 1 (state), u0 - 1 (mixed)] as two tapes.
    let mut b = TapeBuilder::new(3);
    let (x0, x1, u0) = (b.input(0).unwrap(), b.input(1).unwrap(), b.input(2).unwrap());
    let a = b.powc(x0, 2.0).unwrap();
    let c = b.powc(x1, 2.0).unwrap();
    let s = b.binary(Binary::Add, a, c).unwrap();
    let one = b.constant(1.0).unwrap();
    let g0 = b.binary(Binary::Sub, s, one).unwrap();
    let g1 = b.binary(Binary::Sub, u0, one).unwrap();
    let state = TapeConstraint::new(b.clone().finish(&[g0]).unwrap(), 2, Some(1)).unwrap();
    let mixed = TapeConstraint::new(b.finish(&[g0, g1]).unwrap(), 2, Some(1)).unwrap();
    assert!(!Constraint::<U2, U1>::depends_on_control(&state));
    assert!(Constraint::<U2, U1>::depends_on_control(&mixed));
    let (x, u) = (Vector::<2>::new(0.3, 0.4), Vector::<1>::new(2.0));
    let e = safe_cddp::constraint::check_constraint_derivatives(&mixed, 0, &x, &u);
    assert!(e.max_first_order() < 1e-8 && e.hessian < 1e-6, "{e:?}");
    let mut h = Matrix::<2, 2>::zeros();
    Constraint::<U2, U1>::add_hessian(&mixed, 0, &x, &u, &[3.0, 5.0], &mut h);
    assert_eq!(h, Matrix::<2, 2>::new(6.0, 0.0, 0.0, 6.0));
    assert!(Constraint::<U2, U1>::check_sizes(&mixed, 3, 1).is_err());
}

/// The unicycle of ddp-core as a tape (same operation order).
fn unicycle_tape(dt: f64) -> Tape {
    let mut b = TapeBuilder::new(5);
    let z: Vec<u32> = (0..5).map(|k| b.input(k).unwrap()).collect();
    let dtc = b.constant(dt).unwrap();
    let c = b.unary(Unary::Cos, z[2]).unwrap();
    let s = b.unary(Unary::Sin, z[2]).unwrap();
    let row = |b: &mut TapeBuilder, base: u32, f: u32| {
        let t = b.binary(Binary::Mul, f, z[3]).unwrap();
        let t = b.binary(Binary::Mul, t, dtc).unwrap();
        b.binary(Binary::Add, base, t).unwrap()
    };
    let px = row(&mut b, z[0], c);
    let py = row(&mut b, z[1], s);
    let w = b.binary(Binary::Mul, z[4], dtc).unwrap();
    let th = b.binary(Binary::Add, z[2], w).unwrap();
    b.finish(&[px, py, th]).unwrap()
}

#[test]
fn a_tape_unicycle_solves_like_the_built_in_one_at_both_sizes() {
    let tape = unicycle_tape(0.1);
    let x0 = Vector::<3>::new(-1.0, -1.0, 1.0);
    let running = || Arc::new(QuadraticCost::weighted_norms(10.0, 1.0).unwrap());
    let terminal = || Arc::new(QuadraticTerminal::diagonal(&[100.0; 3], Vector::zeros()).unwrap());
    let builtin = Problem::new(x0, Arc::new(Unicycle::new(0.1).unwrap()), running(), terminal(), 100).unwrap();
    let traced = Problem::<U3, U2>::new(
        x0,
        Arc::new(TapeDynamics::new(tape.clone(), 3, 2).unwrap()),
        running(),
        terminal(),
        100,
    )
    .unwrap();
    let mut s1 = Solver::new(&builtin, Settings::default()).unwrap();
    let mut s2 = Solver::new(&traced, Settings::default()).unwrap();
    let (r1, r2) = (s1.solve(&builtin).unwrap(), s2.solve(&traced).unwrap());
    assert_eq!(r1.status, ddp_core::Status::Converged);
    assert_eq!(r1.iterations, r2.iterations);
    assert!((r1.cost - r2.cost).abs() < 1e-12 * r1.cost);
    // Run-time size, with the terminal cost and running cost as tapes too.
    let w = [100.0, 100.0, 100.0, 1.0, 1.0];
    let mut b = TapeBuilder::new(5);
    let mut acc = b.constant(0.0).unwrap();
    for (i, wi) in w.iter().enumerate() {
        let z = b.input(i).unwrap();
        let sq = b.powc(z, 2.0).unwrap();
        let c = b.constant(0.5 * wi).unwrap();
        let t = b.binary(Binary::Mul, c, sq).unwrap();
        acc = b.binary(Binary::Add, acc, t).unwrap();
    }
    let cost = TapeCost::new(b.finish(&[acc]).unwrap(), 3, 2).unwrap();
    let mut b = TapeBuilder::new(3);
    let mut acc = b.constant(0.0).unwrap();
    for i in 0..3 {
        let z = b.input(i).unwrap();
        let sq = b.powc(z, 2.0).unwrap();
        let c = b.constant(50.0).unwrap();
        let t = b.binary(Binary::Mul, c, sq).unwrap();
        acc = b.binary(Binary::Add, acc, t).unwrap();
    }
    let term = TapeTerminal::new(b.finish(&[acc]).unwrap(), 3).unwrap();
    let xd = VectorN::<Dyn>::from_column_slice(x0.as_slice());
    let p3 = Problem::<Dyn, Dyn>::new(
        xd,
        Arc::new(TapeDynamics::new(tape, 3, 2).unwrap()),
        Arc::new(cost),
        Arc::new(term),
        100,
    )
    .unwrap();
    let mut s3 = Solver::new(&p3, Settings::default()).unwrap();
    let r3 = s3.solve(&p3).unwrap();
    assert_eq!(r3.iterations, r1.iterations);
    assert!((r3.cost - r1.cost).abs() < 1e-9 * r1.cost, "{} vs {}", r3.cost, r1.cost);
}

#[test]
fn a_saved_model_loads_equal_and_evaluates_the_same() {
    let tape = discretize(&pendulum_ode(), 2, 1, 0.05, Integrator::Rk4).unwrap();
    let m = TapeModel::Dynamics(TapeDynamics::new(tape.clone(), 2, 1).unwrap());
    let text = m.to_json(Some("test"));
    let back = TapeModel::from_json(&text).unwrap();
    assert_eq!(back, m);
    let dir = std::env::temp_dir().join(format!("ddp-tape-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("pendulum.json");
    m.save(&path, None).unwrap();
    assert_eq!(TapeModel::load(&path).unwrap(), m);
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(values(back.tape(), &[0.8, -0.4, 0.3]), values(&tape, &[0.8, -0.4, 0.3]));
}

#[test]
fn malformed_files_are_errors_naming_the_field() {
    let good = TapeModel::Dynamics(TapeDynamics::new(unicycle_tape(0.1), 3, 2).unwrap()).to_json(None);
    let cases = [
        ("not json", "tape"),
        ("[]", "tape"),
        (&good.replace("ddpkit-tape", "other"), "format"),
        (&good.replace("\"version\":1", "\"version\":2"), "version"),
        (&good.replace("\"dynamics\"", "\"robot\""), "kind"),
        (&good.replace("\"nx\":3", "\"nx\":4"), "dynamics.outputs"),
        (&good.replace("\"nx\":3", "\"nx\":-3"), "nx"),
        (&good.replace("[\"cos\",2]", "[\"cosine\",2]"), "nodes[6]"),
        (&good.replace("[\"cos\",2]", "[\"cos\",99]"), "nodes[6]"),
        (&good.replace("[\"cos\",2]", "[\"cos\",2,3]"), "nodes[6]"),
        (&good.replace("[\"input\",4]", "[\"input\",9]"), "nodes[4]"),
    ];
    for (text, field) in cases {
        match TapeModel::from_json(text) {
            Err(e) => assert!(e.to_string().starts_with(field), "{field}: {e}"),
            Ok(_) => panic!("accepted a bad file for {field}"),
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]
    /// Any corruption of a saved file (cut, replaced bytes) is an error or a valid model, never a panic.
    #[test]
    fn corrupt_files_never_panic(cut in 0usize..2000, at in 0usize..2000, byte in 0u8..128) {
        let good = TapeModel::Dynamics(TapeDynamics::new(unicycle_tape(0.1), 3, 2).unwrap()).to_json(None);
        let mut bytes = good.into_bytes();
        let n = bytes.len();
        bytes[at % n] = byte;
        bytes.truncate(cut.max(1) % (n + 1));
        let text = String::from_utf8_lossy(&bytes);
        let _ = TapeModel::from_json(&text);
    }
}

#[test]
fn wrong_input_sizes_give_nan_not_a_panic() {
    let m = TapeDynamics::new(unicycle_tape(0.1), 3, 2).unwrap();
    let x = VectorN::<Dyn>::from_column_slice(&[0.0, 0.0]);
    let u = VectorN::<Dyn>::from_column_slice(&[0.0, 0.0]);
    let y = Dynamics::<Dyn, Dyn>::step(&m, &x, &u);
    assert!(y.iter().all(|v| v.is_nan()));
    assert!(matches!(m.tape().nodes()[0], Node::Input(_)));
}
