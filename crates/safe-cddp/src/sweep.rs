//! Table I of Alcan and Kyrki (2022) as independent tasks: one task is one seeded MPC episode of
//! one robot under one method, so the sweep can run on one thread, on every core (the binary
//! `safe-cddp-table`, rayon) or on a cluster (`python -m ddpkit.experiments safe-table`, Ray),
//! with the same per-episode results.
//!
//! The three steps, each a plain function of serde values:
//!
//! | step | function | in | out |
//! |---|---|---|---|
//! | list | [`tasks`] | [`TableConfig`] | [`EpisodeTask`]s (robot, noise, method, episode, seed) |
//! | run | [`run_task`] | one [`EpisodeTask`] | one [`EpisodeOutcome`] |
//! | aggregate | [`aggregate`] | the config and the outcomes in task order | [`Table`] (rows, JSON, text) |
//!
//! A task carries its explicit noise seed ([`episode_seed`] of the base seed, the robot and the
//! episode), so the outcome depends on the task alone, not on where or after what it runs.
//!
//! ```
//! use safe_cddp::sweep::{aggregate, run_task, tasks, TableConfig};
//! use safe_cddp::table::Robot;
//! let config = TableConfig { episodes: 1, robots: vec![Robot::Point], betas: vec![0.99], ..TableConfig::default() };
//! let specs = tasks(&config)?;
//! assert_eq!(specs.len(), 1);
//! let outcomes = specs.iter().map(run_task).collect::<Result<Vec<_>, _>>()?;
//! let table = aggregate(&config, &outcomes)?;
//! assert_eq!(table.rows[0].metrics.episodes, 1);
//! # Ok::<(), ddp_core::Error>(())
//! ```

use ddp_core::{Error, Result};
use serde::{Deserialize, Serialize};

use crate::table::{self, episode_seed, EpisodeOutcome, Method, Metrics, Robot, BETAS};

/// What a Table I sweep runs. Every field has a default (the binary's), so `{}` is a valid
/// configuration in JSON.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TableConfig {
    /// Episodes per robot and method (at least 1).
    pub episodes: usize,
    /// Base seed of the process noise.
    pub seed: u64,
    /// Robots, in the order the rows are written.
    pub robots: Vec<Robot>,
    /// Noise scale overrides (m per step); `None` keeps [`Robot::default_noise`].
    pub noise_point: Option<f64>,
    /// See `noise_point`.
    pub noise_car: Option<f64>,
    /// See `noise_point`.
    pub noise_quadrotor: Option<f64>,
    /// The betas (each in (0, 1); 0.5 is plain CDDP).
    pub betas: Vec<f64>,
    /// Run the car's fixed-gain and open-loop baselines of Fig. 4 at `beta = 0.99`.
    pub baselines: bool,
}

impl Default for TableConfig {
    fn default() -> Self {
        Self {
            episodes: 100,
            seed: 1,
            robots: Robot::ALL.to_vec(),
            noise_point: None,
            noise_car: None,
            noise_quadrotor: None,
            betas: BETAS.to_vec(),
            baselines: true,
        }
    }
}

impl TableConfig {
    /// Rejects impossible values, naming the field.
    pub fn validate(&self) -> Result<()> {
        if self.episodes == 0 {
            return Err(Error::invalid("episodes", "must be at least 1, got 0"));
        }
        if self.robots.is_empty() {
            return Err(Error::invalid("robots", "must name at least one robot"));
        }
        if self.betas.is_empty() {
            return Err(Error::invalid("betas", "must hold at least one beta"));
        }
        for b in &self.betas {
            check_beta("betas", *b)?;
        }
        for (field, v) in [
            ("noise_point", self.noise_point),
            ("noise_car", self.noise_car),
            ("noise_quadrotor", self.noise_quadrotor),
        ] {
            if let Some(v) = v {
                check_noise(field, v)?;
            }
        }
        Ok(())
    }

    /// The noise scale of `robot` (the override or the calibrated default).
    pub fn noise(&self, robot: Robot) -> f64 {
        match robot {
            Robot::Point => self.noise_point,
            Robot::Car => self.noise_car,
            Robot::Quadrotor => self.noise_quadrotor,
        }
        .unwrap_or(robot.default_noise())
    }

    /// The methods run on `robot`: one per beta, and for the car the two baselines of Fig. 4.
    pub fn methods(&self, robot: Robot) -> Vec<Method> {
        let mut methods: Vec<Method> = self.betas.iter().map(|&b| Method::for_beta(b)).collect();
        if robot == Robot::Car && self.baselines {
            methods.push(Method::FixedGains { beta: 0.99 });
            methods.push(Method::OpenLoop { beta: 0.99 });
        }
        methods
    }
}

fn check_beta(field: &str, b: f64) -> Result<()> {
    if b > 0.0 && b < 1.0 {
        Ok(())
    } else {
        Err(Error::invalid(field, format!("{b} is not in (0, 1)")))
    }
}

fn check_noise(field: &str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(Error::invalid(field, format!("must be finite and positive, got {v}")))
    }
}

/// One episode of Table I: everything its outcome depends on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EpisodeTask {
    /// The robot (its scenario).
    pub robot: Robot,
    /// Noise scale `s` (m per step).
    pub noise: f64,
    /// The method.
    pub method: Method,
    /// Episode number within the robot (the same noise under every method).
    pub episode: usize,
    /// Noise seed: [`episode_seed`] of the base seed, the robot and the episode.
    pub seed: u64,
}

/// The tasks of `config`: robots in order, then methods, then episodes.
pub fn tasks(config: &TableConfig) -> Result<Vec<EpisodeTask>> {
    config.validate()?;
    let mut out = Vec::new();
    for &robot in &config.robots {
        for method in config.methods(robot) {
            for episode in 0..config.episodes {
                out.push(EpisodeTask {
                    robot,
                    noise: config.noise(robot),
                    method,
                    episode,
                    seed: episode_seed(config.seed, robot, episode),
                });
            }
        }
    }
    Ok(out)
}

/// Runs one episode (builds the robot's scenario and an MPC; single-threaded).
pub fn run_task(task: &EpisodeTask) -> Result<EpisodeOutcome> {
    check_noise("noise", task.noise)?;
    match task.method {
        Method::Cddp => {}
        Method::SafeCddp { beta } | Method::FixedGains { beta } | Method::OpenLoop { beta } => {
            check_beta("method.beta", beta)?
        }
    }
    match task.robot {
        Robot::Point => table::run_episode(&table::point_robot(task.noise)?, task.method, task.seed),
        Robot::Car => table::run_episode(&table::car(task.noise)?, task.method, task.seed),
        Robot::Quadrotor => table::run_episode(&table::quadrotor(task.noise)?, task.method, task.seed),
    }
}

/// One row group of the table: a robot under one method.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Row {
    /// The robot.
    pub robot: Robot,
    /// The method.
    pub method: Method,
    /// Its beta (0.5 for plain CDDP).
    pub beta: f64,
    /// The paper's metrics and a few more.
    pub metrics: Metrics,
    /// The paper's (violated episodes, average in violated episodes, total average), if it has one.
    pub paper: Option<(usize, f64, f64)>,
    /// Collisions per episode.
    pub collisions: Vec<usize>,
}

/// The aggregated table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Table {
    /// The noise scale of each robot run.
    pub noise: Vec<(Robot, f64)>,
    /// Rows: robots in order, then methods.
    pub rows: Vec<Row>,
}

/// What the JSON file holds (the binary's format).
#[derive(Debug, Serialize)]
pub struct TableJson<'a> {
    /// The command line that made it.
    pub command: String,
    /// Base seed.
    pub seed: u64,
    /// Episodes per row.
    pub episodes: usize,
    /// Noise scale per robot.
    pub noise: &'a [(Robot, f64)],
    /// Worker threads (or processes) that ran the episodes.
    pub threads: usize,
    /// Wall time of the sweep (s).
    pub seconds: f64,
    /// The rows.
    pub rows: &'a [Row],
}

fn method_beta(m: &Method) -> f64 {
    match *m {
        Method::Cddp => 0.5,
        Method::SafeCddp { beta } | Method::FixedGains { beta } | Method::OpenLoop { beta } => beta,
    }
}

/// Groups `outcomes` (in the order of [`tasks`]) into the table's rows.
pub fn aggregate(config: &TableConfig, outcomes: &[EpisodeOutcome]) -> Result<Table> {
    config.validate()?;
    let expected: usize = config.robots.iter().map(|&r| config.methods(r).len()).sum::<usize>() * config.episodes;
    if outcomes.len() != expected {
        return Err(Error::invalid(
            "results",
            format!("the configuration has {expected} tasks, got {} results", outcomes.len()),
        ));
    }
    let mut rows = Vec::new();
    let mut chunks = outcomes.chunks(config.episodes);
    for &robot in &config.robots {
        for method in config.methods(robot) {
            let episodes = chunks.next().unwrap_or_default();
            let beta = method_beta(&method);
            let paper = match method {
                Method::Cddp | Method::SafeCddp { .. } => {
                    BETAS.iter().position(|&b| b == beta).map(|i| robot.paper()[i])
                }
                _ => None,
            };
            rows.push(Row {
                robot,
                method,
                beta,
                metrics: Metrics::of(episodes),
                paper,
                collisions: episodes.iter().map(|e| e.collisions).collect(),
            });
        }
    }
    Ok(Table {
        noise: config.robots.iter().map(|&r| (r, config.noise(r))).collect(),
        rows,
    })
}

/// The car's methods and their episodes (Fig. 4 draws them), if the car was run.
pub fn car_runs<'a>(
    config: &TableConfig,
    outcomes: &'a [EpisodeOutcome],
) -> Option<(Vec<Method>, Vec<&'a [EpisodeOutcome]>)> {
    let mut chunks = outcomes.chunks(config.episodes.max(1));
    for &robot in &config.robots {
        let methods = config.methods(robot);
        let runs: Vec<&[EpisodeOutcome]> = chunks.by_ref().take(methods.len()).collect();
        if robot == Robot::Car {
            return Some((methods, runs));
        }
    }
    None
}

fn method_label(m: &Method) -> String {
    match m {
        Method::Cddp => "CDDP (beta=0.5)".into(),
        Method::SafeCddp { beta } => format!("Safe-CDDP beta={beta}"),
        Method::FixedGains { beta } => format!("fixed gains beta={beta}"),
        Method::OpenLoop { beta } => format!("open loop beta={beta}"),
    }
}

impl Table {
    /// The JSON file's contents.
    pub fn json(&self, config: &TableConfig, command: String, threads: usize, seconds: f64) -> Result<String> {
        let out = TableJson {
            command,
            seed: config.seed,
            episodes: config.episodes,
            noise: &self.noise,
            threads,
            seconds,
            rows: &self.rows,
        };
        serde_json::to_string_pretty(&out).map_err(|e| Error::invalid("table", e.to_string()))
    }

    /// The table as printed, beside the paper's figures.
    pub fn render(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "{:<20} {:<24} | {:>9} {:>9} {:>9} | {:>7} {:>7} {:>7} | {:>8} {:>7}",
            "robot", "method", "violated", "avg/viol", "total", "paper", "paper", "paper", "success", "steps"
        );
        let _ = writeln!(s, "{}", "-".repeat(128));
        let mut last = None;
        for r in &self.rows {
            if last.is_some() && last != Some(r.robot) {
                s.push('\n');
            }
            last = Some(r.robot);
            let m = &r.metrics;
            let (pv, pa, pt) = match r.paper {
                Some((v, a, t)) => (v.to_string(), format!("{a:.2}"), format!("{t:.2}")),
                None => ("-".into(), "-".into(), "-".into()),
            };
            let _ = writeln!(
                s,
                "{:<20} {:<24} | {:>9} {:>9.2} {:>9.2} | {:>7} {:>7} {:>7} | {:>4}/{:<3} {:>7.1}",
                r.robot.title(),
                method_label(&r.method),
                m.violated_episodes,
                m.avg_in_violated,
                m.total_avg,
                pv,
                pa,
                pt,
                m.successes,
                m.episodes,
                m.mean_steps
            );
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_json_is_the_binarys_default() {
        let c: TableConfig = serde_json::from_str("{}").unwrap();
        assert_eq!(c, TableConfig::default());
        assert!(serde_json::from_str::<TableConfig>("{\"episode\": 3}").is_err());
    }

    #[test]
    fn tasks_follow_robots_methods_episodes() {
        let c = TableConfig {
            episodes: 2,
            robots: vec![Robot::Car, Robot::Point],
            betas: vec![0.5, 0.99],
            ..TableConfig::default()
        };
        let t = tasks(&c).unwrap();
        // Car: 2 betas + 2 baselines; point: 2 betas.
        assert_eq!(t.len(), (4 + 2) * 2);
        assert_eq!(t[0].robot, Robot::Car);
        assert_eq!(t[1].episode, 1);
        assert_eq!(t[0].seed, t[2].seed, "common random numbers across methods");
        assert_eq!(t[8].robot, Robot::Point);
        let outcomes = vec![EpisodeOutcome::default(); t.len()];
        let (methods, runs) = car_runs(&c, &outcomes).unwrap();
        assert_eq!(methods.len(), 4);
        assert!(runs.iter().all(|r| r.len() == 2));
    }

    #[test]
    fn bad_configs_name_the_field() {
        let bad = |c: TableConfig, field: &str| {
            let e = tasks(&c).unwrap_err().to_string();
            assert!(e.contains(field), "{e}");
        };
        bad(
            TableConfig {
                episodes: 0,
                ..Default::default()
            },
            "episodes",
        );
        bad(
            TableConfig {
                betas: vec![1.0],
                ..Default::default()
            },
            "betas",
        );
        bad(
            TableConfig {
                noise_car: Some(f64::NAN),
                ..Default::default()
            },
            "noise_car",
        );
        let t = EpisodeTask {
            robot: Robot::Point,
            noise: -1.0,
            method: Method::Cddp,
            episode: 0,
            seed: 0,
        };
        assert!(run_task(&t).unwrap_err().to_string().contains("noise"));
        assert!(aggregate(&TableConfig::default(), &[])
            .unwrap_err()
            .to_string()
            .contains("results"));
    }
}
