//! Scratch: prints pose, goal and sub-goals along a run.
use sim2d::run::{CycleView, Observer};
use sim2d::{run_scenario_with, PlannerKind, RunConfig, Scenario};

struct P(usize);
impl Observer for P {
    fn on_cycle(&mut self, c: &CycleView<'_>) -> sim2d::Result<()> {
        self.0 += 1;
        if self.0 % 10 == 0 {
            if let Some(p) = c.plan {
                let end = p.states.last().unwrap();
                println!(
                    "t {:5.1} pose ({:6.2},{:6.2},{:5.2}) cmd ({:4.2},{:5.2}) goal ({:6.2},{:6.2}) sub {:?} end ({:6.2},{:6.2}) cost {:.2} setup {:.2} ms",
                    c.time, c.pose[0], c.pose[1], c.pose[2], c.command[0], c.command[1], c.goal[0], c.goal[1],
                    p.guide.iter().map(|g| format!("({:.2},{:.2})", g[0], g[1])).collect::<Vec<_>>(),
                    end[0], end[1], p.cost, 1e3 * p.setup_seconds
                );
            }
        }
        Ok(())
    }
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let s = if let Some(t) = a[1].strip_prefix("trap:") {
        let (k, i) = t.split_once(':').unwrap();
        sim2d::traps::trap_map(sim2d::traps::TrapKind::parse(k).unwrap(), 1, i.parse().unwrap(), &Default::default()).unwrap()
    } else {
        Scenario::from_file(&a[1]).unwrap()
    };
    for o in &s.obstacles { println!("{o:?}"); }
    let mut config = RunConfig { planner: PlannerKind::parse(&a[2]).unwrap(), ..RunConfig::default() };
    if a.len() > 3 { config.ddp.w_subgoal = a[3].parse().unwrap(); }
    if a.len() > 4 && a[4] == "b" { config.direction = sim2d::Direction::Backward; }
    let mut p = P(0);
    let r = run_scenario_with(&s, &config, &mut [&mut p]).unwrap();
    println!("{} {:.1} s progress {:.1} collisions {}", r.outcome, r.time_s, r.progress_m, r.collisions);
}
