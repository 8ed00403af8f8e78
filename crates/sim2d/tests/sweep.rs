//! The sweeps' task API (`sim2d::sweep`) against the binaries' path: every task run alone by
//! `run_*_task`, its result sent through JSON (as `ddpkit.experiments` sends it) and aggregated,
//! gives what the binaries compute through `run_batch`, apart from the measured wall-clock
//! fields. Tiny sizes: a 12 m route for Table I, one U trap for the benchmark.

use std::path::{Path, PathBuf};

use serde_json::Value;
use sim2d::batch::{run_batch, BatchOptions, Job};
use sim2d::sweep::{
    aggregate_table, aggregate_traps, run_table_task, run_trap_task, table_figures, table_tasks, trap_figures,
    trap_tasks, TableConfig, TableTask, TrapConfig, TrapTask,
};
use sim2d::traps::TrapKind;
use sim2d::{PlannerKind, RunResult};

/// Fields that are wall-clock measurements (never equal across two runs).
const MEASURED: [&str; 7] = [
    "timing",
    "real_time_factor",
    "epoch_ms",
    "epoch_stats",
    "cycle_stats",
    "cycle_ms_mean",
    "cycle_ms_p99_max",
];

fn without_measured(v: Value) -> Value {
    match v {
        Value::Object(m) => Value::Object(
            m.into_iter()
                .filter(|(k, _)| !MEASURED.contains(&k.as_str()))
                .map(|(k, v)| (k, without_measured(v)))
                .collect(),
        ),
        Value::Array(a) => Value::Array(a.into_iter().map(without_measured).collect()),
        other => other,
    }
}

/// The binaries' path: the tasks as jobs through `run_batch` (no logs, no figures).
fn batch(jobs: &[Job]) -> Vec<RunResult> {
    let options = BatchOptions {
        mcap: false,
        png: false,
        progress: false,
        threads: Some(1),
        ..BatchOptions::default()
    };
    run_batch(jobs, &options).unwrap()
}

/// Each task alone, its result through JSON text and back.
fn alone<T: serde::Serialize + serde::de::DeserializeOwned>(
    tasks: &[T],
    run: impl Fn(&T) -> sim2d::Result<RunResult>,
) -> Vec<RunResult> {
    tasks
        .iter()
        .map(|t| {
            let spec: T = serde_json::from_str(&serde_json::to_string(t).unwrap()).unwrap();
            let text = serde_json::to_string(&run(&spec).unwrap()).unwrap();
            serde_json::from_str(&text).unwrap()
        })
        .collect()
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sim2d-sweep-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn short_set(dir: &Path) {
    std::fs::write(
        dir.join("short.toml"),
        "name = \"short\"\n[route]\npoints = [[0.0, 0.0], [12.0, 0.0]]\n[[obstacles]]\ntype = \"cylinder\"\ncenter = [6.0, 0.6]\nradius = 0.5\n",
    )
    .unwrap();
}

#[test]
fn table_tasks_alone_equal_the_binarys_batch_except_measured_fields() {
    let dir = temp_dir("table");
    short_set(&dir);
    let config = TableConfig {
        scenarios: dir.clone(),
        sets: vec!["short".into()],
        planners: vec![PlannerKind::DDP],
        runs: 1,
        seed: 3,
        ..TableConfig::default()
    };
    let tasks = table_tasks(&config).unwrap();
    assert_eq!(tasks.len(), 2, "forward and backward");
    let jobs = tasks
        .iter()
        .map(TableTask::job)
        .collect::<sim2d::Result<Vec<_>>>()
        .unwrap();
    let binary = aggregate_table(&config, &batch(&jobs)).unwrap();
    let results = alone(&tasks, run_table_task);
    let sweep = aggregate_table(&config, &results).unwrap();
    assert!(sweep.runs.iter().all(|r| r.completed), "{:?}", sweep.table);
    assert_eq!(without_measured(sweep.json()), without_measured(binary.json()));
    let text = sweep.render(1.0);
    assert!(text.contains("| Short |"), "{text}");
    let figures = table_figures(&config, &tasks, &results, &dir).unwrap();
    assert_eq!(figures, [dir.join("short_forward.png"), dir.join("short_backward.png")]);
    assert!(figures.iter().all(|f| f.is_file()));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn trap_tasks_alone_equal_the_binarys_batch_except_measured_fields() {
    let config = TrapConfig {
        types: vec![TrapKind::U],
        maps: 1,
        planners: vec![PlannerKind::DDP, PlannerKind::DDPEN_ORACLE],
        route_length: 16.0,
        stall_time: 10.0,
        max_time: 40.0,
        png: 1,
        ..TrapConfig::default()
    };
    let tasks = trap_tasks(&config).unwrap();
    assert_eq!(tasks.len(), 2);
    let jobs = tasks
        .iter()
        .map(TrapTask::job)
        .collect::<sim2d::Result<Vec<_>>>()
        .unwrap();
    let binary = aggregate_traps(&config, &batch(&jobs)).unwrap();
    let results = alone(&tasks, run_trap_task);
    let sweep = aggregate_traps(&config, &results).unwrap();
    assert_eq!(without_measured(sweep.json()), without_measured(binary.json()));
    assert_eq!(sweep.cells.len(), 2);
    assert!(sweep.render(1.0).contains("| u |"));
    let dir = temp_dir("traps");
    let figures = trap_figures(&config, &tasks, &results, &dir).unwrap();
    assert_eq!(figures.len(), 1, "one map, forward");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_task_specifications_name_the_field() {
    let config = TrapConfig {
        types: vec![TrapKind::L],
        maps: 1,
        planners: vec![PlannerKind::DDP],
        ..TrapConfig::default()
    };
    let mut task = trap_tasks(&config).unwrap().remove(0);
    task.traps.route_length = 5.0;
    let e = run_trap_task(&task).unwrap_err().to_string();
    assert!(e.starts_with("traps.route_length"), "{e}");
    let mut task = trap_tasks(&config).unwrap().remove(0);
    task.config.ddp.horizon = 0;
    let e = run_trap_task(&task).unwrap_err().to_string();
    assert!(e.starts_with("ddp.horizon"), "{e}");
    let e = serde_json::from_str::<TrapTask>("{\"kind\": \"v\"}")
        .unwrap_err()
        .to_string();
    assert!(e.contains("unknown variant `v`"), "{e}");
    let e = table_tasks(&TableConfig {
        sets: vec!["nowhere".into()],
        scenarios: "scenarios".into(),
        ..TableConfig::default()
    })
    .unwrap_err()
    .to_string();
    assert!(e.contains("nowhere.toml"), "{e}");
}
