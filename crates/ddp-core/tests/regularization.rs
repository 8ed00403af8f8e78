//! The regularisation schedule's retries (`MuSchedule::until_definite`): which passes run at which
//! `mu`, against a stand-in backward pass that succeeds above a threshold, plain or gated.

use ddp_core::solver::{BackwardOptions, Method, MuSchedule, NotPositiveDefinite, RegularizationSettings};

/// A stand-in pass that records its calls and succeeds when `mu` reaches the threshold of its
/// kind (plain or gated).
fn run(method: Method, plain_from: f64, gated_from: f64) -> (bool, Vec<(f64, bool)>, usize, f64) {
    let s = RegularizationSettings::default();
    let mut reg = MuSchedule::new(&s);
    let (mut calls, mut passes) = (Vec::new(), 0);
    let ok = reg.until_definite(&s, method, &mut passes, |o: BackwardOptions| {
        calls.push((o.mu, o.gated));
        let from = if o.gated { gated_from } else { plain_from };
        if o.mu >= from {
            Ok(())
        } else {
            Err(NotPositiveDefinite)
        }
    });
    (ok, calls, passes, reg.mu)
}

/// The values of Tassa's schedule from `mu_init`, raised until one reaches `until`.
fn schedule(until: f64) -> Vec<f64> {
    let s = RegularizationSettings::default();
    let mut reg = MuSchedule::new(&s);
    let mut mus = vec![reg.mu];
    while reg.mu < until {
        assert!(reg.raise(&s));
        mus.push(reg.mu);
    }
    mus
}

#[test]
fn ilqr_raises_mu_with_plain_passes_only() {
    let (ok, calls, passes, mu) = run(Method::Ilqr, 1e-3, 0.0);
    let mus = schedule(1e-3);
    assert!(ok);
    assert_eq!(passes, calls.len());
    assert_eq!(calls, mus.iter().map(|&m| (m, false)).collect::<Vec<_>>());
    assert_eq!(mu, *mus.last().unwrap());
}

#[test]
fn full_ddp_takes_a_gated_pass_that_succeeds_at_the_same_mu() {
    // The plain pass fails at mu = 0 (second-order terms indefinite), the gated one succeeds.
    let (ok, calls, passes, mu) = run(Method::Ddp, 1.0, 0.0);
    assert!(ok);
    assert_eq!(calls, vec![(0.0, false), (0.0, true)]);
    assert_eq!((passes, mu), (2, 0.0));
}

#[test]
fn full_ddp_stops_gating_once_a_gated_pass_failed() {
    // Both fail until mu reaches 1e-2 (the Gauss-Newton blocks are indefinite): one gated retry
    // at the first mu, then plain passes alone up the schedule, ending where the plain and gated
    // retries at every mu would have ended (the first mu whose plain pass succeeds).
    let (ok, calls, passes, mu) = run(Method::Ddp, 1e-2, 1e-2);
    let mus = schedule(1e-2);
    let mut expected = vec![(mus[0], false), (mus[0], true)];
    expected.extend(mus[1..].iter().map(|&m| (m, false)));
    assert!(ok);
    assert_eq!(calls, expected);
    assert_eq!(passes, mus.len() + 1);
    assert_eq!(mu, *mus.last().unwrap());
}

#[test]
fn every_call_gates_again_after_a_gated_success() {
    // A first gated success leaves gating on for this direction only: a fresh call starts again
    // with both passes.
    let s = RegularizationSettings::default();
    let mut reg = MuSchedule::new(&s);
    let mut passes = 0;
    let mut calls = Vec::new();
    for _ in 0..2 {
        assert!(reg.until_definite(&s, Method::Ddp, &mut passes, |o| {
            calls.push(o.gated);
            if o.gated {
                Ok(())
            } else {
                Err(NotPositiveDefinite)
            }
        }));
    }
    assert_eq!(calls, vec![false, true, false, true]);
    assert_eq!(passes, 4);
}

#[test]
fn past_mu_max_the_retries_end() {
    let s = RegularizationSettings::default();
    for method in [Method::Ilqr, Method::Ddp] {
        let (ok, calls, passes, mu) = run(method, f64::INFINITY, f64::INFINITY);
        assert!(!ok);
        assert!(mu > s.mu_max);
        assert_eq!(passes, calls.len());
        // Full DDP gated once (at the first mu), then plain passes only.
        let gated = calls.iter().filter(|c| c.1).count();
        assert_eq!(gated, usize::from(method == Method::Ddp));
    }
}
