//! Accuracy sweep of cubic arc length against kurbo: for each requested accuracy, the largest
//! error each reaches on a curve set (against a `1e-14` reference) and the time per cubic (best
//! of many interleaved batches, so both see the same machine load).
//!
//! `cargo run --release -p bezier --example arclen_sweep [-- random|smooth|both [ACCURACY...]]`

#[path = "../benches/common/curve_sets.rs"]
mod curve_sets;

use std::hint::black_box;
use std::time::Instant;

use bezier::{CubicBez, ParamCurveArclen};
use kurbo::{CubicBez as KCubic, ParamCurveArclen as KArclen};

fn ours(c: &[f64; 8]) -> CubicBez {
    CubicBez::new((c[0], c[1]), (c[2], c[3]), (c[4], c[5]), (c[6], c[7]))
}

fn theirs(c: &[f64; 8]) -> KCubic {
    KCubic::new((c[0], c[1]), (c[2], c[3]), (c[4], c[5]), (c[6], c[7]))
}

/// Best-of-batches nanoseconds per cubic for ours and kurbo's, interleaved.
fn time_pair(set: &[[f64; 8]], acc: f64) -> (f64, f64) {
    let reps = (20_000 / set.len()).max(1);
    let (mut best_o, mut best_k) = (f64::INFINITY, f64::INFINITY);
    let mut sink = 0.0;
    for _ in 0..25 {
        let t0 = Instant::now();
        for _ in 0..reps {
            for c in set {
                sink += ours(black_box(c)).arclen(black_box(acc));
            }
        }
        best_o = best_o.min(t0.elapsed().as_secs_f64());
        let t0 = Instant::now();
        for _ in 0..reps {
            for c in set {
                sink += theirs(black_box(c)).arclen(black_box(acc));
            }
        }
        best_k = best_k.min(t0.elapsed().as_secs_f64());
    }
    black_box(sink);
    let per = 1e9 / (reps * set.len()) as f64;
    (best_o * per, best_k * per)
}

fn main() {
    let mut args = std::env::args().skip(1);
    let which = args.next().unwrap_or_else(|| "both".to_string());
    let mut accs: Vec<f64> = args.filter_map(|a| a.parse().ok()).collect();
    if accs.is_empty() {
        accs = vec![1e-3, 1e-6, 1e-9, 1e-12];
    }
    let mut sets = Vec::new();
    if which != "smooth" {
        sets.push(("random", curve_sets::random_cubics()));
    }
    if which != "random" {
        sets.push(("smooth", curve_sets::smooth_cubics()));
    }
    println!("set     accuracy  err_ours  err_kurbo  ns_ours  ns_kurbo  kurbo/ours");
    for (name, set) in &sets {
        let refs: Vec<f64> = set.iter().map(|c| ours(c).arclen(1e-14)).collect();
        for &acc in &accs {
            let (mut e_o, mut e_k) = (0.0f64, 0.0f64);
            for (c, &r) in set.iter().zip(&refs) {
                e_o = e_o.max((ours(c).arclen(acc) - r).abs());
                e_k = e_k.max((theirs(c).arclen(acc) - r).abs());
            }
            let (t_o, t_k) = time_pair(set, acc);
            println!(
                "{name:6} {acc:9.0e}  {e_o:8.2e}  {e_k:9.2e}  {t_o:7.1}  {t_k:8.1}  {:10.2}",
                t_k / t_o
            );
        }
    }
}
