//! The experiments as tasks, for `ddpkit.experiments` (sequential, local-process and Ray
//! executors): `experiment_names`, `experiment_tasks`, `experiment_run_task` and
//! `experiment_aggregate`, registered at the top level of `ddpkit._ddpkit`.
//!
//! Everything crosses as JSON text: a configuration, task specifications and task results are
//! plain strings, so they pickle, hash and travel to Ray workers unchanged. Each function calls
//! the experiment crate's own task API (the functions its binary runs), so a task run from
//! Python gives the binary's result for the same seed by construction:
//!
//! | name | crate functions | a task is |
//! |---|---|---|
//! | `safe-table` | [`safe_cddp::sweep`] | one MPC episode of Table I (Alcan and Kyrki 2022) |
//! | `subgoal-dataset` | [`subgoal_infer::dataset::sweep`] | one shard of the DDPEN sub-goal dataset (Gamayunov et al. 2023), written by the task into `out_dir` |
//! | `idnp` | [`idnp::sweep`] | one initial condition of the IDNP experiment (Richter et al. 2023), every method |
//! | `ddpen-table` | [`sim2d::sweep`] | one run of DDPEN's Table I (Gamayunov et al. 2023): set, planner, direction, seed |
//! | `trap-bench` | [`sim2d::sweep`] | one run of the randomised trap benchmark: seeded map, planner |
//! | `safe-turtlebot` | [`sim2d::turtlebot::sweep`] | one episode of CDDP or Safe-CDDP on the simulated Turtlebot (Alcan and Kyrki 2022, §IV-C) |
//!
//! Running a task releases the GIL. Every error is a `ddpkit.DdpError` naming the argument (and,
//! inside it, the field); a panic inside a task is caught and reported as an error too, so an
//! executor can record it against the task's specification and go on.

use std::path::{Path, PathBuf};

use pyo3::prelude::*;
use serde::de::DeserializeOwned;
use serde::Serialize;

use crate::errors::{invalid, CoreError, CoreResult};
use sim2d::turtlebot::sweep as turtlebot;
use subgoal_infer::dataset::sweep as dataset;
use subgoal_infer::dataset::DatasetError;

/// A dataset error as a ddpkit error naming `arg.field`.
fn ds(arg: &str, e: DatasetError) -> CoreError {
    let field = e.field();
    let reason = match &e {
        DatasetError::Invalid(subgoal_infer::Error::Invalid { reason, .. }) => reason.clone(),
        other => other.to_string(),
    };
    invalid(format!("{arg}.{field}"), reason)
}

/// The experiments, by the names the Python CLI uses.
const NAMES: [&str; 6] = [
    "safe-table",
    "subgoal-dataset",
    "idnp",
    "ddpen-table",
    "trap-bench",
    "safe-turtlebot",
];

/// An IDNP error as a ddpkit error naming `arg.field` (or `arg` for a numerical failure).
fn idnp_err(arg: &str, e: idnp::Error) -> CoreError {
    match e {
        idnp::Error::Invalid { field, reason } => invalid(format!("{arg}.{field}"), reason),
        other => invalid(arg, other.to_string()),
    }
}

/// A sim2d error as a ddpkit error naming `arg.field` (or `arg` for any other failure).
fn sim_err(arg: &str, e: sim2d::Error) -> CoreError {
    match e {
        sim2d::Error::Invalid { field, reason } => invalid(format!("{arg}.{field}"), reason),
        other => invalid(arg, other.to_string()),
    }
}

fn parse<T: DeserializeOwned>(field: &str, text: &str) -> CoreResult<T> {
    serde_json::from_str(text).map_err(|e| invalid(field, format!("not a valid specification: {e}")))
}

fn to_json<T: Serialize>(field: &str, value: &T) -> CoreResult<String> {
    serde_json::to_string(value).map_err(|e| invalid(field, format!("cannot be written as JSON: {e}")))
}

fn unknown(name: &str) -> CoreError {
    invalid(
        "name",
        format!("unknown experiment {name:?} (expected one of {})", NAMES.join(", ")),
    )
}

/// Prefixes the field of a crate error with the argument it came from (`config_json.episodes`).
fn core(arg: &str, e: ddp_core::Error) -> CoreError {
    CoreError(e).context(arg)
}

fn tasks_of(name: &str, config_json: &str) -> CoreResult<Vec<String>> {
    match name {
        "safe-table" => {
            let config: safe_cddp::sweep::TableConfig = parse("config_json", config_json)?;
            let tasks = safe_cddp::sweep::tasks(&config).map_err(|e| core("config_json", e))?;
            tasks.iter().map(|t| to_json("spec", t)).collect()
        }
        "subgoal-dataset" => {
            let config: dataset::DatasetConfig = parse("config_json", config_json)?;
            let tasks = dataset::tasks(&config).map_err(|e| ds("config_json", e))?;
            tasks.iter().map(|t| to_json("spec", t)).collect()
        }
        "idnp" => {
            let config: idnp::sweep::IdnpConfig = parse("config_json", config_json)?;
            let tasks = idnp::sweep::tasks(&config).map_err(|e| idnp_err("config_json", e))?;
            tasks.iter().map(|t| to_json("spec", t)).collect()
        }
        "ddpen-table" => {
            let config: sim2d::sweep::TableConfig = parse("config_json", config_json)?;
            let tasks = sim2d::sweep::table_tasks(&config).map_err(|e| sim_err("config_json", e))?;
            tasks.iter().map(|t| to_json("spec", t)).collect()
        }
        "trap-bench" => {
            let config: sim2d::sweep::TrapConfig = parse("config_json", config_json)?;
            let tasks = sim2d::sweep::trap_tasks(&config).map_err(|e| sim_err("config_json", e))?;
            tasks.iter().map(|t| to_json("spec", t)).collect()
        }
        "safe-turtlebot" => {
            let config: turtlebot::TurtlebotSweepConfig = parse("config_json", config_json)?;
            let tasks = turtlebot::tasks(&config).map_err(|e| sim_err("config_json", e))?;
            tasks.iter().map(|t| to_json("spec", t)).collect()
        }
        _ => Err(unknown(name)),
    }
}

fn run_of(name: &str, spec_json: &str) -> CoreResult<String> {
    match name {
        "safe-table" => {
            let task: safe_cddp::sweep::EpisodeTask = parse("spec_json", spec_json)?;
            let outcome = safe_cddp::sweep::run_task(&task).map_err(|e| core("spec_json", e))?;
            to_json("result", &outcome)
        }
        "subgoal-dataset" => {
            let task: dataset::ShardTask = parse("spec_json", spec_json)?;
            let result = dataset::run_task(&task).map_err(|e| ds("spec_json", e))?;
            to_json("result", &result)
        }
        "idnp" => {
            let task: idnp::sweep::CaseTask = parse("spec_json", spec_json)?;
            let result = idnp::sweep::run_task(&task).map_err(|e| idnp_err("spec_json", e))?;
            to_json("result", &result)
        }
        "ddpen-table" => {
            let task: sim2d::sweep::TableTask = parse("spec_json", spec_json)?;
            let result = sim2d::sweep::run_table_task(&task).map_err(|e| sim_err("spec_json", e))?;
            to_json("result", &result)
        }
        "trap-bench" => {
            let task: sim2d::sweep::TrapTask = parse("spec_json", spec_json)?;
            let result = sim2d::sweep::run_trap_task(&task).map_err(|e| sim_err("spec_json", e))?;
            to_json("result", &result)
        }
        "safe-turtlebot" => {
            let task: turtlebot::EpisodeTask = parse("spec_json", spec_json)?;
            let run = turtlebot::run_task(&task).map_err(|e| sim_err("spec_json", e))?;
            to_json("result", &run)
        }
        _ => Err(unknown(name)),
    }
}

/// Parses every result, naming the index of a bad one.
fn parse_all<T: DeserializeOwned>(results: &[String]) -> CoreResult<Vec<T>> {
    results
        .iter()
        .enumerate()
        .map(|(i, r)| parse(&format!("results_json[{i}]"), r))
        .collect()
}

fn write_text(path: &Path, text: &str) -> CoreResult<()> {
    ddpkit_util::fs::write_atomic(path, text).map_err(|e| invalid("out_dir", format!("{}: {e}", path.display())))
}

/// Run facts the binaries write into their JSON.
struct RunInfo {
    command: String,
    workers: usize,
    seconds: f64,
}

fn aggregate_of(
    name: &str,
    config_json: &str,
    results: &[String],
    out_dir: &Path,
    info: &RunInfo,
) -> CoreResult<String> {
    std::fs::create_dir_all(out_dir).map_err(|e| invalid("out_dir", format!("{}: {e}", out_dir.display())))?;
    match name {
        "safe-table" => {
            let config: safe_cddp::sweep::TableConfig = parse("config_json", config_json)?;
            let outcomes: Vec<safe_cddp::table::EpisodeOutcome> = parse_all(results)?;
            let table = safe_cddp::sweep::aggregate(&config, &outcomes).map_err(|e| core("results_json", e))?;
            let json = table
                .json(&config, info.command.clone(), info.workers, info.seconds)
                .map_err(|e| core("results_json", e))?;
            write_text(&out_dir.join("table1.json"), &json)?;
            let mut text = table.render();
            let fig = out_dir.join("fig4.png");
            match safe_cddp::figure::table_figure(&fig, &config, &outcomes) {
                Ok(true) => text.push_str(&format!("\nwrote {}\n", fig.display())),
                Ok(false) => {}
                Err(e) => return Err(invalid("out_dir", format!("{}: {e}", fig.display()))),
            }
            text.push_str(&format!("wrote {}\n", out_dir.join("table1.json").display()));
            Ok(text)
        }
        "subgoal-dataset" => {
            // The shards are in the configuration's `out_dir` (where the tasks wrote them).
            let config: dataset::DatasetConfig = parse("config_json", config_json)?;
            let shards: Vec<dataset::ShardResult> = parse_all(results)?;
            let s = dataset::aggregate(&config, &shards).map_err(|e| ds("results_json", e))?;
            Ok(format!(
                "{}\n",
                s.line(info.seconds, &format!("workers: {}", info.workers))
            ))
        }
        "idnp" => {
            // The binary's `--json` file (its figure needs the `cli` feature: binary only).
            let config: idnp::sweep::IdnpConfig = parse("config_json", config_json)?;
            let cases: Vec<idnp::experiment::CaseResult> = parse_all(results)?;
            let result = idnp::sweep::aggregate(&config, &cases).map_err(|e| idnp_err("results_json", e))?;
            let path = out_dir.join("experiment.json");
            let json = serde_json::to_string_pretty(&result)
                .map_err(|e| invalid("results_json", format!("cannot be written as JSON: {e}")))?;
            write_text(&path, &json)?;
            let mut text = idnp::sweep::report(&config, &result);
            text.push_str(&format!("results: {}\n", path.display()));
            Ok(text)
        }
        "ddpen-table" => {
            // The binary's `--json` file and figures (the MCAP logs are the binary's alone).
            let config: sim2d::sweep::TableConfig = parse("config_json", config_json)?;
            let runs: Vec<sim2d::RunResult> = parse_all(results)?;
            let report = sim2d::sweep::aggregate_table(&config, &runs).map_err(|e| sim_err("results_json", e))?;
            let tasks = sim2d::sweep::table_tasks(&config).map_err(|e| sim_err("config_json", e))?;
            let figures =
                sim2d::sweep::table_figures(&config, &tasks, &runs, out_dir).map_err(|e| sim_err("out_dir", e))?;
            let path = out_dir.join("table.json");
            sim2d::batch::write_json(&path, &report.json()).map_err(|e| sim_err("out_dir", e))?;
            let mut text = report.render(info.seconds);
            if !figures.is_empty() {
                text.push_str(&format!("figures in {}\n", out_dir.display()));
            }
            text.push_str(&format!("JSON in {}\n", path.display()));
            Ok(text)
        }
        "trap-bench" => {
            let config: sim2d::sweep::TrapConfig = parse("config_json", config_json)?;
            let runs: Vec<sim2d::RunResult> = parse_all(results)?;
            let report = sim2d::sweep::aggregate_traps(&config, &runs).map_err(|e| sim_err("results_json", e))?;
            let tasks = sim2d::sweep::trap_tasks(&config).map_err(|e| sim_err("config_json", e))?;
            let figures =
                sim2d::sweep::trap_figures(&config, &tasks, &runs, out_dir).map_err(|e| sim_err("out_dir", e))?;
            let path = out_dir.join("bench.json");
            sim2d::batch::write_json(&path, &report.json()).map_err(|e| sim_err("out_dir", e))?;
            let mut text = report.render(info.seconds);
            if !figures.is_empty() {
                text.push_str(&format!("{} PNG top views in {}\n", figures.len(), out_dir.display()));
            }
            text.push_str(&format!("JSON in {}\n", path.display()));
            Ok(text)
        }
        "safe-turtlebot" => {
            // The binary's `--json` and `--png` files; `seconds` is its `wall_s`.
            let config: turtlebot::TurtlebotSweepConfig = parse("config_json", config_json)?;
            let runs: Vec<sim2d::turtlebot::TurtlebotRun> = parse_all(results)?;
            let e = turtlebot::aggregate(&config, &runs).map_err(|e| sim_err("results_json", e))?;
            let json = out_dir.join("safe-turtlebot.json");
            let png = out_dir.join("safe-turtlebot.png");
            sim2d::batch::write_json(&json, &turtlebot::json(&config, &e, info.seconds))
                .map_err(|e| sim_err("out_dir", e))?;
            sim2d::turtlebot::write_figure(&png, &e).map_err(|e| sim_err("out_dir", e))?;
            let mut text = turtlebot::report(&config, &e, info.seconds);
            text.push_str(&format!("wrote {}\nwrote {}\n", json.display(), png.display()));
            Ok(text)
        }
        _ => Err(unknown(name)),
    }
}

/// Runs `f`, turning a panic into an error (a task that panics must not take its worker down).
fn guarded<T>(what: &str, f: impl FnOnce() -> CoreResult<T>) -> CoreResult<T> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(p) => {
            let msg = p
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| p.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            Err(invalid(what, format!("internal error (panic): {msg}")))
        }
    }
}

/// The experiment names ``experiment_tasks`` and friends accept.
#[pyfunction]
fn experiment_names() -> Vec<String> {
    NAMES.iter().map(|s| s.to_string()).collect()
}

/// The task specifications (JSON text, one per task, in the order ``experiment_aggregate``
/// expects the results) of experiment ``name`` under ``config_json`` (a JSON object; missing
/// fields take the binary's defaults, unknown fields are an error naming them).
#[pyfunction]
fn experiment_tasks(py: Python<'_>, name: &str, config_json: &str) -> PyResult<Vec<String>> {
    let (name, config_json) = (name.to_string(), config_json.to_string());
    Ok(py.detach(|| guarded("config_json", || tasks_of(&name, &config_json)))?)
}

/// Runs one task of experiment ``name`` (a specification from ``experiment_tasks``) on this
/// thread and returns its result as JSON text. The GIL is released while it runs; the result
/// does not depend on the process, thread count or machine.
#[pyfunction]
fn experiment_run_task(py: Python<'_>, name: &str, spec_json: &str) -> PyResult<String> {
    let (name, spec_json) = (name.to_string(), spec_json.to_string());
    Ok(py.detach(|| guarded("spec_json", || run_of(&name, &spec_json)))?)
}

/// Aggregates the results (JSON text, in task order) of experiment ``name`` into the files its
/// binary writes, in ``out_dir`` (created if missing; each file whole or absent), and returns the
/// text the binary prints. ``command``, ``workers`` and ``seconds`` go into the JSON where the
/// binary records its command line, thread count and wall time.
#[pyfunction]
#[pyo3(signature = (name, config_json, results_json, out_dir, command = String::new(), workers = 1, seconds = 0.0))]
fn experiment_aggregate(
    py: Python<'_>,
    name: &str,
    config_json: &str,
    results_json: Vec<String>,
    out_dir: PathBuf,
    command: String,
    #[pyo3(from_py_with = crate::convert::int_usize)] workers: usize,
    seconds: f64,
) -> PyResult<String> {
    let name = name.to_string();
    let config_json = config_json.to_string();
    let info = RunInfo {
        command,
        workers,
        seconds,
    };
    Ok(py.detach(|| {
        guarded("results_json", || {
            aggregate_of(&name, &config_json, &results_json, &out_dir, &info)
        })
    })?)
}

/// Registers the functions.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(experiment_names, m)?)?;
    m.add_function(wrap_pyfunction!(experiment_tasks, m)?)?;
    m.add_function(wrap_pyfunction!(experiment_run_task, m)?)?;
    m.add_function(wrap_pyfunction!(experiment_aggregate, m)?)?;
    Ok(())
}
