//! DP over time-indexed grids (eq. 4) against brute-force enumeration of step sequences.

use idnp::dp::{Dp, DpSettings};
use idnp::quadtree::QuadGrid;
use idnp::scene::Domain;

fn tiny() -> (Domain, DpSettings) {
    let domain = Domain {
        min: [0.0, 0.0],
        cells: [3, 2],
        cell_size: 1.0,
    };
    let settings = DpSettings {
        stages: 4,
        stage_duration: 1.0,
        max_step: 1.0,
        steps_per_axis: 3,
        effort_weight: 0.3,
        penalty_weight: 1.0,
        safety_distance: 0.0,
        collision_weight: 0.0,
        collision_distance: 0.0,
        terminal_weight: 2.0,
        goal_margin: 0.0,
    };
    (domain, settings)
}

/// A penalty with a "wall" at x = 1 except at y = 2, and a goal at (3, 0); the small irregular
/// term makes the optimal path unique.
fn penalty(z: [f64; 2]) -> f64 {
    let irregular = 0.01 * (3.7 * z[0] + 1.3 * z[1] * z[1]).sin();
    if (z[0] - 1.0).abs() < 1e-9 && z[1] < 1.5 {
        5.0 + irregular
    } else {
        0.1 * z[1] + irregular
    }
}
fn terminal(z: [f64; 2]) -> f64 {
    2.0 * ((z[0] - 3.0).hypot(z[1]) - 0.1).max(0.0)
}

/// Minimum over all step sequences of the path cost, by enumeration.
fn brute_force(settings: &DpSettings, domain: &Domain, z0: [f64; 2]) -> (f64, Vec<[f64; 2]>) {
    let steps = settings.steps();
    let t = settings.stages;
    let mut best = (f64::INFINITY, Vec::new());
    let total = steps.len().pow(t as u32);
    for code in 0..total {
        let mut c = code;
        let mut z = z0;
        let mut path = vec![z0];
        let mut cost = penalty(z0);
        let mut ok = true;
        for _ in 0..t {
            let d = steps[c % steps.len()];
            c /= steps.len();
            z = [z[0] + d[0], z[1] + d[1]];
            if !domain.contains(z) {
                ok = false;
                break;
            }
            cost += settings.effort_weight * (d[0] * d[0] + d[1] * d[1]) / settings.stage_duration + penalty(z);
            path.push(z);
        }
        if ok {
            cost += terminal(z);
            if cost < best.0 - 1e-12 {
                best = (cost, path);
            }
        }
    }
    best
}

#[test]
fn dp_on_a_tiny_grid_equals_brute_force() {
    let (domain, settings) = tiny();
    let grids = vec![QuadGrid::new(domain, 2).unwrap(); settings.stages + 1];
    let dp = Dp {
        settings,
        penalty: &penalty,
        terminal: &terminal,
    };
    for z0 in [[0.0, 0.0], [0.0, 2.0], [2.0, 1.0], [1.0, 0.0]] {
        let sol = dp.solve(&grids, None, z0).unwrap();
        let (cost, path) = brute_force(&settings, &domain, z0);
        // The value at a grid point and the cost of the waypoints both equal the optimum.
        let v0 = grids[0].interpolate(&sol.values[0], z0).unwrap();
        assert!((v0 - cost).abs() < 1e-12, "V_0({z0:?}) = {v0}, brute force {cost}");
        assert!((sol.cost - cost).abs() < 1e-12, "waypoint cost {} vs {cost}", sol.cost);
        assert_eq!(sol.waypoints.len(), settings.stages + 1);
        // The optimum here is unique: the same path.
        assert_eq!(sol.waypoints, path, "from {z0:?}");
    }
}

#[test]
fn dp_interpolates_inside_cells_and_adds_penalties() {
    let (domain, settings) = tiny();
    let mut grids = vec![QuadGrid::new(domain, 2).unwrap(); settings.stages + 1];
    // Refine one grid: values at its new points are computed too, and the result stays a
    // consistent recursion: V_j(v) = P(v) + min_s [effort + V_{j+1}(v + s)].
    grids[2].split_at(&[[1.5, 0.5]]);
    let dp = Dp {
        settings,
        penalty: &penalty,
        terminal: &terminal,
    };
    let sol = dp.solve(&grids, None, [0.5, 0.5]).unwrap();
    let steps = settings.steps();
    for j in 0..settings.stages {
        for (v, &p) in grids[j].vertices().iter().enumerate() {
            let best = steps
                .iter()
                .filter_map(|d| {
                    let q = [p[0] + d[0], p[1] + d[1]];
                    let next = grids[j + 1].interpolate(&sol.values[j + 1], q)?;
                    let last = if j + 1 == settings.stages { terminal(q) } else { 0.0 };
                    Some(settings.effort_weight * (d[0] * d[0] + d[1] * d[1]) + next + last)
                })
                .fold(f64::INFINITY, f64::min);
            assert!((sol.values[j][v] - penalty(p) - best).abs() < 1e-12);
        }
    }
    // Extra penalties (the fixed-grid adaptation) raise the values.
    let extra: Vec<Vec<f64>> = grids.iter().map(|g| vec![1.0; g.vertex_count()]).collect();
    let sol2 = dp.solve(&grids, Some(&extra), [0.5, 0.5]).unwrap();
    assert!((sol2.values[0][0] - sol.values[0][0] - (settings.stages as f64 + 1.0)).abs() < 1e-9);
    // Bad input is an error naming the field.
    let err = dp.solve(&grids[..2], None, [0.5, 0.5]).unwrap_err().to_string();
    assert!(err.contains("grids"), "{err}");
    let err = dp.solve(&grids, None, [9.0, 0.5]).unwrap_err().to_string();
    assert!(err.contains("z0"), "{err}");
}
