//! Arc length and inverse arc length of cubics, against kurbo at equal accuracy.
//!
//! `cargo bench -p bezier --bench arclen`. Each group runs ours and kurbo's on the same set of
//! cubics at the same requested accuracy; the accuracy both actually reach is printed once
//! against a 1e-14 reference, so the comparison is at equal (verified) accuracy. Two sets:
//! `cubic_arclen` (random control points: loops, near-cusps) and `smooth_arclen` (Catmull-Rom
//! spline segments, see `common/curve_sets.rs`). `examples/arclen_sweep.rs` prints the same comparison
//! over a range of accuracies.

#[path = "common/curve_sets.rs"]
mod curve_sets;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::hint::black_box;

use bezier::{CubicBez, ParamCurveArclen};
use kurbo::{CubicBez as KCubic, ParamCurveArclen as KArclen};

fn ours(c: &[f64; 8]) -> CubicBez {
    CubicBez::new((c[0], c[1]), (c[2], c[3]), (c[4], c[5]), (c[6], c[7]))
}

fn theirs(c: &[f64; 8]) -> KCubic {
    KCubic::new((c[0], c[1]), (c[2], c[3]), (c[4], c[5]), (c[6], c[7]))
}

fn report_accuracy(name: &str, set: &[[f64; 8]]) {
    for acc in [1e-6, 1e-9, 1e-12] {
        let (mut e_ours, mut e_kurbo) = (0.0f64, 0.0f64);
        for c in set {
            let reference = ours(c).arclen(1e-14);
            e_ours = e_ours.max((ours(c).arclen(acc) - reference).abs());
            e_kurbo = e_kurbo.max((theirs(c).arclen(acc) - reference).abs());
        }
        eprintln!("{name} accuracy {acc:e}: max error ours {e_ours:.2e}, kurbo {e_kurbo:.2e}");
    }
}

fn bench_arclen_set(cr: &mut Criterion, group: &str, set: &[[f64; 8]]) {
    report_accuracy(group, set);
    let mut g = cr.benchmark_group(group);
    for acc in [1e-6, 1e-9, 1e-12] {
        g.bench_with_input(BenchmarkId::new("bezier", acc), &acc, |b, &acc| {
            b.iter(|| set.iter().map(|c| ours(black_box(c)).arclen(acc)).sum::<f64>())
        });
        g.bench_with_input(BenchmarkId::new("kurbo", acc), &acc, |b, &acc| {
            b.iter(|| set.iter().map(|c| theirs(black_box(c)).arclen(acc)).sum::<f64>())
        });
    }
    g.finish();
}

fn bench_arclen(cr: &mut Criterion) {
    bench_arclen_set(cr, "cubic_arclen", &curve_sets::random_cubics());
}

fn bench_arclen_smooth(cr: &mut Criterion) {
    bench_arclen_set(cr, "smooth_arclen", &curve_sets::smooth_cubics());
}

fn bench_inv_arclen(cr: &mut Criterion) {
    let set = curve_sets::random_cubics();
    let lens: Vec<f64> = set.iter().map(|c| ours(c).arclen(1e-14)).collect();
    let mut g = cr.benchmark_group("cubic_inv_arclen");
    for acc in [1e-6, 1e-9] {
        // Worst round-trip error of each, as a check of "equal accuracy".
        let (mut e_ours, mut e_kurbo) = (0.0f64, 0.0f64);
        for (c, &l) in set.iter().zip(&lens) {
            for frac in [0.1, 0.37, 0.5, 0.8] {
                let t = ours(c).inv_arclen(frac * l, acc);
                e_ours = e_ours.max((ours(c).arclen_range(0.0, t, 1e-14) - frac * l).abs());
                let tk = theirs(c).inv_arclen(frac * l, acc);
                e_kurbo = e_kurbo.max((ours(c).arclen_range(0.0, tk, 1e-14) - frac * l).abs());
            }
        }
        eprintln!("inv_arclen accuracy {acc:e}: max length error ours {e_ours:.2e}, kurbo {e_kurbo:.2e}");
        g.bench_with_input(BenchmarkId::new("bezier", acc), &acc, |b, &acc| {
            b.iter(|| {
                set.iter()
                    .zip(&lens)
                    .map(|(c, &l)| ours(black_box(c)).inv_arclen(0.37 * l, acc))
                    .sum::<f64>()
            })
        });
        g.bench_with_input(BenchmarkId::new("kurbo", acc), &acc, |b, &acc| {
            b.iter(|| {
                set.iter()
                    .zip(&lens)
                    .map(|(c, &l)| theirs(black_box(c)).inv_arclen(0.37 * l, acc))
                    .sum::<f64>()
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench_arclen, bench_arclen_smooth, bench_inv_arclen);
criterion_main!(benches);
