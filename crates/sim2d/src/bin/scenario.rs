//! Runs one scenario file with one or more planners, both directions by default.
//!
//! ```text
//! cargo run --release -p sim2d --bin scenario -- scenarios/cylinders.toml --planner ddp
//! ```
//!
//! Prints one line per run and a summary (completion, time, collisions, per-epoch compute time,
//! real-time factor); writes an MCAP log per run and a PNG top view per direction under `--out`,
//! and every figure as JSON with `--json`.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use clap::{Parser, ValueEnum};
use serde_json::json;
use sim2d::batch::{run_batch, run_seed, write_json, BatchOptions, Job};
use sim2d::log::LogOptions;
use sim2d::run::Stats;
use sim2d::{Direction, PlannerKind, RunConfig, Scenario};

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Directions {
    Forward,
    Backward,
    Both,
}

/// Run a DDPEN scenario (route + obstacles) with DDP planners in the loop.
#[derive(Debug, Parser)]
#[command(version)]
struct Args {
    /// Scenario file (TOML).
    #[arg(default_value = "scenarios/cylinders.toml")]
    scenario: PathBuf,
    /// Planner (repeatable): ddp, ddp-astar, ddpen, ddpen-oracle.
    #[arg(long = "planner", default_value = "ddp")]
    planners: Vec<String>,
    /// Route direction.
    #[arg(long, value_enum, default_value_t = Directions::Both)]
    direction: Directions,
    /// Runs per planner and direction.
    #[arg(long, default_value_t = 1)]
    runs: usize,
    /// Base seed of the actuation and lidar noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Write every figure (runs, trajectories, per-epoch times) as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Output folder for MCAP logs and PNG figures (default: `out/` and the scenario name).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write no MCAP logs.
    #[arg(long)]
    no_mcap: bool,
    /// Draw no PNG figures.
    #[arg(long)]
    no_png: bool,
    /// Seconds between costmap messages in the MCAP logs.
    #[arg(long, default_value_t = 1.0)]
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
    let scenario = Arc::new(Scenario::from_file(&args.scenario)?);
    let planners = args
        .planners
        .iter()
        .map(|p| PlannerKind::parse(p))
        .collect::<sim2d::Result<Vec<_>>>()?;
    if args.runs == 0 {
        return Err(sim2d::Error::invalid("runs", "must be at least 1"));
    }
    let directions: &[Direction] = match args.direction {
        Directions::Forward => &[Direction::Forward],
        Directions::Backward => &[Direction::Backward],
        Directions::Both => &[Direction::Forward, Direction::Backward],
    };
    let mut base = RunConfig::default();
    args.planner.apply(&mut base);
    base.validate()?;
    let mut jobs = Vec::new();
    for &planner in &planners {
        for &direction in directions {
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
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&scenario.name));
    // Before any run: a port in use fails here.
    let live = args.live.start()?;
    if let Some(l) = &live {
        println!("live view on ws://127.0.0.1:{} (Foxglove: Open connection)", l.port);
    }
    let options = BatchOptions {
        out_dir: Some(out.clone()),
        mcap: !args.no_mcap,
        log: LogOptions {
            costmap_period: args.costmap_period,
        },
        png: !args.no_png,
        progress: !args.quiet,
        threads: args.threads,
        live: live.as_ref().map(|l| l.link.clone()),
    };
    println!(
        "{}: {} m route, {} obstacles, {} run(s), horizon N = {} ({:.1} s)",
        scenario.name,
        scenario.route.length(),
        scenario.obstacles.len(),
        jobs.len(),
        base.ddp.horizon,
        base.ddp.horizon as f64 * base.ddp.dt
    );
    let results = run_batch(&jobs, &options)?;

    println!(
        "\n{:<10} {:<9} {:>3} {:<10} {:>8} {:>10} {:>10} {:>11} {:>11} {:>9}",
        "planner", "direction", "run", "outcome", "time s", "progress m", "collisions", "epoch ms", "epoch max", "RTF"
    );
    for r in &results {
        println!(
            "{:<10} {:<9} {:>3} {:<10} {:>8.1} {:>10.1} {:>10} {:>11.3} {:>11.3} {:>8.0}x",
            r.planner,
            r.direction.name(),
            jobs.iter()
                .zip(&results)
                .find(|(_, x)| std::ptr::eq(*x, r))
                .map_or(0, |(j, _)| j.run),
            r.outcome.name(),
            r.time_s,
            r.progress_m,
            r.collisions,
            r.epoch_stats.mean,
            r.epoch_stats.max,
            r.real_time_factor
        );
    }
    let epochs: Vec<f64> = results.iter().flat_map(|r| r.epoch_ms.iter().copied()).collect();
    let e = Stats::of(&epochs);
    let sim: f64 = results.iter().map(|r| r.time_s).sum();
    let wall: f64 = results.iter().map(|r| r.timing.total).sum();
    let t = results.iter().fold([0.0; 4], |a, r| {
        [
            a[0] + r.timing.physics,
            a[1] + r.timing.lidar,
            a[2] + r.timing.costmap,
            a[3] + r.timing.planning,
        ]
    });
    println!(
        "\nper epoch: mean {:.3} ms, p50 {:.3} ms, p99 {:.3} ms, max {:.3} ms over {} epochs",
        e.mean, e.p50, e.p99, e.max, e.count
    );
    println!(
        "real-time factor {:.0}x on one core ({:.0} s simulated in {:.2} s; physics {:.0} %, lidar {:.0} %, costmap {:.0} %, planning {:.0} %)",
        sim / wall,
        sim,
        wall,
        100.0 * t[0] / wall,
        100.0 * t[1] / wall,
        100.0 * t[2] / wall,
        100.0 * t[3] / wall
    );
    if options.mcap || options.png {
        println!("logs and figures in {}", out.display());
    }
    if let Some(path) = &args.json {
        write_json(
            path,
            &json!({
                "scenario": scenario.name,
                "config": base,
                "epoch_ms": e,
                "real_time_factor": sim / wall,
                "runs": results,
            }),
        )?;
        println!("JSON in {}", path.display());
    }
    Ok(())
}
