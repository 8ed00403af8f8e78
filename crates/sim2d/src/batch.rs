//! Many runs in parallel (rayon), with a progress bar, an MCAP log per run and a PNG per
//! scenario and direction: what the `scenario` and `ddpen-table` binaries share.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::log::{check_output_dir, LiveLink, LogOptions, Pacer, Recorder};
use crate::plot::{planner_style, top_view, PlotOptions, Track};
use crate::run::{run_scenario_with, CycleView, Direction, Observer, RunConfig, RunResult};
use crate::scenario::Scenario;

/// One run to do.
#[derive(Debug, Clone)]
pub struct Job {
    /// The scenario.
    pub scenario: Arc<Scenario>,
    /// Its configuration (planner, direction, seed, ...).
    pub config: RunConfig,
    /// Index of the run among the repetitions of the same scenario, planner and direction.
    pub run: usize,
}

impl Job {
    /// File stem of this run's outputs: `<scenario>_<planner>_<direction>_<run>`.
    pub fn stem(&self) -> String {
        format!(
            "{}_{}_{}_{}",
            self.scenario.name,
            self.config.planner.name(),
            self.config.direction.name(),
            self.run
        )
    }
}

/// The seed of repetition `run` in `direction`: the same for every planner, so planners meet the
/// same noise; distinct across runs and directions.
pub fn run_seed(base: u64, run: usize, direction: Direction) -> u64 {
    let d = match direction {
        Direction::Forward => 0,
        Direction::Backward => 1,
    };
    base.wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add(2 * run as u64 + d)
}

/// Outputs and execution of a batch.
#[derive(Debug, Clone, PartialEq)]
pub struct BatchOptions {
    /// Where logs and figures go (`None`: nowhere).
    pub out_dir: Option<PathBuf>,
    /// Write an MCAP log per run (under `<out_dir>/logs/`).
    pub mcap: bool,
    /// MCAP options.
    pub log: LogOptions,
    /// Draw a PNG per scenario and direction (in `<out_dir>`).
    pub png: bool,
    /// Show a progress bar (metres driven over all runs).
    pub progress: bool,
    /// Worker threads (`None`: one per core).
    pub threads: Option<usize>,
    /// Mirror every run to a live view (`crate::live`, feature `live`); the runs then go one
    /// after another, paced at the link's rate.
    pub live: Option<LiveLink>,
}

impl Default for BatchOptions {
    fn default() -> Self {
        Self {
            out_dir: None,
            mcap: true,
            log: LogOptions::default(),
            png: true,
            progress: true,
            threads: None,
            live: None,
        }
    }
}

struct Progress {
    bar: ProgressBar,
    done: f64,
    run: usize,
}

impl Observer for Progress {
    fn on_cycle(&mut self, c: &CycleView<'_>) -> Result<()> {
        if c.progress > self.done + 0.5 {
            self.bar.inc((c.progress - self.done) as u64);
            self.done = c.progress.floor();
        }
        Ok(())
    }
    fn on_end(&mut self, r: &RunResult) -> Result<()> {
        self.bar.inc((r.route_length_m - self.done).max(0.0) as u64);
        self.done = r.route_length_m;
        self.bar.println(format!(
            "  {:<22} {:<9} {:<8} run {:<2} {:<9} {:7.1} s  collisions {}  {:5.0}x real time",
            r.scenario,
            r.planner,
            r.direction.name(),
            self.run,
            r.outcome.name(),
            r.time_s,
            r.collisions,
            r.real_time_factor
        ));
        Ok(())
    }
}

/// Runs `jobs` (in parallel), writing logs and figures as `options` say. Results come back in
/// the order of `jobs`.
///
/// The output folder (and its `logs/`) is checked before the first run: a folder that cannot be
/// created or written is an error naming it, and no run starts.
pub fn run_batch(jobs: &[Job], options: &BatchOptions) -> Result<Vec<RunResult>> {
    options.log.validate()?;
    if let Some(dir) = &options.out_dir {
        if options.mcap || options.png {
            check_output_dir(dir)?;
        }
        if options.mcap {
            check_output_dir(&dir.join("logs"))?;
        }
    }
    // A live view shows one run at a time.
    let threads = if options.live.is_some() {
        Some(1)
    } else {
        options.threads
    };
    let total: f64 = jobs.iter().map(|j| j.scenario.route.length()).sum();
    let bar = if options.progress {
        let b = ProgressBar::new(total as u64);
        b.set_style(
            ProgressStyle::with_template("{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} m driven (eta {eta})")
                .expect("valid template"),
        );
        b
    } else {
        ProgressBar::hidden()
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .map_err(|e| Error::invalid("threads", e.to_string()))?;
    let results: Vec<Result<RunResult>> = pool.install(|| {
        jobs.par_iter()
            .map(|job| {
                let mut progress = Progress {
                    bar: bar.clone(),
                    done: 0.0,
                    run: job.run,
                };
                let file = match (&options.out_dir, options.mcap) {
                    (Some(dir), true) => Some(Recorder::mcap(
                        dir.join("logs").join(format!("{}.mcap", job.stem())),
                        options.log,
                    )?),
                    _ => None,
                };
                let mut logger = match (file, &options.live) {
                    (Some(f), Some(live)) => Some(f.with_mirror(live.topics.clone())),
                    (None, Some(live)) => Some(Recorder::mirror_only(live.topics.clone(), options.log)?),
                    (f, None) => f,
                };
                let mut pacer = options.live.as_ref().map(|l| Pacer::new(l.rate)).transpose()?;
                let mut observers: Vec<&mut dyn Observer> = vec![&mut progress];
                if let Some(l) = logger.as_mut() {
                    observers.push(l);
                }
                if let Some(p) = pacer.as_mut() {
                    observers.push(p);
                }
                run_scenario_with(&job.scenario, &job.config, &mut observers)
            })
            .collect()
    });
    bar.finish_and_clear();
    let results = results.into_iter().collect::<Result<Vec<_>>>()?;
    if let (Some(dir), true) = (&options.out_dir, options.png) {
        write_figures(dir, jobs, &results)?;
    }
    Ok(results)
}

/// One PNG per scenario and direction with every run of every planner:
/// `<dir>/<scenario>_<direction>.png`.
pub fn write_figures(dir: &Path, jobs: &[Job], results: &[RunResult]) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    let mut keys: Vec<(String, Direction)> = Vec::new();
    for j in jobs {
        let k = (j.scenario.name.clone(), j.config.direction);
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    for (name, direction) in keys {
        let idx: Vec<usize> = (0..jobs.len())
            .filter(|&i| jobs[i].scenario.name == name && jobs[i].config.direction == direction)
            .collect();
        let scenario = &jobs[idx[0]].scenario;
        let route = match direction {
            Direction::Forward => scenario.route.clone(),
            Direction::Backward => scenario.route.reversed(),
        };
        let tracks: Vec<Track> = idx
            .iter()
            .map(|&i| {
                let (color, dashed) = planner_style(&results[i].planner);
                Track::from_result(&results[i], color, dashed)
            })
            .collect();
        let path = dir.join(format!("{name}_{}.png", direction.name()));
        let title = format!("{name}: {} route, {} run(s), top view", direction.name(), tracks.len());
        top_view(&path, &title, scenario, &route, &tracks, PlotOptions::default())?;
        written.push(path);
    }
    Ok(written)
}

/// Writes `value` as pretty JSON to `path` (creating its folder) through a temporary file, so
/// the file is whole or absent ([`ddpkit_util::fs::write_atomic`]).
pub fn write_json(path: &Path, value: &serde_json::Value) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| Error::write(dir, e))?;
    }
    let text = serde_json::to_vec_pretty(value).map_err(|e| Error::write(path, e))?;
    ddpkit_util::fs::write_atomic(path, text).map_err(|e| Error::write(path, e))
}
