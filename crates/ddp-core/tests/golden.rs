//! Golden iteration logs: each reference problem's iteration table (iLQR and full DDP) is
//! committed under `tests/golden/`; a change in iterations, step lengths, regularisation or
//! costs fails here. Numbers compare to 1e-6 relative (libm differences across machines are far
//! smaller), words exactly. Regenerate after an intended change with `DDPKIT_BLESS=1 cargo test`.

use nalgebra::Const;
use std::path::PathBuf;

use ddp_core::{reference, Method, Problem, Settings, Solver, Status};

fn golden_path(name: &str) -> PathBuf {
    // Relative to the package root (cargo runs tests there): a path baked in at compile time would
    // point at a stale checkout when a build cache is shared between clones.
    PathBuf::from("tests/golden").join(format!("{name}.txt"))
}

fn same_token(a: &str, b: &str) -> bool {
    match (
        a.trim_end_matches(',').parse::<f64>(),
        b.trim_end_matches(',').parse::<f64>(),
    ) {
        (Ok(x), Ok(y)) => (x.is_nan() && y.is_nan()) || (x - y).abs() <= 1e-6 * x.abs().max(y.abs()) + 1e-12,
        _ => a == b,
    }
}

fn check<const NX: usize, const NU: usize>(name: &str, problem: &Problem<Const<NX>, Const<NU>>) {
    for (label, method) in [("ilqr", Method::Ilqr), ("ddp", Method::Ddp)] {
        let mut solver = Solver::new(
            problem,
            Settings {
                method,
                ..Settings::default()
            },
        )
        .unwrap();
        let report = solver.solve(problem).unwrap();
        assert_eq!(report.status, Status::Converged, "{name} {label}:\n{}", report.table());
        let table = report.table();
        let path = golden_path(&format!("{name}_{label}"));
        if std::env::var_os("DDPKIT_BLESS").is_some() {
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(&path, &table).unwrap();
            continue;
        }
        let expected = std::fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("{}: {e} (run with DDPKIT_BLESS=1 to create it)", path.display()));
        let (got, want): (Vec<&str>, Vec<&str>) = (
            table.split_whitespace().collect(),
            expected.split_whitespace().collect(),
        );
        let same = got.len() == want.len() && got.iter().zip(&want).all(|(a, b)| same_token(a, b));
        assert!(
            same,
            "{name} {label}: iteration log changed\n--- expected\n{expected}\n--- got\n{table}"
        );
    }
}

#[test]
fn p1_unicycle() {
    check("p1_unicycle", &reference::p1_unicycle());
}

#[test]
fn car_parking() {
    check("car_parking", &reference::car_parking());
}

#[test]
fn point_reach() {
    check("point_reach", &reference::point_reach());
}

#[test]
fn diff_drive_goal() {
    check("diff_drive_goal", &reference::diff_drive_goal());
}

#[test]
fn quadrotor_reach() {
    check("quadrotor_reach", &reference::quadrotor_reach());
}

#[test]
fn arm_base_reach() {
    check("arm_base_reach", &reference::arm_base_reach());
}
