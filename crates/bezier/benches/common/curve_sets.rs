//! Curve sets shared by `benches/arclen.rs` and `examples/arclen_sweep.rs` (included with
//! `#[path]`), as raw control points `[x0, y0, x1, y1, x2, y2, x3, y3]`.
#![allow(dead_code)] // not every includer uses every set

use bezier::{Point, Spline};

/// A small deterministic LCG, uniform in `[-1, 1)`.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
}

/// A fixed, varied set of cubics (smooth, S-shaped, loops, near-cusps): 64 with random control
/// points in `[-1, 1]^2`, a typical smooth arc and an exact cusp.
pub fn random_cubics() -> Vec<[f64; 8]> {
    let mut rng = Lcg(0x9E37_79B9_7F4A_7C15);
    let mut v: Vec<[f64; 8]> = (0..64).map(|_| core::array::from_fn(|_| rng.next())).collect();
    v.push([0.0, 0.0, 0.3, 0.9, 0.7, 0.9, 1.0, 0.0]); // typical smooth arc
    v.push([0.0, 0.0, 1.0, 1.0, 0.0, 1.0, 1.0, 0.0]); // exact cusp
    v
}

/// 64 smooth, spline-like cubics: the segments of a uniform Catmull-Rom spline through a random
/// walk whose heading turns by up to 0.9 rad and whose steps are 0.5 to 1.5 long (what a robot
/// path looks like).
pub fn smooth_cubics() -> Vec<[f64; 8]> {
    smooth_cubics_n(64)
}

/// [`smooth_cubics`] with `n` segments: the same walk, continued.
pub fn smooth_cubics_n(n: usize) -> Vec<[f64; 8]> {
    let mut rng = Lcg(0x2545_F491_4F6C_DD1D);
    let mut p = Point::new(0.0, 0.0);
    let mut heading = 0.0f64;
    let mut waypoints = vec![p];
    for _ in 0..n {
        heading += 0.9 * rng.next();
        let step = 1.0 + 0.5 * rng.next();
        p = Point::new(p.x + step * heading.cos(), p.y + step * heading.sin());
        waypoints.push(p);
    }
    let spline = Spline::catmull_rom(&waypoints).expect("finite waypoints");
    spline
        .segments()
        .iter()
        .map(|c| [c.p0.x, c.p0.y, c.p1.x, c.p1.y, c.p2.x, c.p2.y, c.p3.x, c.p3.y])
        .collect()
}
