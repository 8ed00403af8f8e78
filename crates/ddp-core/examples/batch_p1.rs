//! Batch solve against a loop, measured in one run: P1 (the README's unicycle, N = 100) from 64
//! seeded random initial states, solved one after another on one workspace and by
//! `ddp_core::batch::solve_batch` on 2 threads (and on every core), with the results checked
//! equal bit for bit. Reports the median of 15 repetitions and the ratio.
//!
//! `cargo build --release -p ddp-core --example batch_p1 && $CARGO_TARGET_DIR/release/examples/batch_p1`
use std::time::{Duration, Instant};

use ddp_core::batch::{default_threads, solve_batch};
use ddp_core::reference::p1_unicycle;
use ddp_core::{Problem, Settings, Solver, Vector};

/// `count` copies of P1 with `x0` uniform in [-2, 2] x [-2, 2] x [-pi, pi], from a seeded
/// SplitMix64 (no rand dependency in ddp-core).
fn seeded_p1(count: usize, seed: u64) -> Vec<Problem<nalgebra::U3, nalgebra::U2>> {
    let mut state = seed;
    let mut uniform = move || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    (0..count)
        .map(|_| {
            let mut p = p1_unicycle();
            let x0 = Vector::<3>::new(2.0 * uniform(), 2.0 * uniform(), std::f64::consts::PI * uniform());
            p.set_x0(x0).expect("finite x0");
            p
        })
        .collect()
}

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v[v.len() / 2]
}

fn main() -> ddp_core::Result<()> {
    let problems = seeded_p1(64, 42);
    let settings = Settings::default();
    let reps = 15;
    // The loop a user writes today: one workspace, a cold start per problem.
    let mut solver = Solver::new(&problems[0], settings)?;
    let mut loop_costs = Vec::new();
    let mut t_loop = Vec::new();
    for _ in 0..reps {
        let t = Instant::now();
        loop_costs.clear();
        for p in &problems {
            solver.reset();
            loop_costs.push(solver.solve(p)?.cost);
        }
        t_loop.push(t.elapsed());
    }
    let mut rows = vec![("sequential loop".to_string(), median(t_loop))];
    let all = default_threads();
    let mut counts = vec![1, 2];
    if all > 2 {
        counts.push(all);
    }
    for threads in counts {
        let mut times = Vec::new();
        for _ in 0..reps {
            let t = Instant::now();
            let sols = solve_batch(&problems, &settings, Some(threads))?;
            times.push(t.elapsed());
            for (s, c) in sols.iter().zip(&loop_costs) {
                assert_eq!(s.report.cost.to_bits(), c.to_bits(), "batch differs from the loop");
            }
        }
        rows.push((format!("solve_batch, {threads} thread(s)"), median(times)));
    }
    let base = rows[0].1.as_secs_f64();
    println!("64 P1 problems (unicycle, N = 100, seeded x0), median of {reps} runs, {all} core(s) available");
    println!("{:<28} {:>10} {:>12} {:>8}", "", "total ms", "per problem", "speedup");
    for (name, t) in &rows {
        println!(
            "{:<28} {:>10.2} {:>9.1} us {:>7.2}x",
            name,
            t.as_secs_f64() * 1e3,
            t.as_secs_f64() * 1e6 / 64.0,
            base / t.as_secs_f64()
        );
    }
    Ok(())
}
