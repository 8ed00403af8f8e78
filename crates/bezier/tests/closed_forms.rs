//! Closed-form references: straight lines, parabolas, circles-ish, Simpson vs Gauss.

use bezier::*;

const PARABOLA_EXACT: f64 = 1.478_942_857_544_597_4; // int_0^1 sqrt(1 + 4 x^2) dx = sqrt(5)/2 + asinh(2)/4

#[test]
fn straight_line_length_is_the_distance() {
    let c = CubicBez::line((1.0, -2.0), (4.0, 2.0));
    assert!((c.arclen(1e-12) - 5.0).abs() < 1e-13);
    // Non-uniform speed on the same segment: still the distance.
    let c2 = CubicBez::new((1.0, -2.0), (1.0, -2.0), (1.3, -1.6), (4.0, 2.0));
    assert!((c2.arclen(1e-12) - 5.0).abs() < 1e-12);
    let q = QuadBez::new((0.0, 0.0), (0.1, 0.0), (3.0, 0.0));
    assert!((q.arclen(1e-12) - 3.0).abs() < 1e-13);
    let b = Bezier::new([
        Point::new(0.0, 0.0),
        Point::new(0.5, 0.5),
        Point::new(2.0, 2.0),
        Point::new(2.5, 2.5),
        Point::new(3.0, 3.0),
    ]);
    assert!((b.arclen(1e-12) - 18f64.sqrt()).abs() < 1e-12);
}

#[test]
fn parabola_arc_length_matches_closed_form() {
    assert!((PARABOLA_EXACT - (5f64.sqrt() / 2.0 + 2f64.asinh() / 4.0)).abs() < 1e-15);
    let q = QuadBez::new((0.0, 0.0), (0.5, 0.0), (1.0, 1.0));
    assert!((q.arclen(1e-12) - PARABOLA_EXACT).abs() < 1e-14);
    // The same parabola as an exact cubic (degree elevation) and as a quartic.
    let c = q.elevate();
    for acc in [1e-6, 1e-9, 1e-10, 1e-12] {
        assert!((c.arclen(acc) - PARABOLA_EXACT).abs() <= acc, "cubic at {acc}");
        let b4 = c.elevate();
        assert!((b4.arclen(acc) - PARABOLA_EXACT).abs() <= acc, "quartic at {acc}");
    }
    // Part of it: x in [0, 1/2] is t in [0, 1/2].
    let half = 0.5 * (0.5 * 2f64.sqrt()) + 1f64.asinh() / 4.0;
    assert!((q.arclen_range(0.0, 0.5, 1e-13) - half).abs() < 1e-14);
    assert!((c.arclen_range(0.0, 0.5, 1e-13) - half).abs() < 1e-13);
    assert!((c.arclen_range(0.5, 0.0, 1e-13) + half).abs() < 1e-13);
}

#[test]
fn simpson_agrees_with_gauss_as_in_the_paper() {
    let c = CubicBez::new((0.0, 0.0), (0.3, 1.2), (1.4, -0.5), (2.0, 1.0));
    let g = c.arclen(1e-13);
    let s = c.arclen_simpson(1e-11);
    assert!((g - s).abs() < 1e-9, "{g} vs {s}");
    let q = QuadBez::new((0.0, 0.0), (0.5, 0.0), (1.0, 1.0));
    assert!((q.arclen_simpson(1e-12) - PARABOLA_EXACT).abs() < 1e-10);
}

/// High-accuracy reference: 64 equal pieces, 32-point Gauss each, plus pieces split at cusps.
fn reference(c: &CubicBez) -> f64 {
    let mut sum = 0.0;
    let n = 4096;
    let (x, w) = gl8();
    for i in 0..n {
        let a = i as f64 / n as f64;
        let b = (i + 1) as f64 / n as f64;
        let (m, h) = (0.5 * (a + b), 0.5 * (b - a));
        for j in 0..8 {
            sum += h * w[j] * (c.speed(m - h * x[j]) + c.speed(m + h * x[j]));
        }
    }
    sum
}

fn gl8() -> ([f64; 8], [f64; 8]) {
    // 16-point rule, positive half.
    (
        [
            0.0950125098376374,
            0.2816035507792589,
            0.4580167776572274,
            0.6178762444026438,
            0.755404408355003,
            0.8656312023878318,
            0.9445750230732326,
            0.9894009349916499,
        ],
        [
            0.1894506104550685,
            0.1826034150449236,
            0.1691565193950025,
            0.1495959888165767,
            0.1246289712555339,
            0.0951585116824928,
            0.0622535239386479,
            0.0271524594117541,
        ],
    )
}

#[test]
fn requested_accuracy_is_met_on_hard_cubics() {
    let cases = [
        CubicBez::new((0.0, 0.0), (1.0, 1.0), (0.0, 1.0), (1.0, 0.0)), // cusp-like loop
        CubicBez::new((0.0, 0.0), (1.0, 1.0), (-0.0001, 1.0), (1.0, 0.0)), // near-cusp
        CubicBez::new((0.0, 0.0), (2.0, 0.0), (-1.0, 0.0), (1.0, 0.0)), // collinear with reversals (real roots)
        CubicBez::new((0.0, 0.0), (10.0, 0.1), (-9.0, 0.1), (1.0, 0.0)), // nearly collinear, huge speed range
        CubicBez::new((0.0, 0.0), (0.0, 0.0), (1.0, 1.0), (1.0, 1.0)), // coincident ends
        CubicBez::new((0.0, 0.0), (3.0, 4.0), (-2.0, 5.0), (7.0, -1.0)),
    ];
    for c in cases {
        let r = reference(&c);
        for acc in [1e-4, 1e-7, 1e-10] {
            let got = c.arclen(acc);
            assert!(
                (got - r).abs() <= acc.max(1e-12),
                "{c:?} acc {acc}: err {}",
                (got - r).abs()
            );
        }
    }
}
