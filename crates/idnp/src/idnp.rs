//! The iterative loop (Richter et al. (2023), Algorithm 1 and Fig. 1): DP on the TCP grids gives
//! waypoints; the inverse mapping turns them into configurations; the NLP follows them with the
//! full model; where a waypoint cannot be mapped, or the optimised trajectory collides, the grids
//! are refined (adaptive IDNP, eq. (6)) or the penalties raised (the original IDNP, fixed grid).
//!
//! Refinement (eq. (6)): an infeasible point `z` at time `t`, with `t_j <= t < t_{j+1}`, splits
//! the leaves of `G_j` and of `G_{j+1}` that contain `z` (the time index and its successor, which
//! keeps the Markov property of eq. (4)). "Contain" is taken with a tolerance,
//! [`IdnpSettings::refinement_radius`] (half the DP step lattice): every leaf meeting the square
//! of that half-side around `z`, so that a waypoint just below a cell edge also splits the cell
//! across it, whose grid points on the edge it was interpolated from. Infeasible points are
//! - waypoints `z_j` whose inverse mapping fails (time `t_j`, the NLP is skipped), and
//! - TCP positions `tcp(x_k)` of knots where the optimised trajectory collides (time `k dt`).
//!
//! After the splits, a grid that changed is 2:1-balanced ([`QuadGrid::balance`]): a leaf next
//! to one more than a level deeper is split too. Without it, a coarse leaf beside the refined
//! cells keeps interpolating its value from far corners (one inside an obstacle, say), and the DP
//! keeps returning to the refined cell of an infeasible waypoint although the free space lies
//! just across the edge (found on case 191 of the seed-1 experiment, which the fixed grid solved
//! and the unbalanced adaptive grid did not).
//!
//! Since our NLP carries the collision rows as constraints, it may also end collision-free but
//! short of its waypoints; then the waypoints it missed by more than
//! [`crate::nlp::NlpSettings::tracking_tolerance`] count as infeasible, and when it met them all
//! but did not end at rest in the goal ball, the last waypoint does (additions to the paper, whose
//! NLP has no collision constraints and shows such failures as collisions).
//!
//! The fixed-grid baseline adds [`IdnpSettings::penalty_increment`] to the penalty of the
//! corners of the same leaves instead of splitting them: the penalty adaptation of the original
//! IDNP, which spreads the penalty onto the neighbouring grid points without changing the grid.
//!
//! Our grids have a deepest level ([`IdnpSettings::max_level`]); where every cell an infeasible
//! point names is already there, the adaptive variant adapts the penalties like the baseline
//! ([`IdnpSettings::penalize_at_max_level`], on by default; the paper, without a deepest level,
//! would go on splitting).
//!
//! A run stops at the first successful NLP result, after `max_iterations`, or when an iteration
//! can change nothing (no infeasible point found, or every cell to split is at the deepest level
//! and penalties are not adapted there): the next DP would return the same waypoints.

use std::collections::HashMap;
use std::sync::Arc;
use std::time::Instant;

use ddp_core::Vector;
use serde::Serialize;

use crate::dp::{Dp, DpSettings, GridSize};
use crate::error::{positive, Error, Result};
use crate::inverse::{map_waypoints, InverseFailure, InverseSettings};
use crate::nlp::{self, NlpOutcome, NlpSettings};
use crate::quadtree::{QuadGrid, VertexKey};
use crate::scene::{Config, Scene};

/// Which grid strategy.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Variant {
    /// Algorithm 1: cells split where waypoints are infeasible or the trajectory collides.
    Adaptive,
    /// The original IDNP: a fixed grid whose penalties are raised at those places.
    FixedGrid,
}

impl Variant {
    /// Short name (`"adaptive"`, `"fixed"`).
    pub fn as_str(&self) -> &'static str {
        match self {
            Variant::Adaptive => "adaptive",
            Variant::FixedGrid => "fixed",
        }
    }
}

/// Most DP stages `T`.
pub const MAX_STAGES: usize = 10_000;

/// Most cells of the `T + 1` initial grids together.
pub const MAX_TOTAL_CELLS: usize = 1 << 22;

/// Settings of the loop and its blocks.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct IdnpSettings {
    /// DP block.
    pub dp: DpSettings,
    /// Inverse mapping.
    pub inverse: InverseSettings,
    /// NLP block.
    pub nlp: NlpSettings,
    /// Iterations of the loop (the paper uses 15).
    pub max_iterations: usize,
    /// Initial level of every grid below the root cells (0: the coarse grid).
    pub initial_level: u8,
    /// Deepest level a split may create.
    pub max_level: u8,
    /// Penalty added to a grid point per infeasible point in its cell (fixed grid only).
    pub penalty_increment: f64,
    /// The cells refined (or penalised) for an infeasible point `z` are those meeting the square
    /// of half-side `refinement_radius` around `z` (m); 0 gives the closed cells containing `z`
    /// of eq. (6). Half the DP step lattice by default: a waypoint is only known to that
    /// resolution, and one just below a cell edge is interpolated from the edge's grid points,
    /// which the cell across the edge shares.
    pub refinement_radius: f64,
    /// Adaptive variant: when every cell an infeasible point names is already at `max_level`
    /// (nothing left to split), adapt the penalties there as the fixed grid does. Our addition:
    /// the paper has no deepest level, and without it the loop would stall at such a point.
    pub penalize_at_max_level: bool,
}

impl Default for IdnpSettings {
    fn default() -> Self {
        Self {
            dp: DpSettings::default(),
            inverse: InverseSettings::default(),
            nlp: NlpSettings::default(),
            max_iterations: 15,
            initial_level: 0,
            max_level: 4,
            penalty_increment: 100.0,
            refinement_radius: 0.05,
            penalize_at_max_level: true,
        }
    }
}

impl IdnpSettings {
    /// Rejects settings that cannot work (including a stage duration other than the NLP's knots
    /// per stage times the model's step), naming the field.
    pub fn validate(&self, scene: &Scene) -> Result<()> {
        scene.validate()?;
        self.dp.validate()?;
        self.inverse.validate()?;
        self.nlp.validate()?;
        if self.max_iterations == 0 {
            return Err(Error::invalid("max_iterations", "must be at least 1"));
        }
        if self.initial_level > self.max_level || self.max_level > crate::quadtree::MAX_LEVEL {
            return Err(Error::invalid(
                "max_level",
                format!(
                    "need initial_level <= max_level <= {}, got {} and {}",
                    crate::quadtree::MAX_LEVEL,
                    self.initial_level,
                    self.max_level
                ),
            ));
        }
        // What `Idnp::new` allocates (`stages + 1` uniform grids), bounded before allocating.
        let cells = crate::quadtree::uniform_cells(&scene.domain, self.initial_level, "initial_level")?;
        if self.dp.stages > MAX_STAGES {
            return Err(Error::invalid(
                "dp.stages",
                format!("must be at most {MAX_STAGES}, got {}", self.dp.stages),
            ));
        }
        if cells * (self.dp.stages + 1) > MAX_TOTAL_CELLS {
            return Err(Error::invalid(
                "dp.stages",
                format!(
                    "{} grids of {cells} cells each are more than the {MAX_TOTAL_CELLS} cells allowed",
                    self.dp.stages + 1
                ),
            ));
        }
        positive("penalty_increment", self.penalty_increment)?;
        crate::error::nonnegative("refinement_radius", self.refinement_radius)?;
        let stage = self.nlp.knots_per_stage as f64 * scene.robot.dt();
        if (stage - self.dp.stage_duration).abs() > 1e-9 * self.dp.stage_duration {
            return Err(Error::invalid(
                "dp.stage_duration",
                format!(
                    "must equal nlp.knots_per_stage * dt = {} * {} = {stage}, got {}",
                    self.nlp.knots_per_stage,
                    scene.robot.dt(),
                    self.dp.stage_duration
                ),
            ));
        }
        Ok(())
    }
}

/// What one iteration did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IterationRecord {
    /// Iteration number, from 1.
    pub iteration: usize,
    /// Grid size used by the DP of this iteration.
    pub grid: GridSize,
    /// Waypoints `z_0 .. z_T`.
    pub waypoints: Vec<[f64; 2]>,
    /// Waypoints whose inverse mapping failed.
    pub inverse_failures: Vec<InverseFailure>,
    /// The NLP result, when every waypoint mapped.
    pub nlp: Option<NlpOutcome>,
    /// Infeasible points `(time index j, z)` handed to the refinement (or penalty adaptation).
    pub infeasible_points: Vec<(usize, [f64; 2])>,
    /// Cells split (adaptive) or grid points penalised (fixed grid).
    pub grid_changes: usize,
    /// Wall times (s) of the DP, the inverse mappings and the NLP.
    pub dp_time: f64,
    /// See `dp_time`.
    pub inverse_time: f64,
    /// See `dp_time`.
    pub nlp_time: f64,
    /// Whether the NLP result solved the problem.
    pub success: bool,
}

impl IterationRecord {
    /// Total wall time of the iteration (s).
    pub fn time(&self) -> f64 {
        self.dp_time + self.inverse_time + self.nlp_time
    }
}

/// How a run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Termination {
    /// A collision-free trajectory to the goal was found.
    Solved,
    /// `max_iterations` were used.
    MaxIterations,
    /// Nothing left to change: no infeasible point, or every cell at the deepest level.
    Stalled,
}

/// The result of a run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IdnpOutcome {
    /// How it ended.
    pub termination: Termination,
    /// One record per iteration.
    pub iterations: Vec<IterationRecord>,
    /// Final grid size.
    pub grid: GridSize,
}

impl IdnpOutcome {
    /// Whether the run found a solution.
    pub fn success(&self) -> bool {
        self.termination == Termination::Solved
    }
    /// The successful trajectory, if any.
    pub fn trajectory(&self) -> Option<&NlpOutcome> {
        self.iterations
            .last()
            .and_then(|r| r.nlp.as_ref())
            .filter(|n| n.success)
    }
}

/// One IDNP run from one initial state: the grids, the adapted penalties and the loop.
pub struct Idnp {
    scene: Arc<Scene>,
    settings: IdnpSettings,
    variant: Variant,
    x0: Vector<10>,
    q0: Config,
    grids: Vec<QuadGrid>,
    /// Adapted penalties per grid, by grid point key (they survive splits).
    extra: Vec<HashMap<VertexKey, f64>>,
    iteration: usize,
}

impl Idnp {
    /// Validates the input and builds the initial grids (`T + 1` of them). `x0` (at rest or
    /// moving) must be finite, within the joint and base limits and collision-free, with its TCP
    /// in the DP domain; otherwise the error names `x0` and the reason.
    pub fn new(scene: Arc<Scene>, settings: IdnpSettings, variant: Variant, x0: Vector<10>) -> Result<Self> {
        settings.validate(&scene)?;
        check_initial_state(&scene, &x0)?;
        let q0: Config = x0.fixed_rows::<5>(0).into_owned();
        let grid = QuadGrid::uniform(scene.domain, settings.initial_level, settings.max_level)?;
        let grids = vec![grid; settings.dp.stages + 1];
        let extra = vec![HashMap::new(); grids.len()];
        Ok(Self {
            q0,
            scene,
            settings,
            variant,
            x0,
            grids,
            extra,
            iteration: 0,
        })
    }

    /// The grids `G_0 .. G_T`.
    pub fn grids(&self) -> &[QuadGrid] {
        &self.grids
    }
    /// The variant.
    pub fn variant(&self) -> Variant {
        self.variant
    }

    /// One iteration of Algorithm 1 (or of the original IDNP).
    pub fn iterate(&mut self) -> Result<IterationRecord> {
        self.iteration += 1;
        let scene = &*self.scene;
        let s = self.settings;
        let grid = GridSize::of(&self.grids);
        let t0 = Instant::now();
        let penalty = |z: [f64; 2]| s.dp.penalty(scene, z);
        let terminal = |z: [f64; 2]| s.dp.terminal(scene, z);
        let dp = Dp {
            settings: s.dp,
            penalty: &penalty,
            terminal: &terminal,
        };
        let extra: Vec<Vec<f64>> = self
            .grids
            .iter()
            .zip(&self.extra)
            .map(|(g, e)| {
                g.vertex_keys()
                    .iter()
                    .map(|k| e.get(k).copied().unwrap_or(0.0))
                    .collect()
            })
            .collect();
        let sol = dp.solve(&self.grids, Some(&extra), scene.robot.tcp_position(&self.x0))?;
        let dp_time = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let mapped = map_waypoints(scene, &s.inverse, &self.q0, &sol.waypoints);
        let inverse_time = t1.elapsed().as_secs_f64();
        let mut record = IterationRecord {
            iteration: self.iteration,
            grid,
            waypoints: sol.waypoints.clone(),
            inverse_failures: Vec::new(),
            nlp: None,
            infeasible_points: Vec::new(),
            grid_changes: 0,
            dp_time,
            inverse_time,
            nlp_time: 0.0,
            success: false,
        };
        match mapped {
            Err(failures) => {
                record.infeasible_points = failures.iter().map(|f| (f.stage, f.waypoint)).collect();
                record.inverse_failures = failures;
            }
            Ok(qs) => {
                let t2 = Instant::now();
                let out = nlp::solve(&self.scene, &s.nlp, &self.x0, &qs)?;
                record.nlp_time = t2.elapsed().as_secs_f64();
                record.success = out.success;
                if !out.success {
                    let m = s.nlp.knots_per_stage;
                    if !out.colliding_knots.is_empty() {
                        record.infeasible_points = out
                            .colliding_knots
                            .iter()
                            .map(|&k| ((k / m).min(s.dp.stages), self.scene.robot.tcp_position(&out.xs[k])))
                            .collect();
                    } else if !out.missed_waypoints.is_empty() {
                        record.infeasible_points =
                            out.missed_waypoints.iter().map(|&j| (j, sol.waypoints[j])).collect();
                    } else {
                        // Collision-free and on its waypoints, yet not at rest in the goal: the
                        // last waypoint is what failed.
                        let t = s.dp.stages;
                        record.infeasible_points = vec![(t, sol.waypoints[t])];
                    }
                }
                record.nlp = Some(out);
            }
        }
        if !record.success {
            record.grid_changes = self.adapt(&record.infeasible_points);
        }
        Ok(record)
    }

    /// Refinement (eq. (6)) or penalty adaptation at the infeasible points; returns the number
    /// of cells split plus grid points penalised.
    fn adapt(&mut self, points: &[(usize, [f64; 2])]) -> usize {
        let s = self.settings;
        let r = s.refinement_radius;
        match self.variant {
            Variant::Adaptive => {
                // Points whose cells are all at the deepest level cannot be refined further.
                let stuck: Vec<(usize, [f64; 2])> = points
                    .iter()
                    .copied()
                    .filter(|&(j, z)| {
                        [j, j + 1].iter().filter(|&&g| g < self.grids.len()).all(|&g| {
                            let g = &self.grids[g];
                            leaves_near(g, z, r)
                                .iter()
                                .all(|&c| g.cell(c).is_some_and(|c| c.level >= g.max_level()))
                        })
                    })
                    .collect();
                let mut changes = refine(&mut self.grids, points, r);
                if s.penalize_at_max_level && !stuck.is_empty() {
                    changes += adapt_penalties(&self.grids, &mut self.extra, &stuck, r, s.penalty_increment);
                }
                changes
            }
            Variant::FixedGrid => adapt_penalties(&self.grids, &mut self.extra, points, r, s.penalty_increment),
        }
    }

    /// Runs the loop to success, `max_iterations` or a stall.
    pub fn run(&mut self) -> Result<IdnpOutcome> {
        let mut iterations = Vec::new();
        let mut termination = Termination::MaxIterations;
        for _ in 0..self.settings.max_iterations {
            let r = self.iterate()?;
            let (success, changes) = (r.success, r.grid_changes);
            iterations.push(r);
            if success {
                termination = Termination::Solved;
                break;
            }
            if changes == 0 {
                termination = Termination::Stalled;
                break;
            }
        }
        Ok(IdnpOutcome {
            termination,
            iterations,
            grid: GridSize::of(&self.grids),
        })
    }
}

/// Checks an initial state: finite, its TCP in the DP domain, within the joint and base limits
/// and collision-free. The error names `x0` and the reason.
pub fn check_initial_state(scene: &Scene, x0: &Vector<10>) -> Result<()> {
    ddp_core::error::check_finite("x0", x0.iter())?;
    let z0 = scene.robot.tcp_position(x0);
    if !scene.domain.contains(z0) {
        return Err(Error::invalid("x0", format!("its TCP {z0:?} is outside the DP domain")));
    }
    let q0: Config = x0.fixed_rows::<5>(0).into_owned();
    if let Some(which) = scene.limit_violation(&q0) {
        return Err(Error::invalid(
            "x0",
            format!("the initial configuration violates the {which} limit"),
        ));
    }
    let (clearance, body, obstacle) = scene.clearance(x0);
    if clearance < 0.0 {
        return Err(Error::invalid(
            "x0",
            format!(
                "the initial configuration collides: {body:?} penetrates obstacles[{obstacle}] by {:.3} m",
                -clearance
            ),
        ));
    }
    Ok(())
}

/// The leaves of `grid` meeting the square of half-side `radius` around `z` (none outside the
/// domain).
fn leaves_near(grid: &QuadGrid, z: [f64; 2], radius: f64) -> Vec<usize> {
    if grid.domain().contains(z) {
        grid.leaves_intersecting([z[0] - radius, z[1] - radius], [z[0] + radius, z[1] + radius])
    } else {
        Vec::new()
    }
}

/// Refinement, eq. (6): for every infeasible point `(j, z)` splits the leaves of `grids[j]` and
/// `grids[j + 1]` (when it exists) that meet the square of half-side `radius` around `z` (with
/// `radius = 0`: the closed cells containing `z`). Each leaf is split once however many points
/// name it. A grid that changed is then 2:1-balanced ([`QuadGrid::balance`]): neighbours of the
/// refined cells are split until adjacent leaves differ by at most one level, so that the values
/// interpolated next to a refined region come from grid points as close as the region's. Returns
/// the number of cells split, balancing included.
pub fn refine(grids: &mut [QuadGrid], points: &[(usize, [f64; 2])], radius: f64) -> usize {
    let mut per_grid: Vec<Vec<usize>> = vec![Vec::new(); grids.len()];
    for &(j, z) in points {
        for g in [j, j + 1] {
            if g < grids.len() {
                for c in leaves_near(&grids[g], z, radius) {
                    if !per_grid[g].contains(&c) {
                        per_grid[g].push(c);
                    }
                }
            }
        }
    }
    grids
        .iter_mut()
        .zip(&per_grid)
        .map(|(g, cells)| {
            let split = g.split(cells);
            if split > 0 {
                split + g.balance()
            } else {
                0
            }
        })
        .sum()
}

/// Penalty adaptation of the original IDNP: for every infeasible point `(j, z)` adds `increment`
/// to the adapted penalty `extra[g]` of the corners of the leaves of `grids[g]`,
/// `g in {j, j + 1}`, that meet the square of half-side `radius` around `z` (each corner once per
/// point and grid; penalties are keyed by grid point, so they survive later splits). Returns the
/// number of increments.
pub fn adapt_penalties(
    grids: &[QuadGrid],
    extra: &mut [HashMap<VertexKey, f64>],
    points: &[(usize, [f64; 2])],
    radius: f64,
    increment: f64,
) -> usize {
    let mut changes = 0;
    for &(j, z) in points {
        for g in [j, j + 1] {
            if g >= grids.len() || g >= extra.len() {
                continue;
            }
            let mut vertices: Vec<usize> = Vec::new();
            for c in leaves_near(&grids[g], z, radius) {
                for v in grids[g].leaf_corners(c).expect("a leaf") {
                    if !vertices.contains(&v) {
                        vertices.push(v);
                    }
                }
            }
            for v in vertices {
                *extra[g].entry(grids[g].vertex_keys()[v]).or_insert(0.0) += increment;
                changes += 1;
            }
        }
    }
    changes
}

/// The NLP alone from a straight-line guess: configurations translating the base so that the
/// TCP moves on the straight line from its start to the goal centre in `T` equal stages (joint
/// angles and attitude kept), followed with `max_iterations` constrained DDP iterations.
pub fn optimizer_alone(
    scene: &Arc<Scene>,
    settings: &IdnpSettings,
    x0: &Vector<10>,
    max_iterations: usize,
) -> Result<NlpOutcome> {
    settings.validate(scene)?;
    check_initial_state(scene, x0)?;
    let q0: Config = x0.fixed_rows::<5>(0).into_owned();
    let z0 = scene.robot.tcp_position(x0);
    let g = scene.goal.center;
    let t_max = settings.dp.stages;
    let qs: Vec<Config> = (0..=t_max)
        .map(|j| {
            let a = j as f64 / t_max as f64;
            let mut q = q0;
            q[0] += a * (g[0] - z0[0]);
            q[1] += a * (g[1] - z0[1]);
            q
        })
        .collect();
    let nlp = NlpSettings {
        max_iterations,
        ..settings.nlp
    };
    nlp::solve(scene, &nlp, x0, &qs)
}
