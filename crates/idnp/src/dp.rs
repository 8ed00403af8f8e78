//! Dynamic programming over time-indexed TCP grids (Richter et al. (2023), eqs. (2)-(4)).
//!
//! The low-dimensional problem: the TCP `z in R^2` moves by steps `s = z_{j+1} - z_j` from a
//! control grid `U` (a square lattice with `|s_i| <= max_step`, the step bounds that keep
//! `z + s` in the domain), over `T` stages of `stage_duration` seconds:
//!
//! ```text
//! min  sum_{j<T} ( c_u |s_j|^2 / dt + P_j(z_j) ) + P_T(z_T) + phi(z_T)
//! P(z)   = sum_o rho max(0, delta - sd_o(z)) + rho_c max(0, delta_c - sd_o(z))
//!          (+ adapted penalties)                                                    (2)
//! phi(z) = w_phi * max(0, |z - g| - (r_g - goal_margin))                           (Mayer term)
//! V_T(v) = P_T(v),   V_j(v) = P_j(v) + min_{s in U} c_u |s|^2/dt + [j+1 = T] phi(v + s)
//!                                  + sum_i w_i(v + s) V_{j+1}(nu_i(v + s))          (4)
//! ```
//!
//! for every grid point `v` of the grid `G_j` of time index `j` ([`QuadGrid`]). The value of the
//! next stage is interpolated bilinearly inside the leaf that contains `v + s` (`nu_i`, `w_i`);
//! the Mayer term `phi` is a closed form and is evaluated exactly. The waypoints are the greedy
//! forward pass from the initial TCP `z_0` (which need not be a grid point):
//! `z_{j+1} = z_j + argmin_s [c_u |s|^2/dt + [j+1 = T] phi(z_j + s) + V_{j+1}(z_j + s)]`, ties to the
//! first step in lattice order.
//!
//! | symbol | field |
//! |---|---|
//! | `T`, `dt` | [`DpSettings::stages`], [`DpSettings::stage_duration`] |
//! | `U` | [`DpSettings::max_step`], [`DpSettings::steps_per_axis`] |
//! | `c_u` | [`DpSettings::effort_weight`] |
//! | `rho`, `delta` of (2) | [`DpSettings::penalty_weight`], [`DpSettings::safety_distance`] |
//! | `rho_c`, `delta_c` of (2) | [`DpSettings::collision_weight`], [`DpSettings::collision_distance`] |
//! | `w_phi` | [`DpSettings::terminal_weight`] |

use serde::{Deserialize, Serialize};

use crate::error::{nonnegative, positive, Error, Result};
use crate::quadtree::QuadGrid;
use crate::scene::Scene;

/// Most lattice points of the step grid per axis (`steps_per_axis^2` steps are tried per grid
/// point and stage).
pub const MAX_STEPS_PER_AXIS: usize = 1001;

/// Settings of the DP block.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DpSettings {
    /// Number of stages `T` (waypoints `z_0 .. z_T`).
    pub stages: usize,
    /// Duration of a stage (s).
    pub stage_duration: f64,
    /// Step bound per axis (m per stage).
    pub max_step: f64,
    /// Lattice points of the step grid per axis (odd, so that the zero step is in it).
    pub steps_per_axis: usize,
    /// `c_u`: weight of the squared step, per second.
    pub effort_weight: f64,
    /// `rho` of eq. (2), per metre of violated safety distance.
    pub penalty_weight: f64,
    /// `delta` of eq. (2): the clearance below which a TCP position is penalised (m).
    pub safety_distance: f64,
    /// `rho_c`: the steeper weight below `collision_distance`, per metre.
    pub collision_weight: f64,
    /// `delta_c`: the clearance below which the TCP cannot be placed without a collision of the
    /// last link (its radius plus the inverse mapping's minimum clearance, and some slack) (m).
    pub collision_distance: f64,
    /// `w_phi`: weight of the distance to the goal ball at the final stage, per metre.
    pub terminal_weight: f64,
    /// The Mayer term measures the distance to the goal ball shrunk by this much (m), so that the
    /// last waypoint lies inside the ball, not on its rim, and a trajectory that lags a little
    /// behind its waypoints still ends in the ball.
    pub goal_margin: f64,
}

impl Default for DpSettings {
    /// Twelve one-second stages with steps of up to 0.6 m on a 13 x 13 lattice (0.1 m apart), a
    /// penalty of 100 per metre within 0.4 m of an obstacle plus 10000 per metre within 0.1 m (where
    /// the last link would collide), and 10000 per metre of final distance to the goal ball (so
    /// crossing a thin part of a wall is cheaper than missing the goal: the DP still returns
    /// waypoints through walls, which the next iterations repair).
    fn default() -> Self {
        Self {
            stages: 12,
            stage_duration: 1.0,
            max_step: 0.6,
            steps_per_axis: 13,
            effort_weight: 0.1,
            penalty_weight: 100.0,
            safety_distance: 0.4,
            collision_weight: 10000.0,
            collision_distance: 0.1,
            terminal_weight: 10000.0,
            goal_margin: 0.15,
        }
    }
}

impl DpSettings {
    /// Rejects settings that cannot work, naming the field.
    pub fn validate(&self) -> Result<()> {
        if self.stages == 0 {
            return Err(Error::invalid("dp.stages", "must be at least 1"));
        }
        if self.steps_per_axis > MAX_STEPS_PER_AXIS {
            return Err(Error::invalid(
                "dp.steps_per_axis",
                format!("must be at most {MAX_STEPS_PER_AXIS}, got {}", self.steps_per_axis),
            ));
        }
        if self.steps_per_axis == 0 || self.steps_per_axis.is_multiple_of(2) {
            return Err(Error::invalid(
                "dp.steps_per_axis",
                format!(
                    "must be odd (so the zero step is in the lattice), got {}",
                    self.steps_per_axis
                ),
            ));
        }
        positive("dp.stage_duration", self.stage_duration)?;
        nonnegative("dp.max_step", self.max_step)?;
        nonnegative("dp.effort_weight", self.effort_weight)?;
        nonnegative("dp.penalty_weight", self.penalty_weight)?;
        nonnegative("dp.safety_distance", self.safety_distance)?;
        nonnegative("dp.collision_weight", self.collision_weight)?;
        nonnegative("dp.collision_distance", self.collision_distance)?;
        nonnegative("dp.terminal_weight", self.terminal_weight)?;
        nonnegative("dp.goal_margin", self.goal_margin)?;
        Ok(())
    }

    /// The step lattice `U`, row-major from `(-max_step, -max_step)`.
    pub fn steps(&self) -> Vec<[f64; 2]> {
        let n = self.steps_per_axis;
        let h = if n > 1 {
            2.0 * self.max_step / (n - 1) as f64
        } else {
            0.0
        };
        let axis: Vec<f64> = (0..n).map(|i| -self.max_step + i as f64 * h).collect();
        let mut out = Vec::with_capacity(n * n);
        for &dy in &axis {
            for &dx in &axis {
                out.push([dx, dy]);
            }
        }
        out
    }

    /// The collision penalty of eq. (2) at the TCP position `z`.
    pub fn penalty(&self, scene: &Scene, z: [f64; 2]) -> f64 {
        scene
            .obstacles
            .iter()
            .map(|o| {
                let sd = o.point_distance(z);
                self.penalty_weight * (self.safety_distance - sd).max(0.0)
                    + self.collision_weight * (self.collision_distance - sd).max(0.0)
            })
            .sum()
    }

    /// The Mayer term at `z`: `w_phi max(0, |z - g| - (r_g - goal_margin))`.
    pub fn terminal(&self, scene: &Scene, z: [f64; 2]) -> f64 {
        let g = scene.goal;
        let r = (g.radius - self.goal_margin).max(0.0);
        self.terminal_weight * ((z[0] - g.center[0]).hypot(z[1] - g.center[1]) - r).max(0.0)
    }
}

/// Value functions and waypoints of one DP solve.
#[derive(Debug, Clone, PartialEq)]
pub struct DpSolution {
    /// `V_j` on the vertices of `G_j`, `j = 0 .. T`.
    pub values: Vec<Vec<f64>>,
    /// The penalties `P_j` used (eq. (2) plus adapted penalties) on the vertices of `G_j`.
    pub penalties: Vec<Vec<f64>>,
    /// The waypoints `z_0 .. z_T` of the forward pass.
    pub waypoints: Vec<[f64; 2]>,
    /// Cost of the waypoints: sum of steps' effort, penalties `P_j(z_j)` (interpolated from the
    /// grid, as the DP sees them) and the Mayer term.
    pub cost: f64,
}

/// The DP block: the grids `G_0 .. G_T`, the penalty and terminal cost as functions of the TCP
/// position, and the settings. The functions are plain closures so that tests can use their own.
pub struct Dp<'a> {
    /// Settings.
    pub settings: DpSettings,
    /// The running penalty `P(z)` at a grid point (eq. (2)).
    pub penalty: &'a (dyn Fn([f64; 2]) -> f64 + Sync),
    /// The Mayer term `phi(z)`.
    pub terminal: &'a (dyn Fn([f64; 2]) -> f64 + Sync),
}

impl Dp<'_> {
    /// Solves eq. (4) backwards on `grids` (`T + 1` of them) and runs the forward pass from `z0`.
    /// `extra[j][v]`, if given, is added to the penalty of vertex `v` of `G_j` (the penalty
    /// adaptation of the original IDNP). Errors on mismatched lengths or a `z0` outside the domain.
    pub fn solve(&self, grids: &[QuadGrid], extra: Option<&[Vec<f64>]>, z0: [f64; 2]) -> Result<DpSolution> {
        let s = &self.settings;
        s.validate()?;
        let t_max = s.stages;
        if grids.len() != t_max + 1 {
            return Err(Error::invalid(
                "grids",
                format!("need stages + 1 = {} grids, got {}", t_max + 1, grids.len()),
            ));
        }
        if let Some(e) = extra {
            if e.len() != grids.len() {
                return Err(Error::invalid(
                    "extra",
                    format!("need {} penalty tables, got {}", grids.len(), e.len()),
                ));
            }
            for (j, (ej, g)) in e.iter().zip(grids).enumerate() {
                if ej.len() != g.vertex_count() {
                    return Err(Error::invalid(
                        format!("extra[{j}]"),
                        format!(
                            "need {} entries (vertices of grid {j}), got {}",
                            g.vertex_count(),
                            ej.len()
                        ),
                    ));
                }
            }
        }
        if !grids[0].domain().contains(z0) {
            return Err(Error::invalid("z0", format!("{z0:?} is outside the DP domain")));
        }
        let steps = s.steps();
        let effort: Vec<f64> = steps
            .iter()
            .map(|d| s.effort_weight * (d[0] * d[0] + d[1] * d[1]) / s.stage_duration)
            .collect();
        let penalties: Vec<Vec<f64>> = grids
            .iter()
            .enumerate()
            .map(|(j, g)| {
                g.vertices()
                    .iter()
                    .enumerate()
                    .map(|(v, &p)| (self.penalty)(p) + extra.map_or(0.0, |e| e[j][v]))
                    .collect()
            })
            .collect();
        let mut values: Vec<Vec<f64>> = vec![Vec::new(); t_max + 1];
        values[t_max] = penalties[t_max].clone();
        for j in (0..t_max).rev() {
            let (next_grid, next_values) = (&grids[j + 1], &values[j + 1]);
            let last = j + 1 == t_max;
            let vj: Vec<f64> = grids[j]
                .vertices()
                .iter()
                .enumerate()
                .map(|(v, &p)| penalties[j][v] + self.best_step(&steps, &effort, next_grid, next_values, last, p).1)
                .collect();
            values[j] = vj;
        }
        // Forward pass.
        let mut waypoints = Vec::with_capacity(t_max + 1);
        waypoints.push(z0);
        let mut cost = grids[0].interpolate(&penalties[0], z0).unwrap_or(f64::INFINITY);
        let mut z = z0;
        for j in 0..t_max {
            let last = j + 1 == t_max;
            let (k, _) = self.best_step(&steps, &effort, &grids[j + 1], &values[j + 1], last, z);
            let d = steps[k];
            z = [z[0] + d[0], z[1] + d[1]];
            cost += effort[k] + grids[j + 1].interpolate(&penalties[j + 1], z).unwrap_or(f64::INFINITY);
            if last {
                cost += (self.terminal)(z);
            }
            waypoints.push(z);
        }
        Ok(DpSolution {
            values,
            penalties,
            waypoints,
            cost,
        })
    }

    /// `argmin_s` and `min_s` of `effort(s) + [last] phi(p + s) + V_{j+1}(p + s)`.
    #[inline]
    fn best_step(
        &self,
        steps: &[[f64; 2]],
        effort: &[f64],
        grid: &QuadGrid,
        values: &[f64],
        last: bool,
        p: [f64; 2],
    ) -> (usize, f64) {
        let mut best = (usize::MAX, f64::INFINITY);
        for (k, d) in steps.iter().enumerate() {
            let q = [p[0] + d[0], p[1] + d[1]];
            let Some(v) = grid.interpolate(values, q) else {
                continue;
            };
            let mut c = effort[k] + v;
            if last {
                c += (self.terminal)(q);
            }
            if c < best.1 {
                best = (k, c);
            }
        }
        if best.0 == usize::MAX {
            // Only possible with a zero-size lattice outside the domain: stay put.
            let zero = steps.len() / 2;
            return (zero, f64::INFINITY);
        }
        best
    }
}

/// Grid statistics summed over the time indices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct GridSize {
    /// Leaves (cells of the partition).
    pub cells: usize,
    /// Grid points (values stored by the DP).
    pub vertices: usize,
    /// Deepest leaf level.
    pub depth: u8,
}

impl GridSize {
    /// Totals over `grids`.
    pub fn of(grids: &[QuadGrid]) -> Self {
        Self {
            cells: grids.iter().map(|g| g.leaf_count()).sum(),
            vertices: grids.iter().map(|g| g.vertex_count()).sum(),
            depth: grids.iter().map(|g| g.depth()).max().unwrap_or(0),
        }
    }
}
