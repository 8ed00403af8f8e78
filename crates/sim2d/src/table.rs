//! The paper's Table I: execution time of the route, mean ± standard deviation over the runs
//! that completed, per obstacle set, planner and direction; "fail" when no run completed.
//!
//! ```
//! use sim2d::table::Cell;
//! let c = Cell::of(&[(true, 190.0), (true, 192.0)]);
//! assert_eq!(c.text(), "191 ± 1");
//! assert_eq!(Cell::of(&[(false, 400.0)]).text(), "fail");
//! ```

use crate::run::{Direction, RunResult, Stats};

/// One cell of Table I.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Cell {
    /// Runs.
    pub runs: usize,
    /// Runs that completed.
    pub completed: usize,
    /// Mean time of the completed runs (s).
    pub mean: f64,
    /// Sample standard deviation of those times (s; 0 for one run).
    pub sd: f64,
}

impl Cell {
    /// The cell of `(completed, time)` pairs.
    pub fn of(runs: &[(bool, f64)]) -> Self {
        let t: Vec<f64> = runs.iter().filter(|r| r.0).map(|r| r.1).collect();
        let n = t.len();
        let mean = if n > 0 {
            t.iter().sum::<f64>() / n as f64
        } else {
            f64::NAN
        };
        let sd = if n > 1 {
            (t.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        } else if n == 1 {
            0.0
        } else {
            f64::NAN
        };
        Self {
            runs: runs.len(),
            completed: n,
            mean,
            sd,
        }
    }

    /// `"mean ± sd"`, `"fail"` when no run completed, and `" (k/n)"` appended when some failed.
    pub fn text(&self) -> String {
        if self.runs == 0 {
            return "-".into();
        }
        if self.completed == 0 {
            return "fail".into();
        }
        let base = format!("{:.0} ± {:.0}", self.mean, self.sd);
        if self.completed < self.runs {
            format!("{base} ({}/{})", self.completed, self.runs)
        } else {
            base
        }
    }
}

/// A row of the table: one obstacle set.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Row {
    /// Scenario name.
    pub scenario: String,
    /// One cell per `(planner, direction)` column.
    pub cells: Vec<Cell>,
    /// Collisions summed over the runs of each column.
    pub collisions: Vec<usize>,
}

/// Table I of a set of runs.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Table {
    /// `(planner, direction)` per column.
    pub columns: Vec<(String, Direction)>,
    /// One row per scenario, in the order given.
    pub rows: Vec<Row>,
    /// Per-epoch compute time over every run (ms).
    pub epoch_ms: Stats,
    /// Simulated seconds per wall-clock second, over every run (single thread each).
    pub real_time_factor: f64,
}

impl Table {
    /// Builds the table for `scenarios` x `planners` x both directions from `results`.
    pub fn new(results: &[RunResult], scenarios: &[String], planners: &[String]) -> Self {
        let columns: Vec<(String, Direction)> = planners
            .iter()
            .flat_map(|p| [(p.clone(), Direction::Forward), (p.clone(), Direction::Backward)])
            .collect();
        let rows = scenarios
            .iter()
            .map(|s| {
                let sel = |(p, d): &(String, Direction)| -> Vec<&RunResult> {
                    results
                        .iter()
                        .filter(|r| &r.scenario == s && &r.planner == p && r.direction == *d)
                        .collect()
                };
                Row {
                    scenario: s.clone(),
                    cells: columns
                        .iter()
                        .map(|c| Cell::of(&sel(c).iter().map(|r| (r.completed, r.time_s)).collect::<Vec<_>>()))
                        .collect(),
                    collisions: columns
                        .iter()
                        .map(|c| sel(c).iter().map(|r| r.collisions).sum())
                        .collect(),
                }
            })
            .collect();
        let all_epochs: Vec<f64> = results.iter().flat_map(|r| r.epoch_ms.iter().copied()).collect();
        let sim: f64 = results.iter().map(|r| r.time_s).sum();
        let wall: f64 = results.iter().map(|r| r.timing.total).sum();
        Self {
            columns,
            rows,
            epoch_ms: Stats::of(&all_epochs),
            real_time_factor: if wall > 0.0 { sim / wall } else { f64::INFINITY },
        }
    }

    /// The table in Markdown, then the collisions per column.
    pub fn markdown(&self) -> String {
        let head: Vec<String> = self
            .columns
            .iter()
            .map(|(p, d)| format!("{} {}", p.to_uppercase(), d))
            .collect();
        let mut s = format!(
            "| Type of obstacles | {} |\n|---|{}\n",
            head.join(" | "),
            "---|".repeat(head.len())
        );
        for r in &self.rows {
            let cells: Vec<String> = r.cells.iter().map(|c| c.text()).collect();
            s.push_str(&format!("| {} | {} |\n", pretty(&r.scenario), cells.join(" | ")));
        }
        s.push_str("\nCollisions (sum over runs):\n\n");
        s.push_str(&format!(
            "| Type of obstacles | {} |\n|---|{}\n",
            head.join(" | "),
            "---|".repeat(head.len())
        ));
        for r in &self.rows {
            let cells: Vec<String> = r.collisions.iter().map(|c| c.to_string()).collect();
            s.push_str(&format!("| {} | {} |\n", pretty(&r.scenario), cells.join(" | ")));
        }
        s
    }
}

/// `"cubes_with_minima"` -> `"Cubes with minima"`.
pub fn pretty(name: &str) -> String {
    let t = name.replace(['_', '-'], " ");
    let mut c = t.chars();
    match c.next() {
        Some(f) => f.to_uppercase().collect::<String>() + c.as_str(),
        None => t,
    }
}
