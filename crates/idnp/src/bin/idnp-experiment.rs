//! The experiment of Richter et al. (2023), Section V: seeded initial conditions, each solved by
//! fixed-grid IDNP, adaptive IDNP and the NLP alone; prints the table, checks that the adaptive
//! grid never solves fewer cases than the fixed one, and writes a figure like Fig. 3.
//!
//! ```text
//! cargo run --release -p idnp --bin idnp-experiment -- --seed 1 --n 200 --optimizer-iterations 100 \
//!     --json crates/idnp/results/experiment.json --png crates/idnp/results/fig3.png
//! ```

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use clap::Parser;
use idnp::experiment::{run_idnp, ExperimentResult};
use idnp::idnp::Variant;
use idnp::scene::Scene;
use idnp::sweep::{self, IdnpConfig};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;

/// IDNP with adaptive grid refinement: the experiment of Richter et al. (2023) on a planar base
/// with a 2-link arm and a narrow passage.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Seed of the initial conditions.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Number of initial conditions.
    #[arg(long, short = 'n', default_value_t = 200)]
    n: usize,
    /// Iterations of the IDNP loop per case (the paper: 15).
    #[arg(long, default_value_t = 15)]
    iterations: usize,
    /// Region of the initial TCP positions: `x_min y_min x_max y_max` (m).
    #[arg(long, num_args = 4, value_names = ["X_MIN", "Y_MIN", "X_MAX", "Y_MAX"], allow_negative_numbers = true)]
    region: Option<Vec<f64>>,
    /// Iterations of the NLP alone.
    #[arg(long, default_value_t = 400)]
    optimizer_iterations: usize,
    /// Also run fixed-grid IDNP on the uniform grid that resolves the passage.
    #[arg(long)]
    uniform: bool,
    /// Pure Algorithm 1: no penalty adaptation where the adaptive grid is at its deepest level.
    #[arg(long)]
    no_max_level_penalty: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Write every result as JSON here (written to a temporary file, then renamed).
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write the figure (like the paper's Fig. 3) here.
    #[arg(long, default_value = "out/idnp_fig3.png")]
    png: PathBuf,
    /// Skip the figure.
    #[arg(long)]
    no_png: bool,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

fn write_json(path: &PathBuf, result: &ExperimentResult) -> Result<(), String> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    }
    let text = serde_json::to_string_pretty(result).map_err(|e| format!("cannot serialise the results: {e}"))?;
    ddpkit_util::fs::write_atomic(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
}

fn run(args: Args) -> Result<bool, String> {
    if let Some(t) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t.max(1))
            .build_global()
            .map_err(|e| e.to_string())?;
    }
    let scene = Arc::new(Scene::narrow_passage());
    let config = IdnpConfig {
        seed: args.seed,
        n: args.n,
        iterations: args.iterations,
        region: args.region.as_ref().map(|r| [[r[0], r[1]], [r[2], r[3]]]),
        optimizer_iterations: args.optimizer_iterations,
        uniform: args.uniform,
        no_max_level_penalty: args.no_max_level_penalty,
    };
    // The cases as independent tasks (idnp::sweep), the ones `python -m ddpkit.experiments idnp`
    // runs on its executors, here on every core.
    let tasks = sweep::tasks(&config).map_err(|e| e.to_string())?;
    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(args.n as u64)
    };
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} cases [{elapsed_precise} < {eta_precise}]")
            .map_err(|e| e.to_string())?,
    );
    let cases = tasks
        .par_iter()
        .map(|t| {
            let r = sweep::run_task(t);
            bar.inc(1);
            r
        })
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| e.to_string())?;
    let result = sweep::aggregate(&config, &cases).map_err(|e| e.to_string())?;
    bar.finish_and_clear();
    print!("{}", sweep::report(&config, &result));
    let never_fewer = result.summary.fixed_not_adaptive.is_empty();
    if let Some(path) = &args.json {
        write_json(path, &result)?;
        println!("results: {}", path.display());
    }
    if !args.no_png {
        // The first case the adaptive grid solved in three iterations and the fixed grid did not
        // (as in Fig. 3; else after two or more, else any), re-run to keep grids and waypoints.
        let pick = sweep::figure_case(&result);
        if let Some(case) = pick {
            let (out, grids) = run_idnp(&scene, result.config.settings, Variant::Adaptive, case.initial.state())
                .map_err(|e| e.to_string())?;
            if let Some(dir) = args.png.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
            }
            let traj = out.trajectory().map(|t| t.xs.as_slice());
            idnp::plot::figure(&args.png, &scene, &out.iterations, &grids, traj, 80.0).map_err(|e| e.to_string())?;
            println!(
                "figure: {} (case {}, {} iterations; waypoints of iterations 1-4: red, orange, blue, purple)",
                args.png.display(),
                case.index,
                out.iterations.len()
            );
        }
    }
    Ok(never_fewer)
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(2),
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
