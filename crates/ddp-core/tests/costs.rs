//! `Cost::set_derivatives`, which the linearisation calls at every knot, writes every entry of
//! the derivatives and gives what zeroing them and adding the cost's with weight 1 gives, bit for
//! bit: for the quadratic cost's own version (diagonal weights, written without reading back)
//! and for the trait's default (full weights, sums of terms).

use std::sync::Arc;

use ddp_core::costs::{CostSum, QuadraticCost};
use ddp_core::{Cost, CostDerivatives, Matrix, Vector};
use nalgebra::Const;

type Derivatives = CostDerivatives<Const<4>, Const<2>>;

/// Every entry's bits, in a fixed order.
fn bits(d: &Derivatives) -> Vec<u64> {
    let parts = [
        d.lx.as_slice(),
        d.lu.as_slice(),
        d.lxx.as_slice(),
        d.luu.as_slice(),
        d.lux.as_slice(),
    ];
    parts.iter().flat_map(|p| p.iter().map(|v| v.to_bits())).collect()
}

/// Derivatives whose every entry is NaN: an entry `set_derivatives` leaves unwritten shows.
fn garbage() -> Derivatives {
    let mut d = Derivatives::default();
    for part in [
        d.lx.as_mut_slice(),
        d.lu.as_mut_slice(),
        d.lxx.as_mut_slice(),
        d.luu.as_mut_slice(),
        d.lux.as_mut_slice(),
    ] {
        part.fill(f64::NAN);
    }
    d
}

fn check(name: &str, cost: &dyn Cost<Const<4>, Const<2>>) {
    // Points on a grid of signs and sizes, with exact zeros and negative zeros among them.
    let values = [-2.5, -1.0, -0.0, 0.0, 0.3, 1.7];
    for (a, &p) in values.iter().enumerate() {
        for &q in &values[a..] {
            let x = Vector::<4>::new(p, q, -q, 0.5 * p);
            let u = Vector::<2>::new(q, -p);
            let mut added = Derivatives::default();
            let v_added = cost.add_derivatives(&x, &u, 1.0, &mut added);
            let mut set = garbage();
            let v_set = cost.set_derivatives(&x, &u, &mut set);
            assert_eq!(v_set.to_bits(), v_added.to_bits(), "{name}: value at {x:?}, {u:?}");
            assert_eq!(bits(&set), bits(&added), "{name}: derivatives at {x:?}, {u:?}");
        }
    }
}

#[test]
fn set_derivatives_writes_what_zeroing_and_adding_gives_bit_for_bit() {
    let x_ref = Vector::<4>::new(1.0, -2.0, 0.25, 0.0);
    let u_ref = Vector::<2>::new(-0.5, 0.0);
    let diagonal = QuadraticCost::diagonal(&[0.0, 2.0, 10.0, 0.5], &[0.1, 3.0], x_ref, u_ref).unwrap();
    check("diagonal", &diagonal);
    let p1 = QuadraticCost::<Const<4>, Const<2>>::weighted_norms(10.0, 1.0).unwrap();
    check("weighted norms", &p1);
    let q = Matrix::<4, 4>::new(
        2.0, 0.5, 0.0, 0.1, 0.5, 1.0, 0.2, 0.0, 0.0, 0.2, 3.0, 0.3, 0.1, 0.0, 0.3, 1.5,
    );
    let r = Matrix::<2, 2>::new(1.0, 0.2, 0.2, 0.5);
    let full = QuadraticCost::new(q, r, x_ref, u_ref).unwrap();
    check("full", &full);
    let sum = CostSum::new()
        .with(0.5, Arc::new(diagonal.clone()))
        .with(2.0, Arc::new(full));
    check("sum", &sum);
    check("shared", &Arc::new(diagonal));
}
