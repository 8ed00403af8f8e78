//! A PNG like Fig. 3 of Richter et al. (2023): the obstacles (grey), the goal ball (green), the
//! leaves of the refined grids (all time indices overlaid: root cells light, split cells darker),
//! the waypoints of the first iterations (red, orange, blue, purple: iterations 1, 2, 3, 4), and
//! the TCP path of the final trajectory (black) with the robot drawn at a few knots; crosses mark
//! the points each iteration found infeasible (waypoints that could not be mapped, colliding TCP
//! positions). Metre axes, a legend and a title (`ddpkit-plot`, embedded font). The figure is
//! drawn to a temporary PNG next to `path` and renamed: it is whole or absent.

use std::path::Path;

use ddp_core::Vector;
use ddpkit_plot::plotters::prelude::*;
use ddpkit_plot::{box_key, chart, cross_key, disc_key, legend, line_key, Axes, PlotError};

use crate::error::{Error, Result};
use crate::idnp::IterationRecord;
use crate::quadtree::QuadGrid;
use crate::scene::Scene;

/// Colours of the waypoints of iterations 1, 2, 3, 4.
pub const ITERATION_COLORS: [(u8, u8, u8); 4] = [(220, 40, 40), (240, 150, 20), (40, 90, 220), (140, 50, 170)];

/// Draws the figure (see the [module docs](self)) at `px_per_m` pixels per metre.
pub fn figure(
    path: &Path,
    scene: &Scene,
    records: &[IterationRecord],
    grids: &[QuadGrid],
    trajectory: Option<&[Vector<10>]>,
    px_per_m: f64,
) -> Result<()> {
    let d = scene.domain;
    let (lo, hi) = (d.min, d.max());
    let margin = 0.3;
    let (xr, yr) = (lo[0] - margin..hi[0] + margin, lo[1] - margin..hi[1] + margin);
    let size = ddpkit_plot::equal_aspect_size(&xr, &yr, px_per_m);
    if size.0 > 10_000 || size.1 > 10_000 {
        return Err(Error::Plot {
            path: path.display().to_string(),
            reason: format!("figure size {} x {} px out of range; check px_per_m", size.0, size.1),
        });
    }
    let axes = Axes::new(
        "IDNP with adaptive grids: waypoints per iteration and the final TCP path",
        "x (m)",
        "y (m)",
        xr,
        yr,
    );
    let drawn = ddpkit_plot::write_png(path, size, |root| {
        let mut c = chart(root, &axes)?;
        let xy = |p: [f64; 2]| (p[0], p[1]);
        let grey = RGBColor(150, 150, 150).filled();
        c.draw_series(
            scene
                .obstacles
                .iter()
                .map(|o| Polygon::new(o.vertices().iter().map(|&v| xy(v)).collect::<Vec<_>>(), grey)),
        )?
        .label("obstacles")
        .legend(box_key(grey));
        // Grid leaves: root cells light, split ones darker (union over the time indices).
        let mut drawn = std::collections::HashSet::new();
        let (mut roots, mut splits) = (Vec::new(), Vec::new());
        for g in grids {
            for &l in g.leaves() {
                let Some(cell) = g.cell(l) else { continue };
                let key = (
                    (cell.center[0] * 1e6).round() as i64,
                    (cell.center[1] * 1e6).round() as i64,
                    (cell.size * 1e6).round() as i64,
                );
                if drawn.insert(key) {
                    let r = [xy([cell.min()[0], cell.max()[1]]), xy([cell.max()[0], cell.min()[1]])];
                    if cell.level == 0 {
                        roots.push(r)
                    } else {
                        splits.push(r)
                    }
                }
            }
        }
        for (cells, color, name) in [
            (roots, RGBColor(200, 200, 210), "grid cells"),
            (splits, RGBColor(60, 110, 160), "split cells"),
        ] {
            let style = ShapeStyle::from(color);
            c.draw_series(cells.into_iter().map(|r| Rectangle::new(r, style)))?
                .label(name)
                .legend(line_key(color.stroke_width(2)));
        }
        // Goal ball.
        let g = scene.goal;
        let goal = RGBColor(40, 170, 60).stroke_width(3);
        c.draw_series(std::iter::once(PathElement::new(
            (0..=64)
                .map(|k| {
                    let a = k as f64 * std::f64::consts::TAU / 64.0;
                    (g.center[0] + g.radius * a.cos(), g.center[1] + g.radius * a.sin())
                })
                .collect::<Vec<_>>(),
            goal,
        )))?
        .label("goal ball")
        .legend(disc_key(goal, 5));
        // Final trajectory: TCP path and robot snapshots.
        if let Some(xs) = trajectory {
            let tcp: Vec<(f64, f64)> = xs.iter().map(|x| xy(scene.robot.tcp_position(x))).collect();
            c.draw_series(std::iter::once(PathElement::new(tcp, BLACK.stroke_width(2))))?
                .label("final TCP path")
                .legend(line_key(BLACK.stroke_width(2)));
            let step = (xs.len() / 6).max(1);
            let body = RGBColor(60, 60, 60);
            for x in xs.iter().step_by(step).chain(xs.last()) {
                let mut ring: Vec<(f64, f64)> = scene.robot.base_corners(x).iter().map(|&c| xy(c)).collect();
                if let Some(&first) = ring.first() {
                    ring.push(first);
                }
                c.draw_series(std::iter::once(PathElement::new(ring, body.stroke_width(1))))?;
                let arm: Vec<(f64, f64)> = scene.robot.link_endpoints(x).iter().map(|&p| xy(p)).collect();
                c.draw_series(std::iter::once(PathElement::new(arm, body.stroke_width(2))))?;
            }
            c.draw_series(std::iter::empty::<PathElement<(f64, f64)>>())?
                .label("robot (base and arm) at a few knots")
                .legend(line_key(body.stroke_width(2)));
        }
        // Waypoints of the first iterations, later ones on top; infeasible points crossed.
        for (i, (r, color)) in records.iter().zip(ITERATION_COLORS).enumerate() {
            let col = RGBColor(color.0, color.1, color.2);
            let pts: Vec<(f64, f64)> = r.waypoints.iter().map(|&z| xy(z)).collect();
            c.draw_series(std::iter::once(PathElement::new(pts.clone(), col.stroke_width(2))))?
                .label(format!("waypoints, iteration {}", i + 1))
                .legend(line_key(col.stroke_width(2)));
            c.draw_series(pts.into_iter().map(|p| Circle::new(p, 4, col.filled())))?;
        }
        let mut crossed = false;
        for (r, color) in records.iter().zip(ITERATION_COLORS) {
            let col = RGBColor(color.0, color.1, color.2).stroke_width(3);
            c.draw_series(r.infeasible_points.iter().map(|&(_, z)| Cross::new(xy(z), 8, col)))?;
            crossed |= !r.infeasible_points.is_empty();
        }
        if crossed {
            c.draw_series(std::iter::empty::<PathElement<(f64, f64)>>())?
                .label("infeasible point")
                .legend(cross_key(BLACK.stroke_width(2)));
        }
        legend(&mut c, SeriesLabelPosition::UpperLeft)
    });
    drawn.map_err(|e| match e {
        PlotError::Io { path, source } => Error::Io {
            path: path.display().to_string(),
            source,
        },
        PlotError::Draw { reason, .. } => Error::Plot {
            path: path.display().to_string(),
            reason,
        },
    })
}
