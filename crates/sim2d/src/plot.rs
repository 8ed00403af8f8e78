//! PNG top views like the paper's Fig. 5, with metre axes, a legend and a title (the shared setup
//! of `ddpkit-plot`, its embedded font): obstacles (grey), the route (light green, route points
//! as circles), driven paths (solid, or dashed for DDP as the paper's dotted lines), planned
//! trajectories (thin), the start (green disc) and the end (red disc) of the route, and a cross
//! where a run stopped in a local minimum. One legend entry per planner.
//!
//! The PNG is drawn to a temporary file and renamed, so a figure is whole or absent.

use std::path::Path;

use ddpkit_plot::plotters::element::DashedPathElement;
use ddpkit_plot::plotters::prelude::*;
use ddpkit_plot::{box_key, chart, cross_key, dashed_key, disc_key, line_key, Axes, Failure};

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
    /// Legend label (the planner): tracks with the same label share one legend entry.
    pub label: String,
}

impl Track {
    /// The track of a run, with its kept plans, labelled with its planner.
    pub fn from_result(r: &RunResult, color: (u8, u8, u8), dashed: bool) -> Self {
        Self {
            path: r.trajectory.iter().map(|s| [s[1], s[2]]).collect(),
            completed: r.completed,
            color,
            dashed,
            plans: r.plans.iter().map(|p| p.positions.clone()).collect(),
            label: r.planner.clone(),
        }
    }
}

/// The colour and dash of a planner's tracks.
pub fn planner_style(planner: &str) -> ((u8, u8, u8), bool) {
    match planner {
        "ddp" => ((220, 90, 20), true),
        "ddp-astar" => ((30, 90, 220), false),
        "ddpen-oracle" => ((0, 150, 140), false),
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

/// Draws the top view of `scenario` with `route` (as driven) and `tracks` to the PNG `path`,
/// titled `title`.
pub fn top_view(
    path: &Path,
    title: &str,
    scenario: &Scenario,
    route: &Route,
    tracks: &[Track],
    options: PlotOptions,
) -> Result<()> {
    let (axes, size) = top_view_axes(title, scenario, options);
    ddpkit_plot::write_png(path, size, |root| {
        draw_top_view(root, &axes, scenario, route, tracks, options)
    })
    .map_err(|e| Error::write(path, e))
}

impl PlotOptions {
    /// Shortest side, in pixels, of the plotting area of a top view: a small scene (a 20 m trap
    /// map) is drawn larger than `px_per_m` so that the legend and the labels, whose size is
    /// fixed in pixels, leave the scene visible.
    pub const MIN_SIDE_PX: f64 = 640.0;

    /// These options with `px_per_m` raised where the scene would draw smaller than
    /// [`PlotOptions::MIN_SIDE_PX`].
    pub fn fitted(self, scenario: &Scenario) -> Self {
        let b = scenario.bounds();
        let side = (b[2] - b[0]).min(b[3] - b[1]) + 2.0 * self.margin;
        Self {
            px_per_m: self.px_per_m.max(Self::MIN_SIDE_PX / side.max(1e-9)),
            ..self
        }
    }
}

/// The axes (metres, equal scale) and the figure size of a top view.
pub fn top_view_axes(title: &str, scenario: &Scenario, options: PlotOptions) -> (Axes, (u32, u32)) {
    let options = options.fitted(scenario);
    let b = scenario.bounds();
    let m = options.margin;
    let (x, y) = (b[0] - m..b[2] + m, b[1] - m..b[3] + m);
    let size = ddpkit_plot::equal_aspect_size(&x, &y, options.px_per_m);
    (Axes::new(title, "x (m)", "y (m)", x, y), size)
}

/// Draws a top view on `root` (a PNG's or an in-memory buffer's drawing area).
pub fn draw_top_view<DB: DrawingBackend>(
    root: &DrawingArea<DB, ddpkit_plot::plotters::coord::Shift>,
    axes: &Axes,
    scenario: &Scenario,
    route: &Route,
    tracks: &[Track],
    options: PlotOptions,
) -> std::result::Result<(), Failure>
where
    DB::ErrorType: 'static,
{
    let s = options.fitted(scenario).px_per_m;
    let mut c = chart(root, axes)?;
    let xy = |p: &[f64; 2]| (p[0], p[1]);
    // Route and route points.
    let route_style = RGBColor(150, 215, 150).stroke_width(5);
    c.draw_series(std::iter::once(PathElement::new(
        route.points().iter().map(xy).collect::<Vec<_>>(),
        route_style,
    )))?
    .label("route")
    .legend(line_key(route_style));
    let point_style = RGBColor(60, 170, 60).stroke_width(2);
    c.draw_series(
        route
            .points()
            .iter()
            .map(|p| Circle::new(xy(p), (0.6 * s) as i32, point_style)),
    )?
    .label("route points")
    .legend(disc_key(point_style, 5));
    // Obstacles.
    let grey = RGBColor(90, 90, 100).filled();
    let obstacles = c.draw_series(
        scenario
            .obstacles
            .iter()
            .map(|o| Polygon::new(o.outline().iter().map(xy).collect::<Vec<_>>(), grey)),
    )?;
    if !scenario.obstacles.is_empty() {
        obstacles.label("obstacles").legend(box_key(grey));
    }
    // Planned trajectories, then driven paths on top; one legend entry per label.
    let mut any_plans = None;
    for t in tracks {
        let col = RGBColor(t.color.0, t.color.1, t.color.2);
        let style = col.mix(0.35).stroke_width(1);
        c.draw_series(
            t.plans
                .iter()
                .map(|plan| PathElement::new(plan.iter().map(xy).collect::<Vec<_>>(), style)),
        )?;
        if !t.plans.is_empty() {
            any_plans = Some(style);
        }
    }
    if let Some(style) = any_plans {
        c.draw_series(std::iter::empty::<PathElement<(f64, f64)>>())?
            .label("planned trajectories (every 10th)")
            .legend(line_key(style));
    }
    let mut labelled: Vec<&str> = Vec::new();
    let mut stopped = None;
    for t in tracks {
        let style = RGBColor(t.color.0, t.color.1, t.color.2).stroke_width(2);
        let pts: Vec<(f64, f64)> = t.path.iter().map(xy).collect();
        let first = !labelled.contains(&t.label.as_str());
        if t.dashed {
            let a = c.draw_series(std::iter::once(DashedPathElement::new(pts.clone(), 6, 4, style)))?;
            if first {
                a.label(t.label.clone()).legend(dashed_key(style));
            }
        } else {
            let a = c.draw_series(std::iter::once(PathElement::new(pts.clone(), style)))?;
            if first {
                a.label(t.label.clone()).legend(line_key(style));
            }
        }
        if first {
            labelled.push(&t.label);
        }
        if !t.completed {
            if let Some(end) = pts.last() {
                let cross = RGBColor(t.color.0, t.color.1, t.color.2).stroke_width(3);
                c.draw_series(std::iter::once(Cross::new(*end, 9, cross)))?;
                stopped = Some(cross);
            }
        }
    }
    if let Some(style) = stopped {
        c.draw_series(std::iter::empty::<PathElement<(f64, f64)>>())?
            .label("stopped (local minimum)")
            .legend(cross_key(style));
    }
    let start = RGBColor(30, 170, 40).filled();
    c.draw_series(std::iter::once(Circle::new(
        xy(&route.start()),
        (0.9 * s) as i32,
        start,
    )))?
    .label("start")
    .legend(disc_key(start, 5));
    let end = RGBColor(220, 30, 30).filled();
    c.draw_series(std::iter::once(Circle::new(xy(&route.end()), (0.9 * s) as i32, end)))?
        .label("end")
        .legend(disc_key(end, 5));
    if axes.text {
        ddpkit_plot::legend(&mut c, SeriesLabelPosition::UpperRight)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn top_view_draws_ticks_legend_and_title() {
        let s = Scenario::from_toml_str(
            "name = \"t\"\n[route]\npoints = [[0.0, 0.0], [30.0, 0.0]]\n[[obstacles]]\ntype = \"cylinder\"\ncenter = [15.0, 1.0]\nradius = 1.0\n",
            "<test>",
        )
        .unwrap();
        let track = Track {
            path: vec![[0.0, 0.0], [10.0, -1.0], [20.0, -1.0]],
            completed: false,
            color: (220, 90, 20),
            dashed: true,
            plans: vec![vec![[10.0, -1.0], [14.0, -2.0]]],
            label: "ddp".into(),
        };
        let render = |text: bool| {
            let (mut axes, size) = top_view_axes("t: forward", &s, PlotOptions::default());
            axes.text = text;
            let img = ddpkit_plot::render_rgb(size, |root| {
                draw_top_view(
                    root,
                    &axes,
                    &s,
                    &s.route,
                    std::slice::from_ref(&track),
                    PlotOptions::default(),
                )
            })
            .unwrap();
            (img, size)
        };
        let ((with, (w, h)), (without, _)) = (render(true), render(false));
        let (left, bottom, top, m) = ddpkit_plot::FRAME;
        let x_ticks = |img: &[u8]| ddpkit_plot::dark_pixels(img, w, left + m..w - m, h - bottom - m + 4..h - m);
        let y_ticks = |img: &[u8]| ddpkit_plot::dark_pixels(img, w, 0..left + m - 4, top..h - bottom - m);
        let title = |img: &[u8]| ddpkit_plot::dark_pixels(img, w, 0..w, 0..top - 6);
        for (name, a, b) in [
            ("x ticks", x_ticks(&with), x_ticks(&without)),
            ("y ticks", y_ticks(&with), y_ticks(&without)),
            ("title", title(&with), title(&without)),
        ] {
            assert!(a > b + 40, "{name}: {a} dark pixels with text, {b} without");
        }
        // The legend (upper right, drawn only with text) adds dark pixels there.
        let legend = |img: &[u8]| ddpkit_plot::dark_pixels(img, w, w / 2..w - m, top..h / 2);
        assert!(legend(&with) > legend(&without) + 100);
    }
}
