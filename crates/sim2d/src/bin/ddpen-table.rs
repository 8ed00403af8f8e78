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
//! The runs are the tasks of `sim2d::sweep` (`table_tasks`, aggregated by `aggregate_table`),
//! which `python -m ddpkit.experiments ddpen-table` runs on local processes or Ray.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use sim2d::batch::{run_batch, write_json, BatchOptions};
use sim2d::log::{check_output_dir, LogOptions};
use sim2d::sweep::{aggregate_table, table_figures, table_tasks, TableConfig, TableTask};
use sim2d::PlannerKind;

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

impl Args {
    /// The sweep's configuration (what the results depend on).
    fn config(&self) -> sim2d::Result<TableConfig> {
        Ok(TableConfig {
            scenarios: self.scenarios.clone(),
            sets: self.sets.clone(),
            planners: self
                .planners
                .iter()
                .map(|p| PlannerKind::parse(p))
                .collect::<sim2d::Result<Vec<_>>>()?,
            runs: self.runs,
            seed: self.seed,
            options: self.planner.clone(),
            png: !self.no_png,
        })
    }
}

fn run(args: Args) -> sim2d::Result<()> {
    let config = args.config()?;
    // Checks the configuration, the scenario files and the models before any run.
    let tasks = table_tasks(&config)?;
    println!("{}", config.header(&config.base()?));
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
        // The figures are drawn below from the results, as `ddpkit.experiments` draws them.
        png: false,
        progress: !args.quiet,
        threads: args.threads,
        live: live.as_ref().map(|l| l.link.clone()),
    };
    if config.png {
        check_output_dir(&args.out)?;
    }
    let wall = std::time::Instant::now();
    let jobs = tasks.iter().map(TableTask::job).collect::<sim2d::Result<Vec<_>>>()?;
    let results = run_batch(&jobs, &options)?;
    let report = aggregate_table(&config, &results)?;
    table_figures(&config, &tasks, &results, &args.out)?;
    print!("{}", report.render(wall.elapsed().as_secs_f64()));
    if options.mcap || config.png {
        println!("logs and figures in {}", args.out.display());
    }
    if let Some(path) = &args.json {
        write_json(path, &report.json())?;
        println!("JSON in {}", path.display());
    }
    Ok(())
}
