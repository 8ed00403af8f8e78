//! The randomised trap benchmark: seeded random maps per trap type (U, L, cube clusters, cylinder
//! cups; generator in `sim2d::traps`), a trap across the straight line from start to goal; success
//! rate and collisions of each planner.
//!
//! ```text
//! cargo run --release -p sim2d --bin trap-bench -- --maps 50 --json out/trap-bench/bench.json
//! ```
//!
//! The runs are the tasks of `sim2d::sweep` (`trap_tasks`, aggregated by `aggregate_traps`), which
//! `python -m ddpkit.experiments trap-bench` runs on local processes or Ray.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use sim2d::batch::{run_batch, write_json, BatchOptions};
use sim2d::sweep::{aggregate_traps, trap_figures, trap_tasks, TrapConfig, TrapTask};
use sim2d::traps::TrapKind;
use sim2d::PlannerKind;

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

impl Args {
    /// The sweep's configuration (what the results depend on).
    fn config(&self) -> sim2d::Result<TrapConfig> {
        Ok(TrapConfig {
            types: self
                .types
                .iter()
                .map(|t| TrapKind::parse(t))
                .collect::<sim2d::Result<Vec<_>>>()?,
            maps: self.maps,
            planners: self
                .planners
                .iter()
                .map(|p| PlannerKind::parse(p))
                .collect::<sim2d::Result<Vec<_>>>()?,
            seed: self.seed,
            route_length: self.route_length,
            stall_time: self.stall_time,
            max_time: self.max_time,
            png: self.png,
            options: self.planner.clone(),
        })
    }
}

fn run(args: Args) -> sim2d::Result<()> {
    if args.maps == 0 {
        return Err(sim2d::Error::invalid("maps", "must be at least 1"));
    }
    let config = args.config()?;
    // Checks the configuration and the models before any run.
    let tasks = trap_tasks(&config)?;
    println!("{}", config.header());
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
    let jobs = tasks.iter().map(TrapTask::job).collect::<sim2d::Result<Vec<_>>>()?;
    let results = run_batch(&jobs, &options)?;
    let report = aggregate_traps(&config, &results)?;
    print!("{}", report.render(wall.elapsed().as_secs_f64()));
    if config.png > 0 {
        let written = trap_figures(&config, &tasks, &results, &args.out)?;
        println!("{} PNG top views in {}", written.len(), args.out.display());
    }
    if let Some(path) = &args.json {
        write_json(path, &report.json())?;
        println!("JSON in {}", path.display());
    }
    Ok(())
}
