//! The synthetic sub-goal dataset of DDPEN (§II-D): random obstacle maps, A* paths from the
//! centre to a goal near the border, and the path cells at steps 30, 50 and 70 as the sub-goals
//! the network imitates.
//!
//! One sample, [`Generator::sample`]:
//!
//! 1. a 200 x 200 costmap of 5 cm cells ([`GridGeometry::ddpen`] centred on the origin);
//! 2. obstacles — rectangles, circles (ellipses after the transform), L and U shapes — each placed
//!    by a random affine map (rotation, anisotropic scale, shear, translation) and rasterised.
//!    With probability [`DatasetParams::trap_probability`] the first obstacle is a *trap*: a U (or
//!    an L) across the straight line to the goal with its opening towards the robot, either ahead
//!    of it or around it — the local minima that DDP alone does not escape;
//! 3. the centre stays free: no obstacle cell centre lies within [`DatasetParams::free_radius`]
//!    of the map centre (an obstacle that would enter the disc is drawn again);
//!    with [`DatasetParams::lidar_view`] (the default) the map is then what a lidar at the centre
//!    makes of it, as sim2d's perception does in the loop: [`DatasetParams::lidar_beams`] rays
//!    from the centre, each marking the first obstacle cell it meets and the cells behind it along
//!    the ray up to [`DatasetParams::shadow_depth`]; the faces the lidar cannot see, and whatever
//!    lies in the shadows beyond, are unknown and free (the goal, the flood fill and A* below all
//!    work on this view, as the A* oracle does on the live costmap);
//! 4. costs dilated from the obstacles into free space by [`Inflation`], with the parameters of
//!    the simulator's perception (sim2d's `PerceptionParams` defaults), so the network sees the
//!    costmaps it will see in the loop;
//! 5. a goal drawn uniformly among the cells within [`DatasetParams::goal_band`] of the border
//!    that the robot can reach (a flood fill from the centre through passable cells; for a trap,
//!    among those behind it, within 40 degrees of its direction, when there are any); a map with
//!    no reachable border cell is drawn again;
//! 6. 8-connected cost-aware A* ([`AStar`]) from the centre cell to the goal; the sub-goals are
//!    the path cells at [`DatasetParams::subgoal_steps`] (`path[0]` is the start), clamped to the
//!    goal on shorter paths.
//!
//! ## Frame and layout (the contract with training and inference)
//!
//! - Goal and sub-goals are in metres relative to the map centre, in the map's axes: `x` grows
//!   with the column index `ix`, `y` with the row index `iy`. A cell stands for its centre:
//!   `x = (ix - 100 + 0.5) * 0.05`, `y = (iy - 100 + 0.5) * 0.05`, i.e.
//!   `GridGeometry::ddpen([0.0, 0.0]).cell_to_world(ix, iy)`. The robot's start cell is
//!   `(100, 100)`, at `(0.025, 0.025)`.
//! - Costmap bytes are [`Costmap::cells`]: row-major, `index = iy * 200 + ix`, so a
//!   `[200, 200]` array is indexed `[iy, ix]`.
//!
//! ## Determinism
//!
//! Sample `i` of seed `s` comes from its own ChaCha8 stream (`seed_from_u64(s)`, stream `i`), so
//! it is the same whatever the number of threads, the order, or the shard it lands in.
//!
//! ```
//! use subgoal_infer::dataset::{DatasetParams, Generator};
//! let mut gen = Generator::new(DatasetParams::default())?;
//! let s = gen.sample(7, 0);
//! assert_eq!(s.costmap.cells().len(), 200 * 200);
//! assert!(s.costmap.get(100, 100) < subgoal_infer::grid::INSCRIBED); // the start is free
//! // The goal is within 0.5 m of the border.
//! assert!(s.goal[0].abs().max(s.goal[1].abs()) >= 4.5 - 0.05);
//! // Sub-goals are path cells at steps 30, 50, 70.
//! let cell = s.path[30];
//! assert_eq!(s.subgoals[0], subgoal_infer::dataset::cell_position(cell));
//! # Ok::<(), subgoal_infer::Error>(())
//! ```
//!
//! Shards on disk and the reader: [`write_dataset`], [`Shard`], [`Manifest`].

mod shapes;
mod shards;
pub mod sweep;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::error::{nonnegative, positive, Error, Result};
use crate::grid::{AStar, AStarParams, Costmap, DistanceField, GridGeometry, Inflation, LETHAL};
use shapes::{Kind, Obstacle, Placement};

pub use shards::{
    parse_manifest, read_manifest, write_dataset, DatasetError, DatasetSummary, Manifest, Shard, ShardEntry,
    WriteOptions, FORMAT_NAME, FORMAT_VERSION,
};

/// Cells along each side of a dataset costmap.
pub const MAP_CELLS: usize = 200;
/// Cell side (m).
pub const RESOLUTION: f64 = 0.05;
/// Cells of one costmap (`200 * 200`).
pub const MAP_LEN: usize = MAP_CELLS * MAP_CELLS;
/// Number of sub-goals per sample.
pub const NUM_SUBGOALS: usize = 3;
/// The start cell `(ix, iy)`: the cell containing the map centre.
pub const START_CELL: (usize, usize) = (MAP_CELLS / 2, MAP_CELLS / 2);

/// Half-angle of the cone behind a trap where its goal is drawn (degrees).
const TRAP_CONE_DEG: f64 = 40.0;
/// Draws of an obstacle that enters the free disc before it is given up.
const PLACEMENT_TRIES: usize = 8;
/// Maps drawn before a sample without reachable goal falls back to one without clutter.
const MAP_TRIES: usize = 32;

/// The geometry of every dataset costmap: [`GridGeometry::ddpen`] centred on the origin.
pub fn geometry() -> GridGeometry {
    GridGeometry::ddpen([0.0, 0.0])
}

/// Position (m, relative to the map centre) of the centre of cell `(ix, iy)`, as `f32`: the
/// frame of goals and sub-goals (see the module docs).
pub fn cell_position(cell: (usize, usize)) -> [f32; 2] {
    let half = (MAP_CELLS / 2) as f64;
    [
        ((cell.0 as f64 - half + 0.5) * RESOLUTION) as f32,
        ((cell.1 as f64 - half + 0.5) * RESOLUTION) as f32,
    ]
}

/// Parameters of the generator. Defaults: the inflation of sim2d's perception (inscribed
/// 0.3 m, inflation 1.2 m, decay 3 /m), a free disc of 0.5 m, goals within 0.5 m of the
/// border, sub-goals at steps 30, 50, 70, traps in 60 % of the samples, 1 to 8 clutter obstacles.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DatasetParams {
    /// Inscribed radius of the inflation (m); sim2d `PerceptionParams::inscribed_radius`.
    pub inscribed_radius: f64,
    /// Inflation radius (m); sim2d `PerceptionParams::inflation_radius`.
    pub inflation_radius: f64,
    /// Inflation decay rate (1/m); sim2d `PerceptionParams::cost_scaling`.
    pub cost_scaling: f64,
    /// No obstacle cell centre lies within this distance (m) of the map centre.
    pub free_radius: f64,
    /// Goals are drawn among cells within this distance (m) of the map border.
    pub goal_band: f64,
    /// Path steps of the sub-goals (`path[0]` is the start), strictly increasing.
    pub subgoal_steps: [usize; NUM_SUBGOALS],
    /// Probability that a sample has a U or L trap across the line to its goal.
    pub trap_probability: f64,
    /// Fewest random clutter obstacles per map.
    pub min_obstacles: usize,
    /// Most random clutter obstacles per map.
    pub max_obstacles: usize,
    /// A* settings (impassable cost and the weight of the inflation cost).
    pub astar: AStarParams,
    /// Replace the obstacles by a lidar's view of them from the centre (see the module docs).
    pub lidar_view: bool,
    /// Rays of the lidar view over the full circle.
    pub lidar_beams: usize,
    /// Depth behind a ray's first obstacle cell that the lidar view marks (m); sim2d
    /// `PerceptionParams::shadow_depth`.
    pub shadow_depth: f64,
}

impl Default for DatasetParams {
    fn default() -> Self {
        Self {
            inscribed_radius: 0.3,
            inflation_radius: 1.2,
            cost_scaling: 3.0,
            free_radius: 0.5,
            goal_band: 0.5,
            subgoal_steps: [30, 50, 70],
            trap_probability: 0.6,
            min_obstacles: 1,
            max_obstacles: 8,
            astar: AStarParams::default(),
            lidar_view: true,
            lidar_beams: 360,
            shadow_depth: 2.0,
        }
    }
}

impl DatasetParams {
    /// Rejects impossible values, naming the field.
    pub fn validate(&self) -> Result<()> {
        nonnegative("inscribed_radius", self.inscribed_radius)?;
        nonnegative("inflation_radius", self.inflation_radius)?;
        nonnegative("cost_scaling", self.cost_scaling)?;
        if self.inflation_radius < self.inscribed_radius {
            return Err(Error::invalid(
                "inflation_radius",
                format!(
                    "must be >= inscribed_radius = {}, got {}",
                    self.inscribed_radius, self.inflation_radius
                ),
            ));
        }
        nonnegative("shadow_depth", self.shadow_depth)?;
        if self.lidar_view && !(8..=100_000).contains(&self.lidar_beams) {
            return Err(Error::invalid(
                "lidar_beams",
                format!("must be in 8..=100000, got {}", self.lidar_beams),
            ));
        }
        positive("free_radius", self.free_radius)?;
        // The start cell's centre is within one cell diagonal of the map centre: keep it outside
        // the inscribed zone of any obstacle so the robot starts on a passable cell.
        let min_free = self.inscribed_radius + 2.0 * RESOLUTION;
        if self.free_radius < min_free || self.free_radius > 4.0 {
            return Err(Error::invalid(
                "free_radius",
                format!(
                    "must be in [inscribed_radius + 0.1 = {min_free}, 4] m, got {}",
                    self.free_radius
                ),
            ));
        }
        positive("goal_band", self.goal_band)?;
        if self.goal_band < RESOLUTION || self.goal_band > 4.0 {
            return Err(Error::invalid(
                "goal_band",
                format!("must be in [0.05, 4] m, got {}", self.goal_band),
            ));
        }
        let s = self.subgoal_steps;
        if s[0] == 0 || s.windows(2).any(|w| w[1] <= w[0]) {
            return Err(Error::invalid(
                "subgoal_steps",
                format!("must be strictly increasing and >= 1, got {s:?}"),
            ));
        }
        if !(0.0..=1.0).contains(&self.trap_probability) {
            return Err(Error::invalid(
                "trap_probability",
                format!("must be in [0, 1], got {}", self.trap_probability),
            ));
        }
        if self.max_obstacles < self.min_obstacles || self.max_obstacles > 64 {
            return Err(Error::invalid(
                "max_obstacles",
                format!(
                    "must be in [min_obstacles = {}, 64], got {}",
                    self.min_obstacles, self.max_obstacles
                ),
            ));
        }
        if self.astar.blocked == 0 {
            return Err(Error::invalid("astar.blocked", "must be at least 1"));
        }
        nonnegative("astar.cost_weight", self.astar.cost_weight)?;
        Ok(())
    }
}

/// One generated sample (see the module docs for the frame).
#[derive(Debug, Clone, PartialEq)]
pub struct Sample {
    /// The inflated costmap ([`geometry`]).
    pub costmap: Costmap,
    /// Goal (m, relative to the map centre).
    pub goal: [f32; 2],
    /// Sub-goals (m, relative to the map centre), at [`DatasetParams::subgoal_steps`].
    pub subgoals: [[f32; 2]; NUM_SUBGOALS],
    /// The A* path, cells `(ix, iy)` from [`START_CELL`] to the goal.
    pub path: Vec<(usize, usize)>,
    /// Whether the map has a trap across the line to the goal.
    pub trap: bool,
}

/// What a sample stores besides its costmap.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SampleInfo {
    /// Goal (m, relative to the map centre).
    pub goal: [f32; 2],
    /// Sub-goals (m, relative to the map centre).
    pub subgoals: [[f32; 2]; NUM_SUBGOALS],
    /// Cells on the A* path, start and goal included.
    pub path_length: u32,
    /// Whether the map has a trap across the line to the goal.
    pub trap: bool,
}

/// The sample generator: parameters and every buffer of one sample (allocated once, about
/// 1.5 MB; one per thread).
#[derive(Debug, Clone)]
pub struct Generator {
    params: DatasetParams,
    geometry: GridGeometry,
    inflation: Inflation,
    obstacles: Costmap,
    costmap: Costmap,
    field: DistanceField,
    astar: AStar,
    path: Vec<(usize, usize)>,
    /// Cells whose centre lies in the free disc.
    disc: Vec<[f64; 2]>,
    /// Flood fill: visited marks and the spans to scan.
    seen: Vec<bool>,
    spans: Vec<(u16, u16, u16)>,
    /// Every cell of the goal band with the unit vector from the centre to it.
    band_all: Vec<(u32, [f64; 2])>,
    /// Reachable cells of the goal band, and those in the trap's cone.
    band: Vec<u32>,
    cone: Vec<u32>,
}

impl Generator {
    /// Validates `params` and allocates the buffers.
    pub fn new(params: DatasetParams) -> Result<Self> {
        params.validate()?;
        let geometry = geometry();
        let inflation = Inflation::new(
            params.inscribed_radius,
            params.inflation_radius,
            params.cost_scaling,
            RESOLUTION,
        )?;
        let mut disc = Vec::new();
        for iy in 0..MAP_CELLS {
            for ix in 0..MAP_CELLS {
                let p = geometry.cell_to_world(ix, iy);
                if p[0].hypot(p[1]) <= params.free_radius {
                    disc.push(p);
                }
            }
        }
        let k = (params.goal_band / RESOLUTION).round().max(1.0) as usize;
        let mut band_all = Vec::new();
        for iy in 0..MAP_CELLS {
            for ix in 0..MAP_CELLS {
                if ix < k || iy < k || ix >= MAP_CELLS - k || iy >= MAP_CELLS - k {
                    let p = cell_position((ix, iy));
                    let r = (p[0] as f64).hypot(p[1] as f64);
                    band_all.push((geometry.index(ix, iy) as u32, [p[0] as f64 / r, p[1] as f64 / r]));
                }
            }
        }
        Ok(Self {
            geometry,
            inflation,
            obstacles: Costmap::new(geometry),
            costmap: Costmap::new(geometry),
            field: DistanceField::new(geometry),
            astar: AStar::new(&geometry),
            path: Vec::with_capacity(1024),
            disc,
            seen: vec![false; MAP_LEN],
            spans: Vec::with_capacity(4 * MAP_CELLS),
            band: Vec::with_capacity(band_all.len()),
            cone: Vec::with_capacity(band_all.len()),
            band_all,
            params,
        })
    }

    /// The parameters.
    pub fn params(&self) -> &DatasetParams {
        &self.params
    }

    /// Sample `index` of `seed` (see the module docs), owned.
    pub fn sample(&mut self, seed: u64, index: u64) -> Sample {
        let info = self.generate(seed, index);
        Sample {
            costmap: self.costmap.clone(),
            goal: info.goal,
            subgoals: info.subgoals,
            path: self.path.clone(),
            trap: info.trap,
        }
    }

    /// Sample `index` of `seed` with its costmap written into `costmap` (row-major, [`MAP_LEN`]
    /// bytes); no allocation. An error names `costmap` if its length is wrong.
    pub fn sample_into(&mut self, seed: u64, index: u64, costmap: &mut [u8]) -> Result<SampleInfo> {
        if costmap.len() != MAP_LEN {
            return Err(Error::Geometry {
                field: "costmap".into(),
                got: format!("{} bytes", costmap.len()),
                expected: format!("{MAP_CELLS} x {MAP_CELLS} = {MAP_LEN} bytes"),
            });
        }
        let info = self.generate(seed, index);
        costmap.copy_from_slice(self.costmap.cells());
        Ok(info)
    }

    /// The A* path of the last sample.
    pub fn path(&self) -> &[(usize, usize)] {
        &self.path
    }

    /// The inflated costmap of the last sample.
    pub fn costmap(&self) -> &Costmap {
        &self.costmap
    }

    fn generate(&mut self, seed: u64, index: u64) -> SampleInfo {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(index);
        for attempt in 0..=MAP_TRIES {
            // The last attempt drops the clutter: a lone trap always leaves the border reachable.
            let clutter = attempt < MAP_TRIES;
            let trap = self.draw_map(&mut rng, clutter);
            if let Some(info) = self.finish(&mut rng, trap) {
                return info;
            }
        }
        // Unreachable in practice: an empty map always has a goal. Keep the output well formed.
        self.obstacles.fill(0);
        self.costmap.fill(0);
        let goal = (MAP_CELLS - 1, MAP_CELLS / 2);
        self.path.clear();
        self.path.push(START_CELL);
        self.path.push(goal);
        self.info(false)
    }

    /// Draws and inflates an obstacle map; returns the trap direction, if any.
    fn draw_map(&mut self, rng: &mut ChaCha8Rng, clutter: bool) -> Option<f64> {
        self.obstacles.fill(0);
        let mut trap = None;
        if rng.random_bool(self.params.trap_probability) {
            let theta = rng.random_range(0.0..std::f64::consts::TAU);
            for _ in 0..PLACEMENT_TRIES {
                let (kind, pl) = self.trap_placement(rng, theta);
                if self.place(&Obstacle::new(kind, &pl)) {
                    break;
                }
            }
            // The goal is drawn behind the trap even when no draw fitted (then there is none).
            trap = Some(theta);
        }
        if clutter {
            let n = rng.random_range(self.params.min_obstacles..=self.params.max_obstacles);
            for _ in 0..n {
                for _ in 0..PLACEMENT_TRIES {
                    let (kind, pl) = clutter_placement(rng);
                    if self.place(&Obstacle::new(kind, &pl)) {
                        break;
                    }
                }
            }
        }
        if self.params.lidar_view {
            self.lidar_view();
        }
        self.field
            .compute(&self.obstacles, LETHAL)
            .and_then(|()| self.inflation.apply(&self.field, &mut self.costmap))
            .expect("the dataset's grids share one geometry");
        trap
    }

    /// Replaces the obstacle layer by a lidar's view of it from the centre (module docs, step 3):
    /// rays in steps of one cell; the hit cell and `shadow_depth` behind it are marked.
    fn lidar_view(&mut self) {
        let truth = &self.obstacles;
        let view = &mut self.costmap;
        view.fill(0);
        let g = self.geometry;
        let n = self.params.lidar_beams;
        let shadow = (self.params.shadow_depth / RESOLUTION).round() as usize;
        let max_steps = 2 * MAP_CELLS;
        let origin = g.center();
        for k in 0..n {
            let a = k as f64 * std::f64::consts::TAU / n as f64;
            let (dy, dx) = a.sin_cos();
            let at = |j: usize| {
                [
                    origin[0] + j as f64 * RESOLUTION * dx,
                    origin[1] + j as f64 * RESOLUTION * dy,
                ]
            };
            let mut j = 0;
            let hit = loop {
                match g.world_to_cell(at(j)) {
                    Some((ix, iy)) if truth.get(ix, iy) >= LETHAL => break Some(j),
                    Some(_) if j < max_steps => j += 1,
                    _ => break None,
                }
            };
            if let Some(j) = hit {
                for m in j..=j + shadow {
                    if !view.mark(at(m), LETHAL) {
                        break;
                    }
                }
            }
        }
        std::mem::swap(&mut self.obstacles, &mut self.costmap);
    }

    /// Rasterises `o` unless a cell centre of the free disc lies in it.
    fn place(&mut self, o: &Obstacle) -> bool {
        if o.near(self.params.free_radius) && self.disc.iter().any(|&p| o.contains(p)) {
            return false;
        }
        o.rasterize(&mut self.obstacles);
        true
    }

    /// A U (75 %) or an L across the line towards `theta`, its opening towards the centre:
    /// ahead of the robot (75 %) or around it.
    fn trap_placement(&self, rng: &mut ChaCha8Rng, theta: f64) -> (Kind, Placement) {
        let r0 = self.params.free_radius;
        let thickness = rng.random_range(0.1..0.3);
        let shear = rng.random_range(-0.15..0.15);
        let jitter = rng.random_range(-0.25..0.25);
        let dir = [theta.cos(), theta.sin()];
        if rng.random_bool(0.75) {
            let ahead = rng.random_bool(0.75);
            let (sx, sy, base) = if ahead {
                // The inner face of the base 0.9 to 3.5 m ahead, the cup 0.6 to 1.8 m deep.
                let sy = rng.random_range(0.6..1.8);
                let base = rng.random_range((r0 + sy).max(0.9)..(r0 + sy).max(0.9) + 2.0);
                (rng.random_range(1.0..2.6), sy, base)
            } else {
                // The robot inside: arms beyond the free disc on both sides, a pocket up to
                // 3.6 m deep with the robot anywhere in its back half.
                let sx = rng.random_range(2.0 * (r0 + thickness) + 0.2..2.0 * (r0 + thickness) + 2.4);
                (sx, rng.random_range(1.4..3.6), rng.random_range(r0 + 0.1..r0 + 1.4))
            };
            // Centre of the U: the base's inner face minus half the depth, plus the wall.
            let c = base - 0.5 * sy + thickness;
            let pl = Placement {
                scale: [sx, sy],
                shear,
                // Local +y (towards the base) along theta.
                rotation: theta - std::f64::consts::FRAC_PI_2 + jitter,
                translation: [c * dir[0], c * dir[1]],
                thickness,
            };
            (Kind::U, pl)
        } else {
            let (sx, sy): (f64, f64) = (rng.random_range(1.0..2.4), rng.random_range(1.0..2.4));
            // The corner (local (+0.5, +0.5)) towards theta, 1 to 3 m away.
            let corner = rng.random_range(r0 + 0.6..3.0);
            let c = corner - 0.5 * sx.hypot(sy);
            let pl = Placement {
                scale: [sx, sy],
                shear,
                rotation: theta - std::f64::consts::FRAC_PI_4 + jitter,
                translation: [c * dir[0], c * dir[1]],
                thickness,
            };
            (Kind::L, pl)
        }
    }

    /// Flood fill, goal, A*, sub-goals; `None` when no border cell is reachable.
    fn finish(&mut self, rng: &mut ChaCha8Rng, trap: Option<f64>) -> Option<SampleInfo> {
        self.reachable_band(trap);
        let pool = if self.cone.is_empty() { &self.band } else { &self.cone };
        if pool.is_empty() {
            return None;
        }
        let t = pool[rng.random_range(0..pool.len())] as usize;
        let goal = self.geometry.cell_of_index(t);
        self.astar
            .search(&self.costmap, START_CELL, goal, &self.params.astar, &mut self.path)?;
        Some(self.info(trap.is_some()))
    }

    fn info(&self, trap: bool) -> SampleInfo {
        let last = self.path.len() - 1;
        let mut subgoals = [[0.0; 2]; NUM_SUBGOALS];
        for (s, &step) in subgoals.iter_mut().zip(&self.params.subgoal_steps) {
            *s = cell_position(self.path[step.min(last)]);
        }
        SampleInfo {
            goal: cell_position(self.path[last]),
            subgoals,
            path_length: self.path.len() as u32,
            trap,
        }
    }

    /// Flood fill from the start through the cells A* may enter (8-connected, as A*; the start
    /// exempt, as in A*), then the reachable goal-band cells and, for a trap, those in its cone.
    /// Scanline fill: whole runs of a row at a time.
    fn reachable_band(&mut self, trap: Option<f64>) {
        let n = MAP_CELLS;
        let blocked = self.params.astar.blocked;
        let cells = self.costmap.cells();
        let start = START_CELL.1 * n + START_CELL.0;
        let seen = &mut self.seen;
        seen.fill(false);
        let open = |i: usize, seen: &[bool]| !seen[i] && (cells[i] < blocked || i == start);
        // Spans (row, first, last) whose neighbouring rows are still to scan.
        let spans = &mut self.spans;
        spans.clear();
        let fill_span = |y: usize, x: usize, seen: &mut [bool], spans: &mut Vec<(u16, u16, u16)>| -> usize {
            let row = y * n;
            let (mut a, mut b) = (x, x);
            while a > 0 && open(row + a - 1, seen) {
                a -= 1;
            }
            while b + 1 < n && open(row + b + 1, seen) {
                b += 1;
            }
            seen[row + a..=row + b].fill(true);
            spans.push((y as u16, a as u16, b as u16));
            b
        };
        fill_span(START_CELL.1, START_CELL.0, seen, spans);
        while let Some((y, x0, x1)) = spans.pop() {
            let (y, x0, x1) = (y as usize, x0 as usize, x1 as usize);
            let (lo, hi) = (x0.saturating_sub(1), (x1 + 1).min(n - 1));
            for ny in [y.wrapping_sub(1), y + 1] {
                if ny >= n {
                    continue;
                }
                let mut x = lo;
                while x <= hi {
                    if open(ny * n + x, seen) {
                        x = fill_span(ny, x, seen, spans) + 2;
                    } else {
                        x += 1;
                    }
                }
            }
        }
        self.band.clear();
        self.cone.clear();
        let cos_cone = TRAP_CONE_DEG.to_radians().cos();
        let dir = trap.map(|t| [t.cos(), t.sin()]);
        for &(i, u) in &self.band_all {
            if self.seen[i as usize] {
                self.band.push(i);
                if let Some(d) = dir {
                    if u[0] * d[0] + u[1] * d[1] >= cos_cone {
                        self.cone.push(i);
                    }
                }
            }
        }
    }
}

/// A random clutter obstacle anywhere on the map.
fn clutter_placement(rng: &mut ChaCha8Rng) -> (Kind, Placement) {
    let u: f64 = rng.random();
    let kind = if u < 0.35 {
        Kind::Rect
    } else if u < 0.6 {
        Kind::Circle
    } else if u < 0.8 {
        Kind::L
    } else {
        Kind::U
    };
    let scale = match kind {
        Kind::Rect => [rng.random_range(0.15..1.5), rng.random_range(0.15..1.5)],
        Kind::Circle => {
            let d = rng.random_range(0.2..1.2);
            [d, d * rng.random_range(0.7..1.3)]
        }
        Kind::L => [rng.random_range(0.6..2.0), rng.random_range(0.6..2.0)],
        Kind::U => [rng.random_range(0.8..2.2), rng.random_range(0.6..1.8)],
    };
    let half = 0.5 * MAP_CELLS as f64 * RESOLUTION;
    let pl = Placement {
        scale,
        shear: rng.random_range(-0.3..0.3),
        rotation: rng.random_range(0.0..std::f64::consts::TAU),
        translation: [rng.random_range(-half..half), rng.random_range(-half..half)],
        thickness: rng.random_range(0.1..0.3),
    };
    (kind, pl)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::FREE;

    #[test]
    fn lidar_view_keeps_faces_and_shadows_and_hides_what_lies_beyond() {
        let mut g = Generator::new(DatasetParams::default()).unwrap();
        let geo = g.geometry;
        g.obstacles.fill(0);
        // Two walls across +x, |y| < 1 m: at x = 1 m and, beyond the 2 m shadow, at x = 4 m.
        for p in [[1.0, 0.0], [4.0, 0.0]] {
            for k in -20..20 {
                let y = 0.05 * k as f64 + 0.025;
                g.obstacles.mark([p[0] + 0.025, y], LETHAL);
            }
        }
        g.lidar_view();
        let at = |p: [f64; 2]| {
            let (ix, iy) = geo.world_to_cell(p).unwrap();
            g.obstacles.get(ix, iy)
        };
        assert_eq!(at([1.025, 0.025]), LETHAL, "the near face");
        assert_eq!(at([2.5, 0.025]), LETHAL, "its shadow");
        assert_eq!(at([4.025, 0.025]), FREE, "the far wall is hidden");
        assert_eq!(at([0.5, 0.025]), FREE, "in front of the face");
        assert_eq!(at([-2.0, 0.025]), FREE);
    }
}
