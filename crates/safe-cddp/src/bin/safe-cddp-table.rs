//! Reproduces Table I of Safe-CDDP (Alcan and Kyrki 2022) and a figure like its Fig. 4.
//!
//! ```text
//! cargo run --release -p safe-cddp --bin safe-cddp-table -- --seed 1 \
//!     --json crates/safe-cddp/results/table1.json --figure crates/safe-cddp/results/fig4.png
//! ```
//!
//! Runs `--episodes` (default 100) seeded MPC episodes per robot and `beta` in parallel (rayon),
//! with a progress bar, prints the table beside the paper's, and optionally writes every figure
//! of it as JSON and the figure as a PNG. Episode `e` of a robot meets the same noise under every
//! method (see [`safe_cddp::table::episode_seed`]), so results do not depend on the thread count.
//! The scenarios are in [`safe_cddp::table`]. Besides the paper's rows, the car is also run with
//! the two baselines of Fig. 4 at `beta = 0.99` (fixed LQR gains, open loop).

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use plotters::prelude::*;
use rayon::prelude::*;
use safe_cddp::table::{self, episode_seed, EpisodeOutcome, Method, Metrics, Robot, Scenario, BETAS};
use serde::Serialize;

#[derive(Parser, Debug)]
#[command(about = "Reproduce Table I (and Fig. 4) of Safe-CDDP: MPC episodes under process noise")]
struct Args {
    /// Episodes per robot and beta.
    #[arg(long, default_value_t = 100)]
    episodes: usize,
    /// Base seed of the process noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Write every figure of the table (and the settings) as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write the Fig. 4 PNG (car: trajectories, position sigma, gain norms) here.
    #[arg(long)]
    figure: Option<PathBuf>,
    /// Robots to run (comma-separated: point, car, quadrotor).
    #[arg(long, value_delimiter = ',', default_value = "point,car,quadrotor")]
    robots: Vec<String>,
    /// Override the noise scale of the point robot (m per step).
    #[arg(long)]
    noise_point: Option<f64>,
    /// Override the noise scale of the car (m per step).
    #[arg(long)]
    noise_car: Option<f64>,
    /// Override the noise scale of the quadrotor (m per step).
    #[arg(long)]
    noise_quadrotor: Option<f64>,
    /// The betas to run (comma-separated subset of 0.5, 0.9, 0.95, 0.99; 0.5 is plain CDDP).
    #[arg(long, value_delimiter = ',', default_value = "0.5,0.9,0.95,0.99")]
    betas: Vec<f64>,
    /// Skip the car's fixed-gain and open-loop baselines (Fig. 4).
    #[arg(long)]
    no_baselines: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
}

/// One row group of the output: a robot under one method.
#[derive(Debug, Serialize)]
struct Row {
    robot: Robot,
    method: Method,
    beta: f64,
    metrics: Metrics,
    /// The paper's (violated episodes, average in violated episodes, total average), if it has one.
    paper: Option<(usize, f64, f64)>,
    /// Collisions per episode.
    collisions: Vec<usize>,
}

#[derive(Debug, Serialize)]
struct Output {
    command: String,
    seed: u64,
    episodes: usize,
    noise: Vec<(Robot, f64)>,
    threads: usize,
    seconds: f64,
    rows: Vec<Row>,
}

fn robot_of(name: &str) -> Result<Robot, String> {
    Robot::ALL
        .into_iter()
        .find(|r| r.name() == name.trim())
        .ok_or_else(|| format!("unknown robot {name:?} (expected point, car or quadrotor)"))
}

/// Runs `episodes` episodes of every method on `sc` in parallel; returns them per method.
fn run_methods<const NX: usize, const NU: usize>(
    sc: &Scenario<NX, NU>,
    methods: &[Method],
    episodes: usize,
    seed: u64,
    bar: &ProgressBar,
) -> Result<Vec<Vec<EpisodeOutcome>>, ddp_core::Error> {
    let jobs: Vec<(usize, usize)> = (0..methods.len())
        .flat_map(|m| (0..episodes).map(move |e| (m, e)))
        .collect();
    let outcomes: Vec<Result<EpisodeOutcome, ddp_core::Error>> = jobs
        .par_iter()
        .map(|&(m, e)| {
            let r = table::run_episode(sc, methods[m], episode_seed(seed, sc.robot, e));
            bar.inc(1);
            r
        })
        .collect();
    let mut per_method: Vec<Vec<EpisodeOutcome>> = (0..methods.len()).map(|_| Vec::new()).collect();
    for ((m, _), o) in jobs.into_iter().zip(outcomes) {
        per_method[m].push(o?);
    }
    Ok(per_method)
}

fn method_beta(m: &Method) -> f64 {
    match *m {
        Method::Cddp => 0.5,
        Method::SafeCddp { beta } | Method::FixedGains { beta } | Method::OpenLoop { beta } => beta,
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    if args.episodes == 0 {
        return Err("--episodes must be at least 1".into());
    }
    if let Some(t) = args.threads {
        rayon::ThreadPoolBuilder::new().num_threads(t.max(1)).build_global()?;
    }
    let robots: Vec<Robot> = args.robots.iter().map(|r| robot_of(r)).collect::<Result<_, _>>()?;
    let noise = |r: Robot| {
        match r {
            Robot::Point => args.noise_point,
            Robot::Car => args.noise_car,
            Robot::Quadrotor => args.noise_quadrotor,
        }
        .unwrap_or(r.default_noise())
    };
    for b in &args.betas {
        if !(*b > 0.0 && *b < 1.0) {
            return Err(format!("--betas: {b} is not in (0, 1)").into());
        }
    }
    let paper_methods: Vec<Method> = args.betas.iter().map(|&b| Method::for_beta(b)).collect();
    let mut car_methods = paper_methods.clone();
    if !args.no_baselines {
        car_methods.push(Method::FixedGains { beta: 0.99 });
        car_methods.push(Method::OpenLoop { beta: 0.99 });
    }
    let total: usize = robots
        .iter()
        .map(|r| if *r == Robot::Car { car_methods.len() } else { paper_methods.len() } * args.episodes)
        .sum();
    let bar = ProgressBar::new(total as u64);
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} episodes ({eta} left) {msg}")?
            .progress_chars("=> "),
    );
    let start = Instant::now();
    let mut rows = Vec::new();
    let mut car_runs: Option<(Scenario<4, 2>, Vec<Method>, Vec<Vec<EpisodeOutcome>>)> = None;
    for &robot in &robots {
        bar.set_message(robot.name());
        let s = noise(robot);
        let (methods, per_method) = match robot {
            Robot::Point => {
                let sc = table::point_robot(s)?;
                (
                    paper_methods.clone(),
                    run_methods(&sc, &paper_methods, args.episodes, args.seed, &bar)?,
                )
            }
            Robot::Car => {
                let sc = table::car(s)?;
                let runs = run_methods(&sc, &car_methods, args.episodes, args.seed, &bar)?;
                car_runs = Some((sc, car_methods.clone(), runs.clone()));
                (car_methods.clone(), runs)
            }
            Robot::Quadrotor => {
                let sc = table::quadrotor(s)?;
                (
                    paper_methods.clone(),
                    run_methods(&sc, &paper_methods, args.episodes, args.seed, &bar)?,
                )
            }
        };
        for (m, episodes) in methods.iter().zip(&per_method) {
            let beta = method_beta(m);
            let paper = match m {
                Method::Cddp | Method::SafeCddp { .. } => {
                    BETAS.iter().position(|&b| b == beta).map(|i| robot.paper()[i])
                }
                _ => None,
            };
            rows.push(Row {
                robot,
                method: *m,
                beta,
                metrics: Metrics::of(episodes),
                paper,
                collisions: episodes.iter().map(|e| e.collisions).collect(),
            });
        }
    }
    bar.finish_and_clear();
    let seconds = start.elapsed().as_secs_f64();
    print_table(&rows);
    let threads = rayon::current_num_threads();
    println!(
        "\n{} episodes per row, seed {}, {} threads, {:.1} s",
        args.episodes, args.seed, threads, seconds
    );
    if let Some(path) = &args.json {
        let out = Output {
            command: std::env::args().collect::<Vec<_>>().join(" "),
            seed: args.seed,
            episodes: args.episodes,
            noise: robots.iter().map(|&r| (r, noise(r))).collect(),
            threads,
            seconds,
            rows,
        };
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir)?;
        }
        // Whole or absent: a temporary file, then a rename.
        ddpkit_util::fs::write_atomic(path, serde_json::to_string_pretty(&out)?)?;
        println!("wrote {}", path.display());
    }
    if let Some(path) = &args.figure {
        match &car_runs {
            Some((sc, methods, runs)) => {
                figure(path, sc, methods, runs)?;
                println!("wrote {}", path.display());
            }
            None => eprintln!("--figure needs the car (Fig. 4 is the car's); skipped"),
        }
    }
    Ok(())
}

fn method_label(m: &Method) -> String {
    match m {
        Method::Cddp => "CDDP (beta=0.5)".into(),
        Method::SafeCddp { beta } => format!("Safe-CDDP beta={beta}"),
        Method::FixedGains { beta } => format!("fixed gains beta={beta}"),
        Method::OpenLoop { beta } => format!("open loop beta={beta}"),
    }
}

fn print_table(rows: &[Row]) {
    println!(
        "{:<20} {:<24} | {:>9} {:>9} {:>9} | {:>7} {:>7} {:>7} | {:>8} {:>7}",
        "robot", "method", "violated", "avg/viol", "total", "paper", "paper", "paper", "success", "steps"
    );
    println!("{}", "-".repeat(128));
    let mut last = None;
    for r in rows {
        if last.is_some() && last != Some(r.robot) {
            println!();
        }
        last = Some(r.robot);
        let m = &r.metrics;
        let (pv, pa, pt) = match r.paper {
            Some((v, a, t)) => (v.to_string(), format!("{a:.2}"), format!("{t:.2}")),
            None => ("-".into(), "-".into(), "-".into()),
        };
        println!(
            "{:<20} {:<24} | {:>9} {:>9.2} {:>9.2} | {:>7} {:>7} {:>7} | {:>4}/{:<3} {:>7.1}",
            r.robot.title(),
            method_label(&r.method),
            m.violated_episodes,
            m.avg_in_violated,
            m.total_avg,
            pv,
            pa,
            pt,
            m.successes,
            m.episodes,
            m.mean_steps
        );
    }
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
    runs: &[Vec<EpisodeOutcome>],
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
