//! The executor's speed governor: a plan's speed is capped so that the robot can still brake to
//! a stop before its bumper reaches what the costmap has seen straight ahead (or behind, when
//! reversing).
//!
//! The planners' unicycle changes speed instantly, but the robot's actuators ramp at
//! `accel_max` (1 m/s^2): from 1.5 m/s it needs 1.1 m and 1.5 s to stop. A plan that heads at a
//! corner and turns away or backs off "in time" by the model's reckoning runs the real robot into
//! it. The governor closes that gap the way a safety-rated speed limiter does:
//!
//! ```text
//! s_free = free travel of the bumper along the heading (distance field > stand_off at its
//!          centre and corners, marched in half-cell steps up to the braking distance)
//! |v| <= sqrt(2 decel max(s_free - |v_now| dt, 0))     (the reaction step covered first)
//! ```
//!
//! It only ever lowers `|v|` towards 0, never changes the turn rate, and does nothing in the
//! open, so the planners' paths are unchanged away from obstacles. [`GovernorParams::enabled`]
//! `= false` sends the plans' controls as they are (the paper's executor).

use subgoal_infer::grid::DistanceField;

use crate::error::{nonnegative, positive, Result};
use crate::world::RobotParams;

/// Settings of the speed governor (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GovernorParams {
    /// Cap the plan's speed (`false`: the plan's controls as they are).
    pub enabled: bool,
    /// Deceleration the cap assumes (m/s^2); at most the robot's `accel_max` to be sound.
    pub decel: f64,
    /// Distance-field clearance of the bumper at which the robot must have stopped (m); the
    /// field measures to occupied cell centres, half a cell (2.5 cm) inside the surface.
    pub stand_off: f64,
}

impl Default for GovernorParams {
    fn default() -> Self {
        Self {
            enabled: true,
            decel: 0.9,
            stand_off: 0.1,
        }
    }
}

impl GovernorParams {
    /// Rejects impossible values, naming the field (`governor.<name>`).
    pub fn validate(&self) -> Result<()> {
        positive("governor.decel", self.decel)?;
        nonnegative("governor.stand_off", self.stand_off)?;
        Ok(())
    }
}

/// Free travel (m) of the bumper from `pose` in the direction `sign` (+1 forward, -1 back),
/// up to `limit`: the first step where the field at the bumper's centre or a corner is below
/// `stand_off` (0 when already there).
pub fn free_travel(
    field: &DistanceField,
    robot: &RobotParams,
    pose: [f64; 3],
    sign: f64,
    stand_off: f64,
    limit: f64,
) -> f64 {
    let (s, c) = pose[2].sin_cos();
    let (hx, hy) = (sign * c, sign * s);
    let (nx, ny) = (-s, c);
    let half_l = 0.5 * robot.length;
    let half_w = 0.5 * robot.width;
    let step = 0.5 * field.geometry().resolution();
    let blocked = |d: f64| {
        let bx = pose[0] + hx * (half_l + d);
        let by = pose[1] + hy * (half_l + d);
        [0.0, -half_w, half_w]
            .iter()
            .any(|&o| field.sample([bx + nx * o, by + ny * o]).0 < stand_off)
    };
    let mut d = 0.0;
    while d < limit {
        if blocked(d) {
            return d;
        }
        d += step;
    }
    limit
}

/// The command `[v, w]` with `v` capped as in the module docs; `speed` is the robot's forward
/// speed now (m/s, odometry), `dt` the control period (s).
pub fn govern(
    params: &GovernorParams,
    robot: &RobotParams,
    field: &DistanceField,
    pose: [f64; 3],
    speed: f64,
    dt: f64,
    command: [f64; 2],
) -> [f64; 2] {
    let v = command[0];
    if !params.enabled || v == 0.0 {
        return command;
    }
    let sign = v.signum();
    let reaction = speed.abs() * dt;
    // Farther than this, even full speed can still stop.
    let limit = robot.v_max * robot.v_max / (2.0 * params.decel) + reaction + 0.1;
    let free = free_travel(field, robot, pose, sign, params.stand_off, limit);
    let cap = (2.0 * params.decel * (free - reaction).max(0.0)).sqrt();
    [sign * v.abs().min(cap), command[1]]
}

#[cfg(test)]
mod tests {
    use super::*;
    use subgoal_infer::grid::{Costmap, GridGeometry, LETHAL};

    /// A wall across x = 3 (a column of lethal cells), the robot at the origin.
    fn wall_field() -> DistanceField {
        let g = GridGeometry::centered([0.0, 0.0], 200, 200, 0.05).unwrap();
        let mut m = Costmap::new(g);
        for k in 0..60 {
            m.mark([3.0, -1.5 + 0.05 * k as f64], LETHAL);
        }
        let mut f = DistanceField::new(g);
        f.compute(&m, LETHAL).unwrap();
        f
    }

    #[test]
    fn free_travel_reaches_the_wall_minus_the_half_length() {
        let f = wall_field();
        let r = RobotParams::default();
        // The wall's cell centre lies within half a cell of x = 3; the bumper (0.4 m ahead) stops
        // stand_off before it.
        let d = free_travel(&f, &r, [0.0, 0.0, 0.0], 1.0, 0.1, 10.0);
        let want = 3.0 - 0.4 - 0.1;
        assert!((d - want).abs() <= 0.06, "{d} vs {want}");
        // Backwards nothing is in the way up to the limit.
        assert_eq!(free_travel(&f, &r, [0.0, 0.0, 0.0], -1.0, 0.1, 2.0), 2.0);
        // Facing away, forward is free too; driving parallel to the wall is free.
        assert_eq!(
            free_travel(&f, &r, [0.0, 0.0, std::f64::consts::PI], 1.0, 0.1, 2.0),
            2.0
        );
        assert_eq!(
            free_travel(&f, &r, [2.0, -2.0, std::f64::consts::FRAC_PI_2], 1.0, 0.1, 2.0),
            2.0
        );
    }

    #[test]
    fn the_cap_is_the_braking_curve_and_only_lowers_the_speed() {
        let f = wall_field();
        let r = RobotParams::default();
        let p = GovernorParams::default();
        // Far away: the command passes unchanged.
        assert_eq!(govern(&p, &r, &f, [-5.0, 0.0, 0.0], 1.5, 0.1, [1.5, 0.3]), [1.5, 0.3]);
        // 1 m of free travel at rest: sqrt(2 * 0.9 * free).
        let pose = [3.0 - 0.4 - 0.1 - 1.0, 0.0, 0.0];
        let free = free_travel(&f, &r, pose, 1.0, p.stand_off, 10.0);
        let u = govern(&p, &r, &f, pose, 0.0, 0.1, [1.5, -0.2]);
        assert!((u[0] - (1.8 * free).sqrt()).abs() < 1e-12 && u[1] == -0.2, "{u:?}");
        // Moving at 1 m/s, the reaction step's 0.1 m comes off first.
        let u = govern(&p, &r, &f, pose, 1.0, 0.1, [1.5, 0.0]);
        assert!((u[0] - (1.8 * (free - 0.1)).sqrt()).abs() < 1e-12, "{u:?}");
        // A slower command than the cap passes; reversing away from the wall is free.
        assert_eq!(govern(&p, &r, &f, pose, 0.0, 0.1, [0.2, 0.0]), [0.2, 0.0]);
        assert_eq!(govern(&p, &r, &f, pose, 0.0, 0.1, [-0.5, 0.1]), [-0.5, 0.1]);
        // At the wall: forward is stopped, the sign never flips.
        let u = govern(&p, &r, &f, [2.5, 0.0, 0.0], 0.5, 0.1, [1.0, 0.0]);
        assert_eq!(u, [0.0, 0.0]);
        // Disabled: untouched.
        let off = GovernorParams { enabled: false, ..p };
        assert_eq!(govern(&off, &r, &f, [2.5, 0.0, 0.0], 0.5, 0.1, [1.0, 0.0]), [1.0, 0.0]);
    }

    #[test]
    fn bad_params_name_the_field() {
        let e = GovernorParams {
            decel: 0.0,
            ..GovernorParams::default()
        }
        .validate()
        .unwrap_err();
        assert!(e.to_string().starts_with("governor.decel"), "{e}");
        let e = GovernorParams {
            stand_off: -1.0,
            ..GovernorParams::default()
        }
        .validate()
        .unwrap_err();
        assert!(e.to_string().starts_with("governor.stand_off"), "{e}");
    }
}
