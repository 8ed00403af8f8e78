//! Traces a DDPEN (or any) run cycle by cycle: pose, command, local goal, sub-goals, the plan's
//! end point, cost and set-up time, every 10 control steps. For diagnosing planners in traps.
//!
//! ```text
//! cargo run --release -p sim2d --example ddpen_debug -- scenarios/cubes_with_minima.toml ddpen-oracle
//! cargo run --release -p sim2d --example ddpen_debug -- trap:u:3 ddpen      # trap-bench map u_0003, seed 1
//! cargo run --release -p sim2d --example ddpen_debug -- trap:l:6 ddpen 0.5 b  # w_subgoal 0.5, backward
//! ```

use sim2d::run::{CycleView, Observer};
use sim2d::{run_scenario_with, PlannerKind, RunConfig, Scenario};

struct Trace(usize);

impl Observer for Trace {
    fn on_cycle(&mut self, c: &CycleView<'_>) -> sim2d::Result<()> {
        self.0 += 1;
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
    let s = if let Some(t) = a[1].strip_prefix("trap:") {
        let (k, i) = t
            .split_once(':')
            .ok_or_else(|| sim2d::Error::invalid("scenario", "expected trap:<type>:<index>"))?;
        let i = i
            .parse()
            .map_err(|_| sim2d::Error::invalid("scenario", format!("bad map index {i:?}")))?;
        sim2d::traps::trap_map(sim2d::traps::TrapKind::parse(k)?, 1, i, &Default::default())?
    } else {
        Scenario::from_file(&a[1])?
    };
    let mut config = RunConfig {
        planner: PlannerKind::parse(&a[2])?,
        ..RunConfig::default()
    };
    if let Some(w) = a.get(3) {
        config.ddp.w_subgoal = w
            .parse()
            .map_err(|_| sim2d::Error::invalid("w_subgoal", format!("not a number: {w:?}")))?;
    }
    if a.get(4).is_some_and(|d| d == "b") {
        config.direction = sim2d::Direction::Backward;
    }
    let r = run_scenario_with(&s, &config, &mut [&mut Trace(0)])?;
    println!(
        "{} {:.1} s progress {:.1} m collisions {}",
        r.outcome, r.time_s, r.progress_m, r.collisions
    );
    Ok(())
}
