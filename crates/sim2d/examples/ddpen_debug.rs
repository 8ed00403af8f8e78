//! Traces a DDPEN (or any) run cycle by cycle: pose, command, local goal, sub-goals, the plan's
//! end point, cost and set-up time, every 10 control steps. For diagnosing planners in traps.
//!
//! ```text
//! cargo run --release -p sim2d --example ddpen_debug -- scenarios/cubes_with_minima.toml ddpen-oracle
//! cargo run --release -p sim2d --example ddpen_debug -- trap:u:3 ddpen      # trap-bench map u_0003, seed 1
//! cargo run --release -p sim2d --example ddpen_debug -- trap:l:6 ddpen 0.5 b  # w_subgoal 0.5, backward
//! ```
//!
//! `DDPEN_RUN=K` runs a scenario with the noise seed of run `K` of `ddpen-table --seed B`
//! (`DDPEN_BASE=B`, default 1; without `DDPEN_RUN`, the run config's seed). Every contact onset is printed with the plan's next knots and their
//! distance-field clearance. `DDPEN_SNAPSHOTS=DIR` also writes a PNG of the costmap, robot, local goal, sub-goals and plan
//! every 2 s of simulated time; `DDPEN_MODEL=FILE` runs `ddpen` with other weights.

use sim2d::run::{CycleView, Observer};
use sim2d::{run_scenario_with, PlannerKind, RunConfig, Scenario};

struct Trace(usize, Option<std::path::PathBuf>, usize);

/// Writes the inflated costmap (grey), the robot (red), the local goal (blue), the sub-goals
/// (green) and the plan (purple) to `path` as a 400 x 400 PNG.
fn snapshot(path: &std::path::Path, c: &CycleView<'_>) -> Result<(), Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    let map = c.perception.costmap();
    let g = *map.geometry();
    let root = BitMapBackend::new(path, (2 * g.width() as u32, 2 * g.height() as u32)).into_drawing_area();
    root.fill(&WHITE)?;
    for iy in 0..g.height() {
        for ix in 0..g.width() {
            let v = map.get(ix, iy);
            if v > 0 {
                let shade = 255 - (v as u32 * 200 / 254) as u8;
                let (x, y) = (2 * ix as i32, 2 * (g.height() - 1 - iy) as i32);
                root.draw(&Rectangle::new(
                    [(x, y), (x + 2, y + 2)],
                    RGBColor(shade, shade, shade).filled(),
                ))?;
            }
        }
    }
    let px = |p: [f64; 2]| -> (i32, i32) {
        let q = g.world_to_grid(p);
        ((2.0 * q[0]) as i32, (2.0 * (g.height() as f64 - q[1])) as i32)
    };
    if let Some(p) = c.plan {
        let pts: Vec<(i32, i32)> = p.states.iter().map(|s| px([s[0], s[1]])).collect();
        root.draw(&PathElement::new(pts, RGBColor(140, 40, 180).stroke_width(2)))?;
        for s in &p.guide {
            root.draw(&Circle::new(px(*s), 5, RGBColor(20, 170, 40).filled()))?;
        }
    }
    root.draw(&Circle::new(px(c.goal), 6, RGBColor(30, 60, 220).filled()))?;
    let r = px([c.pose[0], c.pose[1]]);
    root.draw(&Circle::new(r, 6, RGBColor(220, 30, 30).filled()))?;
    let h = px([c.pose[0] + 0.6 * c.pose[2].cos(), c.pose[1] + 0.6 * c.pose[2].sin()]);
    root.draw(&PathElement::new(vec![r, h], RGBColor(220, 30, 30).stroke_width(3)))?;
    root.present()?;
    Ok(())
}

impl Observer for Trace {
    fn on_cycle(&mut self, c: &CycleView<'_>) -> sim2d::Result<()> {
        self.0 += 1;
        if c.collisions > self.2 {
            self.2 = c.collisions;
            println!(
                "CONTACT t {:5.1} pose ({:6.2},{:6.2},{:5.2}) cmd ({:5.2},{:5.2}) clearance {:.2}",
                c.time,
                c.pose[0],
                c.pose[1],
                c.pose[2],
                c.command[0],
                c.command[1],
                c.perception.field().sample([c.pose[0], c.pose[1]]).0
            );
            if let Some(p) = c.plan {
                let knots: Vec<String> = p
                    .states
                    .iter()
                    .zip(&p.controls)
                    .take(10)
                    .map(|(s, u)| {
                        let d = c.perception.field().sample([s[0], s[1]]).0;
                        format!("({:.2},{:.2}|{:.2},{:.2}|{:.2})", s[0], s[1], u[0], u[1], d)
                    })
                    .collect();
                println!("  plan {}", knots.join(" "));
                let subs: Vec<String> = p.guide.iter().map(|g| format!("({:.2},{:.2})", g[0], g[1])).collect();
                println!("  sub [{}] goal ({:.2},{:.2})", subs.join(" "), c.goal[0], c.goal[1]);
            }
        }
        if let Some(dir) = &self.1 {
            if self.0 % 20 == 0 {
                let path = dir.join(format!("t{:06.1}.png", c.time));
                snapshot(&path, c).map_err(|e| sim2d::Error::invalid("snapshot", e.to_string()))?;
            }
        }
        if self.0 % 10 == 0 {
            if let Some(p) = c.plan {
                let end = p.states.last().copied().unwrap_or(c.pose);
                let subs: Vec<String> = p.guide.iter().map(|g| format!("({:.2},{:.2})", g[0], g[1])).collect();
                println!(
                    "t {:5.1} pose ({:6.2},{:6.2},{:5.2}) cmd ({:5.2},{:5.2}) goal ({:6.2},{:6.2}) sub [{}] end ({:6.2},{:6.2}) cost {:.2} setup {:.2} ms",
                    c.time, c.pose[0], c.pose[1], c.pose[2], c.command[0], c.command[1], c.goal[0], c.goal[1],
                    subs.join(" "), end[0], end[1], p.cost, 1e3 * p.setup_seconds
                );
            }
        }
        Ok(())
    }
}

fn main() -> sim2d::Result<()> {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 3 {
        eprintln!("usage: ddpen_debug <scenario.toml | trap:<type>:<index>> <planner> [w_subgoal] [b]");
        std::process::exit(2);
    }
    let mut seed = None;
    let s = if let Some(t) = a[1].strip_prefix("trap:") {
        let (k, i) = t
            .split_once(':')
            .ok_or_else(|| sim2d::Error::invalid("scenario", "expected trap:<type>:<index>"))?;
        let i = i
            .parse()
            .map_err(|_| sim2d::Error::invalid("scenario", format!("bad map index {i:?}")))?;
        // The noise seed trap-bench gives this map (seed 1).
        seed = Some(sim2d::batch::run_seed(1, i, sim2d::Direction::Forward));
        sim2d::traps::trap_map(sim2d::traps::TrapKind::parse(k)?, 1, i, &Default::default())?
    } else {
        Scenario::from_file(&a[1])?
    };
    let mut config = RunConfig {
        planner: PlannerKind::parse(&a[2])?,
        ..RunConfig::default()
    };
    // DDPEN_MODEL=<weights>: the network of `ddpen` (default: the shipped model).
    if let Some(m) = std::env::var_os("DDPEN_MODEL") {
        config.ddpen.model = Some(m.into());
    }
    if let Some(seed) = seed {
        config.seed = seed;
        config.stall_time = 30.0;
    }
    if let Some(w) = a.get(3) {
        config.ddpen.w_subgoal = w
            .parse()
            .map_err(|_| sim2d::Error::invalid("w_subgoal", format!("not a number: {w:?}")))?;
    }
    if a.get(4).is_some_and(|d| d == "b") {
        config.direction = sim2d::Direction::Backward;
    }
    if let Some(k) = std::env::var_os("DDPEN_RUN") {
        let k: usize = k
            .to_string_lossy()
            .parse()
            .map_err(|_| sim2d::Error::invalid("DDPEN_RUN", "not a run index"))?;
        // DDPEN_BASE=<seed>: the table's --seed (default 1).
        let base = std::env::var("DDPEN_BASE")
            .ok()
            .and_then(|b| b.parse().ok())
            .unwrap_or(1);
        config.seed = sim2d::batch::run_seed(base, k, config.direction);
    }
    // DDPEN_SNAPSHOTS=<dir>: a costmap PNG every 2 s of simulated time.
    let dir = std::env::var_os("DDPEN_SNAPSHOTS").map(std::path::PathBuf::from);
    if let Some(d) = &dir {
        std::fs::create_dir_all(d).map_err(|e| sim2d::Error::invalid("DDPEN_SNAPSHOTS", e.to_string()))?;
    }
    let r = run_scenario_with(&s, &config, &mut [&mut Trace(0, dir, 0)])?;
    println!(
        "{} {:.1} s progress {:.1} m collisions {}",
        r.outcome, r.time_s, r.progress_m, r.collisions
    );
    Ok(())
}
