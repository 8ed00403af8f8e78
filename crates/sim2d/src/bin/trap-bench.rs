//! The randomised trap benchmark: seeded random maps per trap type (U, L, cube clusters, cylinder
//! cups; generator in `sim2d::traps`), a trap across the straight line from start to goal; success
//! rate and collisions of each planner.
//!
//! ```text
//! cargo run --release -p sim2d --bin trap-bench -- --maps 50 --json out/trap-bench/bench.json
//! ```

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use clap::Parser;
use serde_json::json;
use sim2d::batch::{run_batch, run_seed, write_figures, write_json, BatchOptions, Job};
use sim2d::run::Stats;
use sim2d::traps::{trap_map, TrapKind, TrapParams};
use sim2d::{Direction, PlannerKind, RunConfig, RunResult};

/// Success rates of DDP planners on seeded random trap maps.
#[derive(Debug, Parser)]
#[command(version)]
struct Args {
    /// Trap types, in table order: u, l, cubes, cylinders.
    #[arg(long, value_delimiter = ',', default_value = "u,l,cubes,cylinders")]
    types: Vec<String>,
    /// Maps per trap type.
    #[arg(long, default_value_t = 50)]
    maps: usize,
    /// Planner (repeatable): ddp, ddp-astar, ddpen, ddpen-oracle.
    #[arg(long = "planner", default_values = ["ddp", "ddp-astar", "ddpen", "ddpen-oracle"])]
    planners: Vec<String>,
    /// Seed of the maps and of the actuation and lidar noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Route length of every map (m).
    #[arg(long, default_value_t = 22.0)]
    route_length: f64,
    /// A run fails after this many simulated seconds without progress (s); Table I's 30 s: a
    /// U-turn alone takes 6.3 s at the 0.5 rad/s turn-rate limit.
    #[arg(long, default_value_t = 30.0)]
    stall_time: f64,
    /// A run is stopped after this much simulated time (s).
    #[arg(long, default_value_t = 120.0)]
    max_time: f64,
    /// Write the summary and every run's figures as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Output folder for the PNG top views.
    #[arg(long, default_value = "out/trap-bench")]
    out: PathBuf,
    /// Draw a PNG of the first this many maps of each type, with every planner's path.
    #[arg(long, default_value_t = 2)]
    png: usize,
    /// Planner and executor options.
    #[command(flatten)]
    planner: sim2d::cli::PlannerArgs,
    /// Live view.
    #[command(flatten)]
    live: sim2d::cli::LiveArgs,
    /// Worker threads [default: one per core].
    #[arg(long)]
    threads: Option<usize>,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// One cell of the summary: a planner on a trap type.
#[derive(Debug, Clone, serde::Serialize)]
struct Cell {
    trap: String,
    planner: String,
    maps: usize,
    completed: usize,
    success_rate: f64,
    /// Runs with at least one collision.
    runs_with_collisions: usize,
    /// Contact onsets over all runs.
    collisions: usize,
    /// Mean time of the completed runs (s).
    mean_time_s: f64,
    /// Planning cycle (set-up incl. sub-goals + 4 epochs), mean over cycles (ms).
    cycle_ms_mean: f64,
    /// Largest 99th percentile of the cycle time over the runs (ms).
    cycle_ms_p99_max: f64,
}

fn cell(trap: &str, planner: &str, runs: &[&RunResult]) -> Cell {
    let completed = runs.iter().filter(|r| r.completed).count();
    let times: Vec<f64> = runs.iter().filter(|r| r.completed).map(|r| r.time_s).collect();
    let cycles: usize = runs.iter().map(|r| r.cycle_stats.count).sum();
    Cell {
        trap: trap.into(),
        planner: planner.into(),
        maps: runs.len(),
        completed,
        success_rate: if runs.is_empty() {
            f64::NAN
        } else {
            completed as f64 / runs.len() as f64
        },
        runs_with_collisions: runs.iter().filter(|r| r.collisions > 0).count(),
        collisions: runs.iter().map(|r| r.collisions).sum(),
        mean_time_s: Stats::of(&times).mean,
        cycle_ms_mean: runs
            .iter()
            .map(|r| r.cycle_stats.mean * r.cycle_stats.count as f64)
            .sum::<f64>()
            / cycles.max(1) as f64,
        cycle_ms_p99_max: runs.iter().map(|r| r.cycle_stats.p99).fold(0.0, f64::max),
    }
}

fn run(args: Args) -> sim2d::Result<()> {
    if args.maps == 0 {
        return Err(sim2d::Error::invalid("maps", "must be at least 1"));
    }
    let kinds = args
        .types
        .iter()
        .map(|t| TrapKind::parse(t))
        .collect::<sim2d::Result<Vec<_>>>()?;
    let planners = args
        .planners
        .iter()
        .map(|p| PlannerKind::parse(p))
        .collect::<sim2d::Result<Vec<_>>>()?;
    let params = TrapParams {
        route_length: args.route_length,
        ..TrapParams::default()
    };
    params.validate()?;
    let mut base = RunConfig {
        stall_time: args.stall_time,
        max_time: args.max_time,
        keep_plan_every: 0,
        ..RunConfig::default()
    };
    args.planner.apply(&mut base);
    base.validate()?;
    // Fail early (`ddpen`: naming the model) rather than in every run.
    for p in &planners {
        p.prepare(&base.ddp, &base.ddpen)?;
    }

    let mut jobs = Vec::new();
    for &kind in &kinds {
        for i in 0..args.maps {
            let scenario = Arc::new(trap_map(kind, args.seed, i, &params)?);
            for &planner in &planners {
                jobs.push(Job {
                    scenario: scenario.clone(),
                    config: RunConfig {
                        planner,
                        direction: Direction::Forward,
                        seed: run_seed(args.seed, i, Direction::Forward),
                        ..base.clone()
                    },
                    run: i,
                });
            }
        }
    }
    println!(
        "trap bench: {} type(s) x {} maps x {} planner(s) = {} runs; route {} m, stall {} s, seed {}",
        kinds.len(),
        args.maps,
        planners.len(),
        jobs.len(),
        args.route_length,
        args.stall_time,
        args.seed
    );
    // Before any run: a port in use fails here.
    let live = args.live.start()?;
    if let Some(l) = &live {
        println!("live view on ws://127.0.0.1:{} (Foxglove: Open connection)", l.port);
    }
    let options = BatchOptions {
        out_dir: None,
        mcap: false,
        png: false,
        progress: !args.quiet,
        threads: args.threads,
        live: live.as_ref().map(|l| l.link.clone()),
        ..BatchOptions::default()
    };
    let wall = std::time::Instant::now();
    let results = run_batch(&jobs, &options)?;

    let mut cells = Vec::new();
    for &kind in &kinds {
        for &planner in &planners {
            let runs: Vec<&RunResult> = jobs
                .iter()
                .zip(&results)
                .filter(|(j, _)| {
                    j.config.planner == planner && j.scenario.name.starts_with(&format!("{}_", kind.name()))
                })
                .map(|(_, r)| r)
                .collect();
            cells.push(cell(kind.name(), planner.name(), &runs));
        }
    }
    let head: Vec<String> = planners.iter().map(|p| p.name().to_uppercase()).collect();
    println!(
        "\nSuccess rate (completed / maps) and runs with collisions\n\n| trap type | {} |\n|---|{}",
        head.join(" | "),
        "---|".repeat(head.len())
    );
    for (k, kind) in kinds.iter().enumerate() {
        let row: Vec<String> = (0..planners.len())
            .map(|p| {
                let c = &cells[k * planners.len() + p];
                format!(
                    "{:.0} % ({}/{}), {} coll.",
                    100.0 * c.success_rate,
                    c.completed,
                    c.maps,
                    c.runs_with_collisions
                )
            })
            .collect();
        println!("| {} | {} |", kind.name(), row.join(" | "));
    }
    let all: Vec<String> = planners
        .iter()
        .map(|&p| {
            let sel: Vec<&Cell> = cells.iter().filter(|c| c.planner == p.name()).collect();
            let (done, n): (usize, usize) = sel.iter().fold((0, 0), |a, c| (a.0 + c.completed, a.1 + c.maps));
            let coll: usize = sel.iter().map(|c| c.runs_with_collisions).sum();
            format!("{:.0} % ({done}/{n}), {coll} coll.", 100.0 * done as f64 / n as f64)
        })
        .collect();
    println!("| all | {} |", all.join(" | "));
    println!(
        "\nPlanning cycle (set-up incl. sub-goals + {} epochs), mean ms:",
        base.ddp.epochs
    );
    for &p in &planners {
        let sel: Vec<&Cell> = cells.iter().filter(|c| c.planner == p.name()).collect();
        let mean = sel.iter().map(|c| c.cycle_ms_mean).sum::<f64>() / sel.len() as f64;
        let p99 = sel.iter().map(|c| c.cycle_ms_p99_max).fold(0.0, f64::max);
        println!("  {:<13} mean {mean:.3} ms, largest per-run p99 {p99:.3} ms", p.name());
    }
    println!("batch wall time {:.1} s", wall.elapsed().as_secs_f64());

    if args.png > 0 {
        let idx: Vec<usize> = (0..jobs.len()).filter(|&i| jobs[i].run < args.png).collect();
        let sub_jobs: Vec<Job> = idx.iter().map(|&i| jobs[i].clone()).collect();
        let sub_results: Vec<RunResult> = idx.iter().map(|&i| results[i].clone()).collect();
        let written = write_figures(&args.out, &sub_jobs, &sub_results)?;
        println!("{} PNG top views in {}", written.len(), args.out.display());
    }
    if let Some(path) = &args.json {
        let runs: Vec<serde_json::Value> = jobs
            .iter()
            .zip(&results)
            .map(|(j, r)| {
                json!({
                    "map": j.scenario.name, "map_index": j.run, "planner": r.planner, "outcome": r.outcome,
                    "completed": r.completed, "time_s": r.time_s, "progress_m": r.progress_m,
                    "route_length_m": r.route_length_m, "collisions": r.collisions,
                    "contact_time_s": r.contact_time_s, "final_pose": r.final_pose,
                    "epoch_stats": r.epoch_stats, "cycle_stats": r.cycle_stats,
                    "real_time_factor": r.real_time_factor,
                })
            })
            .collect();
        write_json(
            path,
            &json!({
                "seed": args.seed, "maps_per_type": args.maps, "trap_params": params, "config": base,
                "types": kinds, "planners": planners, "summary": cells, "runs": runs,
            }),
        )?;
        println!("JSON in {}", path.display());
    }
    Ok(())
}
