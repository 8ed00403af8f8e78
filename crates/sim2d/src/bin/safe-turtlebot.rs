//! The Safe-CDDP hardware experiment (Alcan and Kyrki (2022), §IV-C, Fig. 5) in simulation: a
//! Turtlebot3 Burger in sim2d's rapier world, CDDP versus Safe-CDDP (`beta = 0.8`) over seeded
//! episodes.
//!
//! ```text
//! cargo run --release -p sim2d --bin safe-turtlebot -- --runs 100 --seed 1 \
//!     --json out/turtlebot/safe-turtlebot.json --png out/turtlebot/safe-turtlebot.png
//! ```
//!
//! Prints the table (goal reached, collisions, minimum clearance to the closest obstacle, solve
//! times); `--json` writes every figure (and `--paths` every trajectory), `--png` the figure:
//! (a) the driven paths, (b) the histograms of the minimum clearance (Fig. 5c).
//!
//! The episodes are the tasks of [`sim2d::turtlebot::sweep`] (the functions `python -m
//! ddpkit.experiments safe-turtlebot` runs on other executors), run here on rayon's pool.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use sim2d::turtlebot::sweep::{self, TurtlebotSweepConfig};
use sim2d::turtlebot::{run_experiment, write_figure, Turtlebot};

/// CDDP versus Safe-CDDP on a simulated Turtlebot3 (Alcan and Kyrki (2022), §IV-C).
#[derive(Debug, Parser)]
#[command(version)]
struct Args {
    /// Episodes per controller.
    #[arg(long, default_value_t = 100)]
    runs: usize,
    /// Base seed of the actuation and localisation noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Safe-CDDP's satisfaction probability.
    #[arg(long, default_value_t = 0.8)]
    beta: f64,
    /// The robot: waffle-pi (the paper's) or burger.
    #[arg(long, default_value = "waffle-pi")]
    robot: String,
    /// Localisation noise on x and y (m).
    #[arg(long)]
    sigma_xy: Option<f64>,
    /// Localisation noise on the heading (rad).
    #[arg(long)]
    sigma_theta: Option<f64>,
    /// Process noise per step the tightening assumes on x and y (m).
    #[arg(long)]
    sigma_w_xy: Option<f64>,
    /// Write every figure as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Include every trajectory (poses, commands) in the JSON.
    #[arg(long)]
    paths: bool,
    /// Write the figure (PNG) here.
    #[arg(long)]
    png: Option<PathBuf>,
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
    if let Some(t) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build_global()
            .map_err(|e| sim2d::Error::invalid("threads", e.to_string()))?;
    }
    let sweep_config = TurtlebotSweepConfig {
        runs: args.runs,
        seed: args.seed,
        beta: args.beta,
        robot: Turtlebot::parse(&args.robot)?,
        sigma_xy: args.sigma_xy,
        sigma_theta: args.sigma_theta,
        sigma_w_xy: args.sigma_w_xy,
        paths: args.paths,
    };
    let config = sweep_config.turtlebot()?;
    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(2 * args.runs as u64)
    };
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} episodes, {elapsed} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let start = std::time::Instant::now();
    let e = run_experiment(&config, args.runs, args.seed, args.beta, &|| bar.inc(1))?;
    bar.finish_and_clear();
    let wall = start.elapsed().as_secs_f64();

    print!("{}", sweep::report(&sweep_config, &e, wall));
    if let Some(path) = &args.json {
        sim2d::batch::write_json(path, &sweep::json(&sweep_config, &e, wall))?;
        println!("wrote {}", path.display());
    }
    if let Some(path) = &args.png {
        write_figure(path, &e)?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
