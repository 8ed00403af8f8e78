//! The paper's Table I: 4 obstacle sets x forward/backward x 5 runs per planner; mean ± sd of
//! the execution time, "fail" when no run completed (no progress for 30 simulated seconds).
//!
//! ```text
//! cargo run --release -p sim2d --bin ddpen-table -- --planner ddp --planner ddpen --json out/table.json
//! ```
//!
//! Columns as the paper's Table I: DDP and DDPEN by default; `ddpen-oracle` (A* sub-goals) and
//! `ddp-astar` can be added with `--planner`.
//!
//! ```text
//! ```

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use clap::Parser;
use serde_json::json;
use sim2d::batch::{run_batch, run_seed, write_json, BatchOptions, Job};
use sim2d::log::LogOptions;
use sim2d::table::Table;
use sim2d::{Direction, PlannerKind, RunConfig, Scenario};

/// Reproduce DDPEN's Table I (execution time of the 278 m route, forward and backward).
#[derive(Debug, Parser)]
#[command(version)]
struct Args {
    /// Folder with the scenario files.
    #[arg(long, default_value = "scenarios")]
    scenarios: PathBuf,
    /// Obstacle sets (scenario file stems), in table order.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "free,cylinders,cubes_without_minima,cubes_with_minima"
    )]
    sets: Vec<String>,
    /// Planner (repeatable): ddp, ddp-astar, ddpen, ddpen-oracle.
    #[arg(long = "planner", default_values = ["ddp", "ddpen"])]
    planners: Vec<String>,
    /// Runs per set, planner and direction.
    #[arg(long, default_value_t = 5)]
    runs: usize,
    /// Base seed of the actuation and lidar noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Write the table and every figure (runs, trajectories, per-epoch times) as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Output folder for MCAP logs and PNG figures.
    #[arg(long, default_value = "out/ddpen-table")]
    out: PathBuf,
    /// Write no MCAP logs.
    #[arg(long)]
    no_mcap: bool,
    /// Draw no PNG figures.
    #[arg(long)]
    no_png: bool,
    /// Seconds between costmap messages in the MCAP logs.
    #[arg(long, default_value_t = 2.0)]
    costmap_period: f64,
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

fn run(args: Args) -> sim2d::Result<()> {
    if args.runs == 0 {
        return Err(sim2d::Error::invalid("runs", "must be at least 1"));
    }
    let planners = args
        .planners
        .iter()
        .map(|p| PlannerKind::parse(p))
        .collect::<sim2d::Result<Vec<_>>>()?;
    let scenarios = args
        .sets
        .iter()
        .map(|s| Scenario::from_file(args.scenarios.join(format!("{s}.toml"))).map(Arc::new))
        .collect::<sim2d::Result<Vec<_>>>()?;
    let mut base = RunConfig::default();
    args.planner.apply(&mut base);
    base.validate()?;
    // Fail early (`ddpen`: naming the model) rather than in every run.
    for p in &planners {
        p.prepare(&base.ddp, &base.ddpen)?;
    }
    let mut jobs = Vec::new();
    for scenario in &scenarios {
        for &planner in &planners {
            for direction in [Direction::Forward, Direction::Backward] {
                for run in 0..args.runs {
                    jobs.push(Job {
                        scenario: scenario.clone(),
                        config: RunConfig {
                            planner,
                            direction,
                            seed: run_seed(args.seed, run, direction),
                            ..base.clone()
                        },
                        run,
                    });
                }
            }
        }
    }
    println!(
        "Table I: {} obstacle sets x {} planner(s) x 2 directions x {} runs = {} runs, horizon N = {} ({:.1} s), {} epochs per cycle",
        scenarios.len(),
        planners.len(),
        args.runs,
        jobs.len(),
        base.ddp.horizon,
        base.ddp.horizon as f64 * base.ddp.dt,
        base.ddp.epochs
    );
    // Before any run: a port in use fails here.
    let live = args.live.start()?;
    if let Some(l) = &live {
        println!("live view on ws://127.0.0.1:{} (Foxglove: Open connection)", l.port);
    }
    let options = BatchOptions {
        out_dir: Some(args.out.clone()),
        mcap: !args.no_mcap,
        log: LogOptions {
            costmap_period: args.costmap_period,
        },
        png: !args.no_png,
        progress: !args.quiet,
        threads: args.threads,
        live: live.as_ref().map(|l| l.link.clone()),
    };
    let wall = std::time::Instant::now();
    let results = run_batch(&jobs, &options)?;
    let names: Vec<String> = scenarios.iter().map(|s| s.name.clone()).collect();
    let planner_names: Vec<String> = planners.iter().map(|p| p.name().to_string()).collect();
    let table = Table::new(&results, &names, &planner_names);
    println!("\nTable I: execution time of the route, mean ± sd over completed runs (s); \"fail\": no run completed\n");
    println!("{}", table.markdown());
    let e = table.epoch_ms;
    println!(
        "per epoch: mean {:.3} ms, p50 {:.3} ms, p99 {:.3} ms, max {:.3} ms over {} epochs (paper: 75 ms)",
        e.mean, e.p50, e.p99, e.max, e.count
    );
    for p in &planner_names {
        let sel: Vec<&sim2d::RunResult> = results.iter().filter(|r| &r.planner == p).collect();
        let n: usize = sel.iter().map(|r| r.cycle_stats.count).sum();
        let mean = sel
            .iter()
            .map(|r| r.cycle_stats.mean * r.cycle_stats.count as f64)
            .sum::<f64>()
            / n.max(1) as f64;
        let p99 = sel.iter().map(|r| r.cycle_stats.p99).fold(0.0, f64::max);
        println!("planning cycle of {p} (set-up incl. sub-goals + epochs): mean {mean:.3} ms, largest per-run p99 {p99:.3} ms over {n} cycles");
    }
    println!(
        "real-time factor {:.0}x per core (whole loop: physics, lidar, costmap, planning); batch wall time {:.1} s",
        table.real_time_factor,
        wall.elapsed().as_secs_f64()
    );
    if options.mcap || options.png {
        println!("logs and figures in {}", args.out.display());
    }
    if let Some(path) = &args.json {
        write_json(path, &json!({"config": base, "table": table, "runs": results}))?;
        println!("JSON in {}", path.display());
    }
    Ok(())
}
