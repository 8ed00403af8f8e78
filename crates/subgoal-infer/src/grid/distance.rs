//! A distance field: the Euclidean distance (metres) from every cell centre of a costmap to the
//! nearest obstacle cell centre, with a bilinear interpolant and its gradient for smooth
//! obstacle costs.
//!
//! ```
//! use subgoal_infer::grid::{Costmap, DistanceField, GridGeometry, LETHAL};
//! let g = GridGeometry::centered([0.0, 0.0], 100, 100, 0.05)?;
//! let mut map = Costmap::new(g);
//! map.mark([1.0, 0.0], LETHAL);
//! let mut field = DistanceField::new(g);
//! field.compute(&map, LETHAL)?;
//! let (d, grad) = field.sample([0.0, 0.0]);
//! assert!((d - 1.0).abs() < 0.05);
//! assert!(grad[0] < -0.9); // moving towards +x brings the obstacle closer
//! # Ok::<(), subgoal_infer::Error>(())
//! ```

use super::costmap::{Costmap, GridGeometry};
use super::edt::Edt;
use crate::error::{Error, Result};

/// Euclidean distance field over a grid (see the module docs).
#[derive(Debug, Clone)]
pub struct DistanceField {
    geometry: GridGeometry,
    squared: Vec<f64>,
    inside: Vec<f64>,
    dist: Vec<f32>,
    edt: Edt,
    signed: bool,
}

impl DistanceField {
    /// A field with no obstacle (every distance infinite) over `geometry`; allocates the
    /// distances and the transform's scratch once.
    pub fn new(geometry: GridGeometry) -> Self {
        let n = geometry.len();
        Self {
            geometry,
            squared: vec![f64::INFINITY; n],
            inside: vec![f64::INFINITY; n],
            dist: vec![f32::INFINITY; n],
            edt: Edt::new(geometry.width(), geometry.height()),
            signed: false,
        }
    }

    /// Recomputes the field from `costmap`: cells with cost `>= threshold` are obstacles. The
    /// field takes the costmap's placement (a rolling window moves); an error if the costmap's
    /// size or resolution differs from the field's. No allocation.
    pub fn compute(&mut self, costmap: &Costmap, threshold: u8) -> Result<()> {
        self.compute_impl(costmap, threshold, false)
    }

    /// Like [`DistanceField::compute`], but signed: inside obstacles the field is minus the
    /// distance to the nearest free cell, so a cost on it keeps growing into an obstacle and its
    /// gradient points out of it. With `r` the resolution, `d_o` and `d_f` the distances between
    /// cell centres to the nearest obstacle and free cell:
    ///
    /// ```text
    /// sdf = d_o - r/2     on a free cell        sdf = -(d_f - r/2)     on an obstacle cell
    /// ```
    ///
    /// so the zero crossing lies on the cell boundary and the slope across it is 1. Costs two
    /// transforms instead of one.
    pub fn compute_signed(&mut self, costmap: &Costmap, threshold: u8) -> Result<()> {
        self.compute_impl(costmap, threshold, true)
    }

    fn compute_impl(&mut self, costmap: &Costmap, threshold: u8, signed: bool) -> Result<()> {
        let g = costmap.geometry();
        if g.width() != self.geometry.width()
            || g.height() != self.geometry.height()
            || g.resolution() != self.geometry.resolution()
        {
            return Err(Error::Geometry {
                field: "costmap".into(),
                got: format!("{} x {} cells of {} m", g.width(), g.height(), g.resolution()),
                expected: format!(
                    "{} x {} cells of {} m",
                    self.geometry.width(),
                    self.geometry.height(),
                    self.geometry.resolution()
                ),
            });
        }
        self.geometry = *g;
        self.signed = signed;
        let cells = costmap.cells();
        self.edt
            .squared(g.width(), g.height(), |i| cells[i] >= threshold, &mut self.squared);
        let r = g.resolution();
        if signed {
            self.edt
                .squared(g.width(), g.height(), |i| cells[i] < threshold, &mut self.inside);
            for ((d, &o), &f) in self.dist.iter_mut().zip(&self.squared).zip(&self.inside) {
                *d = if o > 0.0 {
                    ((o.sqrt() - 0.5) * r) as f32
                } else {
                    (-(f.sqrt() - 0.5) * r) as f32
                };
            }
        } else {
            for (d, &s) in self.dist.iter_mut().zip(&self.squared) {
                *d = (s.sqrt() * r) as f32;
            }
        }
        Ok(())
    }

    /// Whether the last computation was signed ([`DistanceField::compute_signed`]).
    pub fn is_signed(&self) -> bool {
        self.signed
    }
    /// Grid geometry (the placement of the last [`DistanceField::compute`]).
    pub fn geometry(&self) -> &GridGeometry {
        &self.geometry
    }
    /// Distances in metres, row-major; `INFINITY` when the costmap had no obstacle (and
    /// `-INFINITY` for a signed field without free cells).
    pub fn distances(&self) -> &[f32] {
        &self.dist
    }
    /// Squared distances in cells to the nearest obstacle cell (exact integers), row-major; signed
    /// or not, this is the unsigned transform (inflation reads it).
    pub fn squared_cells(&self) -> &[f64] {
        &self.squared
    }
    /// Distance (m) at the centre of cell `(ix, iy)`.
    pub fn at_cell(&self, ix: usize, iy: usize) -> f64 {
        self.dist[self.geometry.index(ix, iy)] as f64
    }
    /// Whether the field saw any obstacle.
    pub fn has_obstacles(&self) -> bool {
        self.dist.first().is_some_and(|d| d.is_finite())
    }

    /// Distance (m) at world point `p` by bilinear interpolation between cell centres, and its
    /// gradient `[d/dx, d/dy]`. Outside the grid the query is clamped to the border and the
    /// gradient across the border is zero. Without obstacles: `(INFINITY, [0, 0])`.
    #[inline]
    pub fn sample(&self, p: [f64; 2]) -> (f64, [f64; 2]) {
        let g = &self.geometry;
        let (w, h) = (g.width(), g.height());
        let [gx, gy] = g.world_to_grid(p);
        // Cell centres sit at integer + 0.5 grid coordinates.
        let (fx, fy) = (gx - 0.5, gy - 0.5);
        let (ix, tx, clamp_x) = split(fx, w);
        let (iy, ty, clamp_y) = split(fy, h);
        let i00 = iy * w + ix;
        let d00 = self.dist[i00] as f64;
        if d00.is_infinite() {
            // No obstacle (or, signed, no free cell) anywhere: the field is constant.
            return (d00, [0.0, 0.0]);
        }
        let d10 = self.dist[i00 + 1] as f64;
        let d01 = self.dist[i00 + w] as f64;
        let d11 = self.dist[i00 + w + 1] as f64;
        let d = (1.0 - ty) * ((1.0 - tx) * d00 + tx * d10) + ty * ((1.0 - tx) * d01 + tx * d11);
        let r = g.resolution();
        let gx = if clamp_x {
            0.0
        } else {
            ((1.0 - ty) * (d10 - d00) + ty * (d11 - d01)) / r
        };
        let gy = if clamp_y {
            0.0
        } else {
            ((1.0 - tx) * (d01 - d00) + tx * (d11 - d10)) / r
        };
        (d, [gx, gy])
    }
}

/// Lower corner index in `[0, n - 2]`, fraction in `[0, 1]`, and whether the coordinate was
/// clamped.
#[inline]
fn split(f: f64, n: usize) -> (usize, f64, bool) {
    let max = (n - 2) as f64;
    if f.is_nan() || f < 0.0 {
        return (0, 0.0, true);
    }
    let i = f.floor();
    if i > max {
        if f > max + 1.0 {
            return (n - 2, 1.0, true);
        }
        return (n - 2, f - max, false);
    }
    (i as usize, f - i, false)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::LETHAL;
    use rand::{Rng, SeedableRng};

    fn random_map(seed: u64) -> Costmap {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let g = GridGeometry::centered([1.3, -0.7], 60, 50, 0.05).unwrap();
        let mut m = Costmap::new(g);
        for _ in 0..25 {
            let p = [rng.random_range(-0.2..2.8), rng.random_range(-1.9..0.5)];
            m.mark(p, LETHAL);
        }
        m
    }

    #[test]
    fn cells_equal_brute_force_distance() {
        let m = random_map(1);
        let mut f = DistanceField::new(*m.geometry());
        f.compute(&m, LETHAL).unwrap();
        let g = m.geometry();
        let obs: Vec<[f64; 2]> = (0..g.len())
            .filter(|&i| m.cells()[i] >= LETHAL)
            .map(|i| {
                let (x, y) = g.cell_of_index(i);
                g.cell_to_world(x, y)
            })
            .collect();
        for iy in 0..g.height() {
            for ix in 0..g.width() {
                let c = g.cell_to_world(ix, iy);
                let brute = obs
                    .iter()
                    .map(|o| (c[0] - o[0]).hypot(c[1] - o[1]))
                    .fold(f64::INFINITY, f64::min);
                assert!((f.at_cell(ix, iy) - brute).abs() < 1e-5, "({ix}, {iy})");
                let (s, _) = f.sample(c);
                assert!((s - brute).abs() < 1e-5, "sample at the centre of ({ix}, {iy})");
            }
        }
    }

    #[test]
    fn gradient_matches_finite_differences() {
        let m = random_map(2);
        let mut f = DistanceField::new(*m.geometry());
        f.compute(&m, LETHAL).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let h = 1e-6;
        let mut checked = 0;
        while checked < 300 {
            let p = [rng.random_range(-0.4..3.0), rng.random_range(-2.0..0.6)];
            let (_, g) = f.sample(p);
            let (xp, _) = f.sample([p[0] + h, p[1]]);
            let (xm, _) = f.sample([p[0] - h, p[1]]);
            let (yp, _) = f.sample([p[0], p[1] + h]);
            let (ym, _) = f.sample([p[0], p[1] - h]);
            // Skip points within h of a cell-centre line, where the interpolant has a kink.
            let q = f.geometry().world_to_grid(p);
            if q.iter().any(|c| ((c - 0.5) - (c - 0.5).round()).abs() < 1e-4) {
                continue;
            }
            assert!(((xp - xm) / (2.0 * h) - g[0]).abs() < 1e-4, "d/dx at {p:?}");
            assert!(((yp - ym) / (2.0 * h) - g[1]).abs() < 1e-4, "d/dy at {p:?}");
            checked += 1;
        }
    }

    #[test]
    fn signed_field_equals_brute_force() {
        let g = GridGeometry::centered([0.0, 0.0], 40, 30, 0.1).unwrap();
        let mut m = Costmap::new(g);
        // A filled 1.2 m x 0.8 m block and a single cell.
        for iy in 10..18 {
            for ix in 5..17 {
                m.set(ix, iy, LETHAL);
            }
        }
        m.set(30, 5, LETHAL);
        let mut f = DistanceField::new(g);
        f.compute_signed(&m, LETHAL).unwrap();
        assert!(f.is_signed());
        let centres: Vec<([f64; 2], bool)> = (0..g.len())
            .map(|i| {
                let (x, y) = g.cell_of_index(i);
                (g.cell_to_world(x, y), m.cells()[i] >= LETHAL)
            })
            .collect();
        for (c, occ) in &centres {
            let nearest = |want: bool| {
                centres
                    .iter()
                    .filter(|(_, o)| *o == want)
                    .map(|(p, _)| (p[0] - c[0]).hypot(p[1] - c[1]))
                    .fold(f64::INFINITY, f64::min)
            };
            let want = if *occ {
                -(nearest(false) - 0.05)
            } else {
                nearest(true) - 0.05
            };
            let (got, _) = f.sample(*c);
            assert!((got - want).abs() < 1e-5, "{c:?}: {got} vs {want}");
        }
        // Deep inside the block the gradient points out through the nearest side (-y here).
        let (d, grad) = f.sample([-0.92, -0.33]);
        assert!(d < -0.1 && grad[1] < -0.5 && grad[0].abs() < 0.3, "{d} {grad:?}");
    }

    #[test]
    fn no_obstacle_is_infinite_and_flat() {
        let g = GridGeometry::centered([0.0, 0.0], 10, 10, 0.1).unwrap();
        let mut f = DistanceField::new(g);
        f.compute(&Costmap::new(g), LETHAL).unwrap();
        assert!(!f.has_obstacles());
        assert_eq!(f.sample([0.2, 0.1]), (f64::INFINITY, [0.0, 0.0]));
    }

    #[test]
    fn outside_queries_clamp() {
        let g = GridGeometry::centered([0.0, 0.0], 20, 20, 0.1).unwrap();
        let mut m = Costmap::new(g);
        m.mark([0.0, 0.0], LETHAL);
        let mut f = DistanceField::new(g);
        f.compute(&m, LETHAL).unwrap();
        let (d, grad) = f.sample([50.0, 0.02]);
        assert!(d.is_finite() && d > 0.8);
        assert_eq!(grad[0], 0.0);
        let wrong = Costmap::new(GridGeometry::centered([0.0, 0.0], 21, 20, 0.1).unwrap());
        assert!(f
            .compute(&wrong, LETHAL)
            .unwrap_err()
            .to_string()
            .starts_with("costmap"));
    }
}
