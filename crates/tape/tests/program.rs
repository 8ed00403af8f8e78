//! The compiled [`Program`] against the reference interpreter of `eval.rs` (values, Jacobians,
//! weighted gradients and Hessians): every operation, fused `sin`/`cos`, repeated arguments,
//! inputs and constants as outputs, a Hessian row limit, and random tapes (proptest).

use ddp_tape::{Binary, Needs, Program, ProgramWorkspace, Tape, TapeBuilder, Unary, Workspace};
use proptest::prelude::*;

struct Reference {
    values: Vec<f64>,
    jac: Vec<Vec<f64>>,
    grad: Vec<f64>,
    hess: Vec<Vec<f64>>,
}

fn reference(t: &Tape, z: &[f64], lambda: &[f64]) -> Reference {
    let n = t.n_inputs();
    let mut ws = Workspace::default();
    let mut values = vec![0.0; t.n_outputs()];
    t.values(z, &mut ws, &mut values);
    t.forward(z, &mut ws, true);
    let jac = t
        .outputs()
        .iter()
        .map(|&o| {
            let mut row = vec![0.0; n];
            t.tangent_row(&ws, o as usize, &mut row);
            row
        })
        .collect();
    let (mut grad, mut hess) = (vec![0.0; n], vec![vec![0.0; n]; n]);
    t.second_order(lambda, &mut ws, |k, g, h| {
        grad[k] += g;
        for j in 0..n {
            hess[k][j] += h[j];
        }
    });
    Reference {
        values,
        jac,
        grad,
        hess,
    }
}

/// Rounding: the sweeps sum the same products in different orders, and random tapes cancel
/// (`a - a` of large terms), so the bound is relative to the largest entry, loosely; a wrong
/// term is off by its own size.
const TOL: f64 = 1e-9;

/// Equal to rounding. Where an intermediate is not finite (a division by zero, `hypot` at the
/// origin) the two sweeps spread NaN and inf to different entries (the interpreter also forms
/// `0 * NaN` at nodes whose adjoint is zero), so `check` compares derivatives only where the
/// interpreter's are finite, and the Jacobians' finiteness.
fn close(a: f64, b: f64, scale: f64) -> bool {
    a == b || (a - b).abs() <= TOL * (1.0 + scale) || (!a.is_finite() && !b.is_finite())
}

fn finite(m: &[f64]) -> bool {
    m.iter().all(|v| v.is_finite())
}

/// Compares a program of `t` (Hessian rows below `rows`) with the reference at `z` (split as
/// `x = z[..nx]`, `u = z[nx..]`, exercising both halves of the loading).
fn check(t: &Tape, z: &[f64], lambda: &[f64], nx: usize, rows: usize) -> std::result::Result<(), String> {
    let r = reference(t, z, lambda);
    let p = Program::new(t, rows);
    let mut ws = ProgramWorkspace::default();
    let (x, u) = z.split_at(nx);
    let mut v = vec![0.0; t.n_outputs()];
    p.values(&mut ws, x, u, &mut v);
    let scale = |m: &[f64]| m.iter().fold(0.0f64, |s, x| s.max(x.abs()));
    for i in 0..v.len() {
        if !close(v[i], r.values[i], scale(&r.values)) {
            return Err(format!("value {i}: {} vs {}", v[i], r.values[i]));
        }
    }
    p.jacobian(&mut ws, x, u);
    let mut jac = vec![vec![0.0; z.len()]; t.n_outputs()];
    for &(i, c, slot) in p.jacobian_entries() {
        jac[i as usize][c as usize] = ws.dot[slot as usize];
    }
    let theirs = r.jac.iter().all(|row| finite(row));
    if jac.iter().all(|row| finite(row)) != theirs {
        return Err("jacobian finite in one only".into());
    }
    for i in 0..jac.len() {
        if !close(p.output(&ws, i), r.values[i], scale(&r.values)) {
            return Err(format!("value {i} of the Jacobian run"));
        }
        let s = scale(&r.jac[i]);
        for k in 0..z.len() {
            if !close(jac[i][k], r.jac[i][k], s) {
                return Err(format!("jacobian ({i}, {k}): {} vs {}", jac[i][k], r.jac[i][k]));
            }
        }
    }
    p.second_order(&mut ws, x, u, lambda);
    if !(finite(&r.values) && r.jac.iter().all(|row| finite(row))) {
        return Ok(());
    }
    let gs = scale(&r.grad);
    for k in 0..z.len() {
        if !close(ws.bar[k], r.grad[k], gs) {
            return Err(format!("gradient {k}: {} vs {}", ws.bar[k], r.grad[k]));
        }
    }
    let mut hess = vec![vec![0.0; z.len()]; z.len()];
    for (h, &(row, col)) in p.hessian_pattern().iter().enumerate() {
        if row < col || row as usize >= rows {
            return Err(format!(
                "pattern entry ({row}, {col}) outside the lower triangle of {rows} rows"
            ));
        }
        hess[row as usize][col as usize] = ws.hess[h];
    }
    let hs = r.hess.iter().map(|row| scale(row)).fold(0.0, f64::max);
    if !(finite(&r.grad) && r.hess.iter().all(|row| finite(row))) {
        return Ok(());
    }
    for i in 0..rows.min(z.len()) {
        for j in 0..=i {
            if !close(hess[i][j], r.hess[i][j], hs) {
                return Err(format!("hessian ({i}, {j}): {} vs {}", hess[i][j], r.hess[i][j]));
            }
        }
    }
    // A program that computes neither values with the Jacobian nor the gradient (what dynamics
    // read) gives the same Jacobian and Hessian.
    let lean = Program::with_needs(
        t,
        Needs {
            hessian_rows: rows,
            jacobian_values: false,
            gradient: false,
            one_sweep: false,
        },
    );
    let mut ws2 = ProgramWorkspace::default();
    lean.jacobian(&mut ws2, x, u);
    for (e, &(i, c, slot)) in lean.jacobian_entries().iter().enumerate() {
        let want = jac[i as usize][c as usize];
        let got = ws2.dot[slot as usize];
        if !(got == want || (got.is_nan() && want.is_nan())) {
            return Err(format!("lean jacobian entry {e}: {got} vs {want}"));
        }
    }
    lean.second_order(&mut ws2, x, u, lambda);
    if lean.hessian_pattern() != p.hessian_pattern() {
        return Err("lean hessian pattern differs".into());
    }
    for (h, (&a, &b)) in ws2
        .hess
        .iter()
        .zip(&ws.hess)
        .take(p.hessian_pattern().len())
        .enumerate()
    {
        if !(a == b || (a.is_nan() && b.is_nan())) {
            return Err(format!("lean hessian entry {h}: {a} vs {b}"));
        }
    }
    // One forward sweep kept for the second-order terms (what full DDP runs) gives the same
    // bits, and only at the point it was kept at.
    let one = Program::with_needs(
        t,
        Needs {
            hessian_rows: rows,
            jacobian_values: false,
            gradient: false,
            one_sweep: true,
        },
    );
    let same = |a: f64, b: f64| a == b || (a.is_nan() && b.is_nan());
    let mut data = Vec::new();
    let mut ws3 = ProgramWorkspace::default();
    if one.second_order_kept(&mut ws3, &data, x, u, lambda) {
        return Err("a second-order run from empty data".into());
    }
    one.jacobian_keep(&mut data, x, u);
    for (e, &(i, c, slot)) in one.jacobian_entries().iter().enumerate() {
        let (want, got) = (jac[i as usize][c as usize], one.kept_dot(&data)[slot as usize]);
        if !same(got, want) {
            return Err(format!("kept jacobian entry {e}: {got} vs {want}"));
        }
    }
    if one.hessian_pattern() != p.hessian_pattern() {
        return Err("one-sweep hessian pattern differs".into());
    }
    // The one-sweep program materialises the tangents the Jacobian and the curvature both read,
    // the lean one only the curvature's: a linear combination may then be summed in another
    // order, so the two agree to rounding. The same program agrees with itself bit for bit: its
    // kept runs, and its full run at the same point.
    let mut kept = Vec::new();
    for run in 0..2 {
        if !one.second_order_kept(&mut ws3, &data, x, u, lambda) {
            return Err("no second-order run from the kept sweep".into());
        }
        let h3 = &ws3.hess[..p.hessian_pattern().len()];
        for (h, (&a, &b)) in h3.iter().zip(&ws2.hess).enumerate() {
            if !close(a, b, hs) {
                return Err(format!("kept hessian entry {h} (run {run}): {a} vs {b}"));
            }
        }
        if run == 0 {
            kept = h3.to_vec();
        } else if let Some(h) = (0..kept.len()).find(|&h| !same(h3[h], kept[h])) {
            return Err(format!("kept hessian entry {h} changed between runs"));
        }
    }
    one.second_order(&mut ws3, x, u, lambda);
    for (h, (&a, &b)) in ws3.hess.iter().zip(&kept).enumerate() {
        if !same(a, b) {
            return Err(format!("one-sweep hessian entry {h}: {a} vs kept {b}"));
        }
    }
    if !z.is_empty() {
        let mut moved = z.to_vec();
        moved[0] += 1.0;
        let (mx, mu) = moved.split_at(nx);
        if one.second_order_kept(&mut ws3, &data, mx, mu, lambda) {
            return Err("a second-order run from a sweep kept at another point".into());
        }
        if lean.second_order_kept(&mut ws3, &data, x, u, lambda) {
            return Err("a second-order run from another program's sweep".into());
        }
    }
    Ok(())
}

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
fn every_unary_operation_equals_the_interpreter() {
    for name in Unary::names() {
        let op = Unary::from_name(name).unwrap();
        let (lo, hi) = domain(name);
        let mut b = TapeBuilder::new(3);
        let (z0, z1, z2) = (b.input(0).unwrap(), b.input(1).unwrap(), b.input(2).unwrap());
        let p = b.binary(Binary::Mul, z0, z1).unwrap();
        let c = b.constant(0.4 * (hi - lo)).unwrap();
        let s = b.binary(Binary::Mul, c, p).unwrap();
        let off = b.constant(lo + 0.3 * (hi - lo)).unwrap();
        let a = b.binary(Binary::Add, off, s).unwrap();
        let v = b.unary(op, a).unwrap();
        let w = b.binary(Binary::Mul, v, z2).unwrap();
        let w = b.binary(Binary::Sub, w, v).unwrap();
        let t = b.finish(&[v, w]).unwrap();
        for z in [[0.7, 0.9, -0.4], [0.2, 0.5, 1.3]] {
            check(&t, &z, &[0.7, -1.3], 2, 3).unwrap_or_else(|e| panic!("{name}: {e}"));
        }
    }
}

#[test]
fn every_binary_operation_equals_the_interpreter() {
    for name in Binary::names() {
        let op = Binary::from_name(name).unwrap();
        let mut b = TapeBuilder::new(3);
        let (z0, z1, z2) = (b.input(0).unwrap(), b.input(1).unwrap(), b.input(2).unwrap());
        let p = b.binary(Binary::Mul, z0, z1).unwrap();
        let c = b.constant(0.8).unwrap();
        let a = b.binary(Binary::Add, p, c).unwrap();
        let k = b.constant(0.3).unwrap();
        let t0 = b.binary(Binary::Mul, k, z0).unwrap();
        let bb = b.binary(Binary::Sub, z2, t0).unwrap();
        let f1 = b.binary(op, a, bb).unwrap();
        let f2 = b.binary(op, a, a).unwrap();
        let f3 = b.binary(op, bb, c).unwrap();
        let f4 = b.binary(op, c, a).unwrap();
        let s = b.binary(Binary::Add, f2, f3).unwrap();
        let t = b.finish(&[f1, s, f4]).unwrap();
        for z in [[0.7, 0.9, 1.4], [0.2, 0.5, 1.3], [0.5, -0.5, 0.15]] {
            check(&t, &z, &[0.7, -1.3, 0.4], 1, 3).unwrap_or_else(|e| panic!("{name}: {e}"));
        }
    }
}

#[test]
fn fused_sin_cos_repeated_arguments_inputs_and_constants_as_outputs() {
    let mut b = TapeBuilder::new(4);
    let z: Vec<u32> = (0..4).map(|k| b.input(k).unwrap()).collect();
    // cos before sin, sin and cos of one argument, one without its partner.
    let c = b.unary(Unary::Cos, z[1]).unwrap();
    let s = b.unary(Unary::Sin, z[1]).unwrap();
    let s0 = b.unary(Unary::Sin, z[0]).unwrap();
    let sq = b.binary(Binary::Mul, c, c).unwrap();
    let f = b.binary(Binary::Mul, s, z[3]).unwrap();
    let f = b.binary(Binary::Add, f, sq).unwrap();
    let g = b.binary(Binary::Mul, s0, c).unwrap();
    let k = b.constant(2.5).unwrap();
    let t = b.finish(&[f, g, z[2], k, z[0]]).unwrap();
    for z in [[0.3, -1.1, 0.4, 2.0], [1.3, 0.1, -0.4, -0.7]] {
        for rows in [4, 2, 0] {
            check(&t, &z, &[1.0, -0.5, 2.0, 3.0, 0.25], 3, rows).unwrap();
            check(&t, &z, &[1.0, -0.5, 2.0, 3.0, 0.25], 4, rows).unwrap();
        }
    }
    // The pattern of the lower triangle only.
    let p = Program::new(&t, 4);
    assert!(p.hessian_pattern().contains(&(1, 1)));
    assert!(p.hessian_pattern().contains(&(3, 1)));
    assert!(!p.hessian_pattern().contains(&(1, 3)));
    assert!(
        !p.hessian_pattern().iter().any(|&(r, c)| r == 2 || c == 2),
        "z2 enters linearly"
    );
}

#[test]
fn a_zero_weight_does_not_turn_an_infinite_partial_into_nan() {
    // sqrt at 0 has an infinite slope; with its output weighted 0 the Hessian is 0, not NaN.
    let mut b = TapeBuilder::new(2);
    let (x, y) = (b.input(0).unwrap(), b.input(1).unwrap());
    let r = b.unary(Unary::Sqrt, x).unwrap();
    let q = b.binary(Binary::Mul, y, y).unwrap();
    let t = b.finish(&[r, q]).unwrap();
    let p = Program::new(&t, 2);
    let mut ws = ProgramWorkspace::default();
    p.second_order(&mut ws, &[0.0], &[1.5], &[0.0, 1.0]);
    assert_eq!(ws.bar[1], 3.0);
    assert!(ws.bar[0] == 0.0);
    for (h, &(r, c)) in p.hessian_pattern().iter().enumerate() {
        let want = if (r, c) == (1, 1) { 2.0 } else { 0.0 };
        assert_eq!(ws.hess[h], want, "({r}, {c})");
    }
}

/// One random operation: `(kind, first argument, second argument)` picks among the earlier nodes.
fn build(n: usize, ops: &[(u8, usize, usize, f64)]) -> Tape {
    let mut b = TapeBuilder::new(n);
    let mut ids: Vec<u32> = (0..n).map(|k| b.input(k).unwrap()).collect();
    for &(kind, i, j, c) in ops {
        let (a, bb) = (ids[i % ids.len()], ids[j % ids.len()]);
        let id = match kind % 12 {
            0 => b.binary(Binary::Add, a, bb),
            1 => b.binary(Binary::Sub, a, bb),
            2 => b.binary(Binary::Mul, a, bb),
            3 => b.unary(Unary::Sin, a),
            4 => b.unary(Unary::Cos, a),
            5 => b.unary(Unary::Tanh, a),
            6 => b.unary(Unary::Atan, a),
            7 => b.powc(a, 2.0),
            8 => b.binary(Binary::Hypot, a, bb),
            9 => {
                let k = b.constant(c).unwrap();
                b.binary(Binary::Mul, k, a)
            }
            10 => b.unary(Unary::Neg, a),
            _ => {
                let k = b.constant(2.0 + c).unwrap();
                let d = b.binary(Binary::Add, k, bb).unwrap();
                let d = b.powc(d, 2.0).unwrap();
                b.binary(Binary::Div, a, d)
            }
        }
        .unwrap();
        ids.push(id);
    }
    let outs: Vec<u32> = ids.iter().rev().take(3).copied().collect();
    b.finish(&outs).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1000, ..ProptestConfig::default() })]

    #[test]
    fn random_tapes_equal_the_interpreter(
        n in 1usize..6,
        ops in proptest::collection::vec((0u8..12, 0usize..64, 0usize..64, -1.0f64..1.0), 1..30),
        z in proptest::collection::vec(-1.0f64..1.0, 6),
        lambda in proptest::collection::vec(-2.0f64..2.0, 3),
        nx in 0usize..6,
        rows in 0usize..7,
    ) {
        let t = build(n, &ops);
        let nx = nx.min(n);
        let lambda = &lambda[..t.n_outputs()];
        prop_assert!(check(&t, &z[..n], lambda, nx, rows).is_ok(), "{:?}", check(&t, &z[..n], lambda, nx, rows));
    }
}

/// A dense Hessian of more than 256 entries (30 inputs) takes the general curvature loop.
#[test]
fn a_hessian_of_more_than_256_entries_equals_the_interpreter() {
    let n = 30;
    let mut b = TapeBuilder::new(n);
    let mut sum = b.input(0).unwrap();
    for k in 1..n {
        let x = b.input(k).unwrap();
        sum = b.binary(Binary::Add, sum, x).unwrap();
    }
    let sin = b.unary(Unary::Sin, sum).unwrap();
    let x0 = b.input(0).unwrap();
    let out = b.binary(Binary::Mul, sin, x0).unwrap();
    let t = b.finish(&[out, sin]).unwrap();
    assert!(Program::new(&t, n).hessian_pattern().len() > 256);
    let z: Vec<f64> = (0..n).map(|k| 0.1 * k as f64 - 1.0).collect();
    check(&t, &z, &[0.7, -1.3], 20, n).unwrap();
}

/// A program of more scalar slots than the largest fixed-size array the loops index through a
/// mask (8192) takes the bounds-checked loops.
#[test]
fn a_program_wider_than_the_fixed_sizes_equals_the_interpreter() {
    let mut b = TapeBuilder::new(2);
    let (x, y) = (b.input(0).unwrap(), b.input(1).unwrap());
    let mut v = b.binary(Binary::Mul, x, y).unwrap();
    for _ in 0..3000 {
        let t = b.unary(Unary::Tanh, v).unwrap();
        v = b.binary(Binary::Mul, t, y).unwrap();
    }
    let t = b.finish(&[v, x]).unwrap();
    check(&t, &[0.8, 1.1], &[0.7, -1.3], 1, 2).unwrap();
}

#[test]
fn values_of_an_integrator_step_equal_the_interpreter_bit_for_bit() {
    // x + dt f(x, u) by Euler and RK4: the fused `a + c b` instructions do the same operations in
    // the same order.
    let mut b = TapeBuilder::new(3);
    let (q, w, u) = (b.input(0).unwrap(), b.input(1).unwrap(), b.input(2).unwrap());
    let s = b.unary(Unary::Sin, q).unwrap();
    let g = b.constant(9.81).unwrap();
    let gs = b.binary(Binary::Mul, g, s).unwrap();
    let acc = b.binary(Binary::Sub, u, gs).unwrap();
    let ode = b.finish(&[w, acc]).unwrap();
    for integrator in [ddp_tape::Integrator::Euler, ddp_tape::Integrator::Rk4] {
        let t = ddp_tape::discretize(&ode, 2, 1, 0.05, integrator).unwrap();
        let p = Program::new(&t, 3);
        let (mut ws, mut pws) = (Workspace::default(), ProgramWorkspace::default());
        for z in [[0.3, -1.2, 0.7], [2.9, 0.4, -1.5]] {
            let (mut a, mut c) = ([0.0; 2], [0.0; 2]);
            t.values(&z, &mut ws, &mut a);
            p.values(&mut pws, &z[..2], &z[2..], &mut c);
            assert_eq!(a.map(f64::to_bits), c.map(f64::to_bits), "{integrator:?} at {z:?}");
        }
    }
}

#[test]
fn values_of_the_saved_models_equal_the_interpreter_bit_for_bit() {
    // The programs run their instructions grouped by kind (each still after the ones it reads):
    // the same operations on the same operands, so the same bits as the interpreter's node
    // order, on tapes traced in Python and imported from CasADi.
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data");
    let files = [
        "cartpole.json",
        "quadrotor.json",
        "quadrotor_obstacle/dynamics.json",
        "quadrotor_obstacle/running.json",
        "quadrotor_obstacle/terminal.json",
        "quadrotor_obstacle/obstacle.json",
    ];
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 * 4.0 - 2.0
    };
    for file in files {
        let model = ddp_tape::TapeModel::load(format!("{dir}/{file}")).unwrap();
        let t = model.tape();
        let n = t.n_inputs();
        let p = Program::new(t, n);
        let (mut ws, mut pws) = (Workspace::default(), ProgramWorkspace::default());
        for _ in 0..20 {
            let z: Vec<f64> = (0..n).map(|_| next()).collect();
            let (mut a, mut c) = (vec![0.0; t.n_outputs()], vec![0.0; t.n_outputs()]);
            t.values(&z, &mut ws, &mut a);
            p.values(&mut pws, &z, &[], &mut c);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&a), bits(&c), "{file} at {z:?}");
        }
    }
}
