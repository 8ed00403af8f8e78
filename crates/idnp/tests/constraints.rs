//! Collision rows for safe-cddp: capsule-vs-polygon (links) and rectangle-vs-polygon (base)
//! signed distances from parry, and their Jacobians against finite differences.

use std::sync::Arc;

use ddp_core::Vector;
use idnp::constraints::BodyObstacle;
use idnp::scene::{Body, Config, Obstacle, Scene};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use safe_cddp::{check_constraint_derivatives, Constraint};

/// Distance from the segment `[a, b]` to an axis-aligned rectangle (both separated), by sampling
/// the segment densely and projecting on the rectangle: a reference independent of parry.
fn segment_rect_distance(a: [f64; 2], b: [f64; 2], lo: [f64; 2], hi: [f64; 2]) -> f64 {
    (0..=20_000)
        .map(|i| {
            let t = i as f64 / 20_000.0;
            let p = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
            let dx = (lo[0] - p[0]).max(0.0).max(p[0] - hi[0]);
            let dy = (lo[1] - p[1]).max(0.0).max(p[1] - hi[1]);
            dx.hypot(dy)
        })
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn capsule_distance_matches_a_reference() {
    let scene = Scene::narrow_passage();
    let (lo, hi) = ([4.3, -2.3], [5.3, 2.5]);
    let wall = Obstacle::rectangle(lo, hi).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut checked = 0;
    for _ in 0..200 {
        let q = Config::new(
            rng.random_range(1.5..3.5),
            rng.random_range(-2.0..2.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.5..1.5),
            rng.random_range(-2.0..2.0),
        );
        let x = Scene::state_at_rest(&q);
        let pts = scene.robot.link_endpoints(&x);
        for (i, body) in [(0, Body::Link1), (1, Body::Link2)] {
            let reference = segment_rect_distance(pts[i], pts[i + 1], lo, hi) - scene.link_radius;
            if reference <= 0.0 {
                continue;
            }
            let d = scene.body_distance(&x, body, &wall).distance;
            assert!(
                (d - reference).abs() < 1e-6,
                "{body:?}: parry {d}, reference {reference}"
            );
            checked += 1;
        }
    }
    assert!(checked > 100);
}

/// Central differences of `g` in `x` with step `h`.
fn fd_gradient(c: &BodyObstacle, x: &Vector<10>, h: f64) -> Vector<10> {
    let u = Vector::<5>::zeros();
    Vector::<10>::from_fn(|j, _| {
        let (mut xp, mut xm) = (*x, *x);
        xp[j] += h;
        xm[j] -= h;
        let (mut gp, mut gm) = ([0.0], [0.0]);
        c.evaluate(0, &xp, &u, &mut gp);
        c.evaluate(0, &xm, &u, &mut gm);
        (gp[0] - gm[0]) / (2.0 * h)
    })
}

#[test]
fn collision_row_derivatives_match_finite_differences() {
    // Penetration depths come from parry's EPA, accurate to about 1e-9 m, so the differences use
    // a step of 1e-4 (noise ~1e-5); where the steps 1e-4 and 5e-5 disagree the distance has a
    // kink there (the closest features switch) and the point is skipped.
    let scene = Arc::new(Scene::narrow_passage());
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut checked = [0usize; 3];
    let mut skipped = 0;
    let mut separated = 0;
    for _ in 0..300 {
        // Configurations around the wall and the blocks, some penetrating.
        let q = Config::new(
            rng.random_range(1.5..6.5),
            rng.random_range(-3.0..3.0),
            rng.random_range(-1.5..1.5),
            rng.random_range(-2.0..2.0),
            rng.random_range(-2.4..2.4),
        );
        let mut x = Scene::state_at_rest(&q);
        for k in 5..10 {
            x[k] = rng.random_range(-1.0..1.0);
        }
        let u = Vector::<5>::from_fn(|_, _| rng.random_range(-1.0..1.0));
        for o in 0..scene.obstacles.len() {
            for (b, body) in Body::ALL.into_iter().enumerate() {
                // Link 1 rows look back half a step (the midpoint rows of the NLP).
                let lookback = if b == 1 { 0.125 } else { 0.0 };
                let c = BodyObstacle::new(scene.clone(), body, o, 0.05)
                    .unwrap()
                    .with_lookback(lookback)
                    .unwrap();
                let mut g = [0.0];
                c.evaluate(0, &x, &u, &mut g);
                if g[0].abs() > 0.5 {
                    continue;
                }
                let (mut g2, mut g_x, mut g_u) = ([0.0], [Vector::<10>::zeros()], [Vector::<5>::zeros()]);
                c.jacobians(0, &x, &u, &mut g2, &mut g_x, &mut g_u);
                assert_eq!(g, g2, "jacobians and evaluate agree on the value");
                assert_eq!(g_u[0], Vector::<5>::zeros());
                let fd = fd_gradient(&c, &x, 1e-4);
                if (fd - fd_gradient(&c, &x, 5e-5)).amax() > 1e-4 {
                    skipped += 1;
                    continue;
                }
                let err = (g_x[0] - fd).amax();
                assert!(
                    err < 1e-4,
                    "{body:?} vs obstacle {o} at {:?}: error {err}",
                    x.as_slice()
                );
                if g[0] < 0.05 - 0.01 {
                    // Separated: polished witnesses make the distance exact, so the standard
                    // check (steps eps^(1/3) (1 + |x|)) holds to about eps^(1/3).
                    let e = check_constraint_derivatives(&c, 0, &x, &u);
                    assert!(e.max_first_order() < 1e-5, "{body:?} vs obstacle {o}: {e:?}");
                    separated += 1;
                }
                checked[b] += 1;
            }
        }
    }
    assert!(checked.iter().all(|&n| n > 10), "rows checked per body: {checked:?}");
    assert!(
        skipped * 20 < checked.iter().sum::<usize>(),
        "{skipped} kinks of {checked:?}"
    );
    assert!(separated > 100, "{separated} separated rows checked tightly");
}

#[test]
fn rows_and_bad_input() {
    let scene = Arc::new(Scene::narrow_passage());
    let rows = BodyObstacle::all(&scene, 0.05, false).unwrap();
    assert_eq!(rows.len(), 3 * scene.obstacles.len());
    let rows = BodyObstacle::all(&scene, 0.05, true).unwrap();
    assert_eq!(rows.len(), 6 * scene.obstacles.len());
    assert!(BodyObstacle::new(scene.clone(), Body::Base, 0, 0.0)
        .unwrap()
        .with_lookback(-1.0)
        .is_err());
    assert!(rows
        .iter()
        .all(|r| !r.depends_on_control() && r.relative_degree() == Some(1)));
    let err = BodyObstacle::new(scene.clone(), Body::Base, 9, 0.0)
        .unwrap_err()
        .to_string();
    assert!(err.contains("obstacle"), "{err}");
    assert!(BodyObstacle::new(scene, Body::Base, 0, f64::NAN).is_err());
    assert!(Obstacle::polygon(&[[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]).is_err());
    assert!(Obstacle::rectangle([1.0, 0.0], [0.0, 1.0]).is_err());
}
