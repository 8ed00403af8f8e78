//! The paper's sigmoid motion profile and the time-parametrised trajectory along a spline.
//!
//! The distance travelled after time `T` on a path of length `L`, over a duration `T_f`, is
//!
//! ```text
//! s(T) = L S(T / T_f),   S(tau) = (sigma(tau) - sigma(0)) / (sigma(1) - sigma(0)),
//! sigma(tau) = 1 / (1 + exp(-m (tau - k)))
//! ```
//!
//! with steepness `m >= 0` and midpoint `k` (the paper fixes `k = 1/2`, a symmetric profile; `m`
//! is its action, 0 to 100). `S(0) = 0`, `S(1) = 1`; `m -> 0` gives constant speed, large `m` a
//! start and stop at nearly zero speed. The peak speed is `L / T_f * max S'`, with
//! `max S' = (m / 4) / (sigma(1) - sigma(0))` at `tau = k` (for `k in [0, 1]`): growing about
//! linearly in `m`, as the paper observes, so either `T_f` follows from a speed limit
//! ([`SigmoidProfile::with_max_speed`]) or `m` is capped for a given `T_f`
//! ([`SigmoidProfile::max_steepness`]).
//!
//! ```
//! use bezier::SigmoidProfile;
//! let p = SigmoidProfile::with_max_speed(10.0, 8.0, 0.5, 2.0).unwrap();
//! assert!((p.peak_speed() - 2.0).abs() < 1e-12);
//! assert!((p.distance(p.duration()) - 10.0).abs() < 1e-12);
//! let (_, v_mid, _, _) = p.derivatives(0.5 * p.duration());
//! assert!((v_mid - 2.0).abs() < 1e-12);
//! ```
//!
//! Along the curve, with unit tangent `T`, normal `N` (tangent turned left), signed curvature
//! `kappa` and its arc-length derivative `kappa_s`, the chain rule gives
//!
//! ```text
//! x'   = s' T
//! x''  = s'' T + kappa s'^2 N
//! x''' = (s''' - kappa^2 s'^3) T + (3 kappa s' s'' + kappa_s s'^3) N
//! ```
//!
//! which [`Trajectory::sample`] evaluates exactly (up to the inverse arc length's accuracy).

use crate::cubic::CubicArclen;
use crate::error::{check_finite, Error, Result};
use crate::point::{Point, Vec2};
use crate::quadrature::integrate_adaptive;
use crate::spline::Spline;
use crate::traits::{curvature_deriv_from, curvature_from, ParamCurve, ParamCurveCurvature, ParamCurveDeriv};

/// Below this `m` the profile is taken as exactly linear (the difference is `O(m^2)`).
const LINEAR_M: f64 = 1e-9;

/// The sigmoid distance-time profile (see the module docs). A `Copy` value, validated on construction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SigmoidProfile {
    length: f64,
    m: f64,
    k: f64,
    duration: f64,
    /// `tanh(m k / 2)`.
    th0: f64,
    /// `2 (sigma(1) - sigma(0)) = tanh(m (1 - k) / 2) + tanh(m k / 2)`.
    span: f64,
}

impl SigmoidProfile {
    fn validate(length: f64, m: f64, k: f64) -> Result<()> {
        check_finite("length", 0, length)?;
        check_finite("m", 0, m)?;
        check_finite("k", 0, k)?;
        if length < 0.0 {
            return Err(Error::InvalidParameter {
                field: "length",
                value: length,
                reason: "must be >= 0",
            });
        }
        if m < 0.0 {
            return Err(Error::InvalidParameter {
                field: "m",
                value: m,
                reason: "steepness must be >= 0",
            });
        }
        Ok(())
    }

    fn build(length: f64, m: f64, k: f64, duration: f64) -> SigmoidProfile {
        let th0 = (0.5 * m * k).tanh();
        let span = (0.5 * m * (1.0 - k)).tanh() + th0;
        SigmoidProfile {
            length,
            m,
            k,
            duration,
            th0,
            span,
        }
    }

    fn is_linear(&self) -> bool {
        self.m * (1.0 + self.k.abs()) < LINEAR_M || !(self.span > 0.0)
    }

    /// A profile over `length` (m) lasting `duration` (s). Errors name `length`, `m`, `k` or
    /// `duration` (non-finite, negative; `duration` must be positive unless `length` is 0).
    pub fn new(length: f64, m: f64, k: f64, duration: f64) -> Result<SigmoidProfile> {
        SigmoidProfile::validate(length, m, k)?;
        check_finite("duration", 0, duration)?;
        if duration < 0.0 || (duration == 0.0 && length > 0.0) {
            return Err(Error::InvalidParameter {
                field: "duration",
                value: duration,
                reason: "must be > 0",
            });
        }
        Ok(SigmoidProfile::build(length, m, k, duration))
    }

    /// The shortest profile over `length` whose peak speed is `max_speed`:
    /// `T_f = L max S' / v_max`. A zero length gives a zero duration (the robot stays put).
    pub fn with_max_speed(length: f64, m: f64, k: f64, max_speed: f64) -> Result<SigmoidProfile> {
        SigmoidProfile::validate(length, m, k)?;
        check_finite("max_speed", 0, max_speed)?;
        if !(max_speed > 0.0) {
            return Err(Error::InvalidParameter {
                field: "max_speed",
                value: max_speed,
                reason: "must be > 0",
            });
        }
        let unit = SigmoidProfile::build(length, m, k, 1.0);
        let duration = length * unit.peak_normalized_speed() / max_speed;
        Ok(SigmoidProfile { duration, ..unit })
    }

    /// The largest steepness `m` (to relative `1e-12`) for which a profile over `length` lasting
    /// `duration` keeps its peak speed at or below `max_speed`. Error `InvalidParameter` on
    /// `max_speed` when even the constant-speed profile (`m = 0`, speed `length / duration`)
    /// exceeds it.
    pub fn max_steepness(length: f64, k: f64, duration: f64, max_speed: f64) -> Result<f64> {
        SigmoidProfile::validate(length, 0.0, k)?;
        check_finite("duration", 0, duration)?;
        check_finite("max_speed", 0, max_speed)?;
        if !(duration > 0.0) {
            return Err(Error::InvalidParameter {
                field: "duration",
                value: duration,
                reason: "must be > 0",
            });
        }
        if !(max_speed > 0.0) {
            return Err(Error::InvalidParameter {
                field: "max_speed",
                value: max_speed,
                reason: "must be > 0",
            });
        }
        if length == 0.0 {
            return Ok(f64::INFINITY);
        }
        let peak = |m: f64| SigmoidProfile::build(length, m, k, duration).peak_speed();
        if peak(0.0) > max_speed {
            return Err(Error::InvalidParameter {
                field: "max_speed",
                value: max_speed,
                reason: "below length / duration: no profile of this duration respects it",
            });
        }
        let mut hi = 1.0;
        while peak(hi) <= max_speed {
            hi *= 2.0;
            if hi > 1e12 {
                return Ok(hi);
            }
        }
        let mut lo = 0.0;
        while hi - lo > 1e-12 * hi {
            let mid = 0.5 * (lo + hi);
            if peak(mid) <= max_speed {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Ok(lo)
    }

    /// Path length `L`.
    pub fn length(&self) -> f64 {
        self.length
    }

    /// Steepness `m`.
    pub fn m(&self) -> f64 {
        self.m
    }

    /// Midpoint `k` (fraction of the duration).
    pub fn k(&self) -> f64 {
        self.k
    }

    /// Duration `T_f`.
    pub fn duration(&self) -> f64 {
        self.duration
    }

    /// `max_{tau in [0,1]} S'(tau)`.
    fn peak_normalized_speed(&self) -> f64 {
        if self.is_linear() {
            return 1.0;
        }
        self.normalized(self.k.clamp(0.0, 1.0)).1
    }

    /// Peak speed `L / T_f max S'` (0 for a zero-length profile).
    pub fn peak_speed(&self) -> f64 {
        if self.length == 0.0 {
            return 0.0;
        }
        self.length / self.duration * self.peak_normalized_speed()
    }

    /// `(S, S', S'', S''')` at normalised time `tau`.
    fn normalized(&self, tau: f64) -> (f64, f64, f64, f64) {
        if self.is_linear() {
            return (tau, 1.0, 0.0, 0.0);
        }
        let m = self.m;
        let th = (0.5 * m * (tau - self.k)).tanh();
        let sech2 = 1.0 - th * th;
        // sigma' = m sech^2 / 4, sigma'' = -m^2 sech^2 th / 4, sigma''' = m^3 sech^2 (3 th^2 - 1) / 8;
        // S = 2 (sigma - sigma(0)) / span.
        let inv = 1.0 / self.span;
        (
            (th + self.th0) * inv,
            0.5 * m * sech2 * inv,
            -0.5 * m * m * sech2 * th * inv,
            0.25 * m * m * m * sech2 * (3.0 * th * th - 1.0) * inv,
        )
    }

    /// Distance `s(T)`; `0` before the start and `L` after the end.
    pub fn distance(&self, time: f64) -> f64 {
        self.derivatives(time).0
    }

    /// `(s, s', s'', s''')` at `time`: distance, speed, tangential acceleration and jerk. Held
    /// at `(0, 0, 0, 0)` before the start and `(L, 0, 0, 0)` after the end (the robot waits).
    /// Note `s'(0) = s'(T_f) = L S'(0) / T_f > 0` unless `m` is large: the paper's sigmoid
    /// starts and ends with a small non-zero speed.
    pub fn derivatives(&self, time: f64) -> (f64, f64, f64, f64) {
        if self.length == 0.0 || !(time >= 0.0) {
            return (0.0, 0.0, 0.0, 0.0);
        }
        if time > self.duration {
            return (self.length, 0.0, 0.0, 0.0);
        }
        let tf = self.duration;
        let (s, ds, dds, ddds) = self.normalized(time / tf);
        let l = self.length;
        (l * s, l * ds / tf, l * dds / (tf * tf), l * ddds / (tf * tf * tf))
    }

    /// The time at which the distance is `s` (inverse of [`distance`](Self::distance)); `s` is
    /// clamped to `[0, L]`.
    pub fn time_at_distance(&self, s: f64) -> f64 {
        if self.length == 0.0 || !(s > 0.0) {
            return 0.0;
        }
        if s >= self.length {
            return self.duration;
        }
        let frac = s / self.length;
        let tau = if self.is_linear() {
            frac
        } else {
            // tanh(m (tau - k) / 2) = span S - tanh(m k / 2).
            let th = (self.span * frac - self.th0).clamp(-1.0, 1.0);
            (self.k + 2.0 * th.atanh() / self.m).clamp(0.0, 1.0)
        };
        tau * self.duration
    }
}

/// Sampled states (`steps + 1` rows of `NX` values) and controls (`steps` rows of 2 values).
pub type StatesControls<const NX: usize> = (Vec<[f64; NX]>, Vec<[f64; 2]>);

/// State of a [`Trajectory`] at one time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrajectorySample {
    /// Time.
    pub time: f64,
    /// Distance along the path.
    pub distance: f64,
    /// Segment index and its local parameter.
    pub segment: usize,
    /// Local parameter in the segment.
    pub t: f64,
    /// Position.
    pub position: Point,
    /// Velocity (time derivative of the position).
    pub velocity: Vec2,
    /// Acceleration.
    pub acceleration: Vec2,
    /// Jerk.
    pub jerk: Vec2,
    /// Speed `s'` (along the path).
    pub speed: f64,
    /// Tangential acceleration `s''`.
    pub tangential_acceleration: f64,
    /// Heading (angle of the unit tangent), in `(-pi, pi]`.
    pub heading: f64,
    /// Signed curvature of the path.
    pub curvature: f64,
    /// Yaw rate `kappa s'`.
    pub yaw_rate: f64,
}

/// A spline traversed with a [`SigmoidProfile`]: position, velocity, acceleration, jerk,
/// heading and curvature at any time, and sampled states and controls for DDP.
///
/// ```
/// use bezier::{Point, Spline, Trajectory};
/// let w = [Point::new(0.0, 0.0), Point::new(3.0, 0.0), Point::new(3.0, 3.0)];
/// let traj = Trajectory::with_sigmoid(Spline::catmull_rom(&w).unwrap(), 10.0, 0.5, 1.5).unwrap();
/// let (x, u) = traj.car(0.05, (traj.duration() / 0.05).ceil() as usize).unwrap();
/// let last = x.last().unwrap();
/// assert!((last[0] - 3.0).abs() < 1e-6 && (last[1] - 3.0).abs() < 1e-6);
/// assert_eq!(u.len() + 1, x.len());
/// ```
#[derive(Clone, Debug)]
pub struct Trajectory {
    spline: Spline,
    profile: SigmoidProfile,
    engines: Vec<CubicArclen>,
    lengths: Vec<f64>,
    /// `cumulative[i]`: length before segment `i`; last entry is the total.
    cumulative: Vec<f64>,
    accuracy: f64,
}

impl Trajectory {
    /// Accuracy of the arc-length bookkeeping (absolute, in length units).
    pub const ACCURACY: f64 = 1e-10;

    /// The trajectory following `spline` with `profile`. Error `InvalidParameter` on
    /// `profile.length` when it differs from the spline's length by more than `1e-6` relative.
    /// Allocates per-segment tables.
    pub fn new(spline: Spline, profile: SigmoidProfile) -> Result<Trajectory> {
        let accuracy = Trajectory::ACCURACY;
        let engines: Vec<CubicArclen> = spline.segments().iter().map(|s| s.arclen_engine()).collect();
        let lengths: Vec<f64> = engines
            .iter()
            .map(|e| e.arclen_range(0.0, 1.0, accuracy / engines.len() as f64))
            .collect();
        let mut cumulative = Vec::with_capacity(lengths.len() + 1);
        cumulative.push(0.0);
        for l in &lengths {
            cumulative.push(cumulative[cumulative.len() - 1] + l);
        }
        let total = cumulative[cumulative.len() - 1];
        if (profile.length() - total).abs() > 1e-6 * total.max(1e-300) && !(total == 0.0 && profile.length() == 0.0) {
            return Err(Error::InvalidParameter {
                field: "profile.length",
                value: profile.length(),
                reason: "must equal the spline's arc length",
            });
        }
        Ok(Trajectory {
            spline,
            profile,
            engines,
            lengths,
            cumulative,
            accuracy,
        })
    }

    /// The spline traversed with a sigmoid of steepness `m`, midpoint `k`, peak speed `max_speed`
    /// (see [`SigmoidProfile::with_max_speed`]).
    pub fn with_sigmoid(spline: Spline, m: f64, k: f64, max_speed: f64) -> Result<Trajectory> {
        let length = spline.arclen(Trajectory::ACCURACY);
        let profile = SigmoidProfile::with_max_speed(length, m, k, max_speed)?;
        Trajectory::new(spline, profile)
    }

    /// The path.
    pub fn spline(&self) -> &Spline {
        &self.spline
    }

    /// The motion profile.
    pub fn profile(&self) -> &SigmoidProfile {
        &self.profile
    }

    /// Duration `T_f`.
    pub fn duration(&self) -> f64 {
        self.profile.duration()
    }

    /// Path length.
    pub fn length(&self) -> f64 {
        self.cumulative[self.cumulative.len() - 1]
    }

    /// Segment and local parameter at distance `s` along the path (clamped).
    pub fn locate(&self, s: f64) -> (usize, f64) {
        let n = self.lengths.len();
        if !(s > 0.0) {
            return (0, 0.0);
        }
        if s >= self.length() {
            return (n - 1, 1.0);
        }
        // Last segment whose start is <= s, skipping zero-length segments.
        let i = self.cumulative[1..n].partition_point(|&c| c <= s);
        let local = s - self.cumulative[i];
        let t = self.engines[i].inv_arclen(local, Some(self.lengths[i]), self.accuracy);
        (i, t)
    }

    /// Full kinematic state at `time` (held at the ends outside `[0, T_f]`).
    pub fn sample(&self, time: f64) -> TrajectorySample {
        let (s, ds, dds, ddds) = self.profile.derivatives(time);
        let (i, t) = self.locate(s);
        let seg = &self.spline.segments()[i];
        let v = seg.velocity(t);
        let a = seg.acceleration(t);
        let j = seg.jerk(t);
        let speed_t = v.hypot();
        let tangent = seg
            .tangent(t)
            .or_else(|| self.fallback_tangent(i))
            .unwrap_or(Vec2::new(1.0, 0.0));
        let normal = Vec2::new(-tangent.y, tangent.x);
        let kappa = curvature_from(v, a);
        let kappa_s = if speed_t > 0.0 {
            curvature_deriv_from(v, a, j) / speed_t
        } else {
            0.0
        };
        let velocity = ds * tangent;
        let acceleration = dds * tangent + (kappa * ds * ds) * normal;
        let jerk = (ddds - kappa * kappa * ds * ds * ds) * tangent
            + (3.0 * kappa * ds * dds + kappa_s * ds * ds * ds) * normal;
        TrajectorySample {
            time,
            distance: s,
            segment: i,
            t,
            position: seg.eval(t),
            velocity,
            acceleration,
            jerk,
            speed: ds,
            tangential_acceleration: dds,
            heading: tangent.atan2(),
            curvature: kappa,
            yaw_rate: kappa * ds,
        }
    }

    /// A tangent for a segment collapsed to a point: the nearest non-degenerate neighbour's.
    fn fallback_tangent(&self, i: usize) -> Option<Vec2> {
        let segs = self.spline.segments();
        (i + 1..segs.len())
            .find_map(|k| segs[k].tangent(0.0))
            .or_else(|| (0..i).rev().find_map(|k| segs[k].tangent(1.0)))
    }

    fn check_grid(dt: f64) -> Result<()> {
        check_finite("dt", 0, dt)?;
        if !(dt > 0.0) {
            return Err(Error::InvalidParameter {
                field: "dt",
                value: dt,
                reason: "must be > 0",
            });
        }
        Ok(())
    }

    /// Samples at `T_k = k dt`, `k = 0..=steps`, with the heading unwrapped (continuous).
    pub fn sample_grid(&self, dt: f64, steps: usize) -> Result<Vec<TrajectorySample>> {
        Trajectory::check_grid(dt)?;
        let mut out: Vec<TrajectorySample> = Vec::with_capacity(steps + 1);
        for k in 0..=steps {
            let mut smp = self.sample(k as f64 * dt);
            if let Some(prev) = out.last() {
                smp.heading = prev.heading + wrap_angle(smp.heading - prev.heading);
            }
            out.push(smp);
        }
        Ok(out)
    }

    /// Unicycle states `(x, y, theta)` at `T_k = k dt` (`steps + 1` of them) and controls
    /// `(v, omega)` (`steps`), for `x+ = x + dt (v cos th, v sin th, omega)`: `omega_k` makes the
    /// heading step exact, `v_k` is the step's displacement projected on the heading, over `dt`
    /// (the least-squares fit of the position step). Error on `dt` (non-finite or not positive).
    pub fn unicycle(&self, dt: f64, steps: usize) -> Result<StatesControls<3>> {
        let s = self.sample_grid(dt, steps)?;
        let x = s.iter().map(|p| [p.position.x, p.position.y, p.heading]).collect();
        let u = s
            .windows(2)
            .map(|w| {
                let d = w[1].position - w[0].position;
                let (sn, cs) = w[0].heading.sin_cos();
                [(d.x * cs + d.y * sn) / dt, (w[1].heading - w[0].heading) / dt]
            })
            .collect();
        Ok((x, u))
    }

    /// Car states `(x, y, theta, v)` and controls `(omega, a)` on the same grid as
    /// [`unicycle`](Self::unicycle), for `x+ = (px + dt v cos th, py + dt v sin th, th + dt omega,
    /// v + dt a)`: `omega_k` and `a_k` make the heading and speed steps exact.
    pub fn car(&self, dt: f64, steps: usize) -> Result<StatesControls<4>> {
        let s = self.sample_grid(dt, steps)?;
        let x = s
            .iter()
            .map(|p| [p.position.x, p.position.y, p.heading, p.speed])
            .collect();
        let u = s
            .windows(2)
            .map(|w| [(w[1].heading - w[0].heading) / dt, (w[1].speed - w[0].speed) / dt])
            .collect();
        Ok((x, u))
    }

    /// The paper's discrete jerk cost: tangential speeds `v_k = |x(T_{k+1}) - x(T_k)| / dT` at
    /// `samples` times uniform over `[0, T_f]`, jerk by second differences
    /// `j_k = (v_{k+2} - 2 v_{k+1} + v_k) / dT^2`, cost `sum j_k^2 dT` (so it approximates
    /// `int j_t^2 dT` as `samples` grows). Fewer than 4 samples give 0.
    pub fn jerk_cost_discrete(&self, samples: usize) -> f64 {
        if samples < 4 || !(self.duration() > 0.0) {
            return 0.0;
        }
        let dt = self.duration() / (samples - 1) as f64;
        let pos: Vec<Point> = (0..samples).map(|k| self.position_at(k as f64 * dt)).collect();
        let v: Vec<f64> = pos.windows(2).map(|w| w[0].distance(w[1]) / dt).collect();
        v.windows(3)
            .map(|w| ((w[2] - 2.0 * w[1] + w[0]) / (dt * dt)).powi(2) * dt)
            .sum()
    }

    /// Position only (cheaper than [`sample`](Self::sample)).
    pub fn position_at(&self, time: f64) -> Point {
        let (i, t) = self.locate(self.profile.distance(time));
        self.spline.segments()[i].eval(t)
    }

    /// `int_0^{T_f} |x'''(T)|^2 dT` of the full 2D jerk (tangential and normal), by adaptive
    /// Gauss-Legendre between the times the path crosses segment joints, to relative accuracy
    /// `accuracy`. Jumps of curvature at C1 joints are not counted (they would be impulses).
    pub fn jerk_cost_integral(&self, accuracy: f64) -> f64 {
        if !(self.duration() > 0.0) {
            return 0.0;
        }
        let f = |time: f64| self.sample(time).jerk.hypot2();
        let mut times: Vec<f64> = self
            .cumulative
            .iter()
            .map(|&c| self.profile.time_at_distance(c))
            .collect();
        times[0] = 0.0;
        let last = times.len() - 1;
        times[last] = self.duration();
        // A first 16-point pass sizes the integral for the relative tolerance.
        let rough: f64 = times
            .windows(2)
            .map(|w| crate::quadrature::gauss16(w[0], w[1], &f))
            .sum();
        let scale = rough.abs();
        times
            .windows(2)
            .filter(|w| w[1] > w[0])
            .map(|w| integrate_adaptive(&f, w[0], w[1], accuracy * scale, scale))
            .sum()
    }

    /// The paper's curvature measure: `sum |kappa|` at `samples` times uniform over `[0, T_f]`.
    pub fn curvature_sum(&self, samples: usize) -> f64 {
        if samples == 0 {
            return 0.0;
        }
        let dt = if samples > 1 {
            self.duration() / (samples - 1) as f64
        } else {
            0.0
        };
        (0..samples)
            .map(|k| {
                let (i, t) = self.locate(self.profile.distance(k as f64 * dt));
                self.spline.segments()[i].curvature(t).abs()
            })
            .sum()
    }
}

/// Wraps an angle to `(-pi, pi]`.
fn wrap_angle(a: f64) -> f64 {
    let w = a.rem_euclid(2.0 * core::f64::consts::PI);
    if w > core::f64::consts::PI {
        w - 2.0 * core::f64::consts::PI
    } else {
        w
    }
}
