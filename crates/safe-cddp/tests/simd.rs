//! The backward pass compiled for AVX-512 or AVX2 and FMA where the CPU has them
//! (`ddpkit_util::simd`) against the portable build (`DDPKIT_SIMD=off`): the same solutions, bit
//! for bit. The choice is read once per process, so the portable solves run in a child process
//! of this test.

use std::process::Command;

use ddp_core::{reference, Method, Settings as DdpSettings, Solver};
use safe_cddp::benchmark::BenchmarkProblem;
use safe_cddp::{SafeCddpSolver, Settings};

const TEST: &str = "the_vector_builds_solve_bit_for_bit_as_the_portable_one";

/// The bits of the costs, iterations and controls of iLQR and full DDP on three reference
/// problems (4 to 12 states) and of the Safe-CDDP portfolio on P2 and P3.
fn solutions() -> Vec<u64> {
    fn push<'a>(out: &mut Vec<u64>, cost: f64, iterations: usize, us: impl Iterator<Item = &'a f64>) {
        out.push(cost.to_bits());
        out.push(iterations as u64);
        out.extend(us.map(|v| v.to_bits()));
    }
    let mut out = Vec::new();
    for method in [Method::Ilqr, Method::Ddp] {
        let settings = DdpSettings {
            method,
            ..DdpSettings::default()
        };
        let p = reference::p1_unicycle();
        let mut s = Solver::new(&p, settings).unwrap();
        let r = s.solve(&p).unwrap().clone();
        push(&mut out, r.cost, r.iterations, s.us().iter().flat_map(|u| u.iter()));
        let p = reference::car_parking();
        let mut s = Solver::new(&p, settings).unwrap();
        let r = s.solve(&p).unwrap().clone();
        push(&mut out, r.cost, r.iterations, s.us().iter().flat_map(|u| u.iter()));
        let p = reference::quadrotor_reach();
        let mut s = Solver::new(&p, settings).unwrap();
        let r = s.solve(&p).unwrap().clone();
        push(&mut out, r.cost, r.iterations, s.us().iter().flat_map(|u| u.iter()));
    }
    for name in ["p2_car4.json", "p3_point4.json"] {
        let text = std::fs::read_to_string(format!("../../bench/problems/{name}")).unwrap();
        let (problem, constraints) = BenchmarkProblem::from_json(&text).unwrap().car_or_point().unwrap();
        let mut s = SafeCddpSolver::new(&problem, constraints, Settings::default()).unwrap();
        let r = s.solve(&problem).unwrap().clone();
        push(
            &mut out,
            r.cost,
            r.iterations + r.discarded_iterations,
            s.us().iter().flat_map(|u| u.iter()),
        );
    }
    out
}

#[test]
fn the_vector_builds_solve_bit_for_bit_as_the_portable_one() {
    let mine = solutions();
    if std::env::var_os("DDPKIT_SIMD_CHILD").is_some() {
        let words: Vec<String> = mine.iter().map(|b| format!("{b:x}")).collect();
        println!("\nBITS {}", words.join(" "));
        return;
    }
    // On an x86-64 CPU with AVX2 (any CI machine) this process runs the vector build.
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::env::var_os("DDPKIT_SIMD").is_none() {
        assert!(ddpkit_util::simd::available().is_some());
    }
    let out = Command::new(std::env::current_exe().unwrap())
        .args(["--exact", TEST, "--nocapture", "--test-threads=1"])
        .env("DDPKIT_SIMD", "off")
        .env("DDPKIT_SIMD_CHILD", "1")
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "the portable child failed:\n{text}");
    // (The harness may print the test's name on the same line first.)
    let line = text
        .lines()
        .find_map(|l| l.split_once("BITS ").map(|(_, bits)| bits))
        .expect("no BITS line");
    let portable: Vec<u64> = line.split(' ').map(|w| u64::from_str_radix(w, 16).unwrap()).collect();
    assert_eq!(portable.len(), mine.len());
    let first = mine.iter().zip(&portable).position(|(a, b)| a != b);
    assert_eq!(first, None, "the builds differ at word {first:?}");
}
