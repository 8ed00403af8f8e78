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

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use sim2d::turtlebot::{experiment_json, run_experiment, write_figure, Summary, Turtlebot, TurtlebotConfig};

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

fn row(s: &Summary) -> String {
    let c = &s.min_clearance;
    format!(
        "| {} | {}/{} | {} | {} | {:.1} ± {:.1} | {:.1} | {:.1} | {:.1} | {:.1} ± {:.1} | {:.2} / {:.2} |",
        match s.controller {
            sim2d::turtlebot::Controller::Cddp => "CDDP".to_string(),
            sim2d::turtlebot::Controller::SafeCddp { beta } => format!("Safe-CDDP (beta {beta})"),
        },
        s.reached,
        s.runs,
        s.collided_runs,
        s.collisions,
        100.0 * c.mean,
        100.0 * c.sd,
        100.0 * c.min,
        100.0 * c.p10,
        100.0 * c.p50,
        s.time_s.mean,
        s.time_s.sd,
        s.step_solve_ms.mean,
        s.step_solve_ms.max,
    )
}

fn run(args: Args) -> sim2d::Result<()> {
    if let Some(t) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build_global()
            .map_err(|e| sim2d::Error::invalid("threads", e.to_string()))?;
    }
    let mut config = TurtlebotConfig::for_robot(Turtlebot::parse(&args.robot)?);
    if let Some(s) = args.sigma_xy {
        config.sigma_xy = s;
    }
    if let Some(s) = args.sigma_theta {
        config.sigma_theta = s;
    }
    if let Some(s) = args.sigma_w_xy {
        config.sigma_w[0] = s;
        config.sigma_w[1] = s;
    }
    config.validate()?;
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

    println!(
        "Turtlebot3 {} in rapier2d, {} episodes per controller, seed {}, N = {}, localisation noise sigma = {} m / {} rad, Sigma_w = diag({:?})^2, inflation {:.4} m",
        args.robot, args.runs, args.seed, config.horizon, config.sigma_xy, config.sigma_theta, config.sigma_w, config.inflation
    );
    println!(
        "| controller | reached | runs with collision | collisions | min clearance mean ± sd (cm) | min (cm) | p10 (cm) | median (cm) | time (s) | solve ms/step mean / max |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    println!("{}", row(&e.cddp_summary));
    println!("{}", row(&e.safe_summary));
    println!(
        "Safe-CDDP keeps the wider minimum clearance in {} of {} paired episodes; {:.1} s wall.",
        e.safe_wider, args.runs, wall
    );
    if let Some(path) = &args.json {
        let mut v = experiment_json(&e, args.paths);
        v["wall_s"] = serde_json::json!(wall);
        sim2d::batch::write_json(path, &v)?;
        println!("wrote {}", path.display());
    }
    if let Some(path) = &args.png {
        write_figure(path, &e)?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
