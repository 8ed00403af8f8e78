//! A 2D cost grid in the world frame, as nav2's local costmap: `u8` costs, `0` free,
//! [`INSCRIBED`] and [`LETHAL`] at the top, a rolling window that follows the robot.
//!
//! Cells are stored row-major, `index = iy * width + ix`; `ix` grows with world `x` and `iy` with
//! world `y`. Cell `(ix, iy)` covers `[ox + ix r, ox + (ix + 1) r) x [oy + iy r, oy + (iy + 1) r)`
//! where `(ox, oy)` is the [`GridGeometry::origin`] (the outer corner of cell `(0, 0)`) and `r`
//! the resolution.

use crate::error::{finite_each, positive, Error, Result};

/// Free space.
pub const FREE: u8 = 0;
/// Largest cost of the inflation decay (`252`): cells cheaper than [`INSCRIBED`].
pub const MAX_NON_OBSTACLE: u8 = 252;
/// The robot's inscribed circle centred here touches an obstacle.
pub const INSCRIBED: u8 = 253;
/// An obstacle.
pub const LETHAL: u8 = 254;

/// Size, resolution and placement of a grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridGeometry {
    width: usize,
    height: usize,
    resolution: f64,
    origin: [f64; 2],
}

impl GridGeometry {
    /// `width x height` cells of `resolution` metres whose outer corner of cell `(0, 0)` is at
    /// `origin`. Errors name the field: sizes must be at least 2, the resolution positive.
    pub fn new(width: usize, height: usize, resolution: f64, origin: [f64; 2]) -> Result<Self> {
        if width < 2 {
            return Err(Error::invalid(
                "width",
                format!("must be at least 2 cells, got {width}"),
            ));
        }
        if height < 2 {
            return Err(Error::invalid(
                "height",
                format!("must be at least 2 cells, got {height}"),
            ));
        }
        if width.checked_mul(height).is_none_or(|n| n > u32::MAX as usize / 2) {
            return Err(Error::invalid("width", format!("{width} x {height} cells is too many")));
        }
        positive("resolution", resolution)?;
        finite_each("origin", origin)?;
        Ok(Self {
            width,
            height,
            resolution,
            origin,
        })
    }

    /// A grid of `width x height` cells centred on `center`, its cells aligned with the world
    /// lattice of step `resolution` (so a rolling window keeps its cells when it moves).
    pub fn centered(center: [f64; 2], width: usize, height: usize, resolution: f64) -> Result<Self> {
        let mut g = Self::new(width, height, resolution, [0.0, 0.0])?;
        finite_each("center", center)?;
        g.origin = g.aligned_origin(center);
        Ok(g)
    }

    /// The DDPEN costmap: 200 x 200 cells of 5 cm (10 m x 10 m) centred on `center`.
    pub fn ddpen(center: [f64; 2]) -> Self {
        Self::centered(center, 200, 200, 0.05).expect("constant geometry is valid")
    }

    fn aligned_origin(&self, center: [f64; 2]) -> [f64; 2] {
        let r = self.resolution;
        [
            ((center[0] / r).floor() - (self.width / 2) as f64) * r,
            ((center[1] / r).floor() - (self.height / 2) as f64) * r,
        ]
    }

    /// Number of columns (`x`).
    pub fn width(&self) -> usize {
        self.width
    }
    /// Number of rows (`y`).
    pub fn height(&self) -> usize {
        self.height
    }
    /// Number of cells.
    pub fn len(&self) -> usize {
        self.width * self.height
    }
    /// Always `false` (a grid has at least 2 x 2 cells); for clippy's `len` convention.
    pub fn is_empty(&self) -> bool {
        false
    }
    /// Cell side in metres.
    pub fn resolution(&self) -> f64 {
        self.resolution
    }
    /// World position of the outer corner of cell `(0, 0)`.
    pub fn origin(&self) -> [f64; 2] {
        self.origin
    }
    /// World position of the grid's centre.
    pub fn center(&self) -> [f64; 2] {
        [
            self.origin[0] + 0.5 * self.width as f64 * self.resolution,
            self.origin[1] + 0.5 * self.height as f64 * self.resolution,
        ]
    }
    /// Side lengths in metres.
    pub fn size(&self) -> [f64; 2] {
        [
            self.width as f64 * self.resolution,
            self.height as f64 * self.resolution,
        ]
    }
    /// Flat index of `(ix, iy)`.
    #[inline]
    pub fn index(&self, ix: usize, iy: usize) -> usize {
        iy * self.width + ix
    }
    /// `(ix, iy)` of a flat index.
    #[inline]
    pub fn cell_of_index(&self, i: usize) -> (usize, usize) {
        (i % self.width, i / self.width)
    }
    /// The cell containing world point `p`, or `None` outside the grid.
    #[inline]
    pub fn world_to_cell(&self, p: [f64; 2]) -> Option<(usize, usize)> {
        let [gx, gy] = self.world_to_grid(p);
        if gx >= 0.0 && gy >= 0.0 && gx < self.width as f64 && gy < self.height as f64 {
            Some((gx as usize, gy as usize))
        } else {
            None
        }
    }
    /// The cell nearest to world point `p` (clamped into the grid).
    #[inline]
    pub fn world_to_cell_clamped(&self, p: [f64; 2]) -> (usize, usize) {
        let [gx, gy] = self.world_to_grid(p);
        let cx = gx.floor().clamp(0.0, (self.width - 1) as f64) as usize;
        let cy = gy.floor().clamp(0.0, (self.height - 1) as f64) as usize;
        (cx, cy)
    }
    /// Continuous grid coordinates of `p`: cell `(ix, iy)` spans `[ix, ix + 1) x [iy, iy + 1)`.
    #[inline]
    pub fn world_to_grid(&self, p: [f64; 2]) -> [f64; 2] {
        [
            (p[0] - self.origin[0]) / self.resolution,
            (p[1] - self.origin[1]) / self.resolution,
        ]
    }
    /// World position of the centre of cell `(ix, iy)`.
    #[inline]
    pub fn cell_to_world(&self, ix: usize, iy: usize) -> [f64; 2] {
        [
            self.origin[0] + (ix as f64 + 0.5) * self.resolution,
            self.origin[1] + (iy as f64 + 0.5) * self.resolution,
        ]
    }
    /// Whether world point `p` lies inside the grid.
    pub fn contains(&self, p: [f64; 2]) -> bool {
        self.world_to_cell(p).is_some()
    }
}

/// A grid of `u8` costs (see the module docs for the layout and [`FREE`], [`INSCRIBED`],
/// [`LETHAL`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Costmap {
    geometry: GridGeometry,
    cells: Vec<u8>,
}

impl Costmap {
    /// A free costmap with the given geometry (allocates `width * height` bytes).
    pub fn new(geometry: GridGeometry) -> Self {
        Self {
            cells: vec![FREE; geometry.len()],
            geometry,
        }
    }

    /// A costmap from row-major cells; an error if `cells.len()` is not `width * height`.
    pub fn from_cells(geometry: GridGeometry, cells: Vec<u8>) -> Result<Self> {
        if cells.len() != geometry.len() {
            return Err(Error::Geometry {
                field: "cells".into(),
                got: format!("{} cells", cells.len()),
                expected: format!("{} x {} = {}", geometry.width, geometry.height, geometry.len()),
            });
        }
        Ok(Self { geometry, cells })
    }

    /// The free DDPEN costmap (200 x 200 cells of 5 cm) centred on `center`.
    pub fn ddpen(center: [f64; 2]) -> Self {
        Self::new(GridGeometry::ddpen(center))
    }

    /// Size, resolution and placement.
    pub fn geometry(&self) -> &GridGeometry {
        &self.geometry
    }
    /// Number of columns.
    pub fn width(&self) -> usize {
        self.geometry.width
    }
    /// Number of rows.
    pub fn height(&self) -> usize {
        self.geometry.height
    }
    /// Cell side in metres.
    pub fn resolution(&self) -> f64 {
        self.geometry.resolution
    }
    /// Row-major costs.
    pub fn cells(&self) -> &[u8] {
        &self.cells
    }
    /// Row-major costs, mutable.
    pub fn cells_mut(&mut self) -> &mut [u8] {
        &mut self.cells
    }
    /// Cost of cell `(ix, iy)`; panics outside the grid like slice indexing.
    #[inline]
    pub fn get(&self, ix: usize, iy: usize) -> u8 {
        self.cells[self.geometry.index(ix, iy)]
    }
    /// Sets the cost of cell `(ix, iy)`; panics outside the grid like slice indexing.
    #[inline]
    pub fn set(&mut self, ix: usize, iy: usize, cost: u8) {
        let i = self.geometry.index(ix, iy);
        self.cells[i] = cost;
    }
    /// Cost at world point `p`, `None` outside the grid.
    pub fn cost_at(&self, p: [f64; 2]) -> Option<u8> {
        self.geometry.world_to_cell(p).map(|(x, y)| self.get(x, y))
    }
    /// Raises the cell containing `p` to at least `cost`; `false` when `p` is outside.
    #[inline]
    pub fn mark(&mut self, p: [f64; 2], cost: u8) -> bool {
        match self.geometry.world_to_cell(p) {
            Some((x, y)) => {
                let i = self.geometry.index(x, y);
                self.cells[i] = self.cells[i].max(cost);
                true
            }
            None => false,
        }
    }
    /// Moves the grid to `geometry`'s placement without touching the cells (same size).
    pub(crate) fn place(&mut self, geometry: GridGeometry) {
        debug_assert_eq!(geometry.len(), self.cells.len());
        self.geometry = geometry;
    }
    /// Sets every cell to `cost`.
    pub fn fill(&mut self, cost: u8) {
        self.cells.fill(cost);
    }
    /// Cost decay: lowers every cell by `amount` (saturating at [`FREE`]). Called once per sensor
    /// update, obstacles that are not seen again fade out after `254 / amount` updates.
    pub fn decay(&mut self, amount: u8) {
        if amount > 0 {
            self.cells.iter_mut().for_each(|c| *c = c.saturating_sub(amount));
        }
    }
    /// Rolling window: moves the grid so it is centred on `center` (aligned to the world
    /// lattice), keeping the costs of cells that stay inside and setting new cells to [`FREE`].
    /// No allocation.
    pub fn recenter(&mut self, center: [f64; 2]) {
        let g = self.geometry;
        let new_origin = g.aligned_origin(center);
        let dx = ((new_origin[0] - g.origin[0]) / g.resolution).round() as i64;
        let dy = ((new_origin[1] - g.origin[1]) / g.resolution).round() as i64;
        if dx == 0 && dy == 0 {
            return;
        }
        let (w, h) = (g.width as i64, g.height as i64);
        if dx.abs() >= w || dy.abs() >= h {
            self.cells.fill(FREE);
        } else {
            // New cell (x, y) is old cell (x + dx, y + dy). Iterate so that sources are read
            // before they are overwritten.
            for i in 0..h {
                let y = if dy >= 0 { i } else { h - 1 - i };
                let sy = y + dy;
                let row = (y * w) as usize;
                if !(0..h).contains(&sy) {
                    self.cells[row..row + w as usize].fill(FREE);
                    continue;
                }
                let src_row = (sy * w) as usize;
                // Copy the overlapping span, then clear the rest of the row.
                let (x0, x1) = ((-dx).max(0), (w - dx).min(w));
                let len = (x1 - x0) as usize;
                let src = src_row + (x0 + dx) as usize;
                self.cells.copy_within(src..src + len, row + x0 as usize);
                self.cells[row..row + x0 as usize].fill(FREE);
                self.cells[row + x1 as usize..row + w as usize].fill(FREE);
            }
        }
        self.geometry.origin = [
            g.origin[0] + dx as f64 * g.resolution,
            g.origin[1] + dy as f64 * g.resolution,
        ];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transforms_round_trip() {
        let g = GridGeometry::ddpen([3.02, -1.51]);
        assert_eq!((g.width(), g.height()), (200, 200));
        let c = g.center();
        assert!((c[0] - 3.02).abs() <= 0.05 && (c[1] + 1.51).abs() <= 0.05);
        for &(ix, iy) in &[(0, 0), (199, 199), (17, 123), (100, 100)] {
            let p = g.cell_to_world(ix, iy);
            assert_eq!(g.world_to_cell(p), Some((ix, iy)));
        }
        assert_eq!(g.world_to_cell([c[0] + 5.01, c[1]]), None);
        assert_eq!(g.world_to_cell_clamped([c[0] + 50.0, c[1] - 50.0]), (199, 0));
    }

    #[test]
    fn bad_geometry_names_the_field() {
        let e = GridGeometry::new(1, 10, 0.1, [0.0, 0.0]).unwrap_err();
        assert!(e.to_string().starts_with("width"), "{e}");
        let e = GridGeometry::new(10, 10, -0.1, [0.0, 0.0]).unwrap_err();
        assert!(e.to_string().starts_with("resolution"), "{e}");
        let e = GridGeometry::new(10, 10, 0.1, [f64::NAN, 0.0]).unwrap_err();
        assert!(e.to_string().starts_with("origin[0]"), "{e}");
        let e = Costmap::from_cells(GridGeometry::new(4, 4, 0.1, [0.0; 2]).unwrap(), vec![0; 15]).unwrap_err();
        assert!(e.to_string().starts_with("cells"), "{e}");
    }

    #[test]
    fn recenter_keeps_world_costs() {
        let mut m = Costmap::new(GridGeometry::centered([0.0, 0.0], 40, 30, 0.1).unwrap());
        let pts = [[0.33, 0.41], [-1.72, 1.03], [1.55, -1.21], [0.05, -0.05]];
        for p in pts {
            assert!(m.mark(p, LETHAL));
        }
        for shift in [[0.42, -0.13], [-0.91, 0.77], [0.0, 0.35], [3.0, 0.0], [-0.3, -0.6]] {
            let before = m.clone();
            let c = m.geometry().center();
            m.recenter([c[0] + shift[0], c[1] + shift[1]]);
            for iy in 0..m.height() {
                for ix in 0..m.width() {
                    let p = m.geometry().cell_to_world(ix, iy);
                    let expect = before.cost_at(p).unwrap_or(FREE);
                    assert_eq!(m.get(ix, iy), expect, "cell ({ix}, {iy}) after shift {shift:?}");
                }
            }
        }
        m.recenter([100.0, 100.0]);
        assert!(m.cells().iter().all(|&c| c == FREE));
    }

    #[test]
    fn decay_saturates() {
        let mut m = Costmap::new(GridGeometry::new(4, 4, 1.0, [0.0; 2]).unwrap());
        m.set(1, 1, 30);
        m.set(2, 2, LETHAL);
        m.decay(40);
        assert_eq!(m.get(1, 1), 0);
        assert_eq!(m.get(2, 2), LETHAL - 40);
    }
}
