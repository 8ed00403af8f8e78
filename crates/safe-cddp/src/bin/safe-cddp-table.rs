//! Reproduces Table I of Safe-CDDP (Alcan and Kyrki 2022) and a figure like its Fig. 4.
//!
//! ```text
//! cargo run --release -p safe-cddp --bin safe-cddp-table -- --seed 1 \
//!     --json crates/safe-cddp/results/table1.json --figure crates/safe-cddp/results/fig4.png
//! ```
//!
//! Runs `--episodes` (default 100) seeded MPC episodes per robot and `beta` in parallel (rayon),
//! with a progress bar, prints the table beside the paper's, and optionally writes every figure
//! of it as JSON and the figure as a PNG. Episode `e` of a robot meets the same noise under every
//! method (see [`safe_cddp::table::episode_seed`]), so results do not depend on the thread count.
//! The scenarios are in [`safe_cddp::table`]; the episodes are the tasks of
//! [`safe_cddp::sweep`] (the functions `python -m ddpkit.experiments safe-table` runs on other
//! executors). Besides the paper's rows, the car is also run with the two baselines of Fig. 4 at
//! `beta = 0.99` (fixed LQR gains, open loop).

use std::path::PathBuf;
use std::time::Instant;

use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use safe_cddp::sweep::{self, TableConfig};
use safe_cddp::table::Robot;

#[derive(Parser, Debug)]
#[command(about = "Reproduce Table I (and Fig. 4) of Safe-CDDP: MPC episodes under process noise")]
struct Args {
    /// Episodes per robot and beta.
    #[arg(long, default_value_t = 100)]
    episodes: usize,
    /// Base seed of the process noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Write every figure of the table (and the settings) as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write the Fig. 4 PNG (car: trajectories, position sigma, gain norms) here.
    #[arg(long)]
    figure: Option<PathBuf>,
    /// Robots to run (comma-separated: point, car, quadrotor).
    #[arg(long, value_delimiter = ',', default_value = "point,car,quadrotor")]
    robots: Vec<String>,
    /// Override the noise scale of the point robot (m per step).
    #[arg(long)]
    noise_point: Option<f64>,
    /// Override the noise scale of the car (m per step).
    #[arg(long)]
    noise_car: Option<f64>,
    /// Override the noise scale of the quadrotor (m per step).
    #[arg(long)]
    noise_quadrotor: Option<f64>,
    /// The betas to run (comma-separated subset of 0.5, 0.9, 0.95, 0.99; 0.5 is plain CDDP).
    #[arg(long, value_delimiter = ',', default_value = "0.5,0.9,0.95,0.99")]
    betas: Vec<f64>,
    /// Skip the car's fixed-gain and open-loop baselines (Fig. 4).
    #[arg(long)]
    no_baselines: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
}

fn robot_of(name: &str) -> Result<Robot, String> {
    Robot::ALL
        .into_iter()
        .find(|r| r.name() == name.trim())
        .ok_or_else(|| format!("unknown robot {name:?} (expected point, car or quadrotor)"))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    if args.episodes == 0 {
        return Err("--episodes must be at least 1".into());
    }
    if let Some(t) = args.threads {
        rayon::ThreadPoolBuilder::new().num_threads(t.max(1)).build_global()?;
    }
    for b in &args.betas {
        if !(*b > 0.0 && *b < 1.0) {
            return Err(format!("--betas: {b} is not in (0, 1)").into());
        }
    }
    let config = TableConfig {
        episodes: args.episodes,
        seed: args.seed,
        robots: args.robots.iter().map(|r| robot_of(r)).collect::<Result<_, _>>()?,
        noise_point: args.noise_point,
        noise_car: args.noise_car,
        noise_quadrotor: args.noise_quadrotor,
        betas: args.betas.clone(),
        baselines: !args.no_baselines,
    };
    let tasks = sweep::tasks(&config)?;
    let bar = ProgressBar::new(tasks.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} episodes ({eta} left) {msg}")?
            .progress_chars("=> "),
    );
    let start = Instant::now();
    let outcomes = tasks
        .par_iter()
        .map(|t| {
            let r = sweep::run_task(t);
            bar.inc(1);
            r
        })
        .collect::<Result<Vec<_>, _>>()?;
    bar.finish_and_clear();
    let seconds = start.elapsed().as_secs_f64();
    let table = sweep::aggregate(&config, &outcomes)?;
    print!("{}", table.render());
    let threads = rayon::current_num_threads();
    println!(
        "\n{} episodes per row, seed {}, {} threads, {:.1} s",
        args.episodes, args.seed, threads, seconds
    );
    if let Some(path) = &args.json {
        let command = std::env::args().collect::<Vec<_>>().join(" ");
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir)?;
        }
        // Whole or absent: a temporary file, then a rename.
        ddpkit_util::fs::write_atomic(path, table.json(&config, command, threads, seconds)?)?;
        println!("wrote {}", path.display());
    }
    if let Some(path) = &args.figure {
        if safe_cddp::figure::table_figure(path, &config, &outcomes)? {
            println!("wrote {}", path.display());
        } else {
            eprintln!("--figure needs the car (Fig. 4 is the car's); skipped");
        }
    }
    Ok(())
}
