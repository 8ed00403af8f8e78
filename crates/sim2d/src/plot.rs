//! PNG top views like the paper's Fig. 5: obstacles (grey), the route (light green, route points
//! as circles), driven paths (solid, or dashed for DDP as the paper's dotted lines), planned
//! trajectories (thin), the start (green disc) and the end (red disc) of the route, and a cross
//! where a run stopped in a local minimum. No text: the figure needs no font.
//!
//! The PNG is drawn to `<name>.tmp.png` and renamed, so a figure is whole or absent.

use std::path::Path;

use plotters::element::DashedPathElement;
use plotters::prelude::*;

use crate::error::{Error, Result};
use crate::route::Route;
use crate::run::RunResult;
use crate::scenario::Scenario;

/// One run drawn on a top view.
#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    /// Driven positions.
    pub path: Vec<[f64; 2]>,
    /// Whether the run reached the end (a cross marks where it stopped otherwise).
    pub completed: bool,
    /// RGB colour.
    pub color: (u8, u8, u8),
    /// Dashed (the paper draws DDP dotted).
    pub dashed: bool,
    /// Planned trajectories to draw thinly.
    pub plans: Vec<Vec<[f64; 2]>>,
}

impl Track {
    /// The track of a run, with its kept plans.
    pub fn from_result(r: &RunResult, color: (u8, u8, u8), dashed: bool) -> Self {
        Self {
            path: r.trajectory.iter().map(|s| [s[1], s[2]]).collect(),
            completed: r.completed,
            color,
            dashed,
            plans: r.plans.iter().map(|p| p.positions.clone()).collect(),
        }
    }
}

/// The colour and dash of a planner's tracks.
pub fn planner_style(planner: &str) -> ((u8, u8, u8), bool) {
    match planner {
        "ddp" => ((220, 90, 20), true),
        "ddp-astar" => ((30, 90, 220), false),
        _ => ((120, 40, 160), false),
    }
}

/// Figure options.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlotOptions {
    /// Scale (pixels per metre).
    pub px_per_m: f64,
    /// Margin around the scene (m).
    pub margin: f64,
}

impl Default for PlotOptions {
    fn default() -> Self {
        Self {
            px_per_m: 8.0,
            margin: 6.0,
        }
    }
}

/// Draws the top view of `scenario` with `route` (as driven) and `tracks` to the PNG `path`.
pub fn top_view(path: &Path, scenario: &Scenario, route: &Route, tracks: &[Track], options: PlotOptions) -> Result<()> {
    let b = scenario.bounds();
    let (x0, y0) = (b[0] - options.margin, b[1] - options.margin);
    let s = options.px_per_m;
    let w = ((b[2] - b[0] + 2.0 * options.margin) * s).ceil().max(16.0) as u32;
    let h = ((b[3] - b[1] + 2.0 * options.margin) * s).ceil().max(16.0) as u32;
    if w > 20_000 || h > 20_000 {
        return Err(Error::write(path, format!("figure of {w} x {h} pixels is too large")));
    }
    let px = |p: [f64; 2]| -> (i32, i32) {
        (
            ((p[0] - x0) * s).round() as i32,
            (h as f64 - (p[1] - y0) * s).round() as i32,
        )
    };

    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| Error::write(dir, e))?;
    }
    // Drawn to a temporary PNG next to `path` and renamed: the figure is whole or absent.
    let draw = |tmp: &Path| -> std::result::Result<(), Box<dyn std::error::Error>> {
        let root = BitMapBackend::new(tmp, (w, h)).into_drawing_area();
        root.fill(&WHITE)?;
        // Route and route points.
        let route_px: Vec<(i32, i32)> = route.points().iter().map(|p| px(*p)).collect();
        root.draw(&PathElement::new(
            route_px.clone(),
            RGBColor(150, 215, 150).stroke_width(5),
        ))?;
        for p in &route_px {
            root.draw(&Circle::new(
                *p,
                (0.6 * s) as i32,
                RGBColor(60, 170, 60).stroke_width(2),
            ))?;
        }
        // Obstacles.
        for o in &scenario.obstacles {
            let poly: Vec<(i32, i32)> = o.outline().iter().map(|p| px(*p)).collect();
            root.draw(&Polygon::new(poly, RGBColor(90, 90, 100).filled()))?;
        }
        // Planned trajectories, then driven paths on top.
        for t in tracks {
            let c = RGBColor(t.color.0, t.color.1, t.color.2);
            for plan in &t.plans {
                let pts: Vec<(i32, i32)> = plan.iter().map(|p| px(*p)).collect();
                root.draw(&PathElement::new(pts, c.mix(0.35).stroke_width(1)))?;
            }
        }
        for t in tracks {
            let c = RGBColor(t.color.0, t.color.1, t.color.2);
            let pts: Vec<(i32, i32)> = t.path.iter().map(|p| px(*p)).collect();
            if t.dashed {
                root.draw(&DashedPathElement::new(pts.clone(), 6, 4, c.stroke_width(2)))?;
            } else {
                root.draw(&PathElement::new(pts.clone(), c.stroke_width(2)))?;
            }
            if !t.completed {
                if let Some(end) = pts.last() {
                    root.draw(&Cross::new(*end, 9, c.stroke_width(3)))?;
                }
            }
        }
        root.draw(&Circle::new(
            px(route.start()),
            (0.9 * s) as i32,
            RGBColor(30, 170, 40).filled(),
        ))?;
        root.draw(&Circle::new(
            px(route.end()),
            (0.9 * s) as i32,
            RGBColor(220, 30, 30).filled(),
        ))?;
        root.present()?;
        Ok(())
    };
    ddpkit_util::fs::write_atomic_at(path, draw).map_err(|e| Error::write(path, e))
}
