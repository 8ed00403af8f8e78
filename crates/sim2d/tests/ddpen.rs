//! DDPEN in the loop: the A* oracle's sub-goals, the sub-goal cost's derivatives, a small trap
//! that DDPEN (oracle) escapes and DDP does not, the trap-map generator, and input errors.

use ddp_core::dims::{U2, U3};
use std::sync::Arc;

use ddp_core::costs::{CostSum, SmoothDistance, StateOnly};
use ddp_core::{Cost, CostDerivatives, TerminalCost, TerminalDerivatives, Vector};
use sim2d::ddpen::{AstarSubgoals, DdpenParams, DdpenPlanner, GoalRepair, MapFrame, SubgoalSource, ORACLE_STEPS};
use sim2d::perception::{Perception, PerceptionParams};
use sim2d::planner::{DdpParams, PlanRequest, Planner};
use sim2d::traps::{solvable, trap_map, TrapKind, TrapParams};
use sim2d::world::{LidarParams, RobotParams, Scan, World};
use sim2d::{run_scenario, Obstacle, Outcome, PlannerKind, Route, RunConfig, Scenario};
use subgoal_infer::grid::{AStar, AStarParams, Costmap, GridGeometry, INSCRIBED, LETHAL};

fn cube(center: [f64; 2]) -> Obstacle {
    Obstacle::Box {
        center,
        size: [2.0, 2.0],
        yaw: 0.0,
    }
}

/// A U of 2 m cubes whose back wall lies across the route at `x`, opening towards the start.
fn u_trap(x: f64) -> Vec<Obstacle> {
    let mut o: Vec<Obstacle> = [-2.0, 0.0, 2.0].iter().map(|&y| cube([x, y])).collect();
    for y in [-2.0, 2.0] {
        for dx in [2.0, 4.0] {
            o.push(cube([x - dx, y]));
        }
    }
    o
}

/// The perception after one lidar scan of `scenario` from `pose`.
fn seen(scenario: &Scenario, pose: [f64; 3]) -> Perception {
    let mut world = World::new(scenario, RobotParams::default(), pose, 0.02, 1).unwrap();
    let mut scan = Scan::default();
    world.scan(&LidarParams::default(), &mut scan);
    let mut p = Perception::new(PerceptionParams::default()).unwrap();
    p.update(&scan);
    p
}

#[test]
fn oracle_subgoals_lie_on_free_cells_along_an_astar_path() {
    let scenario = Scenario {
        name: "t".into(),
        description: String::new(),
        route: Route::new(vec![[0.0, 0.0], [20.0, 0.0]]).unwrap(),
        obstacles: vec![cube([3.5, 0.3])],
    };
    let perception = seen(&scenario, [0.0, 0.0, 0.0]);
    let map = perception.costmap();
    let goal = [4.9, 0.0];
    let mut oracle = AstarSubgoals::default();
    let mut subgoals = Vec::new();
    oracle
        .subgoals(perception.costmap(), [0.0, 0.0, 0.0], goal, &mut subgoals)
        .unwrap();
    assert_eq!(subgoals.len(), ORACLE_STEPS.len());
    // The oracle's path is an optimal A* path: the same cost as a fresh search.
    let path = oracle.path().to_vec();
    assert!(path.len() > 70, "{}", path.len());
    let g = map.geometry();
    let mut fresh = Vec::new();
    let want = AStar::new(g)
        .search(
            map,
            g.world_to_cell_clamped([0.0, 0.0]),
            g.world_to_cell_clamped(goal),
            &AStarParams::default(),
            &mut fresh,
        )
        .unwrap();
    let cost: f64 = path
        .windows(2)
        .map(|w| {
            let len = if w[0].0 != w[1].0 && w[0].1 != w[1].1 {
                std::f64::consts::SQRT_2
            } else {
                1.0
            };
            len * (1.0 + 3.0 * map.get(w[1].0, w[1].1).min(252) as f64 / 252.0)
        })
        .sum();
    assert!((cost - want).abs() < 1e-9, "{cost} vs {want}");
    for (k, (s, &step)) in subgoals.iter().zip(&ORACLE_STEPS).enumerate() {
        let c = g.world_to_cell(*s).unwrap();
        assert_eq!(c, path[step], "sub-goal {k} is path step {step}");
        assert!(map.get(c.0, c.1) < INSCRIBED, "sub-goal {k} on a blocked cell");
        assert_eq!(g.cell_to_world(c.0, c.1), *s, "sub-goal {k} is a cell centre");
    }
    // The cube sits across the straight line: the path bends round it.
    assert!(subgoals.iter().any(|s| s[1].abs() > 0.5), "{subgoals:?}");
}

#[test]
fn oracle_clamps_on_short_paths_and_aims_round_a_blocked_goal() {
    let mut map = Costmap::new(GridGeometry::ddpen([0.0, 0.0]));
    let mut oracle = AstarSubgoals::default();
    let mut cells = Vec::new();
    // A goal 1 m away: 20 steps, every sub-goal is the goal.
    assert!(oracle.search_cells(&map, [0.0, 0.0], [1.0, 0.0], &mut cells));
    let goal_cell = map.geometry().world_to_cell([1.0, 0.0]).unwrap();
    assert_eq!(cells, vec![goal_cell; 3]);
    // A wall through the goal at the border (x = 4.5 .. 5 m, |y| < 2 m): the goal moves along
    // the border band, not into the free cells in front of the wall.
    for iy in 60..140 {
        for ix in 190..200 {
            map.set(ix, iy, LETHAL);
        }
    }
    let goal = [4.9, 0.0];
    let c = GoalRepair::default().repair(&map, [0.0, 0.0], goal, INSCRIBED).unwrap();
    assert!(c.1 < 60 || c.1 >= 140, "{c:?}");
    assert!(c.0 >= 190, "{c:?}");
}

#[test]
fn exit_is_a_reachable_border_cell_and_keeps_its_side() {
    let mut map = Costmap::new(GridGeometry::ddpen([0.0, 0.0]));
    // A wall across the whole map at x = 3.5 .. 4 m: the right border is out of reach.
    for iy in 0..200 {
        for ix in 170..180 {
            map.set(ix, iy, LETHAL);
        }
    }
    let mut repair = GoalRepair::default();
    assert!(repair.repair(&map, [0.0, 0.0], [4.9, 0.0], INSCRIBED).is_some());
    let far = [15.0, 0.0];
    let (ix, iy) = repair.best_exit(&map, [0.0, 0.0], far, None, &[]).unwrap();
    assert!(ix < 170, "beyond the wall: {ix}");
    assert!(iy < 2 || iy >= 198, "not on the border: {iy}");
    // Top and bottom are equally good: the previous exit decides, either way.
    let g = *map.geometry();
    for side in [-4.9, 4.9] {
        let previous = [3.0, side];
        let (_, iy) = repair.best_exit(&map, [0.0, 0.0], far, Some(previous), &[]).unwrap();
        assert_eq!(g.cell_to_world(0, iy)[1] > 0.0, side > 0.0, "side {side}: row {iy}");
    }
    // A wall only across the middle (|y| < 3 m): the best exit lies behind it, reached round it.
    let mut map = Costmap::new(GridGeometry::ddpen([0.0, 0.0]));
    for iy in 40..160 {
        for ix in 170..180 {
            map.set(ix, iy, LETHAL);
        }
    }
    assert!(repair.repair(&map, [0.0, 0.0], [4.9, 0.0], INSCRIBED).is_some());
    let (ix, iy) = repair.best_exit(&map, [0.0, 0.0], far, None, &[]).unwrap();
    assert!(ix >= 198 && (95..105).contains(&iy), "({ix}, {iy})");
    let mut path = Vec::new();
    let found = AStar::new(map.geometry()).search(&map, (100, 100), (ix, iy), &AStarParams::default(), &mut path);
    assert!(found.is_some() && path.iter().any(|c| c.1 < 40 || c.1 >= 160));
    // Once that exit is known to be a dead end, another one is chosen, 2 m or more away.
    let dead = [g.cell_to_world(ix, iy)];
    let (jx, jy) = repair.best_exit(&map, [0.0, 0.0], far, None, &dead).unwrap();
    let q = g.cell_to_world(jx, jy);
    assert!((q[0] - dead[0][0]).hypot(q[1] - dead[0][1]) >= 2.0, "{q:?}");
    assert_eq!(repair.reachable(&map, q), Some(true));
    assert_eq!(repair.reachable(&map, [3.75, 0.0]), Some(false), "inside the wall");
    assert_eq!(repair.reachable(&map, [30.0, 0.0]), None, "off the map");
}

#[test]
fn map_frame_matches_the_costmap_cells_of_perception() {
    // The costmap is world-aligned and centred on the robot up to one cell.
    let scenario = Scenario {
        name: "t".into(),
        description: String::new(),
        route: Route::new(vec![[0.0, 0.0], [20.0, 0.0]]).unwrap(),
        obstacles: vec![],
    };
    let pose = [12.34, -5.67, 2.0];
    let perception = seen(&scenario, pose);
    let g = perception.costmap().geometry();
    let frame = MapFrame::of(g);
    // The robot's cell is (100, 100), whose centre is (0.025, 0.025) in map coordinates, as in
    // the dataset; the heading plays no part (map axes are world axes).
    assert_eq!(g.world_to_cell([pose[0], pose[1]]), Some((100, 100)));
    let q = frame.to_map([pose[0], pose[1]]);
    assert!(q[0] >= 0.0 && q[0] < 0.05 && q[1] >= 0.0 && q[1] < 0.05, "{q:?}");
    // A point 3 m east and 1 m north of the robot is (3, 1) + the robot's offset in map coords.
    let p = [pose[0] + 3.0, pose[1] + 1.0];
    let m = frame.to_map(p);
    assert!((m[0] - (3.0 + q[0])).abs() < 1e-5 && (m[1] - (1.0 + q[1])).abs() < 1e-5);
    let back = frame.to_world(m);
    assert!((back[0] - p[0]).abs() < 1e-5 && (back[1] - p[1]).abs() < 1e-5);
    // Cell (ix, iy) centre in map coordinates: ((ix - 100 + 0.5) 0.05, (iy - 100 + 0.5) 0.05).
    let c = frame.to_map(g.cell_to_world(130, 40));
    assert!((c[0] - 1.525).abs() < 1e-5 && (c[1] + 2.975).abs() < 1e-5, "{c:?}");
}

#[test]
fn subgoal_cost_derivatives_match_finite_differences() {
    // The running cost of eq. (8) restricted to its sub-goal part, sum_k w_s c_s(x, x_s^k)
    // (eq. 9), on the unicycle state, plus a control term.
    let subgoals = [[1.0, 0.5], [2.0, -0.3], [0.2, 0.1]];
    let mut cost = CostSum::<U3, U2>::new().with(0.1, Arc::new(ddp_core::costs::ControlSquared::new(1.0).unwrap()));
    for s in subgoals {
        cost.push(
            0.7,
            Arc::new(StateOnly(SmoothDistance::<3>::sub_goal(s, [0, 1], 0.05, 1.0).unwrap())),
        )
        .unwrap();
    }
    let h = 1e-5;
    let grad = |x: &Vector<3>, u: &Vector<2>| {
        let mut d = CostDerivatives::<U3, U2>::default();
        cost.add_derivatives(x, u, 1.0, &mut d);
        d
    };
    for x in [[0.3, -0.2, 0.4], [1.0, 0.5, -1.0], [2.5, 1.0, 3.0]] {
        let x = Vector::<3>::new(x[0], x[1], x[2]);
        let u = Vector::<2>::new(0.7, -0.2);
        let d = grad(&x, &u);
        for i in 0..3 {
            let (mut xp, mut xm) = (x, x);
            xp[i] += h;
            xm[i] -= h;
            let g = (cost.value(&xp, &u) - cost.value(&xm, &u)) / (2.0 * h);
            assert!((g - d.lx[i]).abs() < 1e-6, "l_x[{i}] {g} vs {}", d.lx[i]);
            let (dp, dm) = (grad(&xp, &u), grad(&xm, &u));
            for j in 0..3 {
                let hx = (dp.lx[j] - dm.lx[j]) / (2.0 * h);
                assert!(
                    (hx - d.lxx[(j, i)]).abs() < 1e-4,
                    "l_xx[{j},{i}] {hx} vs {}",
                    d.lxx[(j, i)]
                );
            }
        }
        for i in 0..2 {
            let (mut up, mut um) = (u, u);
            up[i] += h;
            um[i] -= h;
            let g = (cost.value(&x, &up) - cost.value(&x, &um)) / (2.0 * h);
            assert!((g - d.lu[i]).abs() < 1e-6, "l_u[{i}] {g} vs {}", d.lu[i]);
        }
        // One sub-goal term as a terminal cost.
        let t = SmoothDistance::<3>::sub_goal(subgoals[0], [0, 1], 0.05, 1.0).unwrap();
        let mut td = TerminalDerivatives::<U3>::default();
        t.add_derivatives(&x, 1.0, &mut td);
        for i in 0..2 {
            let (mut xp, mut xm) = (x, x);
            xp[i] += h;
            xm[i] -= h;
            let g = (t.value(&xp) - t.value(&xm)) / (2.0 * h);
            assert!((g - td.lx[i]).abs() < 1e-6, "terminal l_x[{i}]");
        }
    }
}

#[test]
fn ddpen_subgoals_bend_the_plan_round_an_obstacle() {
    // With sub-goals beside a wall, the plan passes them; vanilla DDP drives at the wall.
    let scenario = Scenario {
        name: "t".into(),
        description: String::new(),
        route: Route::new(vec![[0.0, 0.0], [20.0, 0.0]]).unwrap(),
        // A 6 m wall across the line 2.5 m ahead; the local goal lies behind it.
        obstacles: [-2.0, 0.0, 2.0].iter().map(|&y| cube([3.5, y])).collect(),
    };
    let perception = seen(&scenario, [0.0, 0.0, 0.0]);
    let params = DdpParams::default();
    let mut ddpen = DdpenPlanner::oracle(params, &DdpenParams::default()).unwrap();
    let mut ddp = PlannerKind::DDP.build(&params, &DdpenParams::default()).unwrap();
    let req = |k: usize| PlanRequest {
        time: 0.0,
        state: [0.0, 0.0, 0.0],
        goal: [4.9, 0.0],
        far_goal: [15.0, 0.0],
        perception: &perception,
        steps_since_last: usize::from(k > 0),
    };
    let (mut a, mut b) = (None, None);
    for k in 0..15 {
        a = Some(ddpen.plan(&req(k)).unwrap().clone());
        b = Some(ddp.plan(&req(k)).unwrap().clone());
    }
    let (a, b) = (a.unwrap(), b.unwrap());
    assert_eq!(a.guide, ddpen.subgoals());
    let lateral = |p: &sim2d::planner::Plan| p.states.iter().map(|s| s[1].abs()).fold(0.0, f64::max);
    assert!(lateral(&b) < 0.5, "ddp {}", lateral(&b));
    assert!(lateral(&a) > 2.0, "ddpen {}", lateral(&a));
}

#[test]
fn ddpen_oracle_escapes_a_u_trap_where_ddp_stalls() {
    // An 18 m route with a U of 2 m cubes (pocket 2 m x 4 m) across it at x = 10.
    let scenario = Scenario {
        name: "trap".into(),
        description: String::new(),
        route: Route::new(vec![[0.0, 0.0], [18.0, 0.0]]).unwrap(),
        obstacles: u_trap(10.0),
    };
    let config = RunConfig {
        max_time: 90.0,
        keep_plan_every: 0,
        ..RunConfig::default()
    };
    let ddp = run_scenario(&scenario, &config).unwrap();
    assert_eq!(ddp.outcome, Outcome::Stalled);
    let ddpen = run_scenario(
        &scenario,
        &RunConfig {
            planner: PlannerKind::DDPEN_ORACLE,
            ..config
        },
    )
    .unwrap();
    assert_eq!(ddpen.outcome, Outcome::Completed, "progress {}", ddpen.progress_m);
    assert_eq!(ddpen.collisions, 0);
    assert_eq!(ddpen.planner, "ddpen-oracle");
}

#[test]
fn trap_maps_are_deterministic_per_seed_and_valid() {
    let p = TrapParams::default();
    for kind in TrapKind::ALL {
        for i in 0..3 {
            let a = trap_map(kind, 5, i, &p).unwrap();
            assert_eq!(a, trap_map(kind, 5, i, &p).unwrap(), "{kind} {i}");
            assert_ne!(a, trap_map(kind, 6, i, &p).unwrap(), "{kind} {i}: seed ignored");
            assert!((a.route.length() - p.route_length).abs() < 1e-9);
            assert!(a.clearance(a.route.start()) >= p.endpoint_clearance);
            assert!(a.clearance(a.route.end()) >= p.endpoint_clearance);
            // The straight line is blocked, a path with clearance exists.
            let (s, e) = (a.route.start(), a.route.end());
            let blocked = (0..=440).any(|k| {
                let t = k as f64 / 440.0;
                a.clearance([s[0] + t * (e[0] - s[0]), s[1] + t * (e[1] - s[1])]) <= 0.0
            });
            assert!(blocked, "{kind} {i}");
            assert!(solvable(&a, p.path_clearance), "{kind} {i}");
        }
        assert_ne!(trap_map(kind, 5, 0, &p).unwrap(), trap_map(kind, 5, 1, &p).unwrap());
    }
}

#[test]
fn bad_input_names_the_field() {
    let e = PlannerKind::parse("ddpen-magic").unwrap_err().to_string();
    assert!(e.starts_with("planner") && e.contains("ddpen-oracle"), "{e}");
    let e = TrapKind::parse("z").unwrap_err().to_string();
    assert!(e.starts_with("types"), "{e}");
    let bad = DdpenParams {
        subgoal_every: 0,
        ..DdpenParams::default()
    };
    let e = PlannerKind::DDPEN_ORACLE
        .build(&DdpParams::default(), &bad)
        .err()
        .unwrap()
        .to_string();
    assert!(e.starts_with("ddpen.subgoal_every"), "{e}");
    let missing = DdpenParams {
        model: Some("no/such/model.safetensors".into()),
        ..DdpenParams::default()
    };
    let e = PlannerKind::DDPEN
        .build(&DdpParams::default(), &missing)
        .err()
        .unwrap()
        .to_string();
    assert!(e.starts_with("model") && e.contains("no/such/model.safetensors"), "{e}");
    let e = trap_map(
        TrapKind::L,
        1,
        0,
        &TrapParams {
            path_clearance: -1.0,
            ..TrapParams::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.starts_with("traps.path_clearance"), "{e}");
}

/// Sub-goals 2, 3 and 4 m ahead of the robot, recording the costmap cells at `probes` of every
/// map it is given.
struct Ahead {
    probes: Vec<[f64; 2]>,
    seen: Arc<std::sync::Mutex<Vec<Vec<u8>>>>,
}

impl SubgoalSource for Ahead {
    fn name(&self) -> &str {
        "ahead"
    }
    fn subgoals(
        &mut self,
        map: &Costmap,
        state: [f64; 3],
        _goal: [f64; 2],
        out: &mut Vec<[f64; 2]>,
    ) -> sim2d::Result<()> {
        let g = map.geometry();
        let cells = self
            .probes
            .iter()
            .map(|&p| g.world_to_cell(p).map_or(0, |(x, y)| map.get(x, y)))
            .collect();
        self.seen.lock().unwrap().push(cells);
        out.clear();
        out.extend([2.0, 3.0, 4.0].map(|d| [state[0] + d, state[1]]));
        Ok(())
    }
}

#[test]
fn a_stuck_ddpen_backs_out_along_its_trail_and_keeps_out_of_the_spot() {
    use sim2d::ddpen::{BACKUP_DISTANCE, KEEPOUT_RADIUS, STUCK_TIME};
    // Inside the costmap, which stays centred on the origin (no scans here).
    let stuck_at = [3.0, 0.0];
    let seen = Arc::new(std::sync::Mutex::new(Vec::new()));
    // The spot, and just outside the keep-out disc round it.
    let source = Ahead {
        probes: vec![stuck_at, [stuck_at[0], KEEPOUT_RADIUS + 0.15]],
        seen: seen.clone(),
    };
    let mut planner = DdpenPlanner::new("t", DdpParams::default(), &DdpenParams::default(), Box::new(source)).unwrap();
    let perception = Perception::new(PerceptionParams::default()).unwrap();
    let request = |time: f64, x: f64| PlanRequest {
        time,
        state: [x, 0.0, 0.0],
        goal: [x + 4.9, 0.0],
        far_goal: [x + 15.0, 0.0],
        perception: &perception,
        steps_since_last: 1,
    };
    // Drive 7.5 m along x, then stand still (pushing against something the map does not show).
    let mut time = 0.0;
    for k in 0..=25 {
        planner
            .plan(&request(time, stuck_at[0] - 7.5 + 0.3 * k as f64))
            .unwrap();
        assert!(!planner.backing_out());
        time += 0.1;
    }
    let mut started = None;
    while time < 2.5 + STUCK_TIME + 1.0 {
        let plan = planner.plan(&request(time, stuck_at[0])).unwrap().clone();
        if planner.backing_out() {
            started = Some((time, plan));
            break;
        }
        time += 0.1;
    }
    let (t0, plan) = started.expect("no back-out");
    assert!(t0 >= 2.5 + STUCK_TIME - 0.15, "backed out after {} s", t0 - 2.5);
    // Sub-goals 1, 2, 3 m back along the trail (the straight line it came along), the plan backs.
    assert_eq!(plan.guide.len(), 3);
    for (i, s) in plan.guide.iter().enumerate() {
        let back = stuck_at[0] - s[0];
        assert!(
            s[1].abs() < 1e-9 && back >= i as f64 + 1.0 - 1e-9 && back <= BACKUP_DISTANCE + 0.31,
            "{s:?}"
        );
    }
    assert!(plan.controls[0][0] < 0.0, "{:?}", plan.controls[0]);
    assert!(plan.states[10][0] < stuck_at[0] - 0.3, "{:?}", plan.states[10]);
    // Until then the source saw the spot free; after backing out it sees a lethal keep-out disc.
    assert!(seen.lock().unwrap().iter().all(|c| c == &[0, 0]));
    let mut x = stuck_at[0];
    while planner.backing_out() {
        x -= 0.05;
        time += 0.1;
        planner.plan(&request(time, x)).unwrap();
        assert!(x > stuck_at[0] - BACKUP_DISTANCE - 1.0, "the back-out does not end");
    }
    assert_eq!(seen.lock().unwrap().last(), Some(&vec![LETHAL, 0]));
}

#[test]
fn cost_to_go_is_the_shortest_way_round_obstacles() {
    use sim2d::ddpen::CostToGo;
    let g = GridGeometry::centered([0.0, 0.0], 100, 100, 0.05).unwrap();
    let mut map = Costmap::new(g);
    let target = [2.0, 0.0];
    let mut togo = CostToGo::default();
    togo.compute(&map, target, INSCRIBED);
    // Free space: the octile length, between the straight line and 8 % over it (plus a cell).
    for p in [[-2.0, 0.0], [-1.5, 1.5], [0.3, -2.2], [2.0, 2.0]] {
        let straight = dist(p, target);
        let m = togo.metres(&map, p);
        assert!(
            m >= straight - 0.08 && m <= 1.08 * straight + 0.08,
            "{p:?}: {m} vs {straight}"
        );
    }
    assert_eq!(togo.metres(&map, [9.0, 0.0]), f64::INFINITY);
    // A wall of cells across x = 0 from y = -2.5 to 1.5: from (-1, 0) the way passes its end.
    for iy in 0..80 {
        map.set(50, iy, LETHAL);
    }
    togo.compute(&map, target, INSCRIBED);
    let p = [-1.0, 0.0];
    let round = dist(p, [0.0, 1.6]) + dist([0.0, 1.6], target);
    let m = togo.metres(&map, p);
    assert!(m >= round - 0.1 && m <= 1.08 * round + 0.1, "{m} vs {round}");
    // The way through sub-goals: the polyline plus the way on from the last.
    let w = togo.way_through(&map, [0.5, 0.0], &[[1.0, 0.0], [1.5, 0.0]]);
    assert!((w - (1.0 + togo.metres(&map, [1.5, 0.0]))).abs() < 1e-12, "{w}");
    assert_eq!(togo.way_through(&map, p, &[]), f64::INFINITY);
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// Proposes, in turn, sub-goals ahead towards the goal and sub-goals straight behind.
struct Flipping(usize);

impl SubgoalSource for Flipping {
    fn name(&self) -> &str {
        "flipping"
    }
    fn subgoals(
        &mut self,
        _map: &Costmap,
        state: [f64; 3],
        _goal: [f64; 2],
        out: &mut Vec<[f64; 2]>,
    ) -> sim2d::Result<()> {
        self.0 += 1;
        let sign = if self.0 % 2 == 1 { -1.0 } else { 1.0 };
        out.clear();
        out.extend([1.0, 2.0, 3.0].map(|d| [state[0] + sign * d, state[1]]));
        Ok(())
    }
}

#[test]
fn ddpen_keeps_the_better_of_flipping_subgoal_proposals() {
    let perception = Perception::new(PerceptionParams::default()).unwrap();
    let mut planner = DdpenPlanner::new(
        "t",
        DdpParams::default(),
        &DdpenParams::default(),
        Box::new(Flipping(0)),
    )
    .unwrap();
    let request = PlanRequest {
        time: 0.0,
        state: [0.0, 0.0, 0.0],
        goal: [4.9, 0.0],
        far_goal: [15.0, 0.0],
        perception: &perception,
        steps_since_last: 1,
    };
    // First proposal (behind): nothing in force, taken. Second (ahead): shorter, taken. After
    // that the proposals behind are 6 m longer and rejected, those ahead taken.
    let mut in_force = Vec::new();
    for _ in 0..6 {
        planner.plan(&request).unwrap();
        in_force.push(planner.subgoals()[0][0]);
    }
    assert_eq!(in_force, vec![-1.0, 1.0, 1.0, 1.0, 1.0, 1.0]);
}
