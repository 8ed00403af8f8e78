//! Obstacle shapes of the dataset and their rasterisation.
//!
//! Every shape lives in a local unit square `[-0.5, 0.5]^2` as the union of at most three parts
//! (axis-aligned rectangles or the inscribed disc) and is placed by an affine map
//!
//! ```text
//! p = A q + t,     A = R(phi) [[1, k], [0, 1]] diag(s_x, s_y)
//! ```
//!
//! (anisotropic scale `s`, shear `k`, rotation `phi`, translation `t`). A cell is an obstacle when
//! its centre `p` maps back, `q = A^-1 (p - t)`, into one of the parts.

use crate::grid::{Costmap, LETHAL};

/// One part of a shape, in local coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Part {
    /// `[x0, x1] x [y0, y1]`.
    Rect { x0: f64, x1: f64, y0: f64, y1: f64 },
    /// The disc of radius 0.5 around the local origin.
    Disc,
}

impl Part {
    #[inline]
    fn contains(&self, q: [f64; 2]) -> bool {
        match *self {
            Part::Rect { x0, x1, y0, y1 } => q[0] >= x0 && q[0] <= x1 && q[1] >= y0 && q[1] <= y1,
            Part::Disc => q[0] * q[0] + q[1] * q[1] <= 0.25,
        }
    }
}

/// The kinds of obstacle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    Rect,
    Circle,
    /// Two bars meeting in the local corner `(+0.5, +0.5)`; the concave side faces `(-1, -1)`.
    L,
    /// A base along local `x` at `y = +0.5` and two arms; the opening faces local `-y`.
    U,
}

/// A shape placed in the world (see the module docs).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Obstacle {
    parts: [Part; 3],
    n_parts: usize,
    a_inv: [[f64; 2]; 2],
    t: [f64; 2],
    /// World bounding box `[x_min, x_max, y_min, y_max]`.
    bbox: [f64; 4],
}

/// Placement of a shape: scale `[s_x, s_y]` (m), shear `k`, rotation `phi` (rad), translation
/// `t` (m), and the wall thickness (m) of L and U shapes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Placement {
    pub scale: [f64; 2],
    pub shear: f64,
    pub rotation: f64,
    pub translation: [f64; 2],
    pub thickness: f64,
}

impl Obstacle {
    /// `kind` placed by `pl`. Scales must be positive (callers draw them so).
    pub(crate) fn new(kind: Kind, pl: &Placement) -> Self {
        let [sx, sy] = pl.scale;
        // Wall thickness in local units along each axis (at most the whole side).
        let tx = (pl.thickness / sx).min(1.0);
        let ty = (pl.thickness / sy).min(1.0);
        let full = Part::Rect {
            x0: -0.5,
            x1: 0.5,
            y0: -0.5,
            y1: 0.5,
        };
        let top = Part::Rect {
            x0: -0.5,
            x1: 0.5,
            y0: 0.5 - ty,
            y1: 0.5,
        };
        let right = Part::Rect {
            x0: 0.5 - tx,
            x1: 0.5,
            y0: -0.5,
            y1: 0.5,
        };
        let left = Part::Rect {
            x0: -0.5,
            x1: -0.5 + tx,
            y0: -0.5,
            y1: 0.5,
        };
        let (parts, n_parts) = match kind {
            Kind::Rect => ([full, full, full], 1),
            Kind::Circle => ([Part::Disc, Part::Disc, Part::Disc], 1),
            Kind::L => ([top, right, right], 2),
            Kind::U => ([top, left, right], 3),
        };
        let (s, c) = pl.rotation.sin_cos();
        // A = R Sh S = [[c, -s], [s, c]] [[sx, k sy], [0, sy]].
        let a = [
            [c * sx, c * pl.shear * sy - s * sy],
            [s * sx, s * pl.shear * sy + c * sy],
        ];
        let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
        let a_inv = [[a[1][1] / det, -a[0][1] / det], [-a[1][0] / det, a[0][0] / det]];
        let mut bbox = [f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY];
        for (u, v) in [(-0.5, -0.5), (0.5, -0.5), (-0.5, 0.5), (0.5, 0.5)] {
            let x = a[0][0] * u + a[0][1] * v + pl.translation[0];
            let y = a[1][0] * u + a[1][1] * v + pl.translation[1];
            bbox = [bbox[0].min(x), bbox[1].max(x), bbox[2].min(y), bbox[3].max(y)];
        }
        Self {
            parts,
            n_parts,
            a_inv,
            t: pl.translation,
            bbox,
        }
    }

    /// Whether the bounding box reaches within `r` of the origin (in both axes).
    #[inline]
    pub(crate) fn near(&self, r: f64) -> bool {
        self.bbox[0] <= r && self.bbox[1] >= -r && self.bbox[2] <= r && self.bbox[3] >= -r
    }

    /// Whether world point `p` lies in the shape.
    #[inline]
    pub(crate) fn contains(&self, p: [f64; 2]) -> bool {
        let (dx, dy) = (p[0] - self.t[0], p[1] - self.t[1]);
        let q = [
            self.a_inv[0][0] * dx + self.a_inv[0][1] * dy,
            self.a_inv[1][0] * dx + self.a_inv[1][1] * dy,
        ];
        if q[0].abs() > 0.5 || q[1].abs() > 0.5 {
            return false;
        }
        self.parts[..self.n_parts].iter().any(|part| part.contains(q))
    }

    /// Marks every cell whose centre lies in the shape [`LETHAL`]; returns how many.
    pub(crate) fn rasterize(&self, map: &mut Costmap) -> usize {
        let g = *map.geometry();
        let (w, h) = (g.width(), g.height());
        let lo = g.world_to_grid([self.bbox[0], self.bbox[2]]);
        let hi = g.world_to_grid([self.bbox[1], self.bbox[3]]);
        // Cells whose centre (index + 0.5) can lie in the box.
        let range = |a: f64, b: f64, n: usize| -> Option<(usize, usize)> {
            let first = (a - 0.5).ceil().max(0.0);
            let last = (b - 0.5).floor().min(n as f64 - 1.0);
            (first <= last).then_some((first as usize, last as usize))
        };
        let (Some((x0, x1)), Some((y0, y1))) = (range(lo[0], hi[0], w), range(lo[1], hi[1], h)) else {
            return 0;
        };
        let mut marked = 0;
        let cells = map.cells_mut();
        for iy in y0..=y1 {
            for ix in x0..=x1 {
                if self.contains(g.cell_to_world(ix, iy)) {
                    cells[iy * w + ix] = LETHAL;
                    marked += 1;
                }
            }
        }
        marked
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::GridGeometry;

    fn place(scale: [f64; 2], rotation: f64, translation: [f64; 2]) -> Placement {
        Placement {
            scale,
            shear: 0.0,
            rotation,
            translation,
            thickness: 0.2,
        }
    }

    #[test]
    fn rectangle_area_and_rotation() {
        // A 1 m x 0.5 m rectangle covers 200 cells of 5 cm, rotated by 90 degrees too.
        for rot in [0.0, std::f64::consts::FRAC_PI_2] {
            let mut m = Costmap::new(GridGeometry::centered([0.0, 0.0], 100, 100, 0.05).unwrap());
            let o = Obstacle::new(Kind::Rect, &place([1.0, 0.5], rot, [0.01, 0.01]));
            assert_eq!(o.rasterize(&mut m), 200);
            let lethal = m.cells().iter().filter(|&&c| c == LETHAL).count();
            assert_eq!(lethal, 200);
        }
    }

    #[test]
    fn u_shape_opening_faces_minus_local_y() {
        // Unrotated U of 2 m x 1 m: base at y = +0.5, opening at y = -0.5, interior free.
        let o = Obstacle::new(Kind::U, &place([2.0, 1.0], 0.0, [0.0, 0.0]));
        assert!(o.contains([0.0, 0.45])); // base
        assert!(o.contains([-0.95, 0.0]) && o.contains([0.95, 0.0])); // arms
        assert!(!o.contains([0.0, 0.0])); // inside the cup
        assert!(!o.contains([0.0, -0.45])); // the opening
                                            // Rotated by +90 degrees the base points to -x.
        let o = Obstacle::new(Kind::U, &place([2.0, 1.0], std::f64::consts::FRAC_PI_2, [0.0, 0.0]));
        assert!(o.contains([-0.45, 0.0]) && !o.contains([0.45, 0.0]));
    }

    #[test]
    fn circle_and_l() {
        let c = Obstacle::new(Kind::Circle, &place([1.0, 1.0], 0.3, [1.0, 1.0]));
        assert!(c.contains([1.0, 1.49]) && !c.contains([1.36, 1.36]));
        let l = Obstacle::new(Kind::L, &place([1.0, 1.0], 0.0, [0.0, 0.0]));
        assert!(l.contains([0.45, -0.45]) && l.contains([-0.45, 0.45]) && !l.contains([-0.3, -0.3]));
    }
}
