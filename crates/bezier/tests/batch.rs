//! `CubicBez::arclen_batch` returns what `arclen` returns, bit for bit, on every kind of cubic
//! and batch length, and rejects an output slice of the wrong length.

#[path = "../benches/common/curve_sets.rs"]
mod curve_sets;

use bezier::{CubicBez, Error, ParamCurveArclen, Point};

fn cubic(c: &[f64; 8]) -> CubicBez {
    CubicBez::new((c[0], c[1]), (c[2], c[3]), (c[4], c[5]), (c[6], c[7]))
}

/// Near-cusps (a root of the hodograph close to the real axis, the case the batch groups),
/// loops and the degenerate cubics whose roots take the special cases.
fn hard_cubics() -> Vec<CubicBez> {
    let mut out = vec![
        CubicBez::new((0.0, 0.0), (1.0, 1.0), (0.0, 1.0), (1.0, 0.0)), // exact cusp
        CubicBez::new((0.0, 0.0), (2.0, 1.0), (-1.0, 1.0), (1.0, 0.0)), // loop
        CubicBez::new((0.0, 0.0), (0.0, 0.0), (1.0, 1.0), (2.0, 0.0)), // p0 = p1
        CubicBez::new((0.0, 0.0), (1.0, 1.0), (2.0, 0.0), (2.0, 0.0)), // p2 = p3
        CubicBez::new((1.0, 2.0), (1.0, 2.0), (1.0, 2.0), (1.0, 2.0)), // a point
        CubicBez::new((0.0, 0.0), (3.0, 0.0), (-1.0, 0.0), (2.0, 0.0)), // a line reversing twice
        CubicBez::new((0.0, 0.0), (1.0 / 3.0, 0.0), (2.0 / 3.0, 1.0 / 3.0), (1.0, 1.0)), // parabola
        CubicBez::new((0.0, 0.0), (0.3, 0.9), (0.7, 0.9), (1.0, 0.0)), // the Python bench's arc
    ];
    for &delta in &[1e-12, 1e-6, 1e-3, 0.05, 0.2] {
        for &shift in &[0.0, 0.3, -0.45] {
            out.push(CubicBez::new(
                (0.0, 0.0),
                (1.0 + shift, 1.0),
                (shift, 1.0 + delta),
                (1.0, 0.0),
            ));
        }
    }
    out
}

/// Every curve set, with its cubics scaled by `1e-6` and `1e6` too.
fn all_cubics() -> Vec<CubicBez> {
    let mut out: Vec<CubicBez> = curve_sets::random_cubics().iter().map(cubic).collect();
    out.extend(curve_sets::smooth_cubics().iter().map(cubic));
    out.extend(hard_cubics());
    let scaled: Vec<CubicBez> = out
        .iter()
        .flat_map(|c| [1e-6, 1e6].map(|s| CubicBez::from_points(c.points().map(|p| Point::new(p.x * s, p.y * s)))))
        .collect();
    out.extend(scaled);
    out
}

fn same_bits(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

#[test]
fn batch_equals_one_by_one_bit_for_bit() {
    let curves = all_cubics();
    for &accuracy in &[1e-3, 1e-6, 1e-9, 1e-12, 0.0] {
        let mut out = vec![f64::NAN; curves.len()];
        CubicBez::arclen_batch(curves.iter().copied(), accuracy, &mut out).unwrap();
        for (i, (c, &got)) in curves.iter().zip(&out).enumerate() {
            let want = c.arclen(accuracy);
            assert!(
                same_bits(got, want),
                "curve {i} at {accuracy:e}: batch {got:e}, alone {want:e}"
            );
        }
    }
}

#[test]
fn every_batch_length_and_order_gives_the_same_lengths() {
    // Lengths around the group size of 4 and near-cusps interleaved with smooth curves, so that
    // groups fill at different places and partial groups are left over.
    let hard = hard_cubics();
    let smooth: Vec<CubicBez> = curve_sets::smooth_cubics().iter().map(cubic).collect();
    let mixed: Vec<CubicBez> = hard.iter().zip(&smooth).flat_map(|(h, s)| [*h, *s, *s]).collect();
    for n in 0..=mixed.len().min(13) {
        for start in [0, 1, 2] {
            let curves = &mixed[start.min(mixed.len())..][..n.min(mixed.len() - start)];
            let mut out = vec![0.0; curves.len()];
            CubicBez::arclen_batch(curves.iter().copied(), 1e-10, &mut out).unwrap();
            for (c, &got) in curves.iter().zip(&out) {
                assert!(same_bits(got, c.arclen(1e-10)));
            }
        }
    }
}

#[test]
fn nan_curves_give_nan_without_disturbing_the_others() {
    let mut curves = hard_cubics();
    curves[3].p1.x = f64::NAN;
    curves[9].p2.y = f64::INFINITY;
    let mut out = vec![0.0; curves.len()];
    CubicBez::arclen_batch(curves.iter().copied(), 1e-9, &mut out).unwrap();
    assert!(out[3].is_nan());
    assert!(!out[9].is_finite());
    for (i, c) in curves.iter().enumerate() {
        assert!(same_bits(out[i], c.arclen(1e-9)), "curve {i}");
    }
}

#[test]
fn wrong_output_length_is_an_error_naming_out() {
    let curves = hard_cubics();
    let mut out = vec![0.0; curves.len() - 1];
    match CubicBez::arclen_batch(curves.iter().copied(), 1e-9, &mut out) {
        Err(e @ Error::LengthMismatch { field: "out", .. }) => {
            assert!(e.to_string().contains(&curves.len().to_string()), "{e}");
        }
        other => panic!("expected LengthMismatch on `out`, got {other:?}"),
    }
}
