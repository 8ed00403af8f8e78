//! The experiment of Richter et al. (2023), Section V, as independent tasks: one task is one
//! initial condition solved by every method, so the experiment can run on every core (the binary
//! `idnp-experiment`, rayon) or on a cluster (`python -m ddpkit.experiments idnp`, Ray) with the
//! same per-case results.
//!
//! | step | function | in | out |
//! |---|---|---|---|
//! | list | [`tasks`] | [`IdnpConfig`] | [`CaseTask`]s (the seeded initial conditions) |
//! | run | [`run_task`] | one [`CaseTask`] | one [`CaseResult`] |
//! | aggregate | [`aggregate`] | the config and the results in task order | [`ExperimentResult`] |
//!
//! The initial conditions are drawn once, from the seed, when the tasks are listed; a task
//! carries its own, so its result depends on the task alone. Every field of a result is a
//! function of the task except the wall times (`dp_time`, `inverse_time`, `nlp_time` and the
//! times of the summary), which are measured.
//!
//! ```
//! use idnp::sweep::{aggregate, run_task, tasks, IdnpConfig};
//! let config = IdnpConfig { n: 1, iterations: 2, optimizer_iterations: 20, ..IdnpConfig::default() };
//! let specs = tasks(&config)?;
//! assert_eq!(specs.len(), 1);
//! let cases = specs.iter().map(run_task).collect::<Result<Vec<_>, _>>()?;
//! let result = aggregate(&config, &cases)?;
//! assert_eq!(result.summary.cases, 1);
//! # Ok::<(), idnp::Error>(())
//! ```

use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::experiment::{
    passage_resolving_level, run_case, sample_initial_conditions, summarize, CaseResult, ExperimentConfig,
    ExperimentResult, InitialCondition,
};
use crate::scene::Scene;

/// What the experiment runs: the options of the binary `idnp-experiment`. Every field has the
/// binary's default, so `{}` is a valid configuration in JSON.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IdnpConfig {
    /// Seed of the initial conditions.
    pub seed: u64,
    /// Number of initial conditions (at least 1).
    pub n: usize,
    /// Iterations of the IDNP loop per case (the paper: 15).
    pub iterations: usize,
    /// Region `[[x_min, y_min], [x_max, y_max]]` of the initial TCP positions; `None` keeps
    /// [`ExperimentConfig::default`]'s.
    pub region: Option<[[f64; 2]; 2]>,
    /// Iterations of the NLP alone (at least 1).
    pub optimizer_iterations: usize,
    /// Also run fixed-grid IDNP on the uniform grid that resolves the passage.
    pub uniform: bool,
    /// Pure Algorithm 1: no penalty adaptation where the adaptive grid is at its deepest level.
    pub no_max_level_penalty: bool,
}

impl Default for IdnpConfig {
    fn default() -> Self {
        Self {
            seed: 1,
            n: 200,
            iterations: 15,
            region: None,
            optimizer_iterations: 400,
            uniform: false,
            no_max_level_penalty: false,
        }
    }
}

impl IdnpConfig {
    /// The experiment's configuration in the scene (as the binary builds it), checked: a bad
    /// value is an error naming its field.
    pub fn experiment(&self, scene: &Scene) -> Result<ExperimentConfig> {
        if self.n == 0 {
            return Err(Error::invalid("n", "must be at least 1, got 0"));
        }
        if self.iterations == 0 {
            return Err(Error::invalid("iterations", "must be at least 1, got 0"));
        }
        if self.optimizer_iterations == 0 {
            return Err(Error::invalid("optimizer_iterations", "must be at least 1, got 0"));
        }
        let mut config = ExperimentConfig {
            seed: self.seed,
            initial_conditions: self.n,
            optimizer_iterations: self.optimizer_iterations,
            ..ExperimentConfig::default()
        };
        if let Some(r) = self.region {
            if r.iter().flatten().any(|v| !v.is_finite()) {
                return Err(Error::invalid("region", format!("must be finite, got {r:?}")));
            }
            config.region = r;
        }
        config.settings.max_iterations = self.iterations;
        config.settings.penalize_at_max_level = !self.no_max_level_penalty;
        if self.uniform {
            config.uniform_level = passage_resolving_level(scene, &config.settings);
        }
        config.settings.validate(scene)?;
        Ok(config)
    }
}

/// One case: the configuration it belongs to, its index and its initial condition.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaseTask {
    /// The experiment's configuration (what the methods run with).
    pub config: IdnpConfig,
    /// Index of the case (its place in the seeded draw).
    pub index: usize,
    /// The initial condition.
    pub initial: InitialCondition,
}

/// The scene of the experiment (the narrow passage).
fn scene() -> Arc<Scene> {
    Arc::new(Scene::narrow_passage())
}

/// The cases of `config`, in order: its seeded initial conditions.
pub fn tasks(config: &IdnpConfig) -> Result<Vec<CaseTask>> {
    let scene = scene();
    let exp = config.experiment(&scene)?;
    let ics = sample_initial_conditions(&scene, &exp.settings, exp.region, exp.initial_conditions, exp.seed)?;
    Ok(ics
        .into_iter()
        .enumerate()
        .map(|(index, initial)| CaseTask {
            config: *config,
            index,
            initial,
        })
        .collect())
}

/// Runs every method on one case (on this thread, apart from the rayon pool of the solvers).
pub fn run_task(task: &CaseTask) -> Result<CaseResult> {
    let scene = scene();
    let exp = task.config.experiment(&scene)?;
    run_case(&scene, &exp, task.index, task.initial)
}

/// The experiment's result from the results of [`tasks`] (in order).
pub fn aggregate(config: &IdnpConfig, cases: &[CaseResult]) -> Result<ExperimentResult> {
    let scene = scene();
    let exp = config.experiment(&scene)?;
    if cases.len() != exp.initial_conditions {
        return Err(Error::invalid(
            "cases",
            format!("expected {} case results, got {}", exp.initial_conditions, cases.len()),
        ));
    }
    if let Some((i, c)) = cases.iter().enumerate().find(|(i, c)| c.index != *i) {
        return Err(Error::invalid("cases", format!("result {i} is of case {}", c.index)));
    }
    let summary = summarize(&scene, &exp, cases)?;
    Ok(ExperimentResult {
        config: exp,
        summary,
        cases: cases.to_vec(),
    })
}

/// The case the figure (like the paper's Fig. 3) shows: the first one the adaptive grid solved in
/// three iterations and the fixed grid did not (else after two or more, else any success).
pub fn figure_case(result: &ExperimentResult) -> Option<&CaseResult> {
    let cases = &result.cases;
    cases
        .iter()
        .find(|c| c.adaptive.success && !c.fixed.success && c.adaptive.iterations == 3)
        .or_else(|| {
            cases
                .iter()
                .find(|c| c.adaptive.success && !c.fixed.success && c.adaptive.iterations >= 2)
        })
        .or_else(|| cases.iter().find(|c| c.adaptive.success && c.adaptive.iterations >= 2))
        .or_else(|| cases.iter().find(|c| c.adaptive.success))
}

/// The text the binary prints for a result (heading, table, the "never fewer" check).
pub fn report(config: &IdnpConfig, result: &ExperimentResult) -> String {
    let s = &result.summary;
    format!(
        "IDNP experiment: seed {}, {} initial conditions, at most {} iterations each\n\n{}\ncheck adaptive >= fixed on every case: {}\n",
        config.seed,
        config.n,
        config.iterations,
        s.table(),
        if s.fixed_not_adaptive.is_empty() { "PASS" } else { "FAIL" }
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tasks_and_results_survive_json_and_equal_the_in_process_experiment() {
        let config = IdnpConfig {
            n: 2,
            iterations: 2,
            optimizer_iterations: 20,
            ..IdnpConfig::default()
        };
        let specs = tasks(&config).unwrap();
        let cases: Vec<CaseResult> = specs
            .iter()
            .map(|t| {
                let t: CaseTask = serde_json::from_str(&serde_json::to_string(t).unwrap()).unwrap();
                let r = run_task(&t).unwrap();
                serde_json::from_str(&serde_json::to_string(&r).unwrap()).unwrap()
            })
            .collect();
        let scene = scene();
        let whole = crate::experiment::run_experiment(&scene, &config.experiment(&scene).unwrap(), &|| {}).unwrap();
        let a = aggregate(&config, &cases).unwrap();
        // Everything but the wall times.
        let strip = |c: &CaseResult| {
            let mut c = c.clone();
            for m in [&mut c.fixed, &mut c.adaptive, &mut c.optimizer]
                .into_iter()
                .chain(c.uniform.as_mut())
            {
                (m.dp_time, m.inverse_time, m.nlp_time) = (0.0, 0.0, 0.0);
            }
            c
        };
        assert_eq!(
            a.cases.iter().map(strip).collect::<Vec<_>>(),
            whole.cases.iter().map(strip).collect::<Vec<_>>()
        );
        assert_eq!(a.summary.solved_adaptive, whole.summary.solved_adaptive);
    }

    #[test]
    fn bad_configurations_name_their_field() {
        for (config, field) in [
            (
                IdnpConfig {
                    n: 0,
                    ..IdnpConfig::default()
                },
                "n",
            ),
            (
                IdnpConfig {
                    iterations: 0,
                    ..IdnpConfig::default()
                },
                "iterations",
            ),
            (
                IdnpConfig {
                    optimizer_iterations: 0,
                    ..IdnpConfig::default()
                },
                "optimizer_iterations",
            ),
            (
                IdnpConfig {
                    region: Some([[f64::NAN, 0.0], [1.0, 1.0]]),
                    ..IdnpConfig::default()
                },
                "region",
            ),
        ] {
            let e = tasks(&config).unwrap_err().to_string();
            assert!(e.contains(field), "{e}");
        }
        assert!(serde_json::from_str::<IdnpConfig>(r#"{"cases": 3}"#)
            .unwrap_err()
            .to_string()
            .contains("cases"));
    }
}
