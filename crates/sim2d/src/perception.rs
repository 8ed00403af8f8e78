//! Lidar -> local costmap -> distance field, as a ROS 2 costmap node would do it:
//!
//! 1. the obstacle layer (a [`Costmap`] of 200 x 200 cells of 5 cm) is re-centred on the robot
//!    (rolling window, cells keep their world position);
//! 2. clearing by ray tracing (a ROS obstacle layer's `clearing`): the cells every beam passes
//!    through before its return (or its maximum range) are free, so an obstacle is forgotten only
//!    where the lidar sees through it again, and a dead end the robot has turned away from stays
//!    in the map while it is inside the window; optionally also a cost decay of `decay` per scan
//!    (an obstacle not seen again fades out after `254 / decay` scans; 0 by default);
//! 3. every lidar return marks its cell [`LETHAL`], and so do the cells behind it along the beam
//!    up to `shadow_depth`: a lidar sees the near face of an obstacle only, and without this prior
//!    on its depth a trajectory could tunnel through the one-cell shell of returns;
//! 4. the exact distance transforms of the cells `>= obstacle_threshold` and of the others give
//!    the signed [`DistanceField`] for the planner's obstacle cost (eq. 7), negative inside
//!    obstacles so that the cost keeps growing into them;
//! 5. inflation of that field gives the inflated costmap (A*, logs, the sub-goal network).
//!
//! ```
//! use sim2d::perception::{Perception, PerceptionParams};
//! use sim2d::world::Scan;
//! let mut p = Perception::new(PerceptionParams::default())?;
//! let scan = Scan { pose: [0.0, 0.0, 0.0], ranges: vec![], max_range: 8.0, hits: vec![[1.0, 0.0]] };
//! p.update(&scan);
//! let (d, _) = p.field().sample([0.0, 0.0]);
//! assert!((d - 1.0).abs() < 0.05);
//! # Ok::<(), sim2d::Error>(())
//! ```

use std::sync::Arc;

use subgoal_infer::grid::{Costmap, DistanceField, GridGeometry, Inflation, FREE, LETHAL};

use crate::error::{nonnegative, positive, Error, Result};
use crate::world::Scan;

/// Costmap parameters (defaults: DDPEN's 200 x 200 cells of 5 cm; inflation for the 0.6 x 0.8 m
/// robot).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PerceptionParams {
    /// Cells along each side.
    pub cells: usize,
    /// Cell side (m).
    pub resolution: f64,
    /// Cost lost per scan (0 keeps obstacles until a beam clears them).
    pub decay: u8,
    /// Clear the cells each beam passes through (ray tracing) before marking its return.
    pub raytrace: bool,
    /// Cells at or above this cost are obstacles for the distance field.
    pub obstacle_threshold: u8,
    /// How far behind a lidar return the beam's cells count as obstacle (m; 0: the return only).
    pub shadow_depth: f64,
    /// Signed distance field (negative inside obstacles) rather than unsigned.
    pub signed: bool,
    /// Inscribed radius of the inflation (m).
    pub inscribed_radius: f64,
    /// Inflation radius (m).
    pub inflation_radius: f64,
    /// Inflation decay rate (1/m).
    pub cost_scaling: f64,
}

impl Default for PerceptionParams {
    fn default() -> Self {
        Self {
            cells: 200,
            resolution: 0.05,
            // Obstacles are forgotten where a beam sees through them (ray tracing), not by time:
            // a time decay forgets a dead end once the robot turns its back to it.
            decay: 0,
            raytrace: true,
            obstacle_threshold: 128,
            shadow_depth: 2.0,
            signed: true,
            inscribed_radius: 0.3,
            inflation_radius: 1.2,
            cost_scaling: 3.0,
        }
    }
}

impl PerceptionParams {
    /// Rejects impossible values, naming the field (`perception.<name>`).
    pub fn validate(&self) -> Result<()> {
        if self.cells < 8 || self.cells > 4096 {
            return Err(Error::invalid(
                "perception.cells",
                format!("must be in 8..=4096, got {}", self.cells),
            ));
        }
        positive("perception.resolution", self.resolution)?;
        if self.obstacle_threshold == 0 {
            return Err(Error::invalid("perception.obstacle_threshold", "must be at least 1"));
        }
        nonnegative("perception.inscribed_radius", self.inscribed_radius)?;
        nonnegative("perception.shadow_depth", self.shadow_depth)?;
        nonnegative("perception.cost_scaling", self.cost_scaling)?;
        if self.inflation_radius < self.inscribed_radius {
            return Err(Error::invalid(
                "perception.inflation_radius",
                "must be >= perception.inscribed_radius",
            ));
        }
        Ok(())
    }

    /// Half the side of the costmap (m).
    pub fn half_size(&self) -> f64 {
        0.5 * self.cells as f64 * self.resolution
    }
}

/// The perception pipeline (see the module docs). Buffers are allocated once.
#[derive(Debug, Clone)]
pub struct Perception {
    params: PerceptionParams,
    obstacles: Costmap,
    inflated: Costmap,
    field: Arc<DistanceField>,
    inflation: Inflation,
}

impl Perception {
    /// Allocates the layers, centred on the origin until the first update.
    pub fn new(params: PerceptionParams) -> Result<Self> {
        params.validate()?;
        let g = GridGeometry::centered([0.0, 0.0], params.cells, params.cells, params.resolution)?;
        Ok(Self {
            obstacles: Costmap::new(g),
            inflated: Costmap::new(g),
            field: Arc::new(DistanceField::new(g)),
            inflation: Inflation::new(
                params.inscribed_radius,
                params.inflation_radius,
                params.cost_scaling,
                params.resolution,
            )?,
            params,
        })
    }

    /// Folds one scan in (steps 1-5 of the module docs). No allocation while nobody else holds
    /// the distance field (planners drop their problem after each cycle).
    pub fn update(&mut self, scan: &Scan) {
        self.obstacles.recenter([scan.pose[0], scan.pose[1]]);
        self.obstacles.decay(self.params.decay);
        let step = 0.5 * self.params.resolution;
        if self.params.raytrace && !scan.ranges.is_empty() {
            let n = scan.ranges.len();
            let [x0, y0, heading] = scan.pose;
            for (k, &r) in scan.ranges.iter().enumerate() {
                let a = heading + k as f64 * std::f64::consts::TAU / n as f64;
                let (sin, cos) = a.sin_cos();
                // Up to half a cell short of the return, which is marked below.
                let steps = ((r as f64 - self.params.resolution) / step).floor().max(0.0) as usize;
                for j in 0..steps {
                    let d = j as f64 * step;
                    match self.obstacles.geometry().world_to_cell([x0 + d * cos, y0 + d * sin]) {
                        Some((ix, iy)) => self.obstacles.set(ix, iy, FREE),
                        None => break,
                    }
                }
            }
        }
        let n = (self.params.shadow_depth / step).round() as usize;
        for &h in &scan.hits {
            self.obstacles.mark(h, LETHAL);
            let (dx, dy) = (h[0] - scan.pose[0], h[1] - scan.pose[1]);
            let len = dx.hypot(dy);
            if n > 0 && len > 1e-9 {
                let (ux, uy) = (dx / len * step, dy / len * step);
                for k in 1..=n {
                    let p = [h[0] + k as f64 * ux, h[1] + k as f64 * uy];
                    if !self.obstacles.mark(p, LETHAL) {
                        break;
                    }
                }
            }
        }
        let field = Arc::make_mut(&mut self.field);
        let threshold = self.params.obstacle_threshold;
        if self.params.signed {
            field.compute_signed(&self.obstacles, threshold)
        } else {
            field.compute(&self.obstacles, threshold)
        }
        .expect("field and layers share their geometry");
        self.inflation
            .apply(field, &mut self.inflated)
            .expect("field and layers share their geometry");
    }

    /// The parameters.
    pub fn params(&self) -> &PerceptionParams {
        &self.params
    }
    /// The obstacle layer (decaying lidar evidence).
    pub fn obstacles(&self) -> &Costmap {
        &self.obstacles
    }
    /// The inflated costmap.
    pub fn costmap(&self) -> &Costmap {
        &self.inflated
    }
    /// The distance field of the obstacle layer.
    pub fn field(&self) -> &Arc<DistanceField> {
        &self.field
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scan(pose: [f64; 3], beams: usize, hit: Option<(usize, f64)>) -> Scan {
        let mut s = Scan {
            pose,
            ranges: vec![8.0; beams],
            max_range: 8.0,
            hits: vec![],
        };
        if let Some((k, r)) = hit {
            s.ranges[k] = r as f32;
            let a = pose[2] + k as f64 * std::f64::consts::TAU / beams as f64;
            s.hits.push([pose[0] + r * a.cos(), pose[1] + r * a.sin()]);
        }
        s
    }

    #[test]
    fn obstacles_stay_until_a_beam_sees_through_them() {
        let mut p = Perception::new(PerceptionParams::default()).unwrap();
        // A return 2 m ahead along beam 0 of 4.
        p.update(&scan([0.0, 0.0, 0.0], 4, Some((0, 2.0))));
        let cell = p.obstacles().geometry().world_to_cell([2.0, 0.0]).unwrap();
        assert_eq!(p.obstacles().get(cell.0, cell.1), LETHAL);
        // Turned away (the beams miss the obstacle): it stays, with no time decay.
        for _ in 0..30 {
            p.update(&scan([0.0, 0.0, 0.3], 4, None));
        }
        assert_eq!(p.obstacles().get(cell.0, cell.1), LETHAL);
        // A beam through the cell (no return within 8 m) clears it, and its shadow.
        p.update(&scan([0.0, 0.0, 0.0], 4, None));
        assert_eq!(p.obstacles().get(cell.0, cell.1), FREE);
        let behind = p.obstacles().geometry().world_to_cell([3.5, 0.0]).unwrap();
        assert_eq!(p.obstacles().get(behind.0, behind.1), FREE);
        // With time decay and no ray tracing, an unseen obstacle fades out.
        let mut q = Perception::new(PerceptionParams {
            decay: 25,
            raytrace: false,
            ..PerceptionParams::default()
        })
        .unwrap();
        q.update(&scan([0.0, 0.0, 0.0], 4, Some((0, 2.0))));
        for _ in 0..11 {
            q.update(&scan([0.0, 0.0, 0.3], 4, None));
        }
        assert_eq!(q.obstacles().get(cell.0, cell.1), FREE);
    }
}
