//! Planners in the loop. A [`Planner`] gets the robot state, the local goal and the perception
//! every cycle and returns a [`Plan`]; the executor applies its controls at 10 Hz.
//!
//! [`DdpPlanner`] is DDPEN's vanilla DDP (§II-A, §II-F): the unicycle, the cost of eqs. (3)-(7)
//!
//! ```text
//! l(x, u) = w_c sum u^2 + w_g sqrt(|p - x_goal|^2 + eps^2) + w_o ReLU(d - dist(p))     (3), (5), (6), (7)
//! l_f(x)  = w_gN sqrt(|p - x_goal|^2 + eps^2) + w_o ReLU(d - dist(p))                  (4)
//! ```
//!
//! with `dist` the lidar costmap's distance field, box limits on `(v, w)`, and `epochs`
//! optimisation epochs per cycle (one DDP iteration each: derivatives, backward pass, line
//! search). Each cycle warm-starts from the previous solution shifted by the control steps
//! executed since, the last control repeated (Fig. 6). Optional sub-goal terms
//! `w_s sqrt(|p - x_s|^2 + eps^2)` (eqs. 8-9, [`DdpPlanner::set_subgoals`]) are there for DDPEN.
//!
//! Defaults ([`DdpParams::default`]; the paper gives none of these numbers but the limits):
//!
//! | symbol | field | default | why |
//! |---|---|---|---|
//! | `N`, `dt` | `horizon`, `dt` | 50, 0.1 s | 5 s: reaches the costmap border (5-7 m) at 1.5 m/s |
//! | epochs | `epochs` | 4 | paper §II-F |
//! | `w_c` | `w_control` | 0.1 | small: the robot drives at its speed limit in free space |
//! | `w_g`, `w_gN` | `w_goal`, `w_goal_terminal` | 1, 5 | |
//! | `w_o`, `d` | `w_obstacle`, `margin` | 10, 0.9 m | `w_o > w_g` stops a knot at distance `d`; `d` = circumscribed radius 0.5 m + 0.4 m |
//! | `v`, `w` bounds | `v_min`, `v_max`, `w_max` | [0, 1.5] m/s, 0.5 rad/s | paper §III; no reversing (a DDP allowed to reverse may settle into driving backwards) |
//! | method | `full_ddp` | full DDP | second-order unicycle terms |
//!
//! The linear hinge of eq. (7) pulls a knot out of the margin with the constant force `w_o`,
//! however deep it is; a plan that cuts through an obstacle's corner saves goal cost at every
//! later knot (up to `(w_g + 3 w_s) N` in all), so warm-started plans can run the footprint into
//! a corner and keep pushing against it. A stiff quadratic wall near the footprint,
//! `w_b ReLU(d_b - dist(p))^2` with `d_b` = circumscribed radius + 0.15 m, is added to the running
//! and terminal costs (`w_contact = 0` gives the paper's cost alone).
//!
//! [`AstarDdpPlanner`] is the same optimiser whose initial guess each cycle is a pure-pursuit
//! rollout along the A* path from the robot to the local goal on the inflated costmap.
//!
//! DDPEN (`ddpen`, `ddpen-oracle`, in [`crate::ddpen`]) builds on this optimiser with the
//! sub-goal terms and its own parameters; [`crate::registry`] finds every planner by name. This
//! module knows nothing of either.

use ddp_core::dims::{U2, U3};
use std::sync::Arc;
use std::time::Instant;

use ddp_core::costs::{ControlSquared, CostSum, SmoothDistance, StateOnly, TerminalSum};
use ddp_core::models::Unicycle;
use ddp_core::{ControlBounds, Dynamics, Method, Problem, Settings, Solver, Status, Vector};
use subgoal_infer::grid::{nearest_free, AStar, AStarParams};
use subgoal_infer::DistanceFieldHinge;

use crate::error::{nonnegative, positive, Error, Result};
use crate::perception::Perception;

/// The planner's optimisation problem (defaults: the table in the module docs).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DdpParams {
    /// Horizon `N` (knots).
    pub horizon: usize,
    /// Model time step (s); the executor's control period.
    pub dt: f64,
    /// Optimisation epochs per cycle (paper: 4).
    pub epochs: usize,
    /// `w_c`, control cost (eq. 5).
    pub w_control: f64,
    /// `w_g`, running goal distance (eq. 6).
    pub w_goal: f64,
    /// `w_gN`, terminal goal distance (eq. 4).
    pub w_goal_terminal: f64,
    /// `w_o`, obstacle hinge (eq. 7).
    pub w_obstacle: f64,
    /// `d`, the distance below which the hinge acts (m).
    pub margin: f64,
    /// `w_b`, the quadratic contact wall (not in the paper; 0 switches it off).
    pub w_contact: f64,
    /// `d_b`, the distance below which the contact wall acts (m).
    pub contact_margin: f64,
    /// `eps` of the smooth distances (m).
    pub eps: f64,
    /// Lower speed bound of the plan (m/s; negative allows reversing).
    pub v_min: f64,
    /// Upper speed bound (m/s).
    pub v_max: f64,
    /// Turn-rate bound `|w| <= w_max` (rad/s).
    pub w_max: f64,
    /// Full DDP (second-order dynamics) rather than iLQR.
    pub full_ddp: bool,
}

impl Default for DdpParams {
    fn default() -> Self {
        Self {
            horizon: 50,
            dt: 0.1,
            epochs: 4,
            w_control: 0.1,
            w_goal: 1.0,
            w_goal_terminal: 5.0,
            w_obstacle: 10.0,
            margin: 0.9,
            w_contact: 1000.0,
            contact_margin: 0.65,
            eps: 0.05,
            v_min: 0.0,
            v_max: 1.5,
            w_max: 0.5,
            full_ddp: true,
        }
    }
}

impl DdpParams {
    /// Rejects impossible values, naming the field (`ddp.<name>`).
    pub fn validate(&self) -> Result<()> {
        if self.horizon == 0 {
            return Err(Error::invalid("ddp.horizon", "must be at least 1"));
        }
        if self.epochs == 0 {
            return Err(Error::invalid("ddp.epochs", "must be at least 1"));
        }
        positive("ddp.dt", self.dt)?;
        positive("ddp.eps", self.eps)?;
        for (n, v) in [
            ("w_control", self.w_control),
            ("w_goal", self.w_goal),
            ("w_goal_terminal", self.w_goal_terminal),
            ("w_obstacle", self.w_obstacle),
            ("margin", self.margin),
            ("w_contact", self.w_contact),
            ("contact_margin", self.contact_margin),
            ("w_max", self.w_max),
        ] {
            nonnegative(&format!("ddp.{n}"), v)?;
        }
        if !(self.v_min.is_finite() && self.v_max.is_finite() && self.v_min <= self.v_max) {
            return Err(Error::invalid(
                "ddp.v_min",
                format!("must be finite and <= ddp.v_max = {}, got {}", self.v_max, self.v_min),
            ));
        }
        Ok(())
    }
}

/// How far past the robot's progress along the route [`PlanRequest::far_goal`] lies (m): well
/// beyond the 5 m half-width of the costmap.
pub const FAR_AHEAD: f64 = 15.0;

/// What a planner sees each cycle.
pub struct PlanRequest<'a> {
    /// Simulated time (s).
    pub time: f64,
    /// Measured robot state `[x, y, theta]`.
    pub state: [f64; 3],
    /// The local goal `x_goal`.
    pub goal: [f64; 2],
    /// Where the route leads beyond the costmap: the route point [`FAR_AHEAD`] m past the
    /// robot's progress, or the route's end (DDPEN chooses its way round obstacles towards it).
    pub far_goal: [f64; 2],
    /// The lidar costmap and distance field.
    pub perception: &'a Perception,
    /// Control steps executed since the previous plan (0 for the first plan).
    pub steps_since_last: usize,
}

/// A planner's answer.
#[derive(Debug, Clone, Default)]
pub struct Plan {
    /// Planned states `x_0 .. x_N` (`[x, y, theta]`).
    pub states: Vec<[f64; 3]>,
    /// Planned controls `u_0 .. u_{N-1}` (`[v, w]`).
    pub controls: Vec<[f64; 2]>,
    /// Compute time of each optimisation epoch of this cycle (s).
    pub epoch_seconds: Vec<f64>,
    /// Compute time of this cycle outside the epochs: problem set-up, initial guess, sub-goals (s).
    pub setup_seconds: f64,
    /// Of `setup_seconds`, the time spent computing sub-goals (A* or network; DDPEN only; 0 in
    /// cycles that reuse the previous sub-goals).
    pub subgoal_seconds: f64,
    /// Cost after the last epoch.
    pub cost: f64,
    /// Status of the last epoch's solve.
    pub status: Option<Status>,
    /// Points that guided the plan (A* path, sub-goals), for logs and figures.
    pub guide: Vec<[f64; 2]>,
}

/// A planner in the loop (see the module docs).
pub trait Planner: Send {
    /// Short name (`"ddp"`, `"ddp-astar"`).
    fn name(&self) -> &str;
    /// Plans from the request; the returned plan lives until the next call.
    fn plan(&mut self, request: &PlanRequest<'_>) -> Result<&Plan>;
}

/// Vanilla DDP in the loop (see the module docs). The solver workspace is allocated once.
pub struct DdpPlanner {
    params: DdpParams,
    dynamics: Arc<Unicycle>,
    bounds: ControlBounds<U2>,
    solver: Solver<U3, U2>,
    settings: Settings,
    subgoals: Vec<[f64; 2]>,
    /// `w_s` of each sub-goal term.
    w_subgoal: f64,
    started: bool,
    plan: Plan,
}

impl DdpPlanner {
    /// Validates `params` and allocates the solver workspace.
    pub fn new(params: DdpParams) -> Result<Self> {
        params.validate()?;
        let dynamics = Arc::new(Unicycle::new(params.dt)?);
        let bounds = ControlBounds::new(
            Vector::<2>::new(params.v_min, -params.w_max),
            Vector::<2>::new(params.v_max, params.w_max),
        )?;
        let settings = Settings {
            method: if params.full_ddp { Method::Ddp } else { Method::Ilqr },
            max_iterations: 1,
            ..Settings::default()
        };
        let dummy = Problem::new(
            Vector::<3>::zeros(),
            dynamics.clone(),
            Arc::new(ControlSquared::new(1.0)?),
            Arc::new(ddp_core::costs::NoTerminalCost),
            params.horizon,
        )?;
        let solver = Solver::new(&dummy, settings)?;
        Ok(Self {
            params,
            dynamics,
            bounds,
            solver,
            settings,
            subgoals: Vec::new(),
            w_subgoal: 0.0,
            started: false,
            plan: Plan {
                states: Vec::with_capacity(params.horizon + 1),
                controls: Vec::with_capacity(params.horizon),
                epoch_seconds: Vec::with_capacity(params.epochs),
                ..Plan::default()
            },
        })
    }

    /// The parameters.
    pub fn params(&self) -> &DdpParams {
        &self.params
    }

    /// Restricts the speed of the next plans to `[v_min, v_max]` of the parameters intersected
    /// with `[lo, hi]` (`None`: the parameters' bounds).
    pub(crate) fn restrict_speed(&mut self, range: Option<(f64, f64)>) {
        let (lo, hi) = range.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
        let lo = lo.max(self.params.v_min).min(self.params.v_max);
        let hi = hi.min(self.params.v_max).max(lo);
        self.bounds.lower[0] = lo;
        self.bounds.upper[0] = hi;
    }

    /// The last plan, for wrappers that add to its timings.
    pub(crate) fn plan_mut(&mut self) -> &mut Plan {
        &mut self.plan
    }

    /// Sub-goals `x_s` for the next plans (eqs. 8-9), each weighted by `w_s = weight`; empty for
    /// vanilla DDP.
    pub fn set_subgoals(&mut self, subgoals: &[[f64; 2]], weight: f64) -> Result<()> {
        for (i, s) in subgoals.iter().enumerate() {
            crate::error::finite_each(&format!("subgoals[{i}]"), *s)?;
        }
        self.w_subgoal = nonnegative("w_subgoal", weight)?;
        self.subgoals.clear();
        self.subgoals.extend_from_slice(subgoals);
        Ok(())
    }

    /// Sets the initial guess of the next plan (`N` controls), replacing the shifted warm start.
    pub fn set_initial_guess(&mut self, controls: &[Vector<2>]) -> Result<()> {
        self.solver.set_controls(controls)?;
        self.started = true;
        Ok(())
    }

    /// Warm start (Fig. 6): drop the executed knots, repeating the last control.
    pub(crate) fn warm_start(&mut self, steps: usize) {
        if !self.started {
            self.solver.reset();
            self.started = true;
            return;
        }
        for _ in 0..steps.min(self.params.horizon) {
            self.solver.shift();
        }
    }

    fn build_problem(&self, request: &PlanRequest<'_>) -> Result<Problem<U3, U2>> {
        let p = &self.params;
        let goal = SmoothDistance::<3>::goal(request.goal, [0, 1], p.eps, 1.0)?;
        let hinge = DistanceFieldHinge::<3>::new(request.perception.field().clone(), p.margin, [0, 1], 1.0)?;
        let mut running = CostSum::<U3, U2>::new()
            .with(p.w_control, Arc::new(ControlSquared::new(1.0)?))
            .with(p.w_goal, Arc::new(StateOnly(goal)))
            .with(p.w_obstacle, Arc::new(StateOnly(hinge.clone())));
        let wall = (p.w_contact > 0.0)
            .then(|| {
                DistanceFieldHinge::<3>::squared(request.perception.field().clone(), p.contact_margin, [0, 1], 1.0)
            })
            .transpose()?;
        if let Some(wall) = &wall {
            running.push(p.w_contact, Arc::new(StateOnly(wall.clone())))?;
        }
        for s in &self.subgoals {
            running.push(
                self.w_subgoal,
                Arc::new(StateOnly(SmoothDistance::<3>::sub_goal(*s, [0, 1], p.eps, 1.0)?)),
            )?;
        }
        let mut terminal = TerminalSum::<U3>::new()
            .with(p.w_goal_terminal, Arc::new(goal))
            .with(p.w_obstacle, Arc::new(hinge));
        if let Some(wall) = wall {
            terminal.push(p.w_contact, Arc::new(wall))?;
        }
        let x0 = Vector::<3>::new(request.state[0], request.state[1], request.state[2]);
        Ok(Problem::new(
            x0,
            self.dynamics.clone() as Arc<dyn Dynamics<U3, U2>>,
            Arc::new(running),
            Arc::new(terminal),
            p.horizon,
        )?
        .with_control_bounds(self.bounds.clone())?)
    }

    /// One cycle from the current initial guess: `epochs` solves of one iteration each.
    pub(crate) fn optimise(&mut self, request: &PlanRequest<'_>, setup_start: Instant) -> Result<&Plan> {
        let problem = self.build_problem(request)?;
        self.plan.setup_seconds += setup_start.elapsed().as_secs_f64();
        self.plan.epoch_seconds.clear();
        let mut settings = self.settings;
        for _ in 0..self.params.epochs {
            let t = Instant::now();
            self.solver.set_settings(settings)?;
            let report = self.solver.solve(&problem)?;
            // Carry the regularisation across epochs, as one solve would.
            settings.regularization.mu_init = report.mu;
            self.plan.cost = report.cost;
            self.plan.status = Some(report.status);
            self.plan.epoch_seconds.push(t.elapsed().as_secs_f64());
        }
        drop(problem);
        self.plan.states.clear();
        self.plan
            .states
            .extend(self.solver.xs().iter().map(|x| [x[0], x[1], x[2]]));
        self.plan.controls.clear();
        self.plan.controls.extend(self.solver.us().iter().map(|u| [u[0], u[1]]));
        Ok(&self.plan)
    }
}

impl Planner for DdpPlanner {
    fn name(&self) -> &str {
        "ddp"
    }

    fn plan(&mut self, request: &PlanRequest<'_>) -> Result<&Plan> {
        let t = Instant::now();
        self.plan.setup_seconds = 0.0;
        self.warm_start(request.steps_since_last);
        self.plan.guide.clear();
        self.plan.guide.extend_from_slice(&self.subgoals);
        self.optimise(request, t)
    }
}

/// DDP whose initial guess each cycle follows the A* path to the local goal (see the module
/// docs). Falls back to the shifted warm start when A* finds no path.
pub struct AstarDdpPlanner {
    ddp: DdpPlanner,
    astar: Option<AStar>,
    params: AStarParams,
    cells: Vec<(usize, usize)>,
    path: Vec<[f64; 2]>,
    guess: Vec<Vector<2>>,
    /// Pure-pursuit look-ahead (m).
    lookahead: f64,
}

impl AstarDdpPlanner {
    /// Validates `params`; the A* workspace is allocated on the first plan (it needs the
    /// costmap size).
    pub fn new(params: DdpParams) -> Result<Self> {
        Ok(Self {
            ddp: DdpPlanner::new(params)?,
            astar: None,
            params: AStarParams::default(),
            cells: Vec::new(),
            path: Vec::new(),
            guess: vec![Vector::<2>::zeros(); params.horizon],
            lookahead: 1.0,
        })
    }

    /// A* from the robot to the goal on the inflated costmap, into `self.path`; `false` if none.
    fn search(&mut self, request: &PlanRequest<'_>) -> bool {
        let map = request.perception.costmap();
        let g = map.geometry();
        let astar = self.astar.get_or_insert_with(|| AStar::new(g));
        let start = g.world_to_cell_clamped([request.state[0], request.state[1]]);
        let goal = g.world_to_cell_clamped(request.goal);
        let Some(goal) = nearest_free(map, goal, self.params.blocked, 40) else {
            return false;
        };
        if astar.search(map, start, goal, &self.params, &mut self.cells).is_none() {
            return false;
        }
        self.path.clear();
        self.path.extend(self.cells.iter().map(|&(x, y)| g.cell_to_world(x, y)));
        true
    }

    /// Pure-pursuit rollout of the unicycle along `self.path` into `self.guess`.
    fn guess_from_path(&mut self, state: [f64; 3]) {
        pursuit_guess(
            &self.ddp.params,
            state,
            &self.path,
            self.lookahead,
            false,
            &mut self.guess,
        );
    }
}

/// Pure-pursuit rollout of the unicycle from `state` along the polyline `path` (look-ahead
/// `lookahead` m) into `guess` (one control per knot): it turns in place while the look-ahead
/// point is more than 90 degrees off the heading. With `reverse` it backs along the path instead
/// (the tail leads, at most `-v_min`), turning in place while the point is more than 90 degrees
/// off the tail's direction.
pub(crate) fn pursuit_guess(
    p: &DdpParams,
    state: [f64; 3],
    path: &[[f64; 2]],
    lookahead: f64,
    reverse: bool,
    guess: &mut [Vector<2>],
) {
    let model = Unicycle::new(p.dt).expect("validated dt");
    let mut x = Vector::<3>::new(state[0], state[1], state[2]);
    let mut nearest = 0;
    if path.is_empty() {
        guess.fill(Vector::<2>::zeros());
        return;
    }
    for u in guess.iter_mut() {
        // Advance the nearest path index, then look ahead along the path.
        while nearest + 1 < path.len() && dist2(path[nearest + 1], [x[0], x[1]]) <= dist2(path[nearest], [x[0], x[1]]) {
            nearest += 1;
        }
        let mut target = nearest;
        while target + 1 < path.len() && dist2(path[target], [x[0], x[1]]).sqrt() < lookahead {
            target += 1;
        }
        let q = path[target];
        let (dx, dy) = (q[0] - x[0], q[1] - x[1]);
        let remaining = dx.hypot(dy);
        let facing = if reverse { x[2] + std::f64::consts::PI } else { x[2] };
        let alpha = wrap(dy.atan2(dx) - facing);
        let w = (2.0 * alpha).clamp(-p.w_max, p.w_max);
        let at_end = target + 1 == path.len();
        let top = if reverse { (-p.v_min).max(0.0) } else { p.v_max };
        let mut v = top * alpha.cos().max(0.0);
        if at_end {
            v = v.min(remaining / p.dt);
        }
        let v = if reverse {
            -v.clamp(0.0, top)
        } else {
            v.clamp(p.v_min.max(0.0), p.v_max)
        };
        *u = Vector::<2>::new(v, w);
        x = model.step(&x, u);
    }
}

fn dist2(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}

fn wrap(a: f64) -> f64 {
    (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
}

impl Planner for AstarDdpPlanner {
    fn name(&self) -> &str {
        "ddp-astar"
    }

    fn plan(&mut self, request: &PlanRequest<'_>) -> Result<&Plan> {
        let t = Instant::now();
        self.ddp.plan.setup_seconds = 0.0;
        let found = self.search(request);
        if found {
            self.guess_from_path(request.state);
            self.ddp.set_initial_guess(&self.guess)?;
        } else {
            self.ddp.warm_start(request.steps_since_last);
        }
        self.ddp.plan.guide.clear();
        if found {
            // A few points of the path for logs and figures.
            let stride = (self.path.len() / 20).max(1);
            self.ddp.plan.guide.extend(self.path.iter().step_by(stride).copied());
        }
        self.ddp.optimise(request, t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::perception::PerceptionParams;

    #[test]
    fn ddp_moves_towards_the_goal_within_limits() {
        let perception = Perception::new(PerceptionParams::default()).unwrap();
        let mut planner = DdpPlanner::new(DdpParams::default()).unwrap();
        let mut last_cost = f64::INFINITY;
        for cycle in 0..3 {
            let req = PlanRequest {
                time: 0.0,
                state: [0.0, 0.0, 0.0],
                goal: [5.0, 0.0],
                far_goal: [15.0, 0.0],
                perception: &perception,
                // Nothing executed between cycles: each cycle continues the optimisation.
                steps_since_last: 0,
            };
            let plan = planner.plan(&req).unwrap();
            assert_eq!(plan.controls.len(), 50);
            assert_eq!(plan.states.len(), 51);
            assert_eq!(plan.epoch_seconds.len(), 4);
            for u in &plan.controls {
                assert!(u[0] <= 1.5 + 1e-12 && u[0] >= -1e-12 && u[1].abs() <= 0.5 + 1e-12);
            }
            assert!(plan.controls[0][0] > 1.0, "{:?}", plan.controls[0]);
            assert!(plan.cost <= last_cost + 1e-9 || cycle == 0);
            last_cost = plan.cost;
        }
    }

    #[test]
    fn bad_parameters_are_named() {
        let e = DdpParams {
            horizon: 0,
            ..DdpParams::default()
        };
        assert!(e.validate().unwrap_err().to_string().starts_with("ddp.horizon"));
    }
}
