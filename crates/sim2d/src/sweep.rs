//! DDPEN's Table I (Gamayunov, Postnikov and Ferrer 2023) and the randomised trap benchmark as
//! independent tasks: one task is one run (a scenario or a seeded trap map, a planner, a
//! direction and an explicit noise seed), so a sweep can run on every core (the binaries
//! `ddpen-table` and `trap-bench`, rayon through [`crate::batch::run_batch`]) or on a cluster
//! (`python -m ddpkit.experiments ddpen-table`, local processes or Ray) with the same per-run
//! results.
//!
//! The three steps of each experiment, each a plain function of serde values:
//!
//! | experiment | list | run | aggregate |
//! |---|---|---|---|
//! | Table I | [`table_tasks`]: [`TableConfig`] -> [`TableTask`]s | [`run_table_task`] -> [`RunResult`] | [`aggregate_table`] -> [`TableReport`] (table text, JSON) |
//! | trap benchmark | [`trap_tasks`]: [`TrapConfig`] -> [`TrapTask`]s | [`run_trap_task`] -> [`RunResult`] | [`aggregate_traps`] -> [`TrapReport`] (summary text, JSON) |
//!
//! A task carries its whole [`RunConfig`] (planner, direction, seed from [`run_seed`]) and where
//! its map comes from: a Table I task names its scenario file, a trap task the map's kind, seed,
//! index and generator parameters, so [`run_trap_task`] regenerates the map
//! ([`crate::traps::trap_map`]) deterministically. The result depends on the task alone, not on
//! where or after what it runs; only the measured wall-clock fields differ between two runs
//! ([`RunResult::timing`], `real_time_factor`, `epoch_ms`, `epoch_stats`, `cycle_stats`, and what
//! the tables compute from them).
//!
//! Tasks write no MCAP logs: a run's log is a by-product the binaries write through
//! [`crate::batch::run_batch`] (`--no-mcap` skips it). The figures are drawn from the results by
//! [`table_figures`] and [`trap_figures`], after the runs.
//!
//! ```no_run
//! use sim2d::sweep::{aggregate_traps, run_trap_task, trap_tasks, TrapConfig};
//! use sim2d::traps::TrapKind;
//! use sim2d::PlannerKind;
//! let config = TrapConfig { types: vec![TrapKind::U], maps: 1, planners: vec![PlannerKind::DDP], ..TrapConfig::default() };
//! let tasks = trap_tasks(&config)?;
//! let results = tasks.iter().map(run_trap_task).collect::<sim2d::Result<Vec<_>>>()?;
//! let report = aggregate_traps(&config, &results)?;
//! println!("{}", report.render(0.0));
//! # Ok::<(), sim2d::Error>(())
//! ```

use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::{Deserialize, Serialize};
use serde_json::json;

use crate::batch::{run_seed, write_figures, Job};
use crate::cli::PlannerArgs;
use crate::error::{Error, Result};
use crate::registry::PlannerKind;
use crate::run::{run_scenario, Direction, RunConfig, RunResult, Stats};
use crate::scenario::Scenario;
use crate::table::Table;
use crate::traps::{trap_map, TrapKind, TrapParams};

/// Rejects an empty list, naming the field.
fn non_empty<T>(field: &str, v: &[T]) -> Result<()> {
    if v.is_empty() {
        Err(Error::invalid(field, "must name at least one"))
    } else {
        Ok(())
    }
}

/// Builds the base run configuration (planner options applied onto `base`), validates it and
/// loads what the planners need (`ddpen`: its model, naming it in the error) once, before any run.
fn base_config(mut base: RunConfig, options: &PlannerArgs, planners: &[PlannerKind]) -> Result<RunConfig> {
    options.apply(&mut base);
    base.validate()?;
    for p in planners {
        p.prepare(&base.ddp, &base.ddpen)?;
    }
    Ok(base)
}

/// Checks that `results` has one entry per task.
fn check_count(expected: usize, results: &[RunResult]) -> Result<()> {
    if results.len() == expected {
        Ok(())
    } else {
        Err(Error::invalid(
            "results",
            format!("the configuration has {expected} tasks, got {} results", results.len()),
        ))
    }
}

/// Mean planning cycle (ms, weighted by cycles) and largest per-run 99th percentile over `runs`.
fn cycle_summary<'a>(runs: impl IntoIterator<Item = &'a RunResult> + Clone) -> (usize, f64, f64) {
    let n: usize = runs.clone().into_iter().map(|r| r.cycle_stats.count).sum();
    let mean = runs
        .clone()
        .into_iter()
        .map(|r| r.cycle_stats.mean * r.cycle_stats.count as f64)
        .sum::<f64>()
        / n.max(1) as f64;
    let p99 = runs.into_iter().map(|r| r.cycle_stats.p99).fold(0.0, f64::max);
    (n, mean, p99)
}

// ---------------------------------------------------------------------------------------------
// Table I

/// What a Table I sweep runs (the `ddpen-table` binary's options). Every field has a default
/// (the binary's), so `{}` is a valid configuration in JSON.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TableConfig {
    /// Folder with the scenario files (relative paths are taken from the working directory).
    pub scenarios: PathBuf,
    /// Obstacle sets (scenario file stems), in table order.
    pub sets: Vec<String>,
    /// Planners, in column order.
    pub planners: Vec<PlannerKind>,
    /// Runs per set, planner and direction (at least 1).
    pub runs: usize,
    /// Base seed of the actuation and lidar noise.
    pub seed: u64,
    /// Planner and executor options (the binary's `--horizon`, `--model`, `--w-subgoal`, ...).
    pub options: PlannerArgs,
    /// Draw a PNG per set and direction when aggregating into a folder.
    pub png: bool,
}

impl Default for TableConfig {
    fn default() -> Self {
        Self {
            scenarios: PathBuf::from("scenarios"),
            sets: ["free", "cylinders", "cubes_without_minima", "cubes_with_minima"]
                .map(String::from)
                .to_vec(),
            planners: vec![PlannerKind::DDP, PlannerKind::DDPEN],
            runs: 5,
            seed: 1,
            options: PlannerArgs::default(),
            png: true,
        }
    }
}

impl TableConfig {
    /// Rejects impossible values, naming the field (the files and the model are checked by
    /// [`table_tasks`]).
    pub fn validate(&self) -> Result<()> {
        if self.runs == 0 {
            return Err(Error::invalid("runs", "must be at least 1"));
        }
        non_empty("sets", &self.sets)?;
        non_empty("planners", &self.planners)?;
        Ok(())
    }

    /// The run configuration every task starts from (the binary's JSON `config`).
    pub fn base(&self) -> Result<RunConfig> {
        base_config(RunConfig::default(), &self.options, &self.planners)
    }

    /// The scenario file of `set`.
    pub fn scenario_file(&self, set: &str) -> PathBuf {
        self.scenarios.join(format!("{set}.toml"))
    }

    /// Runs per set: planners x 2 directions x runs.
    fn per_set(&self) -> usize {
        self.planners.len() * 2 * self.runs
    }

    /// The line the binary prints before the runs.
    pub fn header(&self, base: &RunConfig) -> String {
        format!(
            "Table I: {} obstacle sets x {} planner(s) x 2 directions x {} runs = {} runs, horizon N = {} ({:.1} s), {} epochs per cycle",
            self.sets.len(),
            self.planners.len(),
            self.runs,
            self.sets.len() * self.per_set(),
            base.ddp.horizon,
            base.ddp.horizon as f64 * base.ddp.dt,
            base.ddp.epochs
        )
    }
}

/// One run of Table I: everything its result depends on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TableTask {
    /// The scenario file.
    pub scenario: PathBuf,
    /// Repetition index among the runs of the same set, planner and direction.
    pub run: usize,
    /// The run's configuration: planner, direction and noise seed ([`run_seed`] of the base seed,
    /// the run and the direction: the same for every planner).
    pub config: RunConfig,
}

impl TableTask {
    /// The task as a batch job (loads the scenario file).
    pub fn job(&self) -> Result<Job> {
        Ok(Job {
            scenario: Arc::new(Scenario::from_file(&self.scenario)?),
            config: self.config.clone(),
            run: self.run,
        })
    }
}

/// The tasks of `config`: sets in order, then planners, directions (forward, backward) and runs.
/// Loads every scenario file and the planners' models first, so a missing file or model is an
/// error before any run.
pub fn table_tasks(config: &TableConfig) -> Result<Vec<TableTask>> {
    config.validate()?;
    for set in &config.sets {
        Scenario::from_file(config.scenario_file(set))?;
    }
    let base = config.base()?;
    let mut out = Vec::with_capacity(config.sets.len() * config.per_set());
    for set in &config.sets {
        for &planner in &config.planners {
            for direction in [Direction::Forward, Direction::Backward] {
                for run in 0..config.runs {
                    out.push(TableTask {
                        scenario: config.scenario_file(set),
                        run,
                        config: RunConfig {
                            planner,
                            direction,
                            seed: run_seed(config.seed, run, direction),
                            ..base.clone()
                        },
                    });
                }
            }
        }
    }
    Ok(out)
}

/// Runs one Table I task on this thread (no log, no figure).
pub fn run_table_task(task: &TableTask) -> Result<RunResult> {
    let job = task.job()?;
    run_scenario(&job.scenario, &job.config)
}

/// Table I of a sweep, with what the binary writes.
#[derive(Debug, Clone, PartialEq)]
pub struct TableReport {
    /// The base run configuration.
    pub base: RunConfig,
    /// The table.
    pub table: Table,
    /// Every run, in task order.
    pub runs: Vec<RunResult>,
}

/// Builds Table I from `results` (in the order of [`table_tasks`]).
pub fn aggregate_table(config: &TableConfig, results: &[RunResult]) -> Result<TableReport> {
    config.validate()?;
    check_count(config.sets.len() * config.per_set(), results)?;
    // The rows are named as the scenario files name their scenario.
    let names: Vec<String> = results
        .chunks(config.per_set())
        .map(|c| c[0].scenario.clone())
        .collect();
    let planner_names: Vec<String> = config.planners.iter().map(|p| p.name().to_string()).collect();
    Ok(TableReport {
        base: config.base()?,
        table: Table::new(results, &names, &planner_names),
        runs: results.to_vec(),
    })
}

impl TableReport {
    /// The JSON file's contents (the binary's `--json`).
    pub fn json(&self) -> serde_json::Value {
        json!({"config": self.base, "table": self.table, "runs": self.runs})
    }

    /// What the binary prints after the runs; `wall_seconds`: the sweep's wall time.
    pub fn render(&self, wall_seconds: f64) -> String {
        use std::fmt::Write;
        let mut s = String::from(
            "\nTable I: execution time of the route, mean ± sd over completed runs (s); \"fail\": no run completed\n\n",
        );
        let _ = writeln!(s, "{}", self.table.markdown());
        let e = self.table.epoch_ms;
        let _ = writeln!(
            s,
            "per epoch: mean {:.3} ms, p50 {:.3} ms, p99 {:.3} ms, max {:.3} ms over {} epochs (paper: 75 ms)",
            e.mean, e.p50, e.p99, e.max, e.count
        );
        let mut planners: Vec<&str> = Vec::new();
        for (p, _) in &self.table.columns {
            if !planners.contains(&p.as_str()) {
                planners.push(p);
            }
        }
        for p in planners {
            let (n, mean, p99) = cycle_summary(self.runs.iter().filter(|r| r.planner == p));
            let _ = writeln!(s, "planning cycle of {p} (set-up incl. sub-goals + epochs): mean {mean:.3} ms, largest per-run p99 {p99:.3} ms over {n} cycles");
        }
        let _ = writeln!(
            s,
            "real-time factor {:.0}x per core (whole loop: physics, lidar, costmap, planning); batch wall time {:.1} s",
            self.table.real_time_factor, wall_seconds
        );
        s
    }
}

/// One PNG per set and direction with every run of every planner (`<dir>/<set>_<direction>.png`,
/// [`write_figures`]); nothing when `config.png` is off.
pub fn table_figures(
    config: &TableConfig,
    tasks: &[TableTask],
    results: &[RunResult],
    dir: &Path,
) -> Result<Vec<PathBuf>> {
    if !config.png {
        return Ok(Vec::new());
    }
    check_count(tasks.len(), results)?;
    let jobs = tasks.iter().map(TableTask::job).collect::<Result<Vec<_>>>()?;
    write_figures(dir, &jobs, results)
}

// ---------------------------------------------------------------------------------------------
// Trap benchmark

/// What a trap benchmark runs (the `trap-bench` binary's options). Every field has a default
/// (the binary's), so `{}` is a valid configuration in JSON.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrapConfig {
    /// Trap types, in table order.
    pub types: Vec<TrapKind>,
    /// Maps per trap type (at least 1).
    pub maps: usize,
    /// Planners, in column order.
    pub planners: Vec<PlannerKind>,
    /// Seed of the maps and of the actuation and lidar noise.
    pub seed: u64,
    /// Route length of every map (m).
    pub route_length: f64,
    /// A run fails after this many simulated seconds without progress (s); Table I's 30 s: a
    /// U-turn alone takes 6.3 s at the 0.5 rad/s turn-rate limit.
    pub stall_time: f64,
    /// A run is stopped after this much simulated time (s).
    pub max_time: f64,
    /// Draw a PNG of the first this many maps of each type, with every planner's path.
    pub png: usize,
    /// Planner and executor options (the binary's `--horizon`, `--model`, `--w-subgoal`, ...).
    pub options: PlannerArgs,
}

impl Default for TrapConfig {
    fn default() -> Self {
        Self {
            types: TrapKind::ALL.to_vec(),
            maps: 50,
            planners: PlannerKind::ALL.to_vec(),
            seed: 1,
            route_length: 22.0,
            stall_time: 30.0,
            max_time: 120.0,
            png: 2,
            options: PlannerArgs::default(),
        }
    }
}

impl TrapConfig {
    /// Rejects impossible values, naming the field (the model is checked by [`trap_tasks`]).
    pub fn validate(&self) -> Result<()> {
        if self.maps == 0 {
            return Err(Error::invalid("maps", "must be at least 1"));
        }
        non_empty("types", &self.types)?;
        non_empty("planners", &self.planners)?;
        self.traps().validate()
    }

    /// The map generator's parameters.
    pub fn traps(&self) -> TrapParams {
        TrapParams {
            route_length: self.route_length,
            ..TrapParams::default()
        }
    }

    /// The run configuration every task starts from (the binary's JSON `config`).
    pub fn base(&self) -> Result<RunConfig> {
        let base = RunConfig {
            stall_time: self.stall_time,
            max_time: self.max_time,
            keep_plan_every: 0,
            ..RunConfig::default()
        };
        base_config(base, &self.options, &self.planners)
    }

    /// The line the binary prints before the runs.
    pub fn header(&self) -> String {
        format!(
            "trap bench: {} type(s) x {} maps x {} planner(s) = {} runs; route {} m, stall {} s, seed {}",
            self.types.len(),
            self.maps,
            self.planners.len(),
            self.types.len() * self.maps * self.planners.len(),
            self.route_length,
            self.stall_time,
            self.seed
        )
    }

    /// `(kind, map index, planner)` of each task, in task order.
    fn keys(&self) -> Vec<(TrapKind, usize, PlannerKind)> {
        let mut out = Vec::new();
        for &kind in &self.types {
            for map in 0..self.maps {
                for &planner in &self.planners {
                    out.push((kind, map, planner));
                }
            }
        }
        out
    }
}

/// One run of the trap benchmark: the map's recipe and the run's configuration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrapTask {
    /// Trap type.
    pub kind: TrapKind,
    /// Seed of the maps ([`trap_map`]'s `seed`).
    pub map_seed: u64,
    /// Index of the map within its type.
    pub map: usize,
    /// The map generator's parameters.
    pub traps: TrapParams,
    /// The run's configuration: planner, direction (forward) and noise seed ([`run_seed`] of the
    /// base seed and the map index: the same for every planner).
    pub config: RunConfig,
}

impl TrapTask {
    /// The task as a batch job (generates the map).
    pub fn job(&self) -> Result<Job> {
        Ok(Job {
            scenario: Arc::new(trap_map(self.kind, self.map_seed, self.map, &self.traps)?),
            config: self.config.clone(),
            run: self.map,
        })
    }
}

/// The tasks of `config`: types in order, then maps, then planners. Loads the planners' models
/// first, so a missing model is an error before any run.
pub fn trap_tasks(config: &TrapConfig) -> Result<Vec<TrapTask>> {
    config.validate()?;
    let base = config.base()?;
    Ok(config
        .keys()
        .into_iter()
        .map(|(kind, map, planner)| TrapTask {
            kind,
            map_seed: config.seed,
            map,
            traps: config.traps(),
            config: RunConfig {
                planner,
                direction: Direction::Forward,
                seed: run_seed(config.seed, map, Direction::Forward),
                ..base.clone()
            },
        })
        .collect())
}

/// Runs one trap task on this thread (regenerates its map; no log, no figure).
pub fn run_trap_task(task: &TrapTask) -> Result<RunResult> {
    task.traps.validate()?;
    let job = task.job()?;
    run_scenario(&job.scenario, &job.config)
}

/// One cell of the summary: a planner on a trap type.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrapCell {
    /// Trap type.
    pub trap: String,
    /// Planner.
    pub planner: String,
    /// Maps (runs).
    pub maps: usize,
    /// Runs that completed.
    pub completed: usize,
    /// `completed / maps`.
    pub success_rate: f64,
    /// Runs with at least one collision.
    pub runs_with_collisions: usize,
    /// Contact onsets over all runs.
    pub collisions: usize,
    /// Mean time of the completed runs (s).
    pub mean_time_s: f64,
    /// Planning cycle (set-up incl. sub-goals + 4 epochs), mean over cycles (ms).
    pub cycle_ms_mean: f64,
    /// Largest 99th percentile of the cycle time over the runs (ms).
    pub cycle_ms_p99_max: f64,
}

impl TrapCell {
    /// The cell of `runs`.
    pub fn of(trap: &str, planner: &str, runs: &[&RunResult]) -> Self {
        let completed = runs.iter().filter(|r| r.completed).count();
        let times: Vec<f64> = runs.iter().filter(|r| r.completed).map(|r| r.time_s).collect();
        let (_, cycle_ms_mean, cycle_ms_p99_max) = cycle_summary(runs.iter().copied());
        Self {
            trap: trap.into(),
            planner: planner.into(),
            maps: runs.len(),
            completed,
            success_rate: if runs.is_empty() {
                f64::NAN
            } else {
                completed as f64 / runs.len() as f64
            },
            runs_with_collisions: runs.iter().filter(|r| r.collisions > 0).count(),
            collisions: runs.iter().map(|r| r.collisions).sum(),
            mean_time_s: Stats::of(&times).mean,
            cycle_ms_mean,
            cycle_ms_p99_max,
        }
    }
}

/// The trap benchmark's summary, with what the binary writes.
#[derive(Debug, Clone, PartialEq)]
pub struct TrapReport {
    /// The configuration.
    pub config: TrapConfig,
    /// The base run configuration.
    pub base: RunConfig,
    /// One cell per type and planner (types in order, then planners).
    pub cells: Vec<TrapCell>,
    /// Every run, in task order, with its map index.
    pub runs: Vec<(usize, RunResult)>,
}

/// Builds the summary from `results` (in the order of [`trap_tasks`]).
pub fn aggregate_traps(config: &TrapConfig, results: &[RunResult]) -> Result<TrapReport> {
    config.validate()?;
    let keys = config.keys();
    check_count(keys.len(), results)?;
    let mut cells = Vec::new();
    for &kind in &config.types {
        for &planner in &config.planners {
            let runs: Vec<&RunResult> = keys
                .iter()
                .zip(results)
                .filter(|((k, _, p), _)| *k == kind && *p == planner)
                .map(|(_, r)| r)
                .collect();
            cells.push(TrapCell::of(kind.name(), planner.name(), &runs));
        }
    }
    Ok(TrapReport {
        config: config.clone(),
        base: config.base()?,
        cells,
        runs: keys.iter().zip(results).map(|((_, i, _), r)| (*i, r.clone())).collect(),
    })
}

impl TrapReport {
    /// The JSON file's contents (the binary's `--json`).
    pub fn json(&self) -> serde_json::Value {
        let runs: Vec<serde_json::Value> = self
            .runs
            .iter()
            .map(|(i, r)| {
                json!({
                    "map": r.scenario, "map_index": i, "planner": r.planner, "outcome": r.outcome,
                    "completed": r.completed, "time_s": r.time_s, "progress_m": r.progress_m,
                    "route_length_m": r.route_length_m, "collisions": r.collisions,
                    "contact_time_s": r.contact_time_s, "final_pose": r.final_pose,
                    "epoch_stats": r.epoch_stats, "cycle_stats": r.cycle_stats,
                    "real_time_factor": r.real_time_factor,
                })
            })
            .collect();
        let c = &self.config;
        json!({
            "seed": c.seed, "maps_per_type": c.maps, "trap_params": c.traps(), "config": self.base,
            "types": c.types, "planners": c.planners, "summary": self.cells, "runs": runs,
        })
    }

    /// What the binary prints after the runs; `wall_seconds`: the sweep's wall time.
    pub fn render(&self, wall_seconds: f64) -> String {
        use std::fmt::Write;
        let c = &self.config;
        let head: Vec<String> = c.planners.iter().map(|p| p.name().to_uppercase()).collect();
        let mut s = format!(
            "\nSuccess rate (completed / maps) and runs with collisions\n\n| trap type | {} |\n|---|{}\n",
            head.join(" | "),
            "---|".repeat(head.len())
        );
        for (k, kind) in c.types.iter().enumerate() {
            let row: Vec<String> = (0..c.planners.len())
                .map(|p| {
                    let c = &self.cells[k * c.planners.len() + p];
                    format!(
                        "{:.0} % ({}/{}), {} coll.",
                        100.0 * c.success_rate,
                        c.completed,
                        c.maps,
                        c.runs_with_collisions
                    )
                })
                .collect();
            let _ = writeln!(s, "| {} | {} |", kind.name(), row.join(" | "));
        }
        let all: Vec<String> = c
            .planners
            .iter()
            .map(|&p| {
                let sel: Vec<&TrapCell> = self.cells.iter().filter(|c| c.planner == p.name()).collect();
                let (done, n): (usize, usize) = sel.iter().fold((0, 0), |a, c| (a.0 + c.completed, a.1 + c.maps));
                let coll: usize = sel.iter().map(|c| c.runs_with_collisions).sum();
                format!("{:.0} % ({done}/{n}), {coll} coll.", 100.0 * done as f64 / n as f64)
            })
            .collect();
        let _ = writeln!(s, "| all | {} |", all.join(" | "));
        let _ = writeln!(
            s,
            "\nPlanning cycle (set-up incl. sub-goals + {} epochs), mean ms:",
            self.base.ddp.epochs
        );
        for &p in &c.planners {
            let sel: Vec<&TrapCell> = self.cells.iter().filter(|c| c.planner == p.name()).collect();
            let mean = sel.iter().map(|c| c.cycle_ms_mean).sum::<f64>() / sel.len() as f64;
            let p99 = sel.iter().map(|c| c.cycle_ms_p99_max).fold(0.0, f64::max);
            let _ = writeln!(
                s,
                "  {:<13} mean {mean:.3} ms, largest per-run p99 {p99:.3} ms",
                p.name()
            );
        }
        let _ = writeln!(s, "batch wall time {wall_seconds:.1} s");
        s
    }
}

/// A PNG of each of the first `config.png` maps of each type with every planner's path
/// (`<dir>/<map>_forward.png`, [`write_figures`]); nothing when `config.png` is 0.
pub fn trap_figures(
    config: &TrapConfig,
    tasks: &[TrapTask],
    results: &[RunResult],
    dir: &Path,
) -> Result<Vec<PathBuf>> {
    check_count(tasks.len(), results)?;
    let idx: Vec<usize> = (0..tasks.len()).filter(|&i| tasks[i].map < config.png).collect();
    if idx.is_empty() {
        return Ok(Vec::new());
    }
    let jobs = idx.iter().map(|&i| tasks[i].job()).collect::<Result<Vec<_>>>()?;
    let results: Vec<RunResult> = idx.iter().map(|&i| results[i].clone()).collect();
    write_figures(dir, &jobs, &results)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_json_is_the_binarys_default() {
        let c: TableConfig = serde_json::from_str("{}").unwrap();
        assert_eq!(c, TableConfig::default());
        let c: TrapConfig = serde_json::from_str("{}").unwrap();
        assert_eq!(c, TrapConfig::default());
        let e = serde_json::from_str::<TrapConfig>("{\"map\": 3}")
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown field `map`"), "{e}");
        let e = serde_json::from_str::<TableConfig>("{\"planners\": [\"rrt\"]}")
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown planner \"rrt\""), "{e}");
        let e = serde_json::from_str::<TrapConfig>("{\"options\": {\"horizn\": 3}}")
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown field `horizn`"), "{e}");
    }

    #[test]
    fn bad_configs_name_the_field() {
        let table = |c: TableConfig, field: &str| {
            let e = table_tasks(&c).unwrap_err().to_string();
            assert!(e.starts_with(field), "{e}");
        };
        table(
            TableConfig {
                runs: 0,
                ..TableConfig::default()
            },
            "runs",
        );
        table(
            TableConfig {
                sets: vec![],
                ..TableConfig::default()
            },
            "sets",
        );
        table(
            TableConfig {
                planners: vec![],
                ..TableConfig::default()
            },
            "planners",
        );
        let e = table_tasks(&TableConfig {
            scenarios: "no/such/folder".into(),
            ..TableConfig::default()
        })
        .unwrap_err()
        .to_string();
        assert!(e.contains("no/such/folder/free.toml"), "{e}");
        let trap = |c: TrapConfig, field: &str| {
            let e = trap_tasks(&c).unwrap_err().to_string();
            assert!(e.starts_with(field), "{e}");
        };
        trap(
            TrapConfig {
                maps: 0,
                ..TrapConfig::default()
            },
            "maps",
        );
        trap(
            TrapConfig {
                types: vec![],
                ..TrapConfig::default()
            },
            "types",
        );
        trap(
            TrapConfig {
                route_length: 3.0,
                ..TrapConfig::default()
            },
            "traps.route_length",
        );
        let options = PlannerArgs {
            w_contact: Some(-1.0),
            ..PlannerArgs::default()
        };
        trap(
            TrapConfig {
                options,
                ..TrapConfig::default()
            },
            "ddp.w_contact",
        );
        assert!(aggregate_traps(&TrapConfig::default(), &[])
            .unwrap_err()
            .to_string()
            .starts_with("results"));
    }

    #[test]
    fn trap_tasks_follow_types_maps_planners_with_shared_noise() {
        let c = TrapConfig {
            types: vec![TrapKind::L, TrapKind::U],
            maps: 2,
            planners: vec![PlannerKind::DDP, PlannerKind::DDP_ASTAR],
            ..TrapConfig::default()
        };
        let t = trap_tasks(&c).unwrap();
        assert_eq!(t.len(), 8);
        assert_eq!(
            (t[0].kind, t[0].map, t[0].config.planner),
            (TrapKind::L, 0, PlannerKind::DDP)
        );
        assert_eq!((t[3].map, t[3].config.planner), (1, PlannerKind::DDP_ASTAR));
        assert_eq!(t[4].kind, TrapKind::U);
        assert_eq!(
            t[0].config.seed, t[1].config.seed,
            "common random numbers across planners"
        );
        assert_ne!(t[0].config.seed, t[2].config.seed);
        let back: TrapTask = serde_json::from_str(&serde_json::to_string(&t[3]).unwrap()).unwrap();
        assert_eq!(back, t[3]);
        assert_eq!(
            back.job().unwrap().scenario,
            t[3].job().unwrap().scenario,
            "the map is regenerated"
        );
    }
}
