//! DDPEN (§II-B, §II-C): sub-goals `x_s` pull the DDP trajectory out of local minima through the
//! sub-goal cost of eqs. (8)-(9),
//!
//! ```text
//! l(x, u) = c_c(u) + c_g(x, x_goal) + c_o(x, obs) + sum_k w_s c_s(x, x_s^k),   c_s = sqrt(|p - x_s|^2 + eps^2)   (8), (9)
//! ```
//!
//! added to every running knot of [`crate::planner::DdpPlanner`]'s problem. Where the sub-goals
//! come from is a [`SubgoalSource`]:
//!
//! | source | planner | sub-goals |
//! |---|---|---|
//! | [`AstarSubgoals`] | `ddpen-oracle` | path steps 30, 50, 70 of a cost-aware 8-connected A* from the robot to the local goal on the current costmap (the labels the network imitates, §II-D) |
//! | [`NetworkSubgoals`] | `ddpen` | the sub-goal network `SG_theta(map, x_goal)` of eq. (10) ([`subgoal_infer::SubgoalModel`]) |
//!
//! The costmap is world-aligned (its axes are the world's, not the robot's) and centred on the
//! robot up to one cell (a rolling window on the world lattice). The network works in *map
//! coordinates*: metres relative to the map centre, in map axes. [`MapFrame`] converts.
//!
//! [`DdpenPlanner`] asks its source every `subgoal_every` cycles (the cadence of inference) and
//! keeps the sub-goals in between; their compute time is part of the cycle's set-up time.
//!
//! DDPEN's own parameters ([`DdpenParams`], besides the optimiser's
//! [`DdpParams`](crate::planner::DdpParams); the paper gives none of these numbers):
//!
//! | symbol | field | default | why |
//! |---|---|---|---|
//! | `w_s` | `w_subgoal` | 2 per sub-goal | with 1, the goal terms towards an exit behind a wall can balance the sub-goals and hold the robot in a pocket |
//! | | `subgoal_every` | 1 | new sub-goals every planning cycle |
//! | `v` lower bound | `v_min` | -0.5 m/s | replaces the optimiser's `v_min`: DDPEN may back out of a pocket |
//! | | `model` | `None` | the shipped weights |
//!
//! What goal the sources (and the DDP's goal terms) aim for is ours, not the paper's: the paper's
//! local goal, where the route crosses the costmap border (§II-E), sits in the pocket of a trap on
//! the route, or inside or behind its back wall, and sub-goals towards it lead back into the dead
//! end. [`DdpenPlanner`] aims instead for an *exit* ([`GoalRepair::best_exit`]): the reachable
//! cell of the map's border on the best straight-line way to the route further on
//! ([`crate::planner::PlanRequest::far_goal`]). In free space that is the paper's local goal. The
//! exit in force is preferred while it stays reachable (hysteresis), an exit that turns out to be a
//! dead end is remembered in the world frame and avoided, and the oracle keeps its A* path unless a
//! new one is clearly cheaper ([`PATH_HYSTERESIS`]). All of this uses a flood fill of the costmap
//! (reachability), never the network's own path.
//!
//! A recovery behaviour, also ours: a robot that has stayed within [`STUCK_RADIUS`] for
//! [`STUCK_TIME`] (sub-goals that lead into a slot too narrow to turn in, or that keep changing
//! sides) backs out along its own trail for [`BACKUP_DISTANCE`], the way it came, so free of
//! obstacles, and the exit it was heading for counts as a dead end. For [`KEEPOUT_TIME`] the spot
//! is a lethal disc of radius [`KEEPOUT_RADIUS`] on the costmap the sub-goal source and the exit
//! search see, so that the network does not lead the robot straight back in.
//!
//! ```
//! use sim2d::ddpen::MapFrame;
//! use subgoal_infer::grid::GridGeometry;
//! let g = GridGeometry::ddpen([10.02, -3.0]);
//! let frame = MapFrame::of(&g);
//! let q = frame.to_map([12.0, -3.5]);
//! assert_eq!(frame.to_world(q), [12.0, -3.5]);
//! ```

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Instant;

use subgoal_infer::grid::{path_cost, AStar, AStarParams, Costmap, GridGeometry, LETHAL};
use subgoal_infer::SubgoalModel;

use crate::error::{nonnegative, Error, Result};
use crate::planner::{pursuit_guess, DdpParams, DdpPlanner, Plan, PlanRequest, Planner};
use crate::route::dist;
use ddp_core::Vector;

/// Path steps of the A* oracle's sub-goals (§II-D: 30, 50 and 70).
pub const ORACLE_STEPS: [usize; 3] = [30, 50, 70];

/// DDPEN's parameters beyond the optimiser's [`DdpParams`] (defaults: the table in the module
/// docs).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DdpenParams {
    /// `w_s`, sub-goal distance (eq. 9), per sub-goal.
    pub w_subgoal: f64,
    /// Ask for new sub-goals every this many planning cycles (the cadence of inference).
    pub subgoal_every: usize,
    /// Lower speed bound of DDPEN's plans (m/s; replaces [`DdpParams::v_min`]). Negative lets the
    /// robot back out towards sub-goals behind it: with `v >= 0`, standing still is a stationary
    /// point of the cost in the turn rate, and a turn towards a sub-goal behind takes longer than
    /// the horizon before it pays.
    pub v_min: f64,
    /// The sub-goal model's weights (`None`: the shipped default).
    pub model: Option<PathBuf>,
}

impl Default for DdpenParams {
    fn default() -> Self {
        Self {
            w_subgoal: 2.0,
            subgoal_every: 1,
            v_min: -0.5,
            model: None,
        }
    }
}

impl DdpenParams {
    /// Rejects impossible values, naming the field (`ddpen.<name>`); `v_min` must not exceed the
    /// optimiser's `v_max`.
    pub fn validate(&self, ddp: &DdpParams) -> Result<()> {
        if self.subgoal_every == 0 {
            return Err(Error::invalid("ddpen.subgoal_every", "must be at least 1"));
        }
        nonnegative("ddpen.w_subgoal", self.w_subgoal)?;
        if !(self.v_min.is_finite() && self.v_min <= ddp.v_max) {
            return Err(Error::invalid(
                "ddpen.v_min",
                format!("must be finite and <= ddp.v_max = {}, got {}", ddp.v_max, self.v_min),
            ));
        }
        Ok(())
    }
}

/// World <-> map coordinates of a costmap: map coordinates are metres relative to the map's
/// centre ([`GridGeometry::center`]), in map axes (`x` along the columns `ix`, `y` along the rows
/// `iy`; the same as the world's axes, since the costmap is world-aligned).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapFrame {
    center: [f64; 2],
}

impl MapFrame {
    /// The frame of a costmap with this geometry.
    pub fn of(geometry: &GridGeometry) -> Self {
        Self {
            center: geometry.center(),
        }
    }

    /// World position of the map centre.
    pub fn center(&self) -> [f64; 2] {
        self.center
    }

    /// Map coordinates of world point `p` (what the network takes).
    pub fn to_map(&self, p: [f64; 2]) -> [f32; 2] {
        [(p[0] - self.center[0]) as f32, (p[1] - self.center[1]) as f32]
    }

    /// World point of map coordinates `q` (what the network returns).
    pub fn to_world(&self, q: [f32; 2]) -> [f64; 2] {
        [self.center[0] + q[0] as f64, self.center[1] + q[1] as f64]
    }
}

/// Width of the border band in which a blocked local goal is moved (cells): the dataset's goals
/// lie within 0.5 m of the border.
pub const GOAL_BAND_CELLS: usize = 10;

/// Reachability on the costmap, for the goal the sub-goal sources see. A goal may fall inside an
/// obstacle, or in a region the robot cannot reach, where A* has no path and the network has
/// never seen a goal (its dataset's goals are reachable free cells near the border); exits are
/// chosen among reachable border cells ([`GoalRepair::best_exit`]). [`GoalRepair::repair`] floods
/// the map from the robot, keeps a reachable free goal and otherwise moves
/// it to the nearest cell that the robot can reach (a flood fill through cells cheaper than
/// `blocked`) within [`GOAL_BAND_CELLS`] of the border when the goal is in that band (so that the
/// path leads round the obstacle rather than into a pocket in front of it), or anywhere when the
/// goal lies further inside (the route's end). Buffers are allocated on the first call.
#[derive(Debug, Clone, Default)]
pub struct GoalRepair {
    reached: Vec<bool>,
    queue: std::collections::VecDeque<(usize, usize)>,
}

impl GoalRepair {
    /// The cell to aim for from `start` towards `goal` on `map` (see the type's docs); `None`
    /// when the robot can reach no other cell.
    pub fn repair(&mut self, map: &Costmap, start: [f64; 2], goal: [f64; 2], blocked: u8) -> Option<(usize, usize)> {
        let g = map.geometry();
        let (w, h) = (g.width(), g.height());
        let s = g.world_to_cell_clamped(start);
        let cell = g.world_to_cell_clamped(goal);
        self.reached.clear();
        self.reached.resize(w * h, false);
        self.queue.clear();
        self.reached[s.1 * w + s.0] = true;
        self.queue.push_back(s);
        while let Some((x, y)) = self.queue.pop_front() {
            for (dx, dy) in [
                (1i64, 0i64),
                (-1, 0),
                (0, 1),
                (0, -1),
                (1, 1),
                (1, -1),
                (-1, 1),
                (-1, -1),
            ] {
                let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                    continue;
                }
                let (nx, ny) = (nx as usize, ny as usize);
                let i = ny * w + nx;
                if !self.reached[i] && map.get(nx, ny) < blocked {
                    self.reached[i] = true;
                    self.queue.push_back((nx, ny));
                }
            }
        }
        if self.reached[cell.1 * w + cell.0] && cell != s {
            return Some(cell);
        }
        let edge = |c: (usize, usize)| c.0.min(c.1).min(w - 1 - c.0).min(h - 1 - c.1);
        let in_band = edge(cell) < GOAL_BAND_CELLS;
        let mut best: Option<((usize, usize), usize)> = None;
        for iy in 0..h {
            for ix in 0..w {
                if !self.reached[iy * w + ix] || (ix, iy) == s || (in_band && edge((ix, iy)) >= GOAL_BAND_CELLS) {
                    continue;
                }
                let d2 = ix.abs_diff(cell.0).pow(2) + iy.abs_diff(cell.1).pow(2);
                if best.is_none_or(|(_, b)| d2 < b) {
                    best = Some(((ix, iy), d2));
                }
            }
        }
        best.map(|(c, _)| c)
    }

    /// After [`GoalRepair::repair`] on the same map and start: the *exit*, the reachable cell on
    /// the costmap's outermost [`EXIT_CELLS`] rings that minimises the straight-line estimate
    /// `|c - start| + |c - far|` of a way from `start` to the far goal `far` through it (the
    /// unknown space beyond the map counts as free), less [`EXIT_STICKINESS`] m for cells within
    /// 1.5 m of the previous exit `previous` (hysteresis: the exit does not flip between two ways
    /// round an obstacle as the map changes). A dead end inside the map has no exit cells, so it
    /// is never chosen, whatever its straight-line appeal. `None` when no exit is reachable.
    /// Cells within [`DEAD_END_RADIUS`] of a point of `dead` (exits found to be dead ends) are
    /// passed over while any other exit is reachable.
    pub fn best_exit(
        &self,
        map: &Costmap,
        start: [f64; 2],
        far: [f64; 2],
        previous: Option<[f64; 2]>,
        dead: &[[f64; 2]],
    ) -> Option<(usize, usize)> {
        let g = map.geometry();
        let (w, h) = (g.width(), g.height());
        if self.reached.len() != w * h {
            return None;
        }
        // (cell, whether it is near a dead end, score): live exits first, then the lower score.
        let mut best: Option<((usize, usize), bool, f64)> = None;
        let mut consider = |ix: usize, iy: usize| {
            if !self.reached[iy * w + ix] {
                return;
            }
            let p = g.cell_to_world(ix, iy);
            let mut score = (p[0] - start[0]).hypot(p[1] - start[1]) + (p[0] - far[0]).hypot(p[1] - far[1]);
            if previous.is_some_and(|q| (p[0] - q[0]).hypot(p[1] - q[1]) < 1.5) {
                score -= EXIT_STICKINESS;
            }
            let is_dead = dead.iter().any(|q| (p[0] - q[0]).hypot(p[1] - q[1]) < DEAD_END_RADIUS);
            if best.is_none_or(|(_, d, b)| (is_dead, score) < (d, b)) {
                best = Some(((ix, iy), is_dead, score));
            }
        };
        // Only the ring: whole rows at the top and bottom, the ends of the rows between.
        let k = EXIT_CELLS.min(w).min(h);
        for iy in 0..h {
            if iy < k || iy >= h - k {
                (0..w).for_each(|ix| consider(ix, iy));
            } else {
                (0..k).chain(w - k..w).for_each(|ix| consider(ix, iy));
            }
        }
        best.map(|(c, _, _)| c)
    }

    /// After [`GoalRepair::repair`] on the same map: whether world point `p` lies on the map in
    /// a cell the robot can reach (`None` off the map).
    pub fn reachable(&self, map: &Costmap, p: [f64; 2]) -> Option<bool> {
        let (ix, iy) = map.geometry().world_to_cell(p)?;
        self.reached.get(iy * map.width() + ix).copied()
    }
}

/// Exits within this distance (m) of a known dead end are avoided, see [`GoalRepair::best_exit`].
pub const DEAD_END_RADIUS: f64 = 2.0;

/// Dead ends a [`DdpenPlanner`] remembers (the oldest is forgotten first).
pub const DEAD_END_MEMORY: usize = 32;

/// Cosine of the angle off the heading beyond which a [`DdpenPlanner`] whose sub-goals lie behind
/// it backs out towards them rather than turning round first (150 degrees).
pub const REVERSE_COS: f64 = -0.866;

/// Width of the ring of exit cells at the costmap's border (cells), see [`GoalRepair::best_exit`].
pub const EXIT_CELLS: usize = 2;

/// Score bonus of cells near the previous exit (m), see [`GoalRepair::best_exit`].
pub const EXIT_STICKINESS: f64 = 1.0;

/// A [`DdpenPlanner`] that has stayed within this distance (m) for [`STUCK_TIME`] backs out.
pub const STUCK_RADIUS: f64 = 0.5;

/// See [`STUCK_RADIUS`] (s).
pub const STUCK_TIME: f64 = 6.0;

/// How far (m) a stuck [`DdpenPlanner`] backs out along its trail.
pub const BACKUP_DISTANCE: f64 = 3.0;

/// A back-out starts where the trail last came within this distance (m) of the stuck robot.
const ENTRY_RADIUS: f64 = 1.5;

/// Spacing (m) of the trail's points.
const TRAIL_SPACING: f64 = 0.25;

/// Trail points kept (the most recent, [`TRAIL_SPACING`] apart).
const TRAIL_POINTS: usize = 64;

/// Longest a back-out lasts (s) before the planner resumes.
const BACKUP_TIME: f64 = 12.0;

/// A back-out that gets no [`BACKUP_STEP`] closer to its end in this long (s) is over.
const BACKUP_PATIENCE: f64 = 2.0;

/// See [`BACKUP_PATIENCE`] (m).
const BACKUP_STEP: f64 = 0.1;

/// Radius (m) of the keep-out disc at a place where a [`DdpenPlanner`] got stuck.
pub const KEEPOUT_RADIUS: f64 = 1.0;

/// How long (s) a keep-out disc stays.
pub const KEEPOUT_TIME: f64 = 60.0;

/// Where a DDPEN planner's sub-goals come from (see the module docs).
pub trait SubgoalSource: Send {
    /// Short name (`"astar"`, `"network"`).
    fn name(&self) -> &str;
    /// Sub-goals in the world frame, in path order, for a robot at `state` heading for the local
    /// goal `goal`, seen on the inflated costmap `map`; written to `out` (cleared first). Empty
    /// when the source has none (the planner then runs as vanilla DDP).
    fn subgoals(&mut self, map: &Costmap, state: [f64; 3], goal: [f64; 2], out: &mut Vec<[f64; 2]>) -> Result<()>;

    /// Whether the sub-goals come from a search of the costmap (`true` for the A* oracle), which
    /// [`DdpenPlanner`] then takes as they are; otherwise it checks each new set against the one
    /// in force (see [`SUBGOAL_TOLERANCE`]).
    fn searches(&self) -> bool {
        false
    }
}

/// A new set of sub-goals from a source that does not search replaces the set in force unless
/// its way to the goal is longer by more than this (m): the length of the polyline robot -> s_1
/// -> s_2 -> s_3 plus the shortest way on the costmap from s_3 to the goal ([`CostToGo`]). The
/// network's proposals can flip between two ways round an obstacle from one cycle to the next,
/// or lead back into a pocket the robot is leaving; this keeps the better of the two in force.
pub const SUBGOAL_TOLERANCE: f64 = 0.5;

/// The shortest way from every cell to a target cell through cells cheaper than `blocked`
/// (8-connected, steps of 5 and 7 fifths of a cell: at most 8 % longer than the Euclidean length
/// in free space), by Dial's bucket queue. Buffers are allocated on the first call.
#[derive(Debug, Clone, Default)]
pub struct CostToGo {
    cost: Vec<u32>,
    buckets: [Vec<u32>; 8],
    width: usize,
    resolution: f64,
}

impl CostToGo {
    /// Computes the field towards world point `target` (its cell, clamped onto the map) on `map`.
    pub fn compute(&mut self, map: &Costmap, target: [f64; 2], blocked: u8) {
        let g = map.geometry();
        let (w, h) = (g.width(), g.height());
        self.width = w;
        self.resolution = g.resolution();
        self.cost.clear();
        self.cost.resize(w * h, u32::MAX);
        for b in &mut self.buckets {
            b.clear();
        }
        let (tx, ty) = g.world_to_cell_clamped(target);
        let start = (ty * w + tx) as u32;
        self.cost[start as usize] = 0;
        self.buckets[0].push(start);
        let mut d = 0u32;
        let mut pending = 1usize;
        while pending > 0 {
            let slot = (d % 8) as usize;
            while let Some(i) = self.buckets[slot].pop() {
                pending -= 1;
                let i = i as usize;
                if self.cost[i] != d {
                    continue;
                }
                let (x, y) = ((i % w) as i64, (i / w) as i64);
                for (dx, dy, step) in [
                    (1i64, 0i64, 5u32),
                    (-1, 0, 5),
                    (0, 1, 5),
                    (0, -1, 5),
                    (1, 1, 7),
                    (1, -1, 7),
                    (-1, 1, 7),
                    (-1, -1, 7),
                ] {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                        continue;
                    }
                    let j = ny as usize * w + nx as usize;
                    let c = d + step;
                    if c < self.cost[j] && map.get(nx as usize, ny as usize) < blocked {
                        self.cost[j] = c;
                        self.buckets[(c % 8) as usize].push(j as u32);
                        pending += 1;
                    }
                }
            }
            d += 1;
        }
    }

    /// The shortest way (m) from world point `p` to the target: from the best reached cell
    /// within 3 cells of `p`'s cell plus the straight step there (a sub-goal may sit on the
    /// inflated rim of an obstacle); infinite when none is reached or `p` is off the map.
    pub fn metres(&self, map: &Costmap, p: [f64; 2]) -> f64 {
        let Some((cx, cy)) = map.geometry().world_to_cell(p) else {
            return f64::INFINITY;
        };
        if self.cost.len() != map.width() * map.height() || self.width != map.width() {
            return f64::INFINITY;
        }
        let mut best = f64::INFINITY;
        let (w, h) = (map.width() as i64, map.height() as i64);
        for dy in -3i64..=3 {
            for dx in -3i64..=3 {
                let (x, y) = (cx as i64 + dx, cy as i64 + dy);
                if x < 0 || y < 0 || x >= w || y >= h {
                    continue;
                }
                let c = self.cost[(y * w + x) as usize];
                if c == u32::MAX {
                    continue;
                }
                let v = (0.2 * c as f64 + ((dx * dx + dy * dy) as f64).sqrt()) * self.resolution;
                best = best.min(v);
            }
        }
        best
    }

    /// The length (m) of the way `from` -> `subgoals[0]` -> ... -> last sub-goal, plus
    /// [`metres`](Self::metres) from the last sub-goal; infinite for no sub-goals.
    pub fn way_through(&self, map: &Costmap, from: [f64; 2], subgoals: &[[f64; 2]]) -> f64 {
        let Some(&last) = subgoals.last() else {
            return f64::INFINITY;
        };
        let mut length = 0.0;
        let mut at = from;
        for &s in subgoals {
            length += dist(at, s);
            at = s;
        }
        length + self.metres(map, last)
    }
}

/// The A* oracle: sub-goals at path steps [`ORACLE_STEPS`] (clamped to the path's end on short
/// paths) of the cost-aware 8-connected A* path from the robot's cell to the free cell nearest to
/// the local goal, on the inflated costmap; the dataset's labels, computed on the live costmap.
#[derive(Debug, Clone)]
pub struct AstarSubgoals {
    /// The A* workspace and the grid size it was made for.
    astar: Option<(AStar, usize, usize)>,
    params: AStarParams,
    steps: Vec<usize>,
    cells: Vec<(usize, usize)>,
    repair: GoalRepair,
    /// The path in force (world points), for the hysteresis (see [`AstarSubgoals::search_cells`]).
    previous: Vec<[f64; 2]>,
    scratch: Vec<(usize, usize)>,
    subgoal_cells: Vec<(usize, usize)>,
}

/// A new A* path replaces the one in force only when it is cheaper than this share of the old
/// one's remaining cost on the current costmap (plus [`PATH_SLACK_CELLS`]).
pub const PATH_HYSTERESIS: f64 = 0.8;

/// See [`PATH_HYSTERESIS`] (cells).
pub const PATH_SLACK_CELLS: f64 = 10.0;

/// Appends the cells of an 8-connected straight line from `a` (exclusive) to `b` (inclusive).
fn push_line(a: (usize, usize), b: (usize, usize), out: &mut Vec<(usize, usize)>) {
    let (mut x, mut y) = (a.0 as i64, a.1 as i64);
    let (bx, by) = (b.0 as i64, b.1 as i64);
    while (x, y) != (bx, by) {
        let (dx, dy) = (bx - x, by - y);
        // Diagonal while both differ by at least half the larger gap, straight otherwise.
        let (ax, ay) = (dx.abs(), dy.abs());
        if 2 * ax >= ay {
            x += dx.signum();
        }
        if 2 * ay >= ax {
            y += dy.signum();
        }
        out.push((x as usize, y as usize));
    }
}

impl Default for AstarSubgoals {
    fn default() -> Self {
        Self::new(&ORACLE_STEPS, AStarParams::default()).expect("constant steps are valid")
    }
}

impl AstarSubgoals {
    /// Sub-goals at path steps `steps` (each at least 1) with A* parameters `params`. The A*
    /// workspace is allocated on the first call (it needs the costmap's size).
    pub fn new(steps: &[usize], params: AStarParams) -> Result<Self> {
        if steps.is_empty() {
            return Err(Error::invalid("subgoal_steps", "needs at least one step"));
        }
        if let Some(i) = steps.iter().position(|&s| s == 0) {
            return Err(Error::invalid(format!("subgoal_steps[{i}]"), "must be at least 1"));
        }
        Ok(Self {
            astar: None,
            params,
            steps: steps.to_vec(),
            cells: Vec::new(),
            repair: GoalRepair::default(),
            previous: Vec::new(),
            scratch: Vec::new(),
            subgoal_cells: Vec::new(),
        })
    }

    /// The path in force, re-priced from the robot's cell `s` to the new target `t` on `map`:
    /// its cells into `self.scratch` and its cost, or `None` when there is none, it ended more
    /// than 3 m from `t`, the robot is more than 0.5 m off it, or it is blocked now.
    fn previous_path(&mut self, map: &Costmap, s: (usize, usize), t: (usize, usize)) -> Option<f64> {
        let g = map.geometry();
        let (start, target) = (g.cell_to_world(s.0, s.1), g.cell_to_world(t.0, t.1));
        let end = *self.previous.last()?;
        if (end[0] - target[0]).hypot(end[1] - target[1]) > 3.0 {
            return None;
        }
        let (i, d) = self
            .previous
            .iter()
            .enumerate()
            .map(|(i, p)| (i, (p[0] - start[0]).hypot(p[1] - start[1])))
            .min_by(|a, b| a.1.total_cmp(&b.1))?;
        if d > 0.5 {
            return None;
        }
        self.scratch.clear();
        self.scratch.push(s);
        for p in &self.previous[i..] {
            let c = g.world_to_cell(*p)?;
            let last = *self.scratch.last().expect("starts with s");
            push_line(last, c, &mut self.scratch);
        }
        let last = *self.scratch.last().expect("starts with s");
        push_line(last, t, &mut self.scratch);
        path_cost(map, &self.scratch, &self.params)
    }

    /// The cells of the last A* path (start first), empty when it found none.
    pub fn path(&self) -> &[(usize, usize)] {
        &self.cells
    }

    /// A* on `map` from the cell of `start` to the free cell nearest to `goal`; the sub-goal
    /// cells into `out` (cleared first). `false` when there is no path.
    pub fn search_cells(
        &mut self,
        map: &Costmap,
        start: [f64; 2],
        goal: [f64; 2],
        out: &mut Vec<(usize, usize)>,
    ) -> bool {
        out.clear();
        let g = map.geometry();
        if self
            .astar
            .as_ref()
            .is_none_or(|a| a.1 != g.width() || a.2 != g.height())
        {
            self.astar = Some((AStar::new(g), g.width(), g.height()));
        }
        let astar = &mut self.astar.as_mut().expect("just set").0;
        let s = g.world_to_cell_clamped(start);
        let Some(t) = self.repair.repair(map, start, goal, self.params.blocked) else {
            self.cells.clear();
            self.previous.clear();
            return false;
        };
        if t == s {
            self.cells.clear();
            self.previous.clear();
            return false;
        }
        let Some(cost) = astar.search(map, s, t, &self.params, &mut self.cells) else {
            self.previous.clear();
            return false;
        };
        // Hysteresis: keep the path in force unless the new one is clearly cheaper, so that the
        // sub-goals do not flip between two ways round an obstacle as the costmap changes.
        if let Some(old) = self.previous_path(map, s, t) {
            if cost >= PATH_HYSTERESIS * old - PATH_SLACK_CELLS {
                std::mem::swap(&mut self.cells, &mut self.scratch);
            }
        }
        self.previous.clear();
        self.previous
            .extend(self.cells.iter().map(|&(x, y)| g.cell_to_world(x, y)));
        let last = self.cells.len() - 1;
        out.extend(self.steps.iter().map(|&k| self.cells[k.min(last)]));
        true
    }
}

impl SubgoalSource for AstarSubgoals {
    fn name(&self) -> &str {
        "astar"
    }

    fn searches(&self) -> bool {
        true
    }

    fn subgoals(&mut self, map: &Costmap, state: [f64; 3], goal: [f64; 2], out: &mut Vec<[f64; 2]>) -> Result<()> {
        out.clear();
        // The sub-goal cells' buffer is kept between cycles (no allocation per plan).
        let mut cells = std::mem::take(&mut self.subgoal_cells);
        if self.search_cells(map, [state[0], state[1]], goal, &mut cells) {
            out.extend(cells.iter().map(|&(x, y)| map.geometry().cell_to_world(x, y)));
        }
        self.subgoal_cells = cells;
        Ok(())
    }
}

/// The sub-goal network of eq. (10): the inflated costmap and the local goal in map coordinates
/// in, the sub-goals in map coordinates out ([`MapFrame`]).
#[derive(Clone)]
pub struct NetworkSubgoals {
    model: Arc<SubgoalModel>,
}

impl std::fmt::Debug for NetworkSubgoals {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NetworkSubgoals")
            .field("num_subgoals", &self.model.num_subgoals())
            .finish()
    }
}

impl NetworkSubgoals {
    /// A source around a loaded model.
    pub fn new(model: Arc<SubgoalModel>) -> Self {
        Self { model }
    }

    /// The model.
    pub fn model(&self) -> &Arc<SubgoalModel> {
        &self.model
    }
}

impl SubgoalSource for NetworkSubgoals {
    fn name(&self) -> &str {
        "network"
    }

    fn subgoals(&mut self, map: &Costmap, state: [f64; 3], goal: [f64; 2], out: &mut Vec<[f64; 2]>) -> Result<()> {
        out.clear();
        let frame = MapFrame::of(map.geometry());
        let _ = state;
        let predicted = self.model.predict(map.cells(), frame.to_map(goal))?;
        for (i, q) in predicted.iter().enumerate() {
            if !(q[0].is_finite() && q[1].is_finite()) {
                return Err(Error::invalid(
                    format!("subgoals[{i}]"),
                    format!("the network returned a non-finite sub-goal {q:?}"),
                ));
            }
            out.push(frame.to_world(*q));
        }
        Ok(())
    }
}

/// Loaded models by path.
type ModelCache = Mutex<Vec<(PathBuf, Arc<SubgoalModel>)>>;

/// Loaded sub-goal models by path, shared by every run of the process (a model is immutable).
fn models() -> &'static ModelCache {
    static MODELS: OnceLock<ModelCache> = OnceLock::new();
    MODELS.get_or_init(|| Mutex::new(Vec::new()))
}

/// The sub-goal model at `path` (`None`: the shipped default), loaded once per process and
/// shared. Errors name the field `model` and the file.
pub fn load_model(path: Option<&Path>) -> Result<Arc<SubgoalModel>> {
    let key = path.map_or_else(|| PathBuf::from("<default>"), Path::to_path_buf);
    let mut cache = models().lock().unwrap_or_else(|e| e.into_inner());
    if let Some((_, m)) = cache.iter().find(|(p, _)| *p == key) {
        return Ok(m.clone());
    }
    let loaded = match path {
        Some(p) => SubgoalModel::load(p),
        None => SubgoalModel::default_model(),
    }
    .map_err(|e| Error::invalid("model", format!("cannot load {}: {e}", key.display())))?;
    let model = Arc::new(loaded);
    cache.push((key, model.clone()));
    Ok(model)
}

/// DDP with the sub-goal cost of eqs. (8)-(9), its sub-goals from a [`SubgoalSource`] (see the
/// module docs).
pub struct DdpenPlanner {
    ddp: DdpPlanner,
    source: Box<dyn SubgoalSource>,
    name: String,
    every: usize,
    /// `w_s` of each sub-goal term.
    w_subgoal: f64,
    cycle: usize,
    subgoals: Vec<[f64; 2]>,
    /// The goal of the sub-goal source and of the DDP cost, see [`DdpenPlanner::target`].
    target: Option<[f64; 2]>,
    /// Whether `target` is an exit (not the route's end).
    exit: bool,
    /// Exits found to be dead ends (world), see [`DdpenPlanner::choose_target`].
    dead_ends: Vec<[f64; 2]>,
    /// Cosine of the angle beyond which the first sub-goal counts as behind the robot.
    turn_cos: f64,
    repair: GoalRepair,
    path: Vec<[f64; 2]>,
    guess: Vec<Vector<2>>,
    /// The robot's trail, oldest first, [`TRAIL_SPACING`] apart.
    trail: std::collections::VecDeque<[f64; 2]>,
    /// Where and when the robot last moved [`STUCK_RADIUS`] away.
    anchor: ([f64; 2], f64),
    /// A back-out in progress: its path (from the robot back along the trail) and its deadline.
    backup: Option<(Vec<[f64; 2]>, f64)>,
    /// During a back-out: the closest it has come to its end (m), and when.
    backup_best: (f64, f64),
    /// Places the robot got stuck in (world) and when.
    keepouts: Vec<([f64; 2], f64)>,
    /// The costmap with the keep-out discs (reused).
    scratch: Option<Costmap>,
    /// The source's newest proposal, before the check against the set in force.
    candidate: Vec<[f64; 2]>,
    togo: CostToGo,
}

impl DdpenPlanner {
    /// A planner named `name` with the optimiser's `params`, DDPEN's `ddpen`
    /// (`ddpen.subgoal_every` is the inference cadence) and sub-goals from `source`.
    pub fn new(
        name: impl Into<String>,
        params: DdpParams,
        ddpen: &DdpenParams,
        source: Box<dyn SubgoalSource>,
    ) -> Result<Self> {
        params.validate()?;
        ddpen.validate(&params)?;
        Ok(Self {
            ddp: DdpPlanner::new(DdpParams {
                v_min: ddpen.v_min,
                ..params
            })?,
            source,
            name: name.into(),
            every: ddpen.subgoal_every,
            w_subgoal: ddpen.w_subgoal,
            cycle: 0,
            subgoals: Vec::new(),
            target: None,
            exit: false,
            dead_ends: Vec::new(),
            turn_cos: 0.0,
            repair: GoalRepair::default(),
            path: Vec::new(),
            guess: vec![Vector::<2>::zeros(); params.horizon],
            trail: std::collections::VecDeque::with_capacity(TRAIL_POINTS),
            anchor: ([f64::NAN; 2], 0.0),
            backup: None,
            backup_best: (f64::INFINITY, 0.0),
            keepouts: Vec::new(),
            scratch: None,
            candidate: Vec::new(),
            togo: CostToGo::default(),
        })
    }

    /// `map` with the keep-out discs younger than [`KEEPOUT_TIME`] stamped on (in the reused
    /// scratch map), or `None` when there are none.
    fn stamp_keepouts(&mut self, map: &Costmap, time: f64) -> Option<Costmap> {
        self.keepouts.retain(|&(_, t)| time - t < KEEPOUT_TIME);
        if self.keepouts.is_empty() {
            return None;
        }
        let mut out = match self.scratch.take() {
            Some(mut m) if m.geometry() == map.geometry() => {
                m.cells_mut().copy_from_slice(map.cells());
                m
            }
            _ => map.clone(),
        };
        let g = *map.geometry();
        let r = KEEPOUT_RADIUS;
        let n = (r / g.resolution()).ceil() as i64;
        for &(c, _) in &self.keepouts {
            for dy in -n..=n {
                for dx in -n..=n {
                    let p = [c[0] + dx as f64 * g.resolution(), c[1] + dy as f64 * g.resolution()];
                    if dist(p, c) <= r {
                        out.mark(p, LETHAL);
                    }
                }
            }
        }
        Some(out)
    }

    /// Makes the source's proposal (`candidate`) the set in force unless the set in force leads
    /// to `target` by a way shorter by more than [`SUBGOAL_TOLERANCE`] (see there).
    fn accept_or_keep(&mut self, map: &Costmap, xy: [f64; 2], target: [f64; 2]) {
        if !self.source.searches() && !self.subgoals.is_empty() && !self.candidate.is_empty() {
            self.togo.compute(map, target, AStarParams::default().blocked);
            let kept = self.togo.way_through(map, xy, &self.subgoals);
            let new = self.togo.way_through(map, xy, &self.candidate);
            if kept.is_finite() && !(new <= kept + SUBGOAL_TOLERANCE) {
                return;
            }
        }
        std::mem::swap(&mut self.subgoals, &mut self.candidate);
    }

    /// Whether a back-out is in progress (see the module docs).
    pub fn backing_out(&self) -> bool {
        self.backup.is_some()
    }

    /// Updates the trail and the stuck detector with the robot at `xy` at `time`; starts a
    /// back-out (returns `true`) when the robot is stuck and its trail leads somewhere.
    fn watch(&mut self, xy: [f64; 2], time: f64) -> bool {
        if self.trail.back().is_none_or(|&p| dist(p, xy) >= TRAIL_SPACING) {
            if self.trail.len() == TRAIL_POINTS {
                self.trail.pop_front();
            }
            self.trail.push_back(xy);
        }
        if !(dist(self.anchor.0, xy) <= STUCK_RADIUS) {
            self.anchor = (xy, time);
            return false;
        }
        if time - self.anchor.1 < STUCK_TIME {
            return false;
        }
        self.anchor = (xy, time);
        // Back along the trail from where the robot last came within ENTRY_RADIUS of here: its
        // dithering since (which may have gone deeper into the dead end) is skipped.
        let entry = self
            .trail
            .iter()
            .rposition(|&p| dist(p, xy) > ENTRY_RADIUS)
            .unwrap_or(0);
        let mut path = vec![xy];
        let mut length = 0.0;
        for &p in self.trail.iter().take(entry + 1).rev() {
            length += dist(*path.last().expect("not empty"), p);
            path.push(p);
            if length >= BACKUP_DISTANCE {
                break;
            }
        }
        if length < 0.5 * BACKUP_DISTANCE {
            // No trail to speak of (the start of the run).
            return false;
        }
        // The exit in force led here: avoid it from now on.
        if let (true, Some(t)) = (self.exit, self.target) {
            if self.dead_ends.len() == DEAD_END_MEMORY {
                self.dead_ends.remove(0);
            }
            self.dead_ends.push(t);
        }
        self.exit = false;
        self.keepouts.push((xy, time));
        self.backup_best = (f64::INFINITY, time);
        self.backup = Some((path, time + BACKUP_TIME));
        true
    }

    /// One cycle of a back-out: sub-goals 1, 2 and 3 m back along its path, backing along it;
    /// `false` once it is over.
    fn back_out(&mut self, request: &PlanRequest<'_>, t: Instant) -> Result<bool> {
        let Some((path, deadline)) = &self.backup else {
            return Ok(false);
        };
        let xy = [request.state[0], request.state[1]];
        let end = *path.last().expect("at least two points");
        let left = dist(xy, end);
        if left < self.backup_best.0 - BACKUP_STEP {
            self.backup_best = (left, request.time);
        }
        let stuck = request.time - self.backup_best.1 > BACKUP_PATIENCE;
        if request.time >= *deadline || left <= STUCK_RADIUS || stuck {
            self.backup = None;
            self.ddp.restrict_speed(None);
            // The trail behind is where the robot has just been: start afresh, and take the
            // source's next proposal whatever it is (the back-out's sub-goals are no yardstick).
            self.trail.clear();
            self.subgoals.clear();
            return Ok(false);
        }
        self.subgoals.clear();
        let mut along = 0.0;
        let mut next = 1.0;
        for w in path.windows(2) {
            along += dist(w[0], w[1]);
            while along >= next && self.subgoals.len() < 3 {
                self.subgoals.push(w[1]);
                next += 1.0;
            }
        }
        while self.subgoals.len() < 3 {
            self.subgoals.push(end);
        }
        self.ddp.set_subgoals(&self.subgoals, self.w_subgoal)?;
        // Reversing only: the way back is free, turning round in a slot may not be.
        self.ddp.restrict_speed(Some((f64::NEG_INFINITY, 0.0)));
        pursuit_guess(self.ddp.params(), request.state, path, 0.5, true, &mut self.guess);
        self.ddp.set_initial_guess(&self.guess)?;
        self.ddp.plan_mut().setup_seconds = 0.0;
        {
            let plan = self.ddp.plan_mut();
            plan.guide.clear();
            plan.guide.extend_from_slice(&self.subgoals);
            plan.subgoal_seconds = 0.0;
        }
        let aimed = PlanRequest { goal: end, ..*request };
        self.ddp.optimise(&aimed, t)?;
        // Ask for fresh sub-goals once the back-out ends.
        self.target = None;
        Ok(true)
    }

    /// `ddpen-oracle`: A* sub-goals.
    pub fn oracle(params: DdpParams, ddpen: &DdpenParams) -> Result<Self> {
        Self::new("ddpen-oracle", params, ddpen, Box::new(AstarSubgoals::default()))
    }

    /// `ddpen`: the network's sub-goals, with the model at `ddpen.model` or the shipped default
    /// (loaded once per process, see [`load_model`]).
    pub fn network(params: DdpParams, ddpen: &DdpenParams) -> Result<Self> {
        let model = load_model(ddpen.model.as_deref())?;
        Self::new("ddpen", params, ddpen, Box::new(NetworkSubgoals::new(model)))
    }

    /// The sub-goals in force (world frame).
    pub fn subgoals(&self) -> &[[f64; 2]] {
        &self.subgoals
    }

    /// The goal in force: of the sub-goal source and of the DDP's goal terms (eqs. 4, 6).
    pub fn target(&self) -> Option<[f64; 2]> {
        self.target
    }

    /// Chooses the goal of this cycle. The paper's local goal (the route's intersection with the
    /// costmap border, §II-E) lies on the straight line ahead, so on a route into a trap it sits
    /// in the pocket, or inside or behind the trap's back wall, where the sub-goals lead the
    /// robot back into the dead end. Instead, while the local goal is on the border, the goal is
    /// the exit of [`GoalRepair::best_exit`] towards the far goal `far` (the route further on):
    /// in free space that is the local goal itself, and round an obstacle the exit on the cheaper
    /// way round, kept unless another becomes clearly better. Near the route's end (the local goal
    /// inside the map) it is the local goal, or the reachable cell nearest to it.
    fn choose_target(&mut self, map: &Costmap, state: [f64; 3], goal: [f64; 2], far: [f64; 2]) -> [f64; 2] {
        let g = map.geometry();
        let blocked = AStarParams::default().blocked;
        let xy = [state[0], state[1]];
        let repaired = self.repair.repair(map, xy, goal, blocked);
        let (ix, iy) = g.world_to_cell_clamped(goal);
        let edge = ix.min(iy).min(g.width() - 1 - ix).min(g.height() - 1 - iy);
        if edge < GOAL_BAND_CELLS {
            let previous = if self.exit { self.target } else { None };
            // The exit in force has come into view and out of reach: a dead end (a pocket that
            // looked open at the map's border). Remember it in the world frame, as the rolling
            // window forgets it once the robot backs away.
            if let Some(p) = previous {
                if self.repair.reachable(map, p) == Some(false) {
                    if self.dead_ends.len() == DEAD_END_MEMORY {
                        self.dead_ends.remove(0);
                    }
                    self.dead_ends.push(p);
                }
            }
            if let Some((ex, ey)) = self.repair.best_exit(map, xy, far, previous, &self.dead_ends) {
                self.exit = true;
                return g.cell_to_world(ex, ey);
            }
        }
        self.exit = false;
        repaired.map_or(goal, |(x, y)| g.cell_to_world(x, y))
    }
}

impl Planner for DdpenPlanner {
    fn name(&self) -> &str {
        &self.name
    }

    fn plan(&mut self, request: &PlanRequest<'_>) -> Result<&Plan> {
        let t = Instant::now();
        let [x, y, theta] = request.state;
        if self.backup.is_none() {
            self.watch([x, y], request.time);
        }
        if self.back_out(request, t)? {
            return Ok(self.ddp.plan_mut());
        }
        let mut infer = 0.0;
        if self.cycle % self.every == 0 || self.target.is_none() {
            // The costmap with the keep-out discs of places the robot got stuck in.
            let stamped = self.stamp_keepouts(request.perception.costmap(), request.time);
            let map = stamped.as_ref().unwrap_or(request.perception.costmap());
            let target = self.choose_target(map, request.state, request.goal, request.far_goal);
            self.target = Some(target);
            let found = self.source.subgoals(map, request.state, target, &mut self.candidate);
            if found.is_ok() {
                self.accept_or_keep(map, [x, y], target);
            }
            if stamped.is_some() {
                self.scratch = stamped;
            }
            found?;
            self.ddp.set_subgoals(&self.subgoals, self.w_subgoal)?;
            infer = t.elapsed().as_secs_f64();
        }
        self.cycle += 1;
        let alpha = self
            .subgoals
            .first()
            .map_or(0.0, |s| (s[1] - y).atan2(s[0] - x) - theta);
        let behind = !self.subgoals.is_empty() && alpha.cos() < self.turn_cos;
        // Nearly straight behind, with reversing allowed: back out (a narrow pocket may leave no
        // room to turn round in).
        let reverse = behind && alpha.cos() < REVERSE_COS && self.ddp.params().v_min < 0.0;
        self.ddp.plan_mut().setup_seconds = 0.0;
        if behind {
            // v = 0 is a stationary point of the cost in w (the position does not move with the
            // heading), so a DDP standing still never turns towards sub-goals behind it: the
            // initial guess turns in place towards them and then follows them.
            self.path.clear();
            self.path.push([x, y]);
            self.path.extend_from_slice(&self.subgoals);
            pursuit_guess(
                self.ddp.params(),
                request.state,
                &self.path,
                0.5,
                reverse,
                &mut self.guess,
            );
            self.ddp.set_initial_guess(&self.guess)?;
        } else {
            self.ddp.warm_start(request.steps_since_last);
        }
        {
            let plan = self.ddp.plan_mut();
            plan.guide.clear();
            plan.guide.extend_from_slice(&self.subgoals);
        }
        // The DDP's goal terms aim at the chosen goal too, not into the dead end.
        let aimed = PlanRequest {
            goal: self.target.unwrap_or(request.goal),
            ..*request
        };
        self.ddp.optimise(&aimed, t)?;
        let plan = self.ddp.plan_mut();
        plan.subgoal_seconds = infer;
        Ok(plan)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_frame_round_trips_and_matches_cells() {
        let g = GridGeometry::ddpen([3.33, -7.81]);
        let f = MapFrame::of(&g);
        // The centre is within one cell of the requested centre, on the lattice corner.
        assert!((f.center()[0] - 3.33).abs() <= 0.05 && (f.center()[1] + 7.81).abs() <= 0.05);
        // Map coordinates (0.025, 0.025) are the centre of cell (100, 100); x along columns.
        let c = g.cell_to_world(100, 100);
        let q = f.to_map(c);
        assert!((q[0] - 0.025).abs() < 1e-5 && (q[1] - 0.025).abs() < 1e-5, "{q:?}");
        let c = g.cell_to_world(150, 60);
        let q = f.to_map(c);
        assert!((q[0] - 2.525).abs() < 1e-5 && (q[1] + 1.975).abs() < 1e-5, "{q:?}");
        let back = f.to_world(q);
        assert!((back[0] - c[0]).abs() < 1e-5 && (back[1] - c[1]).abs() < 1e-5);
    }

    #[test]
    fn steps_are_validated() {
        let e = AstarSubgoals::new(&[30, 0], AStarParams::default()).unwrap_err();
        assert!(e.to_string().contains("subgoal_steps[1]"), "{e}");
        assert!(AstarSubgoals::new(&[], AStarParams::default()).is_err());
    }
}
