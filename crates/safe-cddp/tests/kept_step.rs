//! The sine and cosine the car's rollout computes for each knot (`Dynamics::step_keep`) serve
//! the Jacobians of the next linearisation (`Dynamics::jacobians_kept`): in iLQR and in every
//! start of the Safe-CDDP portfolio (its augmented-Lagrangian and barrier iterations roll out
//! through the core, its KKT/QP iterations through their own forward pass), every Jacobian is
//! computed from its rollout's data, and the solutions are the same bit for bit as with a model
//! that keeps nothing.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

use ddp_core::dims::{U2, U4};
use ddp_core::models::Car;
use ddp_core::{reference, Dynamics, Knot, Matrix, Problem, Settings as DdpSettings, Solver, Vector};
use safe_cddp::benchmark::BenchmarkProblem;
use safe_cddp::{SafeCddpSolver, Settings};

/// The car, counting the Jacobians of linearisations served from the rollout's data (`hits`)
/// and not (`misses`), and those asked for without data (`plain`: not a linearisation's, or its
/// data lost on the way); with `keep = false`, a model that keeps nothing (the trait's defaults).
struct Counting {
    car: Car,
    keep: bool,
    hits: AtomicUsize,
    misses: AtomicUsize,
    plain: AtomicUsize,
}

impl Counting {
    fn new(dt: f64, keep: bool) -> Arc<Self> {
        Arc::new(Self {
            car: Car::new(dt).unwrap(),
            keep,
            hits: AtomicUsize::new(0),
            misses: AtomicUsize::new(0),
            plain: AtomicUsize::new(0),
        })
    }
}

impl Dynamics<U4, U2> for Counting {
    fn step(&self, x: &Vector<4>, u: &Vector<2>) -> Vector<4> {
        self.car.step(x, u)
    }
    fn step_keep(&self, x: &Vector<4>, u: &Vector<2>, out: &mut Vector<4>, data: &mut Vec<f64>) {
        if self.keep {
            self.car.step_keep(x, u, out, data);
        } else {
            self.car.step_into(x, u, out);
        }
    }
    fn jacobians(&self, x: &Vector<4>, u: &Vector<2>, fx: &mut Matrix<4, 4>, fu: &mut Matrix<4, 2>) {
        self.plain.fetch_add(1, Ordering::Relaxed);
        self.car.jacobians(x, u, fx, fu);
    }
    fn jacobians_kept(&self, x: &Vector<4>, u: &Vector<2>, fx: &mut Matrix<4, 4>, fu: &mut Matrix<4, 2>, data: &[f64]) {
        // The car keeps `[heading, sin, cos]`.
        let own = data.first().is_some_and(|t| t.to_bits() == x[2].to_bits());
        let counter = if own { &self.hits } else { &self.misses };
        counter.fetch_add(1, Ordering::Relaxed);
        self.car.jacobians_kept(x, u, fx, fu, data);
    }
}

/// `problem` with every knot's dynamics replaced by `model`.
fn with_model(mut problem: Problem<U4, U2>, model: &Arc<Counting>) -> Problem<U4, U2> {
    for k in 0..problem.horizon() {
        let cost = problem.knots()[k].cost.clone();
        let knot = Knot {
            dynamics: model.clone(),
            cost,
        };
        problem.set_knot(k, knot).unwrap();
    }
    problem
}

fn bits<'a>(cost: f64, us: impl Iterator<Item = &'a Vector<2>>) -> Vec<u64> {
    std::iter::once(cost.to_bits())
        .chain(us.flat_map(|u| u.iter().map(|v| v.to_bits())))
        .collect()
}

#[test]
fn ilqr_linearises_from_the_rollouts_data() {
    let solve = |keep: bool| {
        let model = Counting::new(0.05, keep);
        let problem = with_model(reference::car_parking(), &model);
        let mut solver = Solver::new(&problem, DdpSettings::default()).unwrap();
        let cost = solver.solve(&problem).unwrap().cost;
        (bits(cost, solver.us().iter()), model)
    };
    let (kept, model) = solve(true);
    let (plain, _) = solve(false);
    assert_eq!(kept, plain, "the same solution bit for bit");
    let (hits, misses) = (model.hits.load(Ordering::Relaxed), model.misses.load(Ordering::Relaxed));
    assert!(hits >= 120 * 10, "{hits} Jacobians from kept data");
    assert_eq!(misses, 0, "every Jacobian from its rollout's data ({hits} were)");
    assert_eq!(model.plain.load(Ordering::Relaxed), 0);
}

#[test]
fn every_portfolio_start_linearises_from_the_rollouts_data() {
    let text = std::fs::read_to_string("../../bench/problems/p2_car4.json").unwrap();
    let bp = BenchmarkProblem::from_json(&text).unwrap();
    let solve = |keep: bool| {
        let (problem, constraints) = bp.car_or_point().unwrap();
        let model = Counting::new(bp.dt, keep);
        let problem = with_model(problem, &model);
        let mut solver = SafeCddpSolver::new(&problem, constraints, Settings::default()).unwrap();
        let r = solver.solve(&problem).unwrap().clone();
        let b = bits(r.cost, solver.us().iter());
        (b, r.iterations + r.discarded_iterations, model)
    };
    let (kept, iterations, model) = solve(true);
    let (plain, plain_iterations, _) = solve(false);
    assert_eq!(iterations, plain_iterations);
    assert_eq!(kept, plain, "the same solution bit for bit");
    let (hits, misses) = (model.hits.load(Ordering::Relaxed), model.misses.load(Ordering::Relaxed));
    assert!(
        hits >= iterations * bp.horizon,
        "{hits} Jacobians from kept data, {iterations} iterations"
    );
    assert_eq!(misses, 0, "every Jacobian from its rollout's data ({hits} were)");
    // Only the probes of the constraints' relative degrees (at x0, before any rollout), fewer
    // than one linearisation's.
    let plain = model.plain.load(Ordering::Relaxed);
    assert!(plain < bp.horizon, "{plain} Jacobians without data");
}
