//! `subgoal-dataset`: generates the DDPEN sub-goal dataset as safetensors shards.
//!
//! ```text
//! cargo run --release -p subgoal-infer --bin subgoal-dataset -- \
//!     --out DIR --samples 60000 --seed 1 --shard-size 5000 [--threads 2]
//! ```
//!
//! Sample `i` depends on `(seed, i)` only, so the bytes are the same for any `--threads`.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use subgoal_infer::dataset::{write_dataset, DatasetParams, WriteOptions};

/// Generate the DDPEN sub-goal dataset (random obstacle maps, A* sub-goals) as safetensors shards.
#[derive(Debug, Parser)]
#[command(version, about)]
struct Args {
    /// Output directory (created if missing); gets shard-NNNNN.safetensors and manifest.json.
    #[arg(long)]
    out: PathBuf,
    /// Number of samples.
    #[arg(long)]
    samples: u64,
    /// Seed: sample i depends on (seed, i) only.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Samples per shard.
    #[arg(long, default_value_t = 5000)]
    shard_size: usize,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Probability of a U or L trap across the line to the goal.
    #[arg(long)]
    trap_probability: Option<f64>,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let mut params = DatasetParams::default();
    if let Some(p) = args.trap_probability {
        params.trap_probability = p;
    }
    let opts = WriteOptions {
        samples: args.samples,
        seed: args.seed,
        shard_size: args.shard_size,
        threads: args.threads,
        params,
    };
    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(args.samples)
    };
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} samples {per_sec} [{elapsed_precise} < {eta_precise}]")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let result = write_dataset(&args.out, &opts, &|k| bar.inc(k));
    bar.finish_and_clear();
    match result {
        Ok(s) => {
            let threads = args.threads.map_or_else(|| "all".to_string(), |t| t.to_string());
            println!("{}", s.line(s.seconds, &format!("threads: {threads}")));
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
