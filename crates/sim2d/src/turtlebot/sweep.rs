//! The Turtlebot experiment (Alcan and Kyrki (2022), §IV-C, Fig. 5) as independent tasks: one
//! task is one seeded episode of one controller (CDDP or Safe-CDDP), so the experiment can run on
//! every core (the binary `safe-turtlebot` and [`run_experiment`], rayon) or on a cluster
//! (`python -m ddpkit.experiments safe-turtlebot`, Ray) with the same per-episode results.
//!
//! | step | function | in | out |
//! |---|---|---|---|
//! | list | [`tasks`] | [`TurtlebotSweepConfig`] | [`EpisodeTask`]s (configuration, controller, episode, seed) |
//! | run | [`run_task`] | one [`EpisodeTask`] | one [`TurtlebotRun`] |
//! | aggregate | [`aggregate`] | the config and the runs in task order | [`Experiment`] |
//! | report | [`report`], [`json`], [`super::write_figure`] | the experiment | the binary's table, JSON and PNG |
//!
//! A task carries the whole [`TurtlebotConfig`] and its noise seed ([`episode_seed`] of the base
//! seed and the episode, the same for both controllers), so its run depends on the task alone.
//! Every figure of a run is a function of the task except the measured wall times of the
//! solves: [`TurtlebotRun::solve_ms`], and from them [`Summary::step_solve_ms`] and
//! [`Summary::first_solve_ms`], the "solve ms/step" column of the table and the JSON's
//! `wall_s`.
//!
//! ```no_run
//! use sim2d::turtlebot::sweep::{aggregate, report, run_task, tasks, TurtlebotSweepConfig};
//! let config = TurtlebotSweepConfig { runs: 1, ..TurtlebotSweepConfig::default() };
//! let specs = tasks(&config)?;
//! assert_eq!(specs.len(), 2); // CDDP and Safe-CDDP on episode 0
//! let runs = specs.iter().map(run_task).collect::<Result<Vec<_>, _>>()?;
//! let experiment = aggregate(&config, &runs)?;
//! print!("{}", report(&config, &experiment, 0.0));
//! # Ok::<(), sim2d::Error>(())
//! ```

use serde::{Deserialize, Serialize};

#[cfg(doc)]
use super::run_experiment;
use super::{
    episode_seed, experiment_json, run_episode, Controller, Experiment, Summary, Turtlebot, TurtlebotConfig,
    TurtlebotRun,
};
use crate::error::{nonnegative, Error, Result};

/// What the experiment runs: the options of the binary `safe-turtlebot`. Every field has the
/// binary's default, so `{}` is a valid configuration in JSON.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TurtlebotSweepConfig {
    /// Episodes per controller (at least 1).
    pub runs: usize,
    /// Base seed of the actuation and localisation noise.
    pub seed: u64,
    /// Safe-CDDP's satisfaction probability, in (0, 1).
    pub beta: f64,
    /// The robot (`"waffle-pi"`, the paper's, or `"burger"`).
    pub robot: Turtlebot,
    /// Localisation noise on x and y (m); `None` keeps [`TurtlebotConfig::for_robot`]'s.
    pub sigma_xy: Option<f64>,
    /// Localisation noise on the heading (rad); `None` keeps the default.
    pub sigma_theta: Option<f64>,
    /// Process noise per step the tightening assumes on x and y (m); `None` keeps the default.
    pub sigma_w_xy: Option<f64>,
    /// Include every trajectory (poses, commands) in the JSON.
    pub paths: bool,
}

impl Default for TurtlebotSweepConfig {
    fn default() -> Self {
        Self {
            runs: 100,
            seed: 1,
            beta: 0.8,
            robot: Turtlebot::WafflePi,
            sigma_xy: None,
            sigma_theta: None,
            sigma_w_xy: None,
            paths: false,
        }
    }
}

impl TurtlebotSweepConfig {
    /// Rejects impossible values, naming the field.
    pub fn validate(&self) -> Result<()> {
        check_runs(self.runs)?;
        check_beta(self.beta)?;
        for (field, v) in [
            ("sigma_xy", self.sigma_xy),
            ("sigma_theta", self.sigma_theta),
            ("sigma_w_xy", self.sigma_w_xy),
        ] {
            if let Some(v) = v {
                nonnegative(field, v)?;
            }
        }
        Ok(())
    }

    /// The experiment's configuration (as the binary builds it): the robot's, with the noise
    /// overrides; checked.
    pub fn turtlebot(&self) -> Result<TurtlebotConfig> {
        self.validate()?;
        let mut config = TurtlebotConfig::for_robot(self.robot);
        if let Some(s) = self.sigma_xy {
            config.sigma_xy = s;
        }
        if let Some(s) = self.sigma_theta {
            config.sigma_theta = s;
        }
        if let Some(s) = self.sigma_w_xy {
            config.sigma_w[0] = s;
            config.sigma_w[1] = s;
        }
        config.validate()?;
        Ok(config)
    }
}

fn check_runs(runs: usize) -> Result<()> {
    if runs == 0 {
        return Err(Error::invalid("runs", "must be at least 1"));
    }
    Ok(())
}

fn check_beta(beta: f64) -> Result<()> {
    if !(beta > 0.0 && beta < 1.0) {
        return Err(Error::invalid("beta", format!("must be in (0, 1), got {beta}")));
    }
    Ok(())
}

/// One episode of one controller: everything its run depends on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EpisodeTask {
    /// The experiment's configuration.
    pub config: TurtlebotConfig,
    /// The controller.
    pub controller: Controller,
    /// Episode number (the same noise under both controllers).
    pub episode: usize,
    /// Noise seed: [`episode_seed`] of the base seed and the episode.
    pub seed: u64,
}

/// The tasks of `runs` episodes of `config` with base seed `seed`: episode by episode, CDDP then
/// Safe-CDDP with `beta`. Checks the configuration, `runs` and `beta`.
pub fn episode_tasks(config: &TurtlebotConfig, runs: usize, seed: u64, beta: f64) -> Result<Vec<EpisodeTask>> {
    config.validate()?;
    check_runs(runs)?;
    check_beta(beta)?;
    Ok((0..runs)
        .flat_map(|episode| {
            [Controller::Cddp, Controller::SafeCddp { beta }].map(|controller| EpisodeTask {
                config: config.clone(),
                controller,
                episode,
                seed: episode_seed(seed, episode),
            })
        })
        .collect())
}

/// The tasks of `config` (see [`episode_tasks`]).
pub fn tasks(config: &TurtlebotSweepConfig) -> Result<Vec<EpisodeTask>> {
    episode_tasks(&config.turtlebot()?, config.runs, config.seed, config.beta)
}

/// Runs one episode (on this thread).
pub fn run_task(task: &EpisodeTask) -> Result<TurtlebotRun> {
    run_episode(&task.config, task.controller, task.seed)
}

/// The experiment from the runs of [`episode_tasks`] (in task order); an error naming
/// `results` when they are not the runs of those tasks.
pub fn experiment_of(
    config: &TurtlebotConfig,
    runs: usize,
    seed: u64,
    beta: f64,
    results: &[TurtlebotRun],
) -> Result<Experiment> {
    let tasks = episode_tasks(config, runs, seed, beta)?;
    if results.len() != tasks.len() {
        return Err(Error::invalid(
            "results",
            format!(
                "the configuration has {} tasks, got {} results",
                tasks.len(),
                results.len()
            ),
        ));
    }
    if let Some((i, (t, r))) = tasks
        .iter()
        .zip(results)
        .enumerate()
        .find(|(_, (t, r))| r.controller != t.controller || r.seed != t.seed)
    {
        return Err(Error::invalid(
            format!("results[{i}]"),
            format!(
                "is an episode of {} with seed {}, expected {} with seed {}",
                r.controller.name(),
                r.seed,
                t.controller.name(),
                t.seed
            ),
        ));
    }
    let (cddp, safe): (Vec<_>, Vec<_>) = results.iter().cloned().partition(|r| r.controller == Controller::Cddp);
    let safe_wider = cddp
        .iter()
        .zip(&safe)
        .filter(|(a, b)| b.min_clearance > a.min_clearance)
        .count();
    Ok(Experiment {
        config: config.clone(),
        seed,
        beta,
        cddp_summary: Summary::of(Controller::Cddp, &cddp),
        safe_summary: Summary::of(Controller::SafeCddp { beta }, &safe),
        cddp,
        safe,
        safe_wider,
    })
}

/// The experiment from the runs of [`tasks`] (in order).
pub fn aggregate(config: &TurtlebotSweepConfig, results: &[TurtlebotRun]) -> Result<Experiment> {
    experiment_of(&config.turtlebot()?, config.runs, config.seed, config.beta, results)
}

fn row(s: &Summary) -> String {
    let c = &s.min_clearance;
    format!(
        "| {} | {}/{} | {} | {} | {:.1} ± {:.1} | {:.1} | {:.1} | {:.1} | {:.1} ± {:.1} | {:.2} / {:.2} |",
        match s.controller {
            Controller::Cddp => "CDDP".to_string(),
            Controller::SafeCddp { beta } => format!("Safe-CDDP (beta {beta})"),
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

/// The text the binary prints for `e`, which took `wall_s` seconds: the setup, the table
/// (goal reached, collisions, minimum clearance, solve times) and the paired comparison.
pub fn report(config: &TurtlebotSweepConfig, e: &Experiment, wall_s: f64) -> String {
    let c = &e.config;
    format!(
        "Turtlebot3 {} in rapier2d, {} episodes per controller, seed {}, N = {}, localisation noise sigma = {} m / {} rad, Sigma_w = diag({:?})^2, inflation {:.4} m\n\
         | controller | reached | runs with collision | collisions | min clearance mean ± sd (cm) | min (cm) | p10 (cm) | median (cm) | time (s) | solve ms/step mean / max |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n\
         {}\n{}\n\
         Safe-CDDP keeps the wider minimum clearance in {} of {} paired episodes; {:.1} s wall.\n",
        config.robot.name(),
        e.cddp.len(),
        e.seed,
        c.horizon,
        c.sigma_xy,
        c.sigma_theta,
        c.sigma_w,
        c.inflation,
        row(&e.cddp_summary),
        row(&e.safe_summary),
        e.safe_wider,
        e.cddp.len(),
        wall_s
    )
}

/// The binary's JSON file: [`experiment_json`] (with the trajectories if `config.paths`) and
/// `wall_s`, the measured wall time of the episodes.
pub fn json(config: &TurtlebotSweepConfig, e: &Experiment, wall_s: f64) -> serde_json::Value {
    let mut v = experiment_json(e, config.paths);
    v["wall_s"] = serde_json::json!(wall_s);
    v
}
