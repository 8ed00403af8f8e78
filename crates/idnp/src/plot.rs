//! A PNG like Fig. 3 of Richter et al. (2023): the obstacles (grey), the goal ball (green), the
//! leaves of the refined grids (all time indices overlaid: root cells light, split cells darker),
//! the waypoints of the first iterations (red, orange, blue, purple: iterations 1, 2, 3, 4), and
//! the TCP path of the final trajectory (black) with the robot drawn at a few knots; crosses mark
//! the points each iteration found infeasible (waypoints that could not be mapped, colliding TCP
//! positions). No text, so no font is needed. The figure is drawn to a temporary PNG next to `path`
//! and renamed: it is whole or absent.

use std::path::Path;

use ddp_core::Vector;
use plotters::prelude::*;

use crate::error::{Error, Result};
use crate::idnp::IterationRecord;
use crate::quadtree::QuadGrid;
use crate::scene::Scene;

/// What stops a drawing: the encoder's message, or the file system's error.
type Failure = Box<dyn std::error::Error + Send + Sync>;

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
    let err = |e: String| Error::Plot {
        path: path.display().to_string(),
        reason: e,
    };
    let d = scene.domain;
    let (lo, hi) = (d.min, d.max());
    let margin = 0.3;
    let (x0, y1) = (lo[0] - margin, hi[1] + margin);
    let w = ((hi[0] - lo[0] + 2.0 * margin) * px_per_m).round() as u32;
    let h = ((hi[1] - lo[1] + 2.0 * margin) * px_per_m).round() as u32;
    if !(16..=10_000).contains(&w) || !(16..=10_000).contains(&h) {
        return Err(err(format!("figure size {w} x {h} px out of range; check px_per_m")));
    }
    let px = |p: [f64; 2]| -> (i32, i32) {
        (
            ((p[0] - x0) * px_per_m).round() as i32,
            ((y1 - p[1]) * px_per_m).round() as i32,
        )
    };
    // Drawn to a temporary PNG next to `path`: drawing errors are `Plot`, the file system's `Io`.
    let drawn = ddpkit_util::fs::write_atomic_at(path, |tmp: &Path| -> std::result::Result<(), Failure> {
        let root = BitMapBackend::new(tmp, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| Failure::from(e.to_string()))?;
        let draw = |e: std::result::Result<(), DrawingAreaErrorKind<_>>| e.map_err(|e| Failure::from(e.to_string()));
        // Obstacles.
        for o in &scene.obstacles {
            let pts: Vec<(i32, i32)> = o.vertices().iter().map(|&v| px(v)).collect();
            draw(root.draw(&Polygon::new(pts, RGBColor(150, 150, 150).filled())))?;
        }
        // Grid leaves: root cells light, split ones darker (union over the time indices).
        let mut drawn = std::collections::HashSet::new();
        for g in grids {
            for &l in g.leaves() {
                let c = g.cell(l).expect("a leaf");
                let key = (
                    (c.center[0] * 1e6).round() as i64,
                    (c.center[1] * 1e6).round() as i64,
                    (c.size * 1e6).round() as i64,
                );
                if !drawn.insert(key) {
                    continue;
                }
                let color = if c.level == 0 {
                    RGBColor(200, 200, 210)
                } else {
                    RGBColor(60, 110, 160)
                };
                draw(root.draw(&Rectangle::new(
                    [px([c.min()[0], c.max()[1]]), px([c.max()[0], c.min()[1]])],
                    color,
                )))?;
            }
        }
        // Goal ball.
        let g = scene.goal;
        draw(root.draw(&Circle::new(
            px(g.center),
            (g.radius * px_per_m).round() as i32,
            RGBColor(40, 170, 60).stroke_width(3),
        )))?;
        // Final trajectory: TCP path and robot snapshots.
        if let Some(xs) = trajectory {
            let tcp: Vec<(i32, i32)> = xs.iter().map(|x| px(scene.robot.tcp_position(x))).collect();
            draw(root.draw(&PathElement::new(tcp, BLACK.stroke_width(2))))?;
            let step = (xs.len() / 6).max(1);
            for x in xs.iter().step_by(step).chain(xs.last()) {
                let corners: Vec<(i32, i32)> = scene.robot.base_corners(x).iter().map(|&c| px(c)).collect();
                let mut ring = corners.clone();
                ring.push(corners[0]);
                draw(root.draw(&PathElement::new(ring, RGBColor(60, 60, 60).stroke_width(1))))?;
                let arm: Vec<(i32, i32)> = scene.robot.link_endpoints(x).iter().map(|&p| px(p)).collect();
                draw(root.draw(&PathElement::new(arm, RGBColor(60, 60, 60).stroke_width(2))))?;
            }
        }
        // Waypoints of the first iterations, later ones on top; infeasible points crossed.
        for (r, color) in records.iter().zip(ITERATION_COLORS) {
            let c = RGBColor(color.0, color.1, color.2);
            let pts: Vec<(i32, i32)> = r.waypoints.iter().map(|&z| px(z)).collect();
            draw(root.draw(&PathElement::new(pts.clone(), c.stroke_width(2))))?;
            for p in pts {
                draw(root.draw(&Circle::new(p, 4, c.filled())))?;
            }
        }
        for (r, color) in records.iter().zip(ITERATION_COLORS) {
            let c = RGBColor(color.0, color.1, color.2);
            for &(_, z) in &r.infeasible_points {
                let (cx, cy) = px(z);
                let s = 8;
                for seg in [
                    [(cx - s, cy - s), (cx + s, cy + s)],
                    [(cx - s, cy + s), (cx + s, cy - s)],
                ] {
                    draw(root.draw(&PathElement::new(seg.to_vec(), c.stroke_width(3))))?;
                }
            }
        }
        root.present().map_err(|e| Failure::from(e.to_string()))?;
        Ok(())
    });
    drawn.map_err(|e| match e.downcast::<std::io::Error>() {
        Ok(source) => Error::Io {
            path: path.display().to_string(),
            source: *source,
        },
        Err(e) => err(e.to_string()),
    })
}
