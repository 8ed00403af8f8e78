//! The experiment of Richter et al. (2023), Section V: many initial conditions, each solved by
//! fixed-grid IDNP (penalty adaptation), adaptive IDNP (Algorithm 1) and the NLP alone from a
//! straight-line guess, with at most `max_iterations` iterations of the loop.
//!
//! Initial conditions are seeded (`rand_chacha`): TCP positions drawn uniformly in
//! [`ExperimentConfig::region`] (at least the DP safety distance from every obstacle), each
//! mapped to a collision-free configuration at rest by the inverse mapping from a randomly bent
//! arm. Cases run in parallel (`rayon`); every result except the wall times is a function of the
//! seed alone.

use std::sync::Arc;

use ddp_core::Vector;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::dp::GridSize;
use crate::error::{Error, Result};
use crate::idnp::{optimizer_alone, Idnp, IdnpOutcome, IdnpSettings, Variant};
use crate::inverse::inverse_map;
use crate::quadtree::QuadGrid;
use crate::scene::{Config, Scene};

/// What to run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ExperimentConfig {
    /// Seed of the initial conditions.
    pub seed: u64,
    /// Number of initial conditions.
    pub initial_conditions: usize,
    /// Region `[[x_min, y_min], [x_max, y_max]]` of the initial TCP positions.
    pub region: [[f64; 2]; 2],
    /// Iterations of the NLP alone (constrained DDP from the straight line).
    pub optimizer_iterations: usize,
    /// Also run fixed-grid IDNP on the uniform grid of this level (e.g. the level that resolves
    /// the passage), for the memory comparison.
    pub uniform_level: Option<u8>,
    /// Settings of the loop (its `max_iterations` is the paper's 15).
    pub settings: IdnpSettings,
}

impl Default for ExperimentConfig {
    fn default() -> Self {
        Self {
            seed: 1,
            initial_conditions: 200,
            region: [[1.2, -2.0], [3.6, 3.2]],
            optimizer_iterations: 400,
            uniform_level: None,
            settings: IdnpSettings::default(),
        }
    }
}

/// An initial condition.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct InitialCondition {
    /// TCP position.
    pub tcp: [f64; 2],
    /// Configuration `(x, y, theta, q1, q2)` (at rest).
    pub q: [f64; 5],
}

impl InitialCondition {
    /// The state at rest.
    pub fn state(&self) -> Vector<10> {
        Scene::state_at_rest(&Config::from_row_slice(&self.q))
    }
}

/// Draws `n` initial conditions from `seed` (see the [module docs](self)).
pub fn sample_initial_conditions(
    scene: &Scene,
    settings: &IdnpSettings,
    region: [[f64; 2]; 2],
    n: usize,
    seed: u64,
) -> Result<Vec<InitialCondition>> {
    let [lo, hi] = region;
    let valid = lo[0] < hi[0] && lo[1] < hi[1] && scene.domain.contains(lo) && scene.domain.contains(hi);
    if !valid {
        return Err(Error::invalid(
            "region",
            format!("must be a non-empty rectangle inside the DP domain, got {region:?}"),
        ));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::with_capacity(n);
    let mut attempts = 0usize;
    while out.len() < n {
        attempts += 1;
        if attempts > 1000 * n.max(1) {
            return Err(Error::invalid(
                "region",
                format!(
                    "found only {} collision-free initial conditions in {attempts} draws",
                    out.len()
                ),
            ));
        }
        let z = [rng.random_range(lo[0]..hi[0]), rng.random_range(lo[1]..hi[1])];
        let heading: f64 = rng.random_range(-0.6..0.6);
        let theta = heading + rng.random_range(-0.3..0.3);
        let q1: f64 = rng.random_range(0.2..0.9);
        let q2: f64 = rng.random_range(-1.5..-0.5);
        if scene.point_clearance(z) < settings.dp.safety_distance {
            continue;
        }
        let nominal = Config::new(z[0] - heading.cos(), z[1] - heading.sin(), theta, q1, q2);
        let Ok(q) = inverse_map(scene, &settings.inverse, &nominal, z, 0) else {
            continue;
        };
        if scene.clearance(&Scene::state_at_rest(&q)).0 < 0.1 {
            continue;
        }
        out.push(InitialCondition {
            tcp: z,
            q: [q[0], q[1], q[2], q[3], q[4]],
        });
    }
    Ok(out)
}

/// Result of one method on one case.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MethodResult {
    /// Whether it found a collision-free trajectory to the goal.
    pub success: bool,
    /// Iterations of the loop used (1 for the NLP alone).
    pub iterations: usize,
    /// How it ended (`"solved"`, `"max_iterations"`, `"stalled"`, or the NLP status).
    pub termination: String,
    /// Wall times (s), summed over the iterations.
    pub dp_time: f64,
    /// See `dp_time`.
    pub inverse_time: f64,
    /// See `dp_time`.
    pub nlp_time: f64,
    /// NLP solves run.
    pub nlp_solves: usize,
    /// Status of the last NLP solve (`"converged"`, `"infeasible"`, ...), if any ran.
    pub nlp_status: Option<String>,
    /// Final grid size (zero for the NLP alone).
    pub grid: GridSize,
}

impl MethodResult {
    fn from_idnp(out: &IdnpOutcome) -> Self {
        let t = |f: fn(&crate::idnp::IterationRecord) -> f64| out.iterations.iter().map(f).sum();
        Self {
            success: out.success(),
            iterations: out.iterations.len(),
            termination: match out.termination {
                crate::idnp::Termination::Solved => "solved",
                crate::idnp::Termination::MaxIterations => "max_iterations",
                crate::idnp::Termination::Stalled => "stalled",
            }
            .to_string(),
            dp_time: t(|r| r.dp_time),
            inverse_time: t(|r| r.inverse_time),
            nlp_time: t(|r| r.nlp_time),
            nlp_solves: out.iterations.iter().filter(|r| r.nlp.is_some()).count(),
            nlp_status: out
                .iterations
                .iter()
                .rev()
                .find_map(|r| r.nlp.as_ref().map(|n| n.status.clone())),
            grid: out.grid,
        }
    }
}

/// One initial condition and the results of every method.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CaseResult {
    /// Index of the case.
    pub index: usize,
    /// The initial condition.
    pub initial: InitialCondition,
    /// Original IDNP on the fixed coarse grid.
    pub fixed: MethodResult,
    /// Algorithm 1.
    pub adaptive: MethodResult,
    /// The NLP alone from the straight line.
    pub optimizer: MethodResult,
    /// Fixed-grid IDNP on the uniform fine grid, if asked for.
    pub uniform: Option<MethodResult>,
}

/// Mean wall times per iteration of a method (ms).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct IterationTimes {
    /// Iterations counted.
    pub iterations: usize,
    /// DP per iteration.
    pub dp_ms: f64,
    /// Inverse mapping per iteration.
    pub inverse_ms: f64,
    /// NLP per iteration (iterations without an NLP count as zero).
    pub nlp_ms: f64,
    /// Total per iteration.
    pub total_ms: f64,
}

impl IterationTimes {
    fn of<'a>(results: impl Iterator<Item = &'a MethodResult>) -> Self {
        let mut t = Self::default();
        for r in results {
            t.iterations += r.iterations;
            t.dp_ms += 1e3 * r.dp_time;
            t.inverse_ms += 1e3 * r.inverse_time;
            t.nlp_ms += 1e3 * r.nlp_time;
        }
        let n = t.iterations.max(1) as f64;
        t.dp_ms /= n;
        t.inverse_ms /= n;
        t.nlp_ms /= n;
        t.total_ms = t.dp_ms + t.inverse_ms + t.nlp_ms;
        t
    }
}

/// The table of the experiment.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// Initial conditions.
    pub cases: usize,
    /// Successes of fixed-grid IDNP.
    pub solved_fixed: usize,
    /// Successes of adaptive IDNP.
    pub solved_adaptive: usize,
    /// Successes of the NLP alone.
    pub solved_optimizer: usize,
    /// Successes of fixed-grid IDNP on the uniform fine grid, if run.
    pub solved_uniform: Option<usize>,
    /// Cases solved by the fixed grid but not by the adaptive one (the paper observed none).
    pub fixed_not_adaptive: Vec<usize>,
    /// Cases solved by the adaptive grid but not by the fixed one.
    pub adaptive_not_fixed: usize,
    /// Mean iterations of the successful runs (fixed, adaptive).
    pub mean_iterations_to_success: [f64; 2],
    /// Size of the initial coarse grids (all time indices).
    pub coarse_grid: GridSize,
    /// Mean and largest number of leaves of the adaptive grids when they succeeded.
    pub adaptive_cells_at_success: [f64; 2],
    /// Mean and largest number of grid points of the adaptive grids when they succeeded.
    pub adaptive_vertices_at_success: [f64; 2],
    /// The coarsest uniform level with a grid point inside the passage and at least the DP
    /// safety distance from the obstacles, and its grid size.
    pub uniform_level: Option<u8>,
    /// See `uniform_level`.
    pub uniform_grid: Option<GridSize>,
    /// Time per iteration of fixed-grid IDNP.
    pub times_fixed: IterationTimes,
    /// Time per iteration of adaptive IDNP.
    pub times_adaptive: IterationTimes,
    /// Mean time of one NLP-alone solve (ms).
    pub optimizer_ms: f64,
}

/// Everything the experiment produced.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ExperimentResult {
    /// The configuration.
    pub config: ExperimentConfig,
    /// The table.
    pub summary: Summary,
    /// Per case.
    pub cases: Vec<CaseResult>,
}

/// The coarsest uniform level at which some grid point lies in the scene's passage with at least
/// the DP safety distance to every obstacle (`None` without a passage or beyond `max_level`).
pub fn passage_resolving_level(scene: &Scene, settings: &IdnpSettings) -> Option<u8> {
    let p = scene.passage?;
    for level in 0..=settings.max_level {
        let n = 1u64 << level;
        let h = scene.domain.cell_size / n as f64;
        let nx = scene.domain.cells[0] as u64 * n;
        let ny = scene.domain.cells[1] as u64 * n;
        for i in 0..=nx {
            let x = scene.domain.min[0] + i as f64 * h;
            if x < p[0][0] || x > p[1][0] {
                continue;
            }
            for j in 0..=ny {
                let y = scene.domain.min[1] + j as f64 * h;
                if y >= p[0][1] && y <= p[1][1] && scene.point_clearance([x, y]) >= settings.dp.safety_distance {
                    return Some(level);
                }
            }
        }
    }
    None
}

/// Runs one method of the loop on one case; also returns the final grids.
pub fn run_idnp(
    scene: &Arc<Scene>,
    settings: IdnpSettings,
    variant: Variant,
    x0: Vector<10>,
) -> Result<(IdnpOutcome, Vec<QuadGrid>)> {
    let mut idnp = Idnp::new(scene.clone(), settings, variant, x0)?;
    let out = idnp.run()?;
    Ok((out, idnp.grids().to_vec()))
}

/// Runs every method on one initial condition.
pub fn run_case(
    scene: &Arc<Scene>,
    config: &ExperimentConfig,
    index: usize,
    ic: InitialCondition,
) -> Result<CaseResult> {
    let x0 = ic.state();
    let s = config.settings;
    let fixed = Idnp::new(scene.clone(), s, Variant::FixedGrid, x0)?.run()?;
    let adaptive = Idnp::new(scene.clone(), s, Variant::Adaptive, x0)?.run()?;
    let alone = optimizer_alone(scene, &s, &x0, config.optimizer_iterations)?;
    let optimizer = MethodResult {
        success: alone.success,
        iterations: 1,
        termination: alone.status.clone(),
        dp_time: 0.0,
        inverse_time: 0.0,
        nlp_time: alone.solve_time,
        nlp_solves: 1,
        nlp_status: Some(alone.status.clone()),
        grid: GridSize::default(),
    };
    let uniform = match config.uniform_level {
        Some(level) => {
            let su = IdnpSettings {
                initial_level: level,
                max_level: s.max_level.max(level),
                ..s
            };
            Some(MethodResult::from_idnp(
                &Idnp::new(scene.clone(), su, Variant::FixedGrid, x0)?.run()?,
            ))
        }
        None => None,
    };
    Ok(CaseResult {
        index,
        initial: ic,
        fixed: MethodResult::from_idnp(&fixed),
        adaptive: MethodResult::from_idnp(&adaptive),
        optimizer,
        uniform,
    })
}

/// Runs the experiment; `progress` is called once per finished case (from worker threads).
pub fn run_experiment(
    scene: &Arc<Scene>,
    config: &ExperimentConfig,
    progress: &(dyn Fn() + Sync),
) -> Result<ExperimentResult> {
    config.settings.validate(scene)?;
    if config.initial_conditions == 0 {
        return Err(Error::invalid("initial_conditions", "must be at least 1"));
    }
    if config.optimizer_iterations == 0 {
        return Err(Error::invalid("optimizer_iterations", "must be at least 1"));
    }
    let ics = sample_initial_conditions(
        scene,
        &config.settings,
        config.region,
        config.initial_conditions,
        config.seed,
    )?;
    let cases: Vec<CaseResult> = ics
        .par_iter()
        .enumerate()
        .map(|(i, ic)| {
            let r = run_case(scene, config, i, *ic);
            progress();
            r
        })
        .collect::<Result<_>>()?;
    let summary = summarize(scene, config, &cases)?;
    Ok(ExperimentResult {
        config: *config,
        summary,
        cases,
    })
}

/// The table of a set of case results.
pub fn summarize(scene: &Scene, config: &ExperimentConfig, cases: &[CaseResult]) -> Result<Summary> {
    let s = &config.settings;
    let count = |f: fn(&CaseResult) -> bool| cases.iter().filter(|c| f(c)).count();
    let solved_adaptive: Vec<&CaseResult> = cases.iter().filter(|c| c.adaptive.success).collect();
    let stats = |v: Vec<f64>| {
        if v.is_empty() {
            [0.0, 0.0]
        } else {
            [
                v.iter().sum::<f64>() / v.len() as f64,
                v.iter().cloned().fold(0.0, f64::max),
            ]
        }
    };
    let mean_its = |f: fn(&CaseResult) -> &MethodResult| {
        let v: Vec<f64> = cases
            .iter()
            .map(f)
            .filter(|r| r.success)
            .map(|r| r.iterations as f64)
            .collect();
        stats(v)[0]
    };
    let coarse = QuadGrid::uniform(scene.domain, s.initial_level, s.max_level)?;
    let stages = s.dp.stages + 1;
    let uniform_level = passage_resolving_level(scene, s);
    let uniform_grid = uniform_level
        .map(|l| QuadGrid::uniform(scene.domain, l, l.max(s.max_level)))
        .transpose()?
        .map(|g| GridSize {
            cells: g.leaf_count() * stages,
            vertices: g.vertex_count() * stages,
            depth: g.depth(),
        });
    Ok(Summary {
        cases: cases.len(),
        solved_fixed: count(|c| c.fixed.success),
        solved_adaptive: solved_adaptive.len(),
        solved_optimizer: count(|c| c.optimizer.success),
        solved_uniform: cases.iter().all(|c| c.uniform.is_some()).then(|| {
            cases
                .iter()
                .filter(|c| c.uniform.as_ref().is_some_and(|u| u.success))
                .count()
        }),
        fixed_not_adaptive: cases
            .iter()
            .filter(|c| c.fixed.success && !c.adaptive.success)
            .map(|c| c.index)
            .collect(),
        adaptive_not_fixed: count(|c| c.adaptive.success && !c.fixed.success),
        mean_iterations_to_success: [mean_its(|c| &c.fixed), mean_its(|c| &c.adaptive)],
        coarse_grid: GridSize {
            cells: coarse.leaf_count() * stages,
            vertices: coarse.vertex_count() * stages,
            depth: coarse.depth(),
        },
        adaptive_cells_at_success: stats(solved_adaptive.iter().map(|c| c.adaptive.grid.cells as f64).collect()),
        adaptive_vertices_at_success: stats(
            solved_adaptive
                .iter()
                .map(|c| c.adaptive.grid.vertices as f64)
                .collect(),
        ),
        uniform_level,
        uniform_grid,
        times_fixed: IterationTimes::of(cases.iter().map(|c| &c.fixed)),
        times_adaptive: IterationTimes::of(cases.iter().map(|c| &c.adaptive)),
        optimizer_ms: 1e3 * cases.iter().map(|c| c.optimizer.nlp_time).sum::<f64>() / cases.len().max(1) as f64,
    })
}

impl Summary {
    /// The table as Markdown, beside the paper's numbers.
    pub fn table(&self) -> String {
        let mut s = String::new();
        s.push_str("| method | solved (ours) | Richter et al. (2023) |\n|---|---|---|\n");
        s.push_str(&format!(
            "| IDNP, fixed grid + penalty adaptation | {} / {} | 132 / 254 |\n",
            self.solved_fixed, self.cases
        ));
        s.push_str(&format!(
            "| IDNP, adaptive grid (Algorithm 1) | {} / {} | 163 / 254 |\n",
            self.solved_adaptive, self.cases
        ));
        s.push_str(&format!(
            "| NLP alone (constrained DDP from a straight line) | {} / {} | IPOPT 0 / 6 |\n",
            self.solved_optimizer, self.cases
        ));
        if let (Some(u), Some(l)) = (self.solved_uniform, self.uniform_level) {
            s.push_str(&format!(
                "| IDNP, uniform grid at level {l} + penalty adaptation | {u} / {} | - |\n",
                self.cases
            ));
        }
        s.push_str(&format!(
            "\nNever fewer: {} case(s) solved by the fixed grid but not by the adaptive one{}; {} solved by the adaptive grid only.\n",
            self.fixed_not_adaptive.len(),
            if self.fixed_not_adaptive.is_empty() {
                String::new()
            } else {
                format!(" ({:?})", self.fixed_not_adaptive)
            },
            self.adaptive_not_fixed
        ));
        s.push_str(&format!(
            "Iterations to success (mean): fixed {:.2}, adaptive {:.2}.\n",
            self.mean_iterations_to_success[0], self.mean_iterations_to_success[1]
        ));
        s.push_str(&format!(
            "DP memory (all time indices): coarse grid {} cells / {} grid points; adaptive grid at success {:.0} cells / {:.0} points on average (at most {:.0} / {:.0})",
            self.coarse_grid.cells,
            self.coarse_grid.vertices,
            self.adaptive_cells_at_success[0],
            self.adaptive_vertices_at_success[0],
            self.adaptive_cells_at_success[1],
            self.adaptive_vertices_at_success[1],
        ));
        match (self.uniform_level, self.uniform_grid) {
            (Some(l), Some(g)) => s.push_str(&format!(
                "; uniform grid resolving the passage (level {l}): {} cells / {} points.\n",
                g.cells, g.vertices
            )),
            _ => s.push_str(".\n"),
        }
        s.push_str("\n| time per iteration (ms) | DP | inverse mapping | NLP | total | iterations |\n|---|---|---|---|---|---|\n");
        for (name, t) in [("fixed grid", self.times_fixed), ("adaptive", self.times_adaptive)] {
            s.push_str(&format!(
                "| {name} | {:.2} | {:.2} | {:.1} | {:.1} | {} |\n",
                t.dp_ms, t.inverse_ms, t.nlp_ms, t.total_ms, t.iterations
            ));
        }
        s.push_str(&format!(
            "| NLP alone (one solve) | - | - | {:.1} | {:.1} | - |\n",
            self.optimizer_ms, self.optimizer_ms
        ));
        s
    }
}
