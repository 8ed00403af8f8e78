//! Inflation (cost dilation from obstacles into free space), as nav2's inflation layer:
//!
//! ```text
//! cost(d) = LETHAL                                         d = 0 (an obstacle cell)
//!         = INSCRIBED                                      0 < d <= r_inscribed
//!         = 252 exp(-k (d - r_inscribed))                  r_inscribed < d <= r_inflation
//!         = FREE                                           d > r_inflation
//! ```
//!
//! with `d` the distance between cell centres from a [`DistanceField`]. The costs depend only on
//! the squared cell distance (an integer), so they come from a table built once.
//!
//! ```
//! use subgoal_infer::grid::{Costmap, DistanceField, GridGeometry, Inflation, INSCRIBED, LETHAL};
//! let g = GridGeometry::centered([0.0, 0.0], 80, 80, 0.05)?;
//! let mut map = Costmap::new(g);
//! map.mark([0.0, 0.0], LETHAL);
//! let mut field = DistanceField::new(g);
//! field.compute(&map, LETHAL)?;
//! let inflation = Inflation::new(0.3, 1.0, 3.0, 0.05)?;
//! let mut out = Costmap::new(g);
//! inflation.apply(&field, &mut out)?;
//! assert_eq!(out.cost_at([0.0, 0.0]), Some(LETHAL));
//! assert_eq!(out.cost_at([0.2, 0.0]), Some(INSCRIBED));
//! assert_eq!(out.cost_at([1.5, 0.0]), Some(0));
//! # Ok::<(), subgoal_infer::Error>(())
//! ```

use super::costmap::{Costmap, FREE, INSCRIBED, LETHAL, MAX_NON_OBSTACLE};
use super::distance::DistanceField;
use crate::error::{nonnegative, positive, Error, Result};

/// Inflation parameters and the cost table for one resolution (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Inflation {
    inscribed_radius: f64,
    inflation_radius: f64,
    cost_scaling: f64,
    resolution: f64,
    /// Cost per squared cell distance `0 ..= (r_inflation / resolution)^2`.
    table: Vec<u8>,
}

impl Inflation {
    /// `inscribed_radius <= inflation_radius` (m), `cost_scaling` the decay rate `k` (1/m), for
    /// grids of `resolution` m. Allocates the cost table.
    pub fn new(inscribed_radius: f64, inflation_radius: f64, cost_scaling: f64, resolution: f64) -> Result<Self> {
        nonnegative("inscribed_radius", inscribed_radius)?;
        nonnegative("inflation_radius", inflation_radius)?;
        nonnegative("cost_scaling", cost_scaling)?;
        positive("resolution", resolution)?;
        if inflation_radius < inscribed_radius {
            return Err(Error::invalid(
                "inflation_radius",
                format!("must be >= inscribed_radius = {inscribed_radius}, got {inflation_radius}"),
            ));
        }
        let max_sq = (inflation_radius / resolution).powi(2).floor() as usize;
        if max_sq > 1 << 24 {
            return Err(Error::invalid(
                "inflation_radius",
                format!("{inflation_radius} m is too many cells of {resolution} m"),
            ));
        }
        let mut s = Self {
            inscribed_radius,
            inflation_radius,
            cost_scaling,
            resolution,
            table: Vec::new(),
        };
        s.table = (0..=max_sq).map(|sq| s.cost((sq as f64).sqrt() * resolution)).collect();
        Ok(s)
    }

    /// The cost of a cell at distance `d` (m) from the nearest obstacle cell.
    pub fn cost(&self, d: f64) -> u8 {
        if d <= 0.0 {
            LETHAL
        } else if d <= self.inscribed_radius {
            INSCRIBED
        } else if d <= self.inflation_radius {
            let c = MAX_NON_OBSTACLE as f64 * (-self.cost_scaling * (d - self.inscribed_radius)).exp();
            c.round().clamp(0.0, MAX_NON_OBSTACLE as f64) as u8
        } else {
            FREE
        }
    }

    /// Inscribed radius (m).
    pub fn inscribed_radius(&self) -> f64 {
        self.inscribed_radius
    }
    /// Inflation radius (m).
    pub fn inflation_radius(&self) -> f64 {
        self.inflation_radius
    }

    /// Writes the inflated costs of `field` into `out` (which takes the field's placement). An
    /// error if the sizes or resolutions differ. No allocation.
    pub fn apply(&self, field: &DistanceField, out: &mut Costmap) -> Result<()> {
        let g = field.geometry();
        let o = out.geometry();
        if g.width() != o.width() || g.height() != o.height() || g.resolution() != self.resolution {
            return Err(Error::Geometry {
                field: "out".into(),
                got: format!("{} x {} cells of {} m", o.width(), o.height(), o.resolution()),
                expected: format!("{} x {} cells of {} m", g.width(), g.height(), self.resolution),
            });
        }
        out.place(*g);
        let max = self.table.len();
        for (c, &sq) in out.cells_mut().iter_mut().zip(field.squared_cells()) {
            *c = if sq < max as f64 { self.table[sq as usize] } else { FREE };
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::GridGeometry;

    #[test]
    fn table_equals_direct_formula() {
        let g = GridGeometry::centered([0.0, 0.0], 60, 60, 0.05).unwrap();
        let mut m = Costmap::new(g);
        m.mark([0.3, -0.2], LETHAL);
        m.mark([-0.6, 0.7], LETHAL);
        let mut f = DistanceField::new(g);
        f.compute(&m, LETHAL).unwrap();
        let inf = Inflation::new(0.3, 0.9, 4.0, 0.05).unwrap();
        let mut out = Costmap::new(g);
        inf.apply(&f, &mut out).unwrap();
        for iy in 0..60 {
            for ix in 0..60 {
                assert_eq!(out.get(ix, iy), inf.cost(f.at_cell(ix, iy)), "({ix}, {iy})");
            }
        }
        assert_eq!(inf.cost(0.0), LETHAL);
        assert_eq!(inf.cost(0.3), INSCRIBED);
        assert!(inf.cost(0.31) <= MAX_NON_OBSTACLE);
        assert_eq!(inf.cost(0.95), FREE);
    }

    #[test]
    fn bad_parameters_name_the_field() {
        let e = Inflation::new(0.5, 0.4, 1.0, 0.05).unwrap_err();
        assert!(e.to_string().starts_with("inflation_radius"), "{e}");
        let e = Inflation::new(0.1, 0.4, -1.0, 0.05).unwrap_err();
        assert!(e.to_string().starts_with("cost_scaling"), "{e}");
    }
}
