//! Times arc length and inverse arc length of one cubic; used by `benches/vs_python_bezier.py`.
//!
//! `cargo run --release -p bezier --example arclen_timing [-- ACCURACY]`. Prints
//! `arclen_ns=<ns per call> inv_arclen_ns=<ns per call> length=<value> value=<value>`: `length` is
//! the `1e-14` reference, `value` what the timed call returns at `ACCURACY`.

use std::hint::black_box;
use std::time::Instant;

use bezier::{CubicBez, ParamCurveArclen};

/// The cubic the Python script uses: control points (0,0), (0.3,0.9), (0.7,0.9), (1,0).
const CUBIC: [(f64, f64); 4] = [(0.0, 0.0), (0.3, 0.9), (0.7, 0.9), (1.0, 0.0)];

/// Best of several batches, in nanoseconds per call.
fn time_ns<F: FnMut() -> f64>(mut f: F) -> f64 {
    let mut best = f64::INFINITY;
    let mut sink = 0.0;
    for _ in 0..15 {
        let n = 20_000;
        let t0 = Instant::now();
        for _ in 0..n {
            sink += f();
        }
        best = best.min(t0.elapsed().as_secs_f64() * 1e9 / n as f64);
    }
    black_box(sink);
    best
}

fn main() {
    let accuracy: f64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(1e-10);
    let c = CubicBez::new(CUBIC[0], CUBIC[1], CUBIC[2], CUBIC[3]);
    let length = c.arclen(1e-14);
    let arclen_ns = time_ns(|| black_box(c).arclen(accuracy));
    let inv_ns = time_ns(|| black_box(c).inv_arclen(0.37 * length, accuracy));
    let value = c.arclen(accuracy);
    println!("arclen_ns={arclen_ns:.2} inv_arclen_ns={inv_ns:.2} length={length:.15} value={value:.15}");
}
