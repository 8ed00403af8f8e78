//! Quadtree grids over the TCP domain: one per DP time index (Richter et al. (2023), Section IV).
//!
//! A [`QuadGrid`] is a forest of quadtrees, one per root cell of the [`Domain`]. Its leaves
//! partition the domain; the grid points of the DP are the corners of the leaves (the vertices),
//! and a value function is stored as one value per vertex. Inside a leaf, values are interpolated
//! bilinearly from the leaf's four corners: the `nu_i` (vertices of the containing cell) and `w_i`
//! (weights) of eq. (4). A corner of a small leaf that lies on the edge of a larger neighbour (a
//! hanging node) is a grid point of the small leaves only.
//!
//! [`QuadGrid::split`] is the splitting operator of Section IV: a leaf becomes four children of
//! half its size, which adds up to five vertices (its centre and edge midpoints). Cells are
//! addressed by [`CellId`]s that stay valid across splits; coordinates are kept as integers in
//! units of the finest possible cell, so vertices shared by neighbours are found exactly.
//!
//! ```
//! use idnp::quadtree::QuadGrid;
//! use idnp::scene::Domain;
//! let domain = Domain { min: [0.0, 0.0], cells: [2, 1], cell_size: 1.0 };
//! let mut grid = QuadGrid::new(domain, 4).unwrap();
//! assert_eq!((grid.leaf_count(), grid.vertex_count()), (2, 6));
//! let cell = grid.locate([0.3, 0.7]).unwrap();
//! assert!(grid.split(&[cell]) == 1);
//! assert_eq!((grid.leaf_count(), grid.vertex_count()), (5, 11));
//! ```

use std::collections::HashMap;

use serde::Serialize;

use crate::error::{Error, Result};
use crate::scene::Domain;

/// Deepest level a grid can reach (`2^MAX_LEVEL` finest cells per root cell side).
pub const MAX_LEVEL: u8 = 20;

/// Most root cells a domain may have (`cells[0] * cells[1]`): a bound checked before anything
/// is allocated, so that a mistyped domain is an error instead of an allocation failure.
pub const MAX_ROOT_CELLS: usize = 1 << 16;

/// Most cells a grid may start with (root cells times `4^level` for a uniform grid).
pub const MAX_INITIAL_CELLS: usize = 1 << 20;

/// Root cells of `domain`, or an error naming `domain.cells` when there are none or more than
/// [`MAX_ROOT_CELLS`].
pub fn root_cells(domain: &Domain) -> Result<usize> {
    if domain.cells[0] == 0 || domain.cells[1] == 0 {
        return Err(Error::invalid(
            "domain.cells",
            "needs at least one cell in each direction",
        ));
    }
    match domain.cells[0].checked_mul(domain.cells[1]) {
        Some(n) if n <= MAX_ROOT_CELLS => Ok(n),
        _ => Err(Error::invalid(
            "domain.cells",
            format!(
                "{} x {} root cells, more than the {MAX_ROOT_CELLS} allowed",
                domain.cells[0], domain.cells[1]
            ),
        )),
    }
}

/// Cells of a uniform grid of `level` on `domain`, or an error naming `field` when there would
/// be more than [`MAX_INITIAL_CELLS`].
pub fn uniform_cells(domain: &Domain, level: u8, field: &str) -> Result<usize> {
    let roots = root_cells(domain)?;
    match 4usize.checked_pow(level.into()).and_then(|f| f.checked_mul(roots)) {
        Some(n) if n <= MAX_INITIAL_CELLS => Ok(n),
        _ => Err(Error::invalid(
            field,
            format!(
                "a uniform grid of level {level} on {roots} root cells has 4^{level} x {roots} cells, more than the {MAX_INITIAL_CELLS} allowed"
            ),
        )),
    }
}

/// Index of a cell in its [`QuadGrid`] (stable across splits).
pub type CellId = usize;

/// A grid point's integer coordinates in units of the finest cell (`2^-MAX_LEVEL` root cells)
/// from the domain's lower corner: unlike vertex indices, keys survive splits.
pub type VertexKey = (u64, u64);

/// One cell of a quadtree.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Node {
    /// Lower-left corner in units of the finest cell.
    ix: u64,
    iy: u64,
    /// Depth below the root cell (0 for a root).
    level: u8,
    /// First of the four children (lower-left, lower-right, upper-left, upper-right), if split.
    children: Option<usize>,
}

/// Geometry of a cell.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Cell {
    /// Centre (m).
    pub center: [f64; 2],
    /// Side length (m).
    pub size: f64,
    /// Depth below its root cell.
    pub level: u8,
}

impl Cell {
    /// Lower-left corner.
    pub fn min(&self) -> [f64; 2] {
        [self.center[0] - 0.5 * self.size, self.center[1] - 0.5 * self.size]
    }
    /// Upper-right corner.
    pub fn max(&self) -> [f64; 2] {
        [self.center[0] + 0.5 * self.size, self.center[1] + 0.5 * self.size]
    }
}

/// A quadtree grid over a [`Domain`]. See the [module docs](self).
#[derive(Debug, Clone)]
pub struct QuadGrid {
    domain: Domain,
    max_level: u8,
    nodes: Vec<Node>,
    /// Leaf ids in a fixed order (roots row-major, children depth-first).
    leaves: Vec<CellId>,
    /// Vertex positions, in the order they are first met along `leaves`.
    vertices: Vec<[f64; 2]>,
    /// Integer coordinates of the vertices (units of the finest cell): stable across splits.
    vertex_keys: Vec<VertexKey>,
    /// Corner vertices of each cell (lower-left, lower-right, upper-left, upper-right); only
    /// meaningful for leaves.
    corners: Vec<[usize; 4]>,
}

impl QuadGrid {
    /// The root cells of `domain`, splittable down to `max_level` (at most [`MAX_LEVEL`]).
    pub fn new(domain: Domain, max_level: u8) -> Result<Self> {
        if max_level > MAX_LEVEL {
            return Err(Error::invalid(
                "max_level",
                format!("must be at most {MAX_LEVEL}, got {max_level}"),
            ));
        }
        let roots = root_cells(&domain)?;
        if !(domain.cell_size.is_finite() && domain.cell_size > 0.0) {
            return Err(Error::invalid("domain.cell_size", "must be finite and > 0"));
        }
        let unit = 1u64 << MAX_LEVEL;
        let mut nodes = Vec::with_capacity(roots);
        for j in 0..domain.cells[1] {
            for i in 0..domain.cells[0] {
                nodes.push(Node {
                    ix: i as u64 * unit,
                    iy: j as u64 * unit,
                    level: 0,
                    children: None,
                });
            }
        }
        let mut grid = Self {
            domain,
            max_level,
            nodes,
            leaves: Vec::new(),
            vertices: Vec::new(),
            vertex_keys: Vec::new(),
            corners: Vec::new(),
        };
        grid.rebuild();
        Ok(grid)
    }

    /// A uniform grid: every root cell split down to `level` (`<= max_level`).
    pub fn uniform(domain: Domain, level: u8, max_level: u8) -> Result<Self> {
        if level > max_level {
            return Err(Error::invalid(
                "level",
                format!("must be at most max_level = {max_level}, got {level}"),
            ));
        }
        uniform_cells(&domain, level, "level")?;
        let mut grid = Self::new(domain, max_level)?;
        for _ in 0..level {
            let leaves = grid.leaves.clone();
            grid.split(&leaves);
        }
        Ok(grid)
    }

    /// The domain.
    pub fn domain(&self) -> &Domain {
        &self.domain
    }
    /// The deepest level a split may create.
    pub fn max_level(&self) -> u8 {
        self.max_level
    }
    /// Number of cells, leaves and internal ones.
    pub fn cell_count(&self) -> usize {
        self.nodes.len()
    }
    /// Number of leaves.
    pub fn leaf_count(&self) -> usize {
        self.leaves.len()
    }
    /// Number of grid points (distinct leaf corners): the memory of a value function.
    pub fn vertex_count(&self) -> usize {
        self.vertices.len()
    }
    /// The leaves, in a fixed order.
    pub fn leaves(&self) -> &[CellId] {
        &self.leaves
    }
    /// The grid points.
    pub fn vertices(&self) -> &[[f64; 2]] {
        &self.vertices
    }
    /// The keys of the grid points, in vertex order.
    pub fn vertex_keys(&self) -> &[VertexKey] {
        &self.vertex_keys
    }
    /// Whether `id` is a leaf (an unknown id is not).
    pub fn is_leaf(&self, id: CellId) -> bool {
        self.nodes.get(id).is_some_and(|n| n.children.is_none())
    }
    /// Deepest level among the leaves.
    pub fn depth(&self) -> u8 {
        self.leaves.iter().map(|&l| self.nodes[l].level).max().unwrap_or(0)
    }

    /// Geometry of cell `id` (`None` for an unknown id).
    pub fn cell(&self, id: CellId) -> Option<Cell> {
        let n = self.nodes.get(id)?;
        let size = self.domain.cell_size / (1u64 << n.level) as f64;
        let [x, y] = self.point(n.ix, n.iy);
        Some(Cell {
            center: [x + 0.5 * size, y + 0.5 * size],
            size,
            level: n.level,
        })
    }

    /// The children of cell `id`, if it was split.
    pub fn children(&self, id: CellId) -> Option<[CellId; 4]> {
        let c = self.nodes.get(id)?.children?;
        Some([c, c + 1, c + 2, c + 3])
    }

    /// Corner vertex indices of leaf `id` (lower-left, lower-right, upper-left, upper-right).
    pub fn leaf_corners(&self, id: CellId) -> Option<[usize; 4]> {
        self.is_leaf(id).then(|| self.corners[id])
    }

    fn point(&self, ix: u64, iy: u64) -> [f64; 2] {
        let unit = (1u64 << MAX_LEVEL) as f64;
        [
            self.domain.min[0] + ix as f64 / unit * self.domain.cell_size,
            self.domain.min[1] + iy as f64 / unit * self.domain.cell_size,
        ]
    }

    /// The leaf containing `p` (cells are half-open `[min, max)`, except that the upper domain
    /// boundary belongs to the last cells), or `None` outside the domain or for NaN.
    pub fn locate(&self, p: [f64; 2]) -> Option<CellId> {
        if !self.domain.contains(p) {
            return None;
        }
        let h = self.domain.cell_size;
        let i = (((p[0] - self.domain.min[0]) / h).floor() as usize).min(self.domain.cells[0] - 1);
        let j = (((p[1] - self.domain.min[1]) / h).floor() as usize).min(self.domain.cells[1] - 1);
        let mut id = j * self.domain.cells[0] + i;
        while let Some(c) = self.nodes[id].children {
            let cell = self.cell(id).expect("valid id");
            let right = p[0] >= cell.center[0];
            let up = p[1] >= cell.center[1];
            id = c + right as usize + 2 * up as usize;
        }
        Some(id)
    }

    /// Every leaf whose closed cell contains `p` (one in the interior of a leaf, two on an edge,
    /// up to four at a corner): the cells "containing" a point in eq. (6). Empty outside the
    /// domain.
    pub fn leaves_containing(&self, p: [f64; 2]) -> Vec<CellId> {
        if !self.domain.contains(p) {
            return Vec::new();
        }
        self.leaves_intersecting(p, p)
    }

    /// Every leaf whose closed cell intersects the closed box `[lo, hi]`, in leaf order (edges
    /// compared with a relative tolerance of `1e-9` of the root cell size).
    pub fn leaves_intersecting(&self, lo: [f64; 2], hi: [f64; 2]) -> Vec<CellId> {
        let tol = 1e-9 * self.domain.cell_size;
        let hits = |id: CellId| {
            let c = self.cell(id).expect("valid id");
            let (a, b) = (c.min(), c.max());
            a[0] <= hi[0] + tol && b[0] >= lo[0] - tol && a[1] <= hi[1] + tol && b[1] >= lo[1] - tol
        };
        let mut out = Vec::new();
        let mut stack = Vec::new();
        let roots = self.domain.cells[0] * self.domain.cells[1];
        for r in 0..roots {
            if !hits(r) {
                continue;
            }
            stack.push(r);
            while let Some(id) = stack.pop() {
                match self.nodes[id].children {
                    Some(c) => stack.extend([c + 3, c + 2, c + 1, c].into_iter().filter(|&k| hits(k))),
                    None => out.push(id),
                }
            }
        }
        out
    }

    /// Bilinear weights of `p` on the corners of the leaf containing it: `(leaf, [(vertex,
    /// weight); 4])`, the `nu_i`, `w_i` of eq. (4). `None` outside the domain.
    pub fn weights(&self, p: [f64; 2]) -> Option<(CellId, [(usize, f64); 4])> {
        let id = self.locate(p)?;
        let cell = self.cell(id).expect("valid id");
        let lo = cell.min();
        let s = ((p[0] - lo[0]) / cell.size).clamp(0.0, 1.0);
        let t = ((p[1] - lo[1]) / cell.size).clamp(0.0, 1.0);
        let c = self.corners[id];
        Some((
            id,
            [
                (c[0], (1.0 - s) * (1.0 - t)),
                (c[1], s * (1.0 - t)),
                (c[2], (1.0 - s) * t),
                (c[3], s * t),
            ],
        ))
    }

    /// The bilinear interpolation at `p` of `values` (one per vertex); `None` outside the domain
    /// or when `values` has fewer entries than the grid has vertices.
    #[inline]
    pub fn interpolate(&self, values: &[f64], p: [f64; 2]) -> Option<f64> {
        let (_, w) = self.weights(p)?;
        let mut sum = 0.0;
        for &(v, a) in &w {
            sum += a * values.get(v)?;
        }
        Some(sum)
    }

    /// Splits the given cells (the splitting operator of Section IV). Cells that are not leaves,
    /// unknown ids and cells at `max_level` are left alone; duplicates count once. Returns the
    /// number of cells split. Vertex indices change when something is split.
    pub fn split(&mut self, ids: &[CellId]) -> usize {
        let mut count = 0;
        for &id in ids {
            let Some(n) = self.nodes.get(id).copied() else {
                continue;
            };
            if n.children.is_some() || n.level >= self.max_level {
                continue;
            }
            let half = 1u64 << (MAX_LEVEL - n.level - 1);
            let first = self.nodes.len();
            for (dx, dy) in [(0, 0), (half, 0), (0, half), (half, half)] {
                self.nodes.push(Node {
                    ix: n.ix + dx,
                    iy: n.iy + dy,
                    level: n.level + 1,
                    children: None,
                });
            }
            self.nodes[id].children = Some(first);
            count += 1;
        }
        if count > 0 {
            self.rebuild();
        }
        count
    }

    /// Restores the 2:1 balance of the grid: splits every leaf that touches (by an edge or a
    /// corner) a leaf more than one level deeper, until none does. Returns the number of cells
    /// split.
    ///
    /// Why: a value inside a leaf is interpolated from the leaf's four corners only. A coarse leaf
    /// next to a refined region keeps the values of its far corners (one of them, say, inside an
    /// obstacle) while its neighbour is resolved finely, so the DP would see the coarse side as
    /// expensive and keep choosing the refined cell even when the free space lies across the edge.
    /// Grading the refinement (neighbours differ by at most one level) spreads it to where the
    /// interpolation draws its values from.
    pub fn balance(&mut self) -> usize {
        let mut total = 0;
        let eps = self.domain.cell_size / (1u64 << (self.max_level.min(MAX_LEVEL - 2) + 2)) as f64;
        loop {
            let mut to_split: Vec<CellId> = Vec::new();
            for &id in &self.leaves {
                let Some(c) = self.cell(id) else { continue };
                if c.level < 2 {
                    continue;
                }
                let reach = 0.5 * c.size + eps;
                for (dx, dy) in [
                    (-1.0, -1.0),
                    (0.0, -1.0),
                    (1.0, -1.0),
                    (-1.0, 0.0),
                    (1.0, 0.0),
                    (-1.0, 1.0),
                    (0.0, 1.0),
                    (1.0, 1.0),
                ] {
                    let p = [c.center[0] + dx * reach, c.center[1] + dy * reach];
                    if let Some(n) = self.locate(p) {
                        if self.nodes[n].level + 1 < c.level && !to_split.contains(&n) {
                            to_split.push(n);
                        }
                    }
                }
            }
            if to_split.is_empty() {
                return total;
            }
            total += self.split(&to_split);
        }
    }

    /// Splits the leaf containing each point (outside points are skipped); returns the number of
    /// cells split.
    pub fn split_at(&mut self, points: &[[f64; 2]]) -> usize {
        let ids: Vec<CellId> = points.iter().filter_map(|&p| self.locate(p)).collect();
        self.split(&ids)
    }

    /// Recomputes the leaf list and the vertex table.
    fn rebuild(&mut self) {
        self.leaves.clear();
        let roots = self.domain.cells[0] * self.domain.cells[1];
        let mut stack = Vec::new();
        for r in 0..roots {
            stack.push(r);
            while let Some(id) = stack.pop() {
                match self.nodes[id].children {
                    // Depth-first, lower-left child first.
                    Some(c) => stack.extend([c + 3, c + 2, c + 1, c]),
                    None => self.leaves.push(id),
                }
            }
        }
        self.vertices.clear();
        self.vertex_keys.clear();
        self.corners.clear();
        self.corners.resize(self.nodes.len(), [usize::MAX; 4]);
        let mut index: HashMap<(u64, u64), usize> = HashMap::with_capacity(2 * self.leaves.len());
        for &id in &self.leaves {
            let n = self.nodes[id];
            let s = 1u64 << (MAX_LEVEL - n.level);
            let mut c = [0; 4];
            for (k, (dx, dy)) in [(0, 0), (s, 0), (0, s), (s, s)].into_iter().enumerate() {
                let key = (n.ix + dx, n.iy + dy);
                let next = self.vertices.len();
                let v = *index.entry(key).or_insert(next);
                if v == next {
                    let p = self.point(key.0, key.1);
                    self.vertices.push(p);
                    self.vertex_keys.push(key);
                }
                c[k] = v;
            }
            self.corners[id] = c;
        }
    }
}
