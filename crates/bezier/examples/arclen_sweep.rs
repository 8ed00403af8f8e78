//! Accuracy sweep of cubic arc length against kurbo: for each requested accuracy, the largest
//! error each reaches on a curve set (against a `1e-14` reference) and the time per cubic (best
//! of many interleaved batches, so both see the same machine load); then the same at equal
//! *achieved* accuracy: kurbo at each request against ours at the loosest request (on a grid)
//! whose largest error is no larger than kurbo's.
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

/// Best-of-batches nanoseconds per cubic for ours (at requested accuracy `acc`) and kurbo's (at
/// `acc_k`), interleaved.
fn time_pair(set: &[[f64; 8]], acc: f64, acc_k: f64) -> (f64, f64) {
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
                sink += theirs(black_box(c)).arclen(black_box(acc_k));
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
    println!("Same requested accuracy:");
    println!("set     accuracy  err_ours  err_kurbo  ns_ours  ns_kurbo  kurbo/ours");
    let max_err = |set: &[[f64; 8]], refs: &[f64], f: &dyn Fn(&[f64; 8]) -> f64| {
        set.iter()
            .zip(refs)
            .map(|(c, &r)| (f(c) - r).abs())
            .fold(0.0f64, f64::max)
    };
    let mut matched = Vec::new();
    for (name, set) in &sets {
        let refs: Vec<f64> = set.iter().map(|c| ours(c).arclen(1e-14)).collect();
        for &acc in &accs {
            let e_o = max_err(set, &refs, &|c| ours(c).arclen(acc));
            let e_k = max_err(set, &refs, &|c| theirs(c).arclen(acc));
            let (t_o, t_k) = time_pair(set, acc, acc);
            println!(
                "{name:6} {acc:9.0e}  {e_o:8.2e}  {e_k:9.2e}  {t_o:7.1}  {t_k:8.1}  {:10.2}",
                t_k / t_o
            );
            // Equal achieved accuracy: our loosest request (of a grid from 50x looser to 1000x
            // tighter) whose largest error on the set is no larger than kurbo's at `acc`.
            let ours_acc = [
                50.0, 30.0, 20.0, 12.0, 8.0, 5.0, 3.0, 2.0, 1.5, 1.0, 0.5, 0.2, 0.1, 0.05, 0.02, 0.01, 1e-3,
            ]
            .iter()
            .map(|f| f * acc)
            .find(|&a| max_err(set, &refs, &|c| ours(c).arclen(a)) <= e_k);
            matched.push((*name, acc, e_k, ours_acc));
        }
    }
    println!("Equal achieved accuracy (our request loosened until our largest error reaches kurbo's):");
    println!("set     kurbo_req  err_kurbo  our_req  err_ours  ns_ours  ns_kurbo  kurbo/ours");
    for (name, acc, e_k, ours_acc) in matched {
        let set = &sets.iter().find(|s| s.0 == name).expect("listed").1;
        let Some(a) = ours_acc else {
            println!("{name:6} {acc:9.0e}  {e_k:9.2e}  (no request of ours reaches it)");
            continue;
        };
        let refs: Vec<f64> = set.iter().map(|c| ours(c).arclen(1e-14)).collect();
        let e_o = max_err(set, &refs, &|c| ours(c).arclen(a));
        let (t_o, t_k) = time_pair(set, a, acc);
        println!(
            "{name:6} {acc:9.0e}  {e_k:9.2e}  {a:7.1e}  {e_o:8.2e}  {t_o:7.1}  {t_k:8.1}  {:10.2}",
            t_k / t_o
        );
    }
}
