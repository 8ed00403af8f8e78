//! 8-connected, cost-aware A* on a [`Costmap`].
//!
//! Moving into cell `c` costs its step length (1 or `sqrt 2` cells) times
//! `1 + cost_weight * min(cost(c), 252) / 252`; cells with cost `>= blocked` are impassable
//! (the start cell is exempt, so a robot inside an inflated zone can leave it). The heuristic is
//! the octile distance, consistent because every step costs at least its length, so the path is
//! optimal.
//!
//! ```
//! use subgoal_infer::grid::{AStar, AStarParams, Costmap, GridGeometry, LETHAL};
//! let mut map = Costmap::new(GridGeometry::new(10, 10, 0.1, [0.0, 0.0])?);
//! for y in 0..9 {
//!     map.set(5, y, LETHAL); // a wall with a gap at the top
//! }
//! let mut astar = AStar::new(map.geometry());
//! let mut path = Vec::new();
//! let cost = astar.search(&map, (0, 0), (9, 0), &AStarParams::default(), &mut path);
//! assert!(cost.is_some());
//! assert!(path.iter().all(|&(x, y)| map.get(x, y) < LETHAL));
//! assert!(path.iter().any(|&(_, y)| y == 9)); // it went through the gap
//! # Ok::<(), subgoal_infer::Error>(())
//! ```

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use super::costmap::{Costmap, GridGeometry, INSCRIBED, MAX_NON_OBSTACLE};

/// Parameters of [`AStar::search`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AStarParams {
    /// Cells with cost `>=` this are impassable (default [`INSCRIBED`]: the robot's inscribed
    /// circle would touch an obstacle).
    pub blocked: u8,
    /// How much the inflation cost lengthens a step: a cell of cost 252 costs
    /// `1 + cost_weight` times its length (default 3).
    pub cost_weight: f64,
}

impl Default for AStarParams {
    fn default() -> Self {
        Self {
            blocked: INSCRIBED,
            cost_weight: 3.0,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Node {
    f: f64,
    g: f64,
    index: u32,
}

impl Eq for Node {}

impl Ord for Node {
    fn cmp(&self, other: &Self) -> Ordering {
        // Min-heap on f; among equal f prefer the deeper node (larger g).
        other
            .f
            .total_cmp(&self.f)
            .then_with(|| self.g.total_cmp(&other.g))
            .then_with(|| other.index.cmp(&self.index))
    }
}

impl PartialOrd for Node {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// A* workspace for grids of one size: searches reuse every buffer (no allocation once the
/// open list and the path have grown to their working size).
#[derive(Debug, Clone)]
pub struct AStar {
    width: usize,
    height: usize,
    g: Vec<f64>,
    parent: Vec<u32>,
    /// `visit[i] == generation` when `g[i]` belongs to the current search; `closed` likewise.
    visit: Vec<u32>,
    closed: Vec<u32>,
    generation: u32,
    open: BinaryHeap<Node>,
    expanded: usize,
}

const NEIGHBOURS: [(i64, i64, f64); 8] = [
    (1, 0, 1.0),
    (-1, 0, 1.0),
    (0, 1, 1.0),
    (0, -1, 1.0),
    (1, 1, std::f64::consts::SQRT_2),
    (1, -1, std::f64::consts::SQRT_2),
    (-1, 1, std::f64::consts::SQRT_2),
    (-1, -1, std::f64::consts::SQRT_2),
];

impl AStar {
    /// Allocates the workspace for grids of `geometry`'s size.
    pub fn new(geometry: &GridGeometry) -> Self {
        let n = geometry.len();
        Self {
            width: geometry.width(),
            height: geometry.height(),
            g: vec![0.0; n],
            parent: vec![0; n],
            visit: vec![0; n],
            closed: vec![0; n],
            generation: 0,
            open: BinaryHeap::with_capacity(1024),
            expanded: 0,
        }
    }

    /// Cells expanded by the last search.
    pub fn expanded(&self) -> usize {
        self.expanded
    }

    fn heuristic(&self, a: usize, goal: (usize, usize)) -> f64 {
        let (x, y) = (a % self.width, a / self.width);
        let dx = x.abs_diff(goal.0) as f64;
        let dy = y.abs_diff(goal.1) as f64;
        dx.max(dy) + (std::f64::consts::SQRT_2 - 1.0) * dx.min(dy)
    }

    /// Cheapest 8-connected path from `start` to `goal` (cells `(ix, iy)`), written to `path`
    /// (start first, goal last). Returns its cost in cells, or `None` when the goal is blocked,
    /// unreachable, outside the grid, or the costmap's size differs from the workspace's.
    pub fn search(
        &mut self,
        map: &Costmap,
        start: (usize, usize),
        goal: (usize, usize),
        params: &AStarParams,
        path: &mut Vec<(usize, usize)>,
    ) -> Option<f64> {
        path.clear();
        self.expanded = 0;
        let (w, h) = (self.width, self.height);
        if map.width() != w || map.height() != h || start.0 >= w || start.1 >= h || goal.0 >= w || goal.1 >= h {
            return None;
        }
        let cells = map.cells();
        let s = start.1 * w + start.0;
        let t = goal.1 * w + goal.0;
        if cells[t] >= params.blocked {
            return None;
        }
        self.generation = self.generation.wrapping_add(1);
        if self.generation == 0 {
            self.visit.fill(0);
            self.closed.fill(0);
            self.generation = 1;
        }
        let gen = self.generation;
        self.open.clear();
        self.g[s] = 0.0;
        self.visit[s] = gen;
        self.parent[s] = s as u32;
        self.open.push(Node {
            f: self.heuristic(s, goal),
            g: 0.0,
            index: s as u32,
        });
        let scale = params.cost_weight / MAX_NON_OBSTACLE as f64;
        while let Some(node) = self.open.pop() {
            let i = node.index as usize;
            if self.closed[i] == gen || node.g > self.g[i] {
                continue;
            }
            self.closed[i] = gen;
            self.expanded += 1;
            if i == t {
                let mut c = t;
                path.push((c % w, c / w));
                while c != s {
                    c = self.parent[c] as usize;
                    path.push((c % w, c / w));
                }
                path.reverse();
                return Some(node.g);
            }
            let (x, y) = ((i % w) as i64, (i / w) as i64);
            for &(dx, dy, len) in &NEIGHBOURS {
                let (nx, ny) = (x + dx, y + dy);
                if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                    continue;
                }
                let j = ny as usize * w + nx as usize;
                let c = cells[j];
                if c >= params.blocked || self.closed[j] == gen {
                    continue;
                }
                let g = node.g + len * (1.0 + scale * c.min(MAX_NON_OBSTACLE) as f64);
                if self.visit[j] != gen || g < self.g[j] {
                    self.visit[j] = gen;
                    self.g[j] = g;
                    self.parent[j] = i as u32;
                    self.open.push(Node {
                        f: g + self.heuristic(j, goal),
                        g,
                        index: j as u32,
                    });
                }
            }
        }
        None
    }
}

/// The cost of `path` (cells, start first) on `map` under [`AStar::search`]'s step costs:
/// `None` when a cell after the first is blocked, outside the grid, or two consecutive cells are
/// not 8-neighbours. A path [`AStar::search`] returned costs what it reported, so a previous
/// path can be re-priced on a newer costmap and compared with a fresh search (hysteresis).
pub fn path_cost(map: &Costmap, path: &[(usize, usize)], params: &AStarParams) -> Option<f64> {
    let scale = params.cost_weight / MAX_NON_OBSTACLE as f64;
    let mut total = 0.0;
    for pair in path.windows(2) {
        let ((ax, ay), (bx, by)) = (pair[0], pair[1]);
        if bx >= map.width() || by >= map.height() {
            return None;
        }
        let len = match (ax.abs_diff(bx), ay.abs_diff(by)) {
            (0, 0) => continue,
            (1, 0) | (0, 1) => 1.0,
            (1, 1) => std::f64::consts::SQRT_2,
            _ => return None,
        };
        let c = map.get(bx, by);
        if c >= params.blocked {
            return None;
        }
        total += len * (1.0 + scale * c.min(MAX_NON_OBSTACLE) as f64);
    }
    Some(total)
}

/// The free cell (cost `< blocked`) nearest to `cell` by Euclidean distance, searching square
/// rings out to `max_radius` cells; `None` if there is none.
pub fn nearest_free(map: &Costmap, cell: (usize, usize), blocked: u8, max_radius: usize) -> Option<(usize, usize)> {
    let (w, h) = (map.width() as i64, map.height() as i64);
    let (cx, cy) = (cell.0 as i64, cell.1 as i64);
    let mut best: Option<((usize, usize), i64)> = None;
    for r in 0..=max_radius as i64 {
        // A free cell in ring r is at Euclidean distance >= r: stop once the best is closer.
        if let Some((_, d2)) = best {
            if d2 <= r * r {
                break;
            }
        }
        for y in (cy - r)..=(cy + r) {
            for x in (cx - r)..=(cx + r) {
                if (x - cx).abs() != r && (y - cy).abs() != r {
                    continue;
                }
                if x < 0 || y < 0 || x >= w || y >= h {
                    continue;
                }
                if map.get(x as usize, y as usize) < blocked {
                    let d2 = (x - cx).pow(2) + (y - cy).pow(2);
                    if best.is_none_or(|(_, b)| d2 < b) {
                        best = Some(((x as usize, y as usize), d2));
                    }
                }
            }
        }
    }
    best.map(|(c, _)| c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::LETHAL;
    use rand::{Rng, SeedableRng};

    /// Bellman-Ford style relaxation to a fixed point: the exact cheapest cost to every cell.
    fn brute_costs(map: &Costmap, start: (usize, usize), p: &AStarParams) -> Vec<f64> {
        let (w, h) = (map.width(), map.height());
        let mut d = vec![f64::INFINITY; w * h];
        d[start.1 * w + start.0] = 0.0;
        let scale = p.cost_weight / 252.0;
        loop {
            let mut changed = false;
            for i in 0..w * h {
                if !d[i].is_finite() {
                    continue;
                }
                let (x, y) = ((i % w) as i64, (i / w) as i64);
                for &(dx, dy, len) in &NEIGHBOURS {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                        continue;
                    }
                    let j = ny as usize * w + nx as usize;
                    let c = map.cells()[j];
                    if c >= p.blocked {
                        continue;
                    }
                    let nd = d[i] + len * (1.0 + scale * c.min(252) as f64);
                    if nd < d[j] - 1e-12 {
                        d[j] = nd;
                        changed = true;
                    }
                }
            }
            if !changed {
                return d;
            }
        }
    }

    #[test]
    fn optimal_against_brute_force() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let p = AStarParams::default();
        for case in 0..25 {
            let (w, h) = (rng.random_range(3..25), rng.random_range(3..25));
            let g = GridGeometry::new(w, h, 0.05, [0.0, 0.0]).unwrap();
            let mut map = Costmap::new(g);
            for c in map.cells_mut() {
                let r: f64 = rng.random();
                *c = if r < 0.25 {
                    LETHAL
                } else if r < 0.5 {
                    rng.random_range(0..=252)
                } else {
                    0
                };
            }
            let start = (rng.random_range(0..w), rng.random_range(0..h));
            let d = brute_costs(&map, start, &p);
            let mut astar = AStar::new(&g);
            let mut path = Vec::new();
            for _ in 0..5 {
                let goal = (rng.random_range(0..w), rng.random_range(0..h));
                let got = astar.search(&map, start, goal, &p, &mut path);
                let want = d[goal.1 * w + goal.0];
                let goal_blocked = map.get(goal.0, goal.1) >= p.blocked;
                match got {
                    None => assert!(goal_blocked || want.is_infinite(), "case {case}: missed a path"),
                    Some(c) => {
                        assert!((c - want).abs() < 1e-9, "case {case}: cost {c} vs {want}");
                        assert_eq!(path.first(), Some(&start));
                        assert_eq!(path.last(), Some(&goal));
                        let mut sum = 0.0;
                        for k in 1..path.len() {
                            let (a, b) = (path[k - 1], path[k]);
                            let (dx, dy) = (a.0.abs_diff(b.0), a.1.abs_diff(b.1));
                            assert!(dx <= 1 && dy <= 1 && dx + dy > 0, "not 8-connected");
                            let cost = map.get(b.0, b.1);
                            assert!(cost < p.blocked, "path through a blocked cell");
                            let len = if dx + dy == 2 { std::f64::consts::SQRT_2 } else { 1.0 };
                            sum += len * (1.0 + p.cost_weight * cost as f64 / 252.0);
                        }
                        assert!((sum - c).abs() < 1e-9, "path cost {sum} vs reported {c}");
                        let priced = path_cost(&map, &path, &p).expect("a found path is passable");
                        assert!((priced - c).abs() < 1e-9, "path_cost {priced} vs reported {c}");
                    }
                }
            }
        }
    }

    #[test]
    fn path_cost_rejects_blocked_and_broken_paths() {
        let g = GridGeometry::new(5, 5, 0.1, [0.0, 0.0]).unwrap();
        let mut map = Costmap::new(g);
        let p = AStarParams::default();
        assert_eq!(
            path_cost(&map, &[(0, 0), (1, 1), (2, 1)], &p),
            Some(std::f64::consts::SQRT_2 + 1.0)
        );
        assert_eq!(path_cost(&map, &[(0, 0), (2, 0)], &p), None, "a jump of two cells");
        assert_eq!(path_cost(&map, &[(3, 3)], &p), Some(0.0));
        map.set(2, 1, LETHAL);
        assert_eq!(path_cost(&map, &[(0, 0), (1, 1), (2, 1)], &p), None);
        // The start cell is exempt, as in the search.
        assert_eq!(path_cost(&map, &[(2, 1), (3, 1)], &p), Some(1.0));
    }

    #[test]
    fn blocked_start_may_leave_and_blocked_goal_fails() {
        let g = GridGeometry::new(5, 5, 0.1, [0.0, 0.0]).unwrap();
        let mut map = Costmap::new(g);
        map.set(0, 0, LETHAL);
        map.set(4, 4, LETHAL);
        let mut a = AStar::new(&g);
        let mut path = Vec::new();
        assert!(a
            .search(&map, (0, 0), (3, 3), &AStarParams::default(), &mut path)
            .is_some());
        assert!(a
            .search(&map, (0, 0), (4, 4), &AStarParams::default(), &mut path)
            .is_none());
        assert!(path.is_empty());
        assert_eq!(nearest_free(&map, (4, 4), INSCRIBED, 3), Some((4, 3)));
    }
}
