//! The inverse arc length meets its accuracy (in length) on every kind of cubic and at every
//! accuracy: the safeguarded Halley iteration stops only within half the request.

#[path = "../benches/common/curve_sets.rs"]
mod curve_sets;

use bezier::{CubicBez, ParamCurveArclen, RELATIVE_ACCURACY_FLOOR};

fn cubic(c: &[f64; 8]) -> CubicBez {
    CubicBez::new((c[0], c[1]), (c[2], c[3]), (c[4], c[5]), (c[6], c[7]))
}

#[test]
fn inverse_arc_length_meets_the_request_in_length() {
    let mut curves: Vec<CubicBez> = curve_sets::random_cubics().iter().map(cubic).collect();
    curves.extend(curve_sets::smooth_cubics().iter().map(cubic));
    // Near-cusps, where the speed almost vanishes inside.
    for &delta in &[1e-9, 1e-5, 1e-2] {
        curves.push(CubicBez::new((0.0, 0.0), (1.0, 1.0), (0.0, 1.0 + delta), (1.0, 0.0)));
    }
    let mut checked = 0;
    for c in &curves {
        let total = c.arclen(1e-14);
        for &accuracy in &[1e-4, 1e-8, 1e-10, 1e-12] {
            for k in 1..8 {
                let s = total * k as f64 / 8.0;
                let t = c.inv_arclen(s, accuracy);
                assert!((0.0..=1.0).contains(&t));
                let got = c.arclen_range(0.0, t, 1e-14);
                let floor = 4.0 * RELATIVE_ACCURACY_FLOOR * total;
                assert!(
                    (got - s).abs() <= accuracy + floor,
                    "{c:?}: s {s} at {accuracy:e}: length to t = {got} (off by {:e})",
                    (got - s).abs()
                );
                checked += 1;
            }
        }
    }
    assert_eq!(checked, curves.len() * 4 * 7);
}
