//! Fig. 4 of Alcan and Kyrki (2022) from the car's episodes of a Table I sweep (feature `figure`):
//! trajectories among the obstacles, the position standard deviation of the first plan and the
//! norms of the gains its covariance used.

use std::path::Path;

use plotters::prelude::*;

use crate::sweep::{car_runs, TableConfig};
use crate::table::{self, EpisodeOutcome, Method, Scenario};

/// Draws Fig. 4 from `outcomes` (in the order of [`crate::sweep::tasks`]) to `path`. Returns
/// `Ok(false)` without writing when the configuration has no car (Fig. 4 is the car's).
pub fn table_figure(
    path: &Path,
    config: &TableConfig,
    outcomes: &[EpisodeOutcome],
) -> Result<bool, Box<dyn std::error::Error>> {
    let Some((methods, runs)) = car_runs(config, outcomes) else {
        return Ok(false);
    };
    let sc = table::car(config.noise(table::Robot::Car))?;
    figure(path, &sc, &methods, &runs)?;
    Ok(true)
}

const CDDP_COLOR: RGBColor = RGBColor(214, 39, 40);
const FIXED_COLOR: RGBColor = RGBColor(31, 119, 180);
const SAFE_COLOR: RGBColor = RGBColor(44, 160, 44);
const OPEN_COLOR: RGBColor = RGBColor(90, 90, 90);

fn color_of(m: &Method) -> RGBColor {
    match m {
        Method::Cddp => CDDP_COLOR,
        Method::SafeCddp { .. } => SAFE_COLOR,
        Method::FixedGains { .. } => FIXED_COLOR,
        Method::OpenLoop { .. } => OPEN_COLOR,
    }
}

fn label_of(m: &Method) -> &'static str {
    match m {
        Method::Cddp => "CDDP",
        Method::SafeCddp { .. } => "Safe-CDDP (beta 0.99)",
        Method::FixedGains { .. } => "fixed gains (LQR at the goal)",
        Method::OpenLoop { .. } => "open loop (K = 0)",
    }
}

/// Fig. 4: (a) car trajectories of CDDP, fixed gains and Safe-CDDP (beta = 0.99) among the
/// obstacles; (b) position standard deviation of the first plan along the horizon for open loop,
/// fixed gains and Safe-CDDP; (c) Frobenius norm of the gains the covariance used. Each panel
/// has axes with units, a legend and a title (`ddpkit-plot`, embedded font).
fn figure(
    path: &Path,
    sc: &Scenario<4, 2>,
    methods: &[Method],
    runs: &[&[EpisodeOutcome]],
) -> Result<(), Box<dyn std::error::Error>> {
    use ddpkit_plot::{chart, disc_key, legend, line_key, Axes};
    let find = |want: fn(&Method) -> bool| methods.iter().position(want);
    let cddp = find(|m| matches!(m, Method::Cddp));
    let safe = find(|m| matches!(m, Method::SafeCddp { beta } if *beta == 0.99));
    let fixed = find(|m| matches!(m, Method::FixedGains { .. }));
    let open = find(|m| matches!(m, Method::OpenLoop { .. }));
    let (width, height) = (2000u32, 560u32);
    ddpkit_plot::write_png(path, (width, height), |root| {
        let (left, right) = root.split_horizontally(1100);
        let panels = [
            left,
            right.split_evenly((1, 2)).remove(0),
            right.split_evenly((1, 2)).remove(1),
        ];
        // (a) Trajectories, equal scales on both axes.
        {
            let (x0, x1) = (-0.3f64, 4.3f64);
            let (l, b, t, m) = ddpkit_plot::FRAME;
            let half = (x1 - x0) * f64::from(height - b - t - 2 * m) / f64::from(1100 - l - 2 * m) / 2.0;
            let axes = Axes::new(
                "(a) car trajectories, 25 episodes each",
                "x (m)",
                "y (m)",
                x0..x1,
                -half..half,
            );
            let mut c = chart(&panels[0], &axes)?;
            let grey = RGBColor(200, 200, 200).filled();
            c.draw_series(sc.obstacles.iter().map(|o| {
                let pts: Vec<(f64, f64)> = (0..=64)
                    .map(|i| {
                        let a = i as f64 / 64.0 * std::f64::consts::TAU;
                        (o.center[0] + o.radius * a.cos(), o.center[1] + o.radius * a.sin())
                    })
                    .collect();
                Polygon::new(pts, grey)
            }))?
            .label("obstacles")
            .legend(ddpkit_plot::box_key(grey));
            for idx in [cddp, fixed, safe].into_iter().flatten() {
                let style = color_of(&methods[idx]).mix(0.6).stroke_width(1);
                c.draw_series(
                    runs[idx]
                        .iter()
                        .take(25)
                        .map(|e| PathElement::new(e.path.iter().map(|p| (p[0], p[1])).collect::<Vec<_>>(), style)),
                )?
                .label(label_of(&methods[idx]))
                .legend(line_key(color_of(&methods[idx]).stroke_width(2)));
            }
            let goal = sc.mpc.goal;
            c.draw_series(std::iter::once(Circle::new((goal[0], goal[1]), 6, BLACK.filled())))?
                .label("goal")
                .legend(disc_key(BLACK.filled(), 5));
            c.draw_series(std::iter::once(Circle::new((0.0, 0.0), 6, BLACK.stroke_width(2))))?
                .label("start")
                .legend(disc_key(BLACK.stroke_width(2), 5));
            legend(&mut c, SeriesLabelPosition::UpperLeft)?;
        }
        // (b) Position sigma and (c) gain norms of the first plan.
        let series = |f: fn(&EpisodeOutcome) -> &Vec<f64>| -> Vec<(usize, Vec<f64>)> {
            [open, fixed, safe]
                .into_iter()
                .flatten()
                .filter_map(|i| runs[i].first().map(|e| (i, f(e).clone())))
                .collect()
        };
        for (panel, data, title, y_label) in [
            (
                &panels[1],
                series(|e| &e.sigma_position),
                "(b) position sd along the first plan",
                "sigma position (m)",
            ),
            (
                &panels[2],
                series(|e| &e.gain_norms),
                "(c) feedback gains of the covariance",
                "|K| Frobenius",
            ),
        ] {
            let n = data.iter().map(|(_, v)| v.len()).max().unwrap_or(1).max(2);
            let top = data
                .iter()
                .flat_map(|(_, v)| v.iter().copied())
                .filter(|v| v.is_finite())
                .fold(0.0f64, f64::max)
                .max(1e-12)
                * 1.05;
            let axes = Axes::new(title, "knot k (time step)", y_label, 0f64..(n - 1) as f64, 0f64..top);
            let mut c = chart(panel, &axes)?;
            for (i, v) in data {
                let style = color_of(&methods[i]).stroke_width(3);
                c.draw_series(std::iter::once(PathElement::new(
                    v.iter().enumerate().map(|(k, &y)| (k as f64, y)).collect::<Vec<_>>(),
                    style,
                )))?
                .label(label_of(&methods[i]))
                .legend(line_key(style));
            }
            legend(&mut c, SeriesLabelPosition::UpperLeft)?;
        }
        Ok(())
    })?;
    Ok(())
}
