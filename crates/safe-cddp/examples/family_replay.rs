//! Replays the problems of a `bench/peers/family.py --json` file with `SafeCddpSolver` and
//! compares with the peers' costs and times stored there (a development loop for the warm-up
//! settings; the benchmark of record is `family.py` itself, which runs every solver in one
//! process).
//!
//! ```sh
//! cargo run --release -p safe-cddp --example family_replay -- family.json [warm_up] [mu_init] \
//!     [mu_factor] [mu_final] [inner] [relaxation]
//! ```
//!
//! Environment: `THIRD_MU=MU` sets the portfolio's third start (`Settings::portfolio_third_mu`;
//! 0: none), `POLISH=0|1` its polish (`Settings::portfolio_polish`), `APART=GAP` when they run
//! (`Settings::portfolio_apart`), `NEW_SIDE=F` the third start where the first two agree
//! (`Settings::portfolio_new_side`; 0: none), `FLIP=F`, `FLIP_GUIDE=K` the flipped starts
//! (`Settings::portfolio_flip`, `portfolio_flip_guide`; 0: none), `FLIP_STARTS=K` at most `K` of
//! them (`portfolio_flip_starts`), `FLIP_APART=F` their gate where the first two
//! starts end apart (`portfolio_flip_apart`), `MIRROR=K`, `PLAN=K` the mirrored and the planned
//! start's guided iterations (`portfolio_mirror`, `portfolio_plan`; 0: none), `THREADS=2` its concurrent starts
//! (`Settings::portfolio_threads`); `THIRD_MU=0 POLISH=0` is the two-start portfolio. `AL_RHO`,
//! `AL_RHO_MAX`, `AL_RHO_FACTOR`, `AL_INNER`, `AL_TOL`, `AL_SWITCH` (`al_switch_violation`) set
//! the augmented Lagrangian, `KKT_STEP_MIN` `kkt_step_min`, `MAX_IT` `max_iterations` (`family.py`
//! solves with 500, the library's default is 200), `STALL` `portfolio_stall`, `ABANDON`, `ABANDON_AFTER`, `ABANDON_RUN` `portfolio_abandon` (0: none), `portfolio_abandon_after`, `portfolio_abandon_run`, `DUAL_BOUND` `portfolio_dual_bound` (negative: none), `EPS` `active_threshold`, `INNER_PROGRESS`, `INNER_PROGRESS_BELOW` its inner solves'
//! `al_inner_progress`, `al_inner_progress_below`, `NEAR_MARGIN`, `NEAR_RHO` `al_near_margin`,
//! `al_near_rho`, `NEAR_CRAWL`, `NEAR_CRAWL_CHANGE` `al_near_crawl`, `al_near_crawl_change`; `LS_MIN`, `LS_FACTOR` the line search's `step_min`, `step_factor`; `REG_MIN`, `REG_FACTOR` the regularisation's `mu_min`, `mu_factor`; `FUNNEL` `barrier_funnel` (`inf`: none); `BARRIER_MU`, `BARRIER_FACTOR`,
//! `BARRIER_FINAL`, `BARRIER_INNER`, `BARRIER_RELAX` the homotopy's `barrier_mu_init`, `barrier_mu_factor`, `barrier_mu_final`,
//! `barrier_inner_iterations`, `barrier_relaxation`; `CON_HESS=1` `constraint_hessian`; `COST_TOL`, `GRAD_TOL` the
//! tolerances; `METHOD=ddp` full DDP; `ONLY=id[,id...]` filters problems (by substring); `TABLE`, `QPS`, `PHASES`, `STARTS` print
//! per-solve details. `REPEATS=R` times the fastest of `R` solves of each problem, each a cold
//! solve (`SafeCddpSolver::reset`) on the same solver, as `family.py` re-solves through the Python
//! wrapper; `AB=1` also
//! solves each problem with the defaults (and the command line's warm-up), interleaved with the
//! settings above, and prints `AB` lines with both outcomes and the time ratio (`bench/peers/README.md`).
use std::time::Instant;

use safe_cddp::benchmark::BenchmarkProblem;
use safe_cddp::{SafeCddpSolver, Settings, WarmUp};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).ok_or("usage: family_replay FILE.json [warm_up ...]")?;
    let text = std::fs::read_to_string(path)?;
    let doc: serde_json::Value = serde_json::from_str(&text)?;
    let mut s = Settings::default();
    let arg = |i: usize| args.get(i).map(|a| a.parse::<f64>()).transpose();
    if let Some(w) = args.get(2) {
        s.warm_up = match w.as_str() {
            "barrier" => WarmUp::Barrier,
            "al" => WarmUp::AugmentedLagrangian,
            "portfolio" => WarmUp::Portfolio,
            "none" => WarmUp::None,
            other => return Err(format!("unknown warm-up {other}").into()),
        };
    }
    if let Some(v) = arg(3)? {
        s.barrier_mu_init = v;
    }
    if let Some(v) = arg(4)? {
        s.barrier_mu_factor = v;
    }
    if let Some(v) = arg(5)? {
        s.barrier_mu_final = v;
    }
    if let Some(v) = arg(6)? {
        s.barrier_inner_iterations = v as usize;
    }
    if let Some(v) = arg(7)? {
        s.barrier_relaxation = v;
    }
    let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok());
    if let Some(v) = env("AL_RHO") {
        s.al_rho_init = v;
    }
    if let Some(v) = env("AL_INNER") {
        s.al_cold_inner_iterations = v as usize;
    }
    if let Some(v) = env("POLISH") {
        s.portfolio_polish = v != 0.0;
    }
    if let Some(v) = env("THREADS") {
        s.portfolio_threads = v as usize;
    }
    if let Some(v) = env("THIRD_MU") {
        // 0: no third start.
        s.portfolio_third_mu = (v > 0.0).then_some(v);
    }
    if let Some(v) = env("NEW_SIDE") {
        // 0: none.
        s.portfolio_new_side = (v > 0.0).then_some(v);
    }
    if let Some(v) = env("FLIP") {
        // 0: none.
        s.portfolio_flip = (v > 0.0).then_some(v);
    }
    if let Some(v) = env("MIRROR") {
        // 0: none.
        s.portfolio_mirror = (v > 0.0).then_some(v as usize);
    }
    if let Some(v) = env("PLAN") {
        // 0: none.
        s.portfolio_plan = (v > 0.0).then_some(v as usize);
    }
    if let Some(v) = env("FLIP_STARTS") {
        s.portfolio_flip_starts = v as usize;
    }
    if let Some(v) = env("FLIP_APART") {
        s.portfolio_flip_apart = v;
    }
    if let Some(v) = env("FLIP_GUIDE") {
        s.portfolio_flip_guide = v as usize;
    }
    if let Some(v) = env("APART") {
        s.portfolio_apart = v;
    }
    if let Some(v) = env("NEAR_CRAWL") {
        s.al_near_crawl = v as usize;
    }
    if let Some(v) = env("NEAR_CRAWL_CHANGE") {
        s.al_near_crawl_change = v;
    }
    if let Some(v) = env("AL_RHO_MAX") {
        s.al_rho_max = v;
    }
    if let Some(v) = env("AL_RHO_FACTOR") {
        s.al_rho_factor = v;
    }
    if let Some(v) = env("AL_TOL") {
        s.al_inner_tolerance = v;
    }
    if std::env::var("METHOD").is_ok_and(|m| m == "ddp") {
        s.method = ddp_core::Method::Ddp;
    }
    if let Some(v) = env("CON_HESS") {
        s.constraint_hessian = v != 0.0;
    }
    if let Some(v) = env("COST_TOL") {
        s.tolerances.cost = v;
    }
    if let Some(v) = env("GRAD_TOL") {
        s.tolerances.gradient = v;
    }
    if let Some(v) = env("INNER_PROGRESS") {
        s.al_inner_progress = v;
    }
    if let Some(v) = env("INNER_PROGRESS_BELOW") {
        s.al_inner_progress_below = v;
    }
    if let Some(v) = env("NEAR_MARGIN") {
        s.al_near_margin = v;
    }
    if let Some(v) = env("NEAR_RHO") {
        s.al_near_rho = v;
    }
    if let Some(v) = env("BARRIER_MU") {
        s.barrier_mu_init = v;
    }
    if let Some(v) = env("BARRIER_FACTOR") {
        s.barrier_mu_factor = v;
    }
    if let Some(v) = env("BARRIER_FINAL") {
        s.barrier_mu_final = v;
    }
    if let Some(v) = env("BARRIER_INNER") {
        s.barrier_inner_iterations = v as usize;
    }
    if let Some(v) = env("BARRIER_RELAX") {
        s.barrier_relaxation = v;
    }
    if let Some(v) = env("FUNNEL") {
        s.barrier_funnel = v;
    }
    if let Some(v) = env("LS_MIN") {
        s.line_search.step_min = v;
    }
    if let Some(v) = env("LS_FACTOR") {
        s.line_search.step_factor = v;
    }
    if let Some(v) = env("REG_MIN") {
        s.regularization.mu_min = v;
    }
    if let Some(v) = env("REG_FACTOR") {
        s.regularization.mu_factor = v;
    }
    if let Some(v) = env("AL_SWITCH") {
        s.al_switch_violation = v;
    }
    if let Some(v) = env("KKT_STEP_MIN") {
        s.kkt_step_min = v;
    }
    if let Some(v) = env("STALL") {
        s.portfolio_stall = v as usize;
    }
    if let Some(v) = env("ABANDON") {
        // 0: none.
        s.portfolio_abandon = (v > 0.0).then_some(v);
    }
    if let Some(v) = env("DUAL_BOUND") {
        s.portfolio_dual_bound = (v >= 0.0).then_some(v);
    }
    if let Some(v) = env("ABANDON_AFTER") {
        s.portfolio_abandon_after = v as usize;
    }
    if let Some(v) = env("ABANDON_RUN") {
        s.portfolio_abandon_run = v as usize;
    }
    if let Some(v) = env("EPS") {
        s.active_threshold = v;
    }
    if let Some(v) = env("MAX_IT") {
        s.max_iterations = v as usize;
    }
    let only = std::env::var("ONLY").ok();
    let problems = doc["problems"].as_array().ok_or("no problems")?;
    let (mut matched, mut total, mut log_ratio, mut worst) = (0, 0, 0.0, 0.0f64);
    let (mut sum_ms, mut sum_iters) = (0.0, 0usize);
    for rec in problems {
        let id = rec["id"].as_str().unwrap_or("?");
        if only.as_deref().is_some_and(|o| !o.split(',').any(|o| id.contains(o))) {
            continue;
        }
        let spec = serde_json::to_string(&rec["spec"])?;
        let bp = BenchmarkProblem::from_json(&spec)?;
        let mut best = f64::INFINITY;
        let mut ipopt_ms = f64::NAN;
        for peer in ["ipopt", "fatrop"] {
            let r = &rec["solvers"][peer];
            if r["feasible"].as_bool() == Some(true) {
                best = best.min(r["cost"].as_f64().unwrap_or(f64::INFINITY));
            }
        }
        if let Some(ms) = rec["solvers"]["ipopt"]["ms"].as_f64() {
            ipopt_ms = ms;
        }
        let variants: Vec<Settings> = if std::env::var("PORTFOLIO").is_ok() {
            vec![
                Settings {
                    warm_up: WarmUp::AugmentedLagrangian,
                    ..s
                },
                s,
            ]
        } else {
            vec![s]
        };
        let mut out = (f64::INFINITY, f64::INFINITY, 0, safe_cddp::Status::MaxIterations, 0.0);
        for v in variants {
            // REPEATS=R: the fastest of R solves (the same iterates), for steadier time ratios.
            // AB=1: also the defaults (with the command line's warm-up), interleaved with these
            // settings on each problem, and the time ratio printed.
            let repeats = env("REPEATS").map_or(1, |r| r as usize);
            let base = std::env::var("AB").is_ok().then_some(Settings {
                warm_up: v.warm_up,
                ..Settings::default()
            });
            let mut base_ms = f64::INFINITY;
            let mut base_out = None;
            let mut base_run = base.map(|b| runner(&bp, b)).transpose()?;
            let mut run = runner(&bp, v)?;
            let (cost, viol, iters, status, mut ms) = run()?;
            for r in 0..repeats {
                if let Some(b) = base_run.as_mut() {
                    let o = b()?;
                    base_ms = base_ms.min(o.4);
                    base_out = Some(o);
                }
                if r > 0 {
                    ms = ms.min(run()?.4);
                }
            }
            if let Some(o) = base_out {
                let ok = o.1 <= 1e-6 && o.0 <= best * (1.0 + 1e-6);
                let gap = (o.0 - best) / best.abs();
                println!(
                    "AB {id:24} base {} gap {gap:+.2e} it {} ms {base_ms:.4} new ms {ms:.4} ratio {:.4}",
                    if ok { "match" } else { "MISS " },
                    o.2,
                    ms / base_ms
                );
            }
            let better = (viol <= 1e-6 && (out.1 > 1e-6 || cost < out.0)) || (out.1 > 1e-6 && viol < out.1);
            if better {
                out = (cost, viol, out.2 + iters, status, out.4 + ms);
            } else {
                out.2 += iters;
                out.4 += ms;
            }
        }
        let (cost, viol, iters, status, ms) = out;
        sum_ms += ms;
        sum_iters += iters;
        let gap = (cost - best) / best.abs();
        let ok = viol <= 1e-6 && cost <= best * (1.0 + 1e-6);
        total += 1;
        matched += usize::from(ok);
        let ratio = ms / ipopt_ms;
        log_ratio += ratio.ln();
        worst = worst.max(ratio);
        println!(
            "{id:24} {} gap {gap:+.2e} viol {viol:.1e} it {iters:4} {:14} t/IPOPT {ratio:.3}",
            if ok { "match" } else { "MISS " },
            status.as_str()
        );
    }
    println!(
        "matched {matched}/{total} ({:.1}%), t/IPOPT geomean {:.4} worst {:.3}",
        100.0 * matched as f64 / total.max(1) as f64,
        (log_ratio / total.max(1) as f64).exp(),
        worst
    );
    println!(
        "total {sum_ms:.1} ms, {sum_iters} iterations ({:.2} us per iteration)",
        1e3 * sum_ms / sum_iters.max(1) as f64
    );
    Ok(())
}

type Outcome = (f64, f64, usize, safe_cddp::Status, f64);

/// A solver of `bp` with settings `s`: each call a cold solve (`SafeCddpSolver::reset`) on the
/// same solver, timed.
fn runner(
    bp: &BenchmarkProblem,
    s: Settings,
) -> Result<Box<dyn FnMut() -> Result<Outcome, Box<dyn std::error::Error>>>, Box<dyn std::error::Error>> {
    let table = std::env::var("TABLE").is_ok();
    macro_rules! run {
        ($pc:expr) => {{
            let (problem, constraints) = $pc;
            let mut solver = SafeCddpSolver::new(&problem, constraints, s)?;
            Box::new(move || {
                solver.reset();
                let t = Instant::now();
                let r = solver.solve(&problem)?;
                let ms = t.elapsed().as_secs_f64() * 1e3;
                if table {
                    println!("{}", r.table());
                }
                if std::env::var("PASSES").is_ok() {
                    println!(
                        "  passes: it {} fp {} bp {}",
                        r.iterations, r.forward_passes, r.backward_passes
                    );
                }
                if std::env::var("STARTS").is_ok() {
                    for st in &r.starts {
                        println!(
                            "  start {:28} it {:4} cost {:.10e} viol {:.1e} {:?} {:?}",
                            st.name(),
                            st.iterations,
                            st.cost,
                            st.max_violation,
                            st.status,
                            st.outcome
                        );
                    }
                }
                if std::env::var("QPS").is_ok() {
                    println!("  qp: {:?}", r.qp);
                }
                if std::env::var("PHASES").is_ok() {
                    let count = |w: Option<WarmUp>| r.log.iter().filter(|l| l.warm_up == w).count();
                    let last = r.log.iter().rev().find(|l| l.accepted).map(|l| l.warm_up);
                    println!(
                        "  phases: barrier {} al {} kkt {} last {:?}",
                        count(Some(WarmUp::Barrier)),
                        count(Some(WarmUp::AugmentedLagrangian)),
                        count(None),
                        last
                    );
                }
                Ok((
                    r.cost,
                    r.max_violation,
                    r.iterations + r.discarded_iterations,
                    r.status,
                    ms,
                ))
            }) as Box<dyn FnMut() -> Result<Outcome, Box<dyn std::error::Error>>>
        }};
    }
    Ok(if bp.model == "unicycle" {
        run!(bp.unicycle()?)
    } else {
        run!(bp.car_or_point()?)
    })
}
