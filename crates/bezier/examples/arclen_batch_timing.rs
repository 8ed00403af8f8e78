//! Times [`CubicBez::arclen_batch`] against a loop of [`ParamCurveArclen::arclen`] on 10 000
//! cubics: the arc of `py/benches/bezier_vs_python.py` repeated, and distinct smooth spline
//! segments; best of interleaved runs, nanoseconds per curve.
//!
//! `cargo run --release -p bezier --example arclen_batch_timing [-- ACCURACY]` (default `1e-12`).
//! `DDPKIT_SIMD=off` times the portable sums.

#[path = "../benches/common/curve_sets.rs"]
mod curve_sets;

use std::hint::black_box;
use std::time::Instant;

use bezier::{CubicBez, ParamCurveArclen};

/// Best nanoseconds per curve of `f` over `runs` runs, `f` filling `out`.
fn best_ns<F: FnMut(&mut [f64])>(n: usize, out: &mut [f64], runs: usize, mut f: F) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..runs {
        let t0 = Instant::now();
        f(out);
        black_box(&*out);
        best = best.min(t0.elapsed().as_secs_f64() * 1e9 / n as f64);
    }
    best
}

fn main() {
    let accuracy: f64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(1e-12);
    let n = 10_000;
    let arc = CubicBez::new((0.0, 0.0), (0.3, 0.9), (0.7, 0.9), (1.0, 0.0));
    let smooth: Vec<CubicBez> = curve_sets::smooth_cubics_n(n)
        .iter()
        .map(|c| CubicBez::new((c[0], c[1]), (c[2], c[3]), (c[4], c[5]), (c[6], c[7])))
        .collect();
    println!("accuracy {accuracy:e}, {n} cubics, ns per curve (best of 7 x 5 interleaved runs)");
    println!("| set | loop of arclen | arclen_batch | ratio |");
    println!("|---|---:|---:|---:|");
    for (name, curves) in [
        ("bench arc, repeated", vec![arc; n]),
        ("smooth spline segments", smooth),
    ] {
        let mut out = vec![0.0; n];
        let (mut l, mut b) = (f64::INFINITY, f64::INFINITY);
        for _ in 0..7 {
            l = l.min(best_ns(n, &mut out, 5, |o| {
                for (o, c) in o.iter_mut().zip(black_box(&curves)) {
                    *o = c.arclen(accuracy);
                }
            }));
            b = b.min(best_ns(n, &mut out, 5, |o| {
                CubicBez::arclen_batch(black_box(&curves).iter().copied(), accuracy, o).expect("out as long as curves");
            }));
        }
        println!("| {name} | {l:.1} | {b:.1} | {:.2}x |", l / b);
    }
}
