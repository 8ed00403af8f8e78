//! Derivatives of every built-in model, checked two ways: against finite differences of `step`
//! (one generic check looped over all models) and against num-dual's exact derivatives of the same
//! model written generically. Also constructor errors and physical sanity checks.

use ddp_core::autodiff::{AutoDiff, DualDynamics};
use ddp_core::finite_diff::check_derivatives;
use ddp_core::models::{ArmBase, ArmBaseParams, Car, DifferentialDrive, DoubleIntegrator2D, Quadrotor, Unicycle};
use ddp_core::{Dynamics, Error, Matrix, Vector};
use nalgebra::Const;

/// Samples per model.
const SAMPLES: usize = 60;

/// SplitMix64: a tiny deterministic generator, enough for test inputs.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[lo, hi)`.
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    fn vector<const N: usize>(&mut self, lo: f64, hi: f64) -> Vector<N> {
        Vector::<N>::from_fn(|_, _| self.uniform(lo, hi))
    }
}

/// Largest relative errors seen by [`check_model`].
#[derive(Debug, Default, Clone, Copy)]
struct Worst {
    first: f64,
    second: f64,
}

/// Second-order blocks of a model at one point.
fn second_order<const NX: usize, const NU: usize, D: Dynamics<Const<NX>, Const<NU>>>(
    model: &D,
    x: &Vector<NX>,
    u: &Vector<NU>,
    lambda: &Vector<NX>,
) -> (Matrix<NX, NX>, Matrix<NU, NX>, Matrix<NU, NU>) {
    let (mut h_xx, mut h_ux, mut h_uu) = (Matrix::zeros(), Matrix::zeros(), Matrix::zeros());
    model.add_second_order(x, u, lambda, &mut h_xx, &mut h_ux, &mut h_uu);
    (h_xx, h_ux, h_uu)
}

/// Compares the analytic derivatives of `model` with central differences at `SAMPLES` seeded
/// random states, controls and multipliers in `[-1, 1]`. Errors are relative to `1 +` the largest
/// entry: about `eps^(2/3)` is expected for the Jacobians (central differences with step
/// `eps^(1/3)`) and about `eps^(1/2)` for the nested second differences; the tolerances leave a
/// margin of more than 30x over the worst errors seen.
fn check_model<const NX: usize, const NU: usize, D: Dynamics<Const<NX>, Const<NU>>>(
    name: &str,
    model: &D,
    seed: u64,
) -> Worst {
    let tol_first = 1e-3 * f64::EPSILON.cbrt();
    let tol_second = 1e-5;
    assert!(
        model.has_second_order(),
        "{name}: built-in models have second derivatives"
    );
    let mut rng = Rng(seed);
    let mut worst = Worst::default();
    for sample in 0..SAMPLES {
        let x = rng.vector::<NX>(-1.0, 1.0);
        let u = rng.vector::<NU>(-1.0, 1.0);
        let lambda = rng.vector::<NX>(-1.0, 1.0);

        // The Jacobians overwrite every entry.
        let (mut fx, mut fu) = (Matrix::<NX, NX>::repeat(f64::NAN), Matrix::<NX, NU>::repeat(f64::NAN));
        model.jacobians(&x, &u, &mut fx, &mut fu);
        assert!(
            fx.iter().chain(fu.iter()).all(|v| v.is_finite()),
            "{name}: jacobians left entries unwritten at sample {sample}"
        );
        let (h_xx, h_ux, h_uu) = second_order(model, &x, &u, &lambda);
        // add_second_order adds: calling it on non-zero blocks gives the sum.
        let (mut a_xx, mut a_ux, mut a_uu) = (h_xx, h_ux, h_uu);
        model.add_second_order(&x, &u, &lambda, &mut a_xx, &mut a_ux, &mut a_uu);
        assert!((a_xx - 2.0 * h_xx).amax() + (a_ux - 2.0 * h_ux).amax() + (a_uu - 2.0 * h_uu).amax() < 1e-12);

        let errors = check_derivatives(model, &x, &u, &lambda);
        let scale1 = 1.0 + fx.amax().max(fu.amax());
        let scale2 = 1.0 + h_xx.amax().max(h_ux.amax()).max(h_uu.amax());
        let first = errors.fx.max(errors.fu) / scale1;
        let second = errors.second_order / scale2;
        assert!(
            first < tol_first,
            "{name}: Jacobian error {first:e} (fx {:e}, fu {:e}) at sample {sample}, x = {x:?}, u = {u:?}",
            errors.fx,
            errors.fu
        );
        assert!(
            second < tol_second,
            "{name}: second-order error {second:e} at sample {sample}, x = {x:?}, u = {u:?}"
        );
        worst.first = worst.first.max(first);
        worst.second = worst.second.max(second);
    }
    println!(
        "{name:>18}: max relative error, Jacobians {:.2e}, second order {:.2e}",
        worst.first, worst.second
    );
    worst
}

/// Compares the analytic step and derivatives with num-dual's exact derivatives of the model's
/// generic step, to 1e-12 relative.
fn check_autodiff<const NX: usize, const NU: usize, D>(name: &str, model: D, seed: u64)
where
    D: Dynamics<Const<NX>, Const<NU>> + DualDynamics<NX, NU> + Copy,
{
    let ad = AutoDiff(model);
    let mut rng = Rng(seed);
    for sample in 0..SAMPLES {
        let x = rng.vector::<NX>(-1.0, 1.0);
        let u = rng.vector::<NU>(-1.0, 1.0);
        let lambda = rng.vector::<NX>(-1.0, 1.0);
        let y = model.step(&x, &u);
        assert!(
            (y - ad.step(&x, &u)).amax() <= 1e-14 * (1.0 + y.amax()),
            "{name}: step at sample {sample}"
        );

        let (mut fx, mut fu) = (Matrix::<NX, NX>::zeros(), Matrix::<NX, NU>::zeros());
        let (mut gx, mut gu) = (Matrix::<NX, NX>::zeros(), Matrix::<NX, NU>::zeros());
        model.jacobians(&x, &u, &mut fx, &mut fu);
        ad.jacobians(&x, &u, &mut gx, &mut gu);
        let err = (fx - gx).amax().max((fu - gu).amax());
        let scale = 1.0 + gx.amax().max(gu.amax());
        assert!(
            err <= 1e-12 * scale,
            "{name}: Jacobian differs from AutoDiff by {err:e} at sample {sample}"
        );

        let (a_xx, a_ux, a_uu) = second_order(&model, &x, &u, &lambda);
        let (b_xx, b_ux, b_uu) = second_order(&ad, &x, &u, &lambda);
        let err = (a_xx - b_xx).amax().max((a_ux - b_ux).amax()).max((a_uu - b_uu).amax());
        let scale = 1.0 + b_xx.amax().max(b_ux.amax()).max(b_uu.amax());
        assert!(
            err <= 1e-12 * scale,
            "{name}: second order differs from AutoDiff by {err:e} at sample {sample}"
        );
    }
}

#[test]
fn all_models_match_finite_differences() {
    check_model("DoubleIntegrator2D", &DoubleIntegrator2D::default(), 1);
    check_model("Unicycle", &Unicycle::default(), 2);
    check_model("Car", &Car::default(), 3);
    check_model("DifferentialDrive", &DifferentialDrive::default(), 4);
    check_model("Quadrotor", &Quadrotor::default(), 5);
    check_model("ArmBase", &ArmBase::default(), 6);
    // Larger steps make the non-linear terms dominate.
    check_model("Unicycle dt=0.5", &Unicycle::new(0.5).unwrap(), 7);
    check_model("DiffDrive dt=0.5", &DifferentialDrive::new(0.5, 0.3).unwrap(), 8);
    check_model(
        "Quadrotor dt=0.2",
        &Quadrotor::with_params(0.2, 1.2, [0.02, 0.03, 0.05], 9.81).unwrap(),
        9,
    );
    let offset = ArmBaseParams {
        dt: 0.3,
        mount: [0.2, -0.15],
        link_lengths: [0.7, 0.4],
        link_masses: [2.0, 0.5],
        link_inertias: [0.05, 0.0],
        ..ArmBaseParams::default()
    };
    check_model("ArmBase offset", &ArmBase::from_params(offset).unwrap(), 10);
}

#[test]
fn analytic_derivatives_equal_autodiff_of_generic_step() {
    check_autodiff("DoubleIntegrator2D", DoubleIntegrator2D::default(), 11);
    check_autodiff("Unicycle", Unicycle::default(), 12);
    check_autodiff("Car", Car::default(), 13);
    check_autodiff("DifferentialDrive", DifferentialDrive::default(), 14);
    check_autodiff("Quadrotor", Quadrotor::default(), 15);
    check_autodiff("ArmBase", ArmBase::default(), 16);
    let offset = ArmBaseParams {
        mount: [-0.1, 0.3],
        link_inertias: [0.0, 0.1],
        ..ArmBaseParams::default()
    };
    check_autodiff("ArmBase offset", ArmBase::from_params(offset).unwrap(), 17);
}

/// The kept paths give the plain path's steps, Jacobians and second-order terms bit for bit:
/// the rollout's ([`Dynamics::step_keep`], [`Dynamics::jacobians_kept`]) and full DDP's
/// ([`Dynamics::jacobians_keep`], [`Dynamics::add_second_order_kept`]), each with the knot's own
/// data, with data kept at another point, and with none. The first two samples are the states
/// of entries `0.0` and `-0.0` (equal, but not to `sin`).
fn check_kept<const NX: usize, const NU: usize, D: Dynamics<Const<NX>, Const<NU>>>(name: &str, model: &D, seed: u64) {
    let mut rng = Rng(seed);
    let mut data = Vec::new();
    let mut step_data = Vec::new();
    let other = rng.vector::<NX>(-1.0, 1.0);
    for sample in 0..SAMPLES {
        let x = match sample {
            0 => Vector::<NX>::zeros(),
            1 => Vector::<NX>::repeat(-0.0),
            _ => rng.vector::<NX>(-3.0, 3.0),
        };
        let u = rng.vector::<NU>(-1.0, 1.0);
        let (mut fx, mut fu) = (Matrix::<NX, NX>::zeros(), Matrix::<NX, NU>::zeros());
        model.jacobians(&x, &u, &mut fx, &mut fu);
        // The rollout's path: the Jacobians from stale data (the previous sample's) and from
        // none, then the step and the Jacobians from its data.
        let bits = |a: &[f64], b: &[f64]| a.iter().chain(b).map(|v| v.to_bits()).collect::<Vec<_>>();
        let plain_bits = bits(fx.as_slice(), fu.as_slice());
        let jacobians_kept = |data: &[f64]| {
            let (mut gx, mut gu) = (Matrix::<NX, NX>::repeat(f64::NAN), Matrix::<NX, NU>::repeat(f64::NAN));
            model.jacobians_kept(&x, &u, &mut gx, &mut gu, data);
            bits(gx.as_slice(), gu.as_slice())
        };
        assert_eq!(
            jacobians_kept(&step_data),
            plain_bits,
            "{name} sample {sample}: Jacobians, stale data"
        );
        assert_eq!(
            jacobians_kept(&[]),
            plain_bits,
            "{name} sample {sample}: Jacobians, no data"
        );
        let mut next = Vector::<NX>::repeat(f64::NAN);
        model.step_keep(&x, &u, &mut next, &mut step_data);
        let step = model.step(&x, &u);
        assert_eq!(
            bits(next.as_slice(), &[]),
            bits(step.as_slice(), &[]),
            "{name} sample {sample}: kept step"
        );
        assert_eq!(
            jacobians_kept(&step_data),
            plain_bits,
            "{name} sample {sample}: Jacobians, own data"
        );
        let lambda = rng.vector::<NX>(-100.0, 100.0);
        let plain = second_order(model, &x, &u, &lambda);
        let kept_at = |at: &Vector<NX>, data: &mut Vec<f64>| {
            let (mut gx, mut gu) = (Matrix::<NX, NX>::repeat(f64::NAN), Matrix::<NX, NU>::repeat(f64::NAN));
            model.jacobians_keep(at, &u, &mut gx, &mut gu, data);
            (gx, gu)
        };
        let (gx, gu) = kept_at(&x, &mut data);
        assert_eq!((gx, gu), (fx, fu), "{name} sample {sample}: kept Jacobians");
        for data in [data.clone(), Vec::new(), {
            let mut d = Vec::new();
            kept_at(&other, &mut d);
            d
        }] {
            let (mut h_xx, mut h_ux, mut h_uu) = (Matrix::zeros(), Matrix::zeros(), Matrix::zeros());
            model.add_second_order_kept(&x, &u, &lambda, &data, &mut h_xx, &mut h_ux, &mut h_uu);
            assert_eq!((h_xx, h_ux, h_uu), plain, "{name} sample {sample}: kept second order");
        }
    }
}

#[test]
fn kept_derivatives_equal_the_plain_ones_bit_for_bit() {
    check_kept("Unicycle", &Unicycle::default(), 21);
    check_kept("Car", &Car::default(), 22);
    check_kept("DoubleIntegrator2D", &DoubleIntegrator2D::default(), 23);
    check_kept("Quadrotor", &Quadrotor::default(), 24);
}

#[test]
fn models_are_thread_safe_values() {
    fn assert_traits<T: Send + Sync + Copy + Clone + std::fmt::Debug + 'static>() {}
    assert_traits::<DoubleIntegrator2D>();
    assert_traits::<Unicycle>();
    assert_traits::<Car>();
    assert_traits::<DifferentialDrive>();
    assert_traits::<Quadrotor>();
    assert_traits::<ArmBase>();
}

// ---------------------------------------------------------------------------------------------
// Constructor errors name the field.

fn field_of<T: std::fmt::Debug>(result: ddp_core::Result<T>) -> String {
    match result {
        Err(Error::Invalid { field, .. }) => field,
        other => panic!("expected Error::Invalid, got {other:?}"),
    }
}

#[test]
fn bad_time_steps_are_rejected_naming_dt() {
    for dt in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert_eq!(field_of(Unicycle::new(dt)), "dt");
        assert_eq!(field_of(Car::new(dt)), "dt");
        assert_eq!(field_of(DoubleIntegrator2D::new(dt)), "dt");
        assert_eq!(field_of(DifferentialDrive::new(dt, 0.16)), "dt");
        assert_eq!(field_of(Quadrotor::new(dt)), "dt");
        assert_eq!(field_of(ArmBase::new(dt)), "dt");
    }
    let message = Unicycle::new(-1.0).unwrap_err().to_string();
    assert!(message.contains("dt") && message.contains("-1"), "{message}");
}

#[test]
fn bad_physical_parameters_are_rejected_naming_the_field() {
    assert_eq!(field_of(DifferentialDrive::new(0.1, 0.0)), "track_width");
    assert_eq!(field_of(Quadrotor::with_params(0.02, -1.0, [1e-3; 3], 9.81)), "mass");
    assert_eq!(
        field_of(Quadrotor::with_params(0.02, 0.5, [1e-3, f64::NAN, 1e-3], 9.81)),
        "inertia[1]"
    );
    assert_eq!(
        field_of(Quadrotor::with_params(0.02, 0.5, [1e-3; 3], f64::NAN)),
        "gravity"
    );
    let p = ArmBaseParams::default();
    assert_eq!(
        field_of(ArmBase::from_params(ArmBaseParams { base_mass: -10.0, ..p })),
        "base_mass"
    );
    assert_eq!(
        field_of(ArmBase::from_params(ArmBaseParams { base_inertia: 0.0, ..p })),
        "base_inertia"
    );
    assert_eq!(
        field_of(ArmBase::from_params(ArmBaseParams {
            link_masses: [1.0, -1.0],
            ..p
        })),
        "link_masses[1]"
    );
    assert_eq!(
        field_of(ArmBase::from_params(ArmBaseParams {
            link_lengths: [0.0, 0.5],
            ..p
        })),
        "link_lengths[0]"
    );
    assert_eq!(
        field_of(ArmBase::from_params(ArmBaseParams {
            link_inertias: [0.0, -0.1],
            ..p
        })),
        "link_inertias[1]"
    );
    assert_eq!(
        field_of(ArmBase::from_params(ArmBaseParams {
            mount: [f64::NAN, 0.0],
            ..p
        })),
        "mount[0]"
    );
    // Zero link inertias (point masses) are allowed.
    assert!(ArmBase::from_params(ArmBaseParams {
        link_inertias: [0.0, 0.0],
        ..p
    })
    .is_ok());
}

// ---------------------------------------------------------------------------------------------
// Physical sanity.

#[test]
fn unicycle_matches_p1_equations_exactly() {
    let model = Unicycle::default();
    assert_eq!(model.dt(), 0.1);
    let mut rng = Rng(21);
    for _ in 0..SAMPLES {
        let x = rng.vector::<3>(-3.0, 3.0);
        let u = rng.vector::<2>(-3.0, 3.0);
        let dt = 0.1;
        let expected = Vector::<3>::new(
            x[0] + x[2].cos() * u[0] * dt,
            x[1] + x[2].sin() * u[0] * dt,
            x[2] + u[1] * dt,
        );
        assert_eq!(model.step(&x, &u), expected);
    }
}

#[test]
fn car_matches_p2_equations() {
    let model = Car::new(0.05).unwrap();
    let mut rng = Rng(22);
    for _ in 0..SAMPLES {
        let x = rng.vector::<4>(-3.0, 3.0);
        let u = rng.vector::<2>(-1.0, 1.0);
        let dt = 0.05;
        let expected = Vector::<4>::new(
            x[0] + dt * x[3] * x[2].cos(),
            x[1] + dt * x[3] * x[2].sin(),
            x[2] + dt * u[0],
            x[3] + dt * u[1],
        );
        assert!((model.step(&x, &u) - expected).amax() < 1e-15);
    }
}

#[test]
fn double_integrator_is_exact_for_constant_acceleration() {
    let dt = 0.05;
    let model = DoubleIntegrator2D::new(dt).unwrap();
    let (p0, v0, a) = ([0.3, -0.2], [1.0, 0.5], Vector::<2>::new(-0.8, 0.6));
    let mut x = Vector::<4>::new(p0[0], p0[1], v0[0], v0[1]);
    for _ in 0..40 {
        x = model.step(&x, &a);
    }
    let t = 40.0 * dt;
    for i in 0..2 {
        assert!((x[i] - (p0[i] + v0[i] * t + 0.5 * a[i] * t * t)).abs() < 1e-12);
        assert!((x[2 + i] - (v0[i] + a[i] * t)).abs() < 1e-12);
    }
}

#[test]
fn differential_drive_goes_straight_and_turns_in_place() {
    let model = DifferentialDrive::default();
    let x = Vector::<3>::new(0.5, -0.5, 0.7);
    // Equal wheel speeds: straight along the heading.
    let y = model.step(&x, &Vector::<2>::new(0.2, 0.2));
    assert!((y - Vector::<3>::new(0.5 + 0.02 * 0.7f64.cos(), -0.5 + 0.02 * 0.7f64.sin(), 0.7)).amax() < 1e-15);
    // Opposite wheel speeds: rotation in place at (v_r - v_l) / b.
    let y = model.step(&x, &Vector::<2>::new(-0.08, 0.08));
    assert!((y - Vector::<3>::new(0.5, -0.5, 0.7 + 0.1 * 0.16 / 0.16)).amax() < 1e-15);
    // The chord of a constant-curvature arc points along the midpoint heading.
    let u = model.wheel_speeds(0.2, 0.5);
    let (v, w) = model.body_twist(&u);
    assert!((v - 0.2).abs() < 1e-15 && (w - 0.5).abs() < 1e-15);
    let y = model.step(&x, &u);
    let heading = (y[1] - x[1]).atan2(y[0] - x[0]);
    assert!((heading - (0.7 + 0.5 * 0.1 * 0.5)).abs() < 1e-12);
}

#[test]
fn quadrotor_hovers_with_thrust_mg() {
    let model = Quadrotor::default();
    let mut rng = Rng(31);
    for _ in 0..10 {
        // Any position and yaw, level and at rest.
        let mut x = Vector::<12>::zeros();
        x[0] = rng.uniform(-5.0, 5.0);
        x[1] = rng.uniform(-5.0, 5.0);
        x[2] = rng.uniform(0.0, 5.0);
        x[5] = rng.uniform(-3.0, 3.0);
        let y = model.step(&x, &model.hover_control());
        assert!((y - x).amax() < 1e-15, "hover drifted: {:?}", y - x);
    }
    assert_eq!(model.hover_thrust(), 0.468 * 9.81);
    // Without thrust it falls at g.
    let y = model.step(&Vector::zeros(), &Vector::zeros());
    assert!((y[8] + 9.81 * model.dt()).abs() < 1e-15);
    // A roll torque spins it up about body x only.
    let y = model.step(
        &Vector::zeros(),
        &Vector::<4>::new(model.hover_thrust(), 1e-3, 0.0, 0.0),
    );
    assert!((y[9] - model.dt() * 1e-3 / model.inertia()[0]).abs() < 1e-15);
    assert_eq!((y[10], y[11]), (0.0, 0.0));
}

#[test]
fn quadrotor_thrust_tilts_with_the_body() {
    // Pitched forward by theta (about body y), the thrust pushes along +x.
    let model = Quadrotor::default();
    let mut x = Vector::<12>::zeros();
    x[4] = 0.3;
    let y = model.step(&x, &model.hover_control());
    let g = model.gravity();
    assert!((y[6] - model.dt() * g * 0.3f64.sin()).abs() < 1e-14);
    assert!((y[8] - model.dt() * (g * 0.3f64.cos() - g)).abs() < 1e-14);
}

/// Rate of change of `quantity` along the continuous-time flow of the arm base at `x`, by a
/// central difference along `x' = (q', q'')`.
fn rate_along_flow<const N: usize>(
    model: &ArmBase,
    x: &Vector<10>,
    u: &Vector<5>,
    quantity: impl Fn(&Vector<10>) -> [f64; N],
) -> [f64; N] {
    let qdd = model.acceleration(x, u);
    let mut xdot = Vector::<10>::zeros();
    for i in 0..5 {
        xdot[i] = x[5 + i];
        xdot[5 + i] = qdd[i];
    }
    let h = 1e-5;
    let (plus, minus) = (quantity(&(x + h * xdot)), quantity(&(x - h * xdot)));
    std::array::from_fn(|i| (plus[i] - minus[i]) / (2.0 * h))
}

#[test]
fn arm_base_momentum_changes_only_by_the_base_force() {
    let model = ArmBase::default();
    let mut rng = Rng(41);
    for _ in 0..SAMPLES {
        let x = rng.vector::<10>(-1.5, 1.5);
        let u = rng.vector::<5>(-2.0, 2.0);
        // d(momentum)/dt = (fx, fy): the joint and base torques are internal or pure couples.
        let dp = rate_along_flow(&model, &x, &u, |x| model.linear_momentum(x));
        assert!(
            (dp[0] - u[0]).abs() < 1e-7 && (dp[1] - u[1]).abs() < 1e-7,
            "{dp:?} vs {u:?}"
        );
        // Power balance dT/dt = u . q': checks that c(q, q') is consistent with M(q).
        let [de] = rate_along_flow(&model, &x, &u, |x| [model.kinetic_energy(x)]);
        let power: f64 = (0..5).map(|i| u[i] * x[5 + i]).sum();
        assert!((de - power).abs() < 1e-7, "dT/dt = {de}, power = {power}");
    }
}

#[test]
fn arm_base_centre_of_mass_stays_put_under_joint_torques() {
    // From rest, joint and base torques only: the centre of mass does not move, up to the O(dt)
    // error of semi-implicit Euler.
    let drift = |dt: f64| {
        let model = ArmBase::new(dt).unwrap();
        let mut x = Vector::<10>::zeros();
        x[3] = 0.4;
        x[4] = -0.7;
        let com0 = model.centre_of_mass(&x);
        let steps = (3.0 / dt).round() as usize;
        let mut worst: f64 = 0.0;
        for k in 0..steps {
            let t = k as f64 * dt;
            let u = Vector::<5>::new(
                0.0,
                0.0,
                0.2 * (1.3 * t).cos(),
                0.3 * (2.0 * t).sin(),
                -0.2 * (3.0 * t).cos(),
            );
            x = model.step(&x, &u);
            let com = model.centre_of_mass(&x);
            worst = worst.max((com[0] - com0[0]).hypot(com[1] - com0[1]));
        }
        // The joints really moved.
        assert!((x[3] - 0.4).abs() + (x[4] + 0.7).abs() > 0.05);
        worst
    };
    let (coarse, fine) = (drift(0.01), drift(0.001));
    println!("centre-of-mass drift over 3 s: {coarse:.2e} m at dt = 0.01, {fine:.2e} m at dt = 0.001");
    assert!(coarse < 5e-3, "drift {coarse}");
    assert!(fine < 0.2 * coarse, "drift does not shrink with dt: {coarse} -> {fine}");
}

#[test]
fn arm_base_forward_kinematics() {
    let model = ArmBase::default();
    let p = *model.params();
    // Zero configuration: the arm stretches along the body x axis from the mount.
    let tcp = model.tcp_position(&Vector::zeros());
    assert!((tcp[0] - (p.mount[0] + p.link_lengths[0] + p.link_lengths[1])).abs() < 1e-15);
    assert!((tcp[1] - p.mount[1]).abs() < 1e-15);
    // Folded back by pi at the elbow, base turned by pi/2 and moved.
    let mut x = Vector::<10>::zeros();
    x[0] = 1.0;
    x[1] = 2.0;
    x[2] = std::f64::consts::FRAC_PI_2;
    x[4] = std::f64::consts::PI;
    let [shoulder, elbow, tcp] = model.link_endpoints(&x);
    assert!((shoulder[0] - 1.0).abs() < 1e-12 && (shoulder[1] - (2.0 + p.mount[0])).abs() < 1e-12);
    assert!((elbow[1] - (shoulder[1] + p.link_lengths[0])).abs() < 1e-12);
    assert!((tcp[1] - (elbow[1] - p.link_lengths[1])).abs() < 1e-12);
    let corners = model.base_corners(&x);
    assert!((corners[0][0] - (1.0 - 0.5 * p.base_size[1])).abs() < 1e-12);

    // Jacobians of the points match finite differences.
    let mut rng = Rng(51);
    for _ in 0..SAMPLES {
        let x = rng.vector::<10>(-2.0, 2.0);
        let jacs = model.link_endpoint_jacobians(&x);
        assert_eq!(jacs[2], model.tcp_jacobian(&x));
        for j in 0..10 {
            let h = 1e-6;
            let (mut xp, mut xm) = (x, x);
            xp[j] += h;
            xm[j] -= h;
            let (pp, pm) = (model.link_endpoints(&xp), model.link_endpoints(&xm));
            for (point, jac) in jacs.iter().enumerate() {
                for r in 0..2 {
                    let fd = (pp[point][r] - pm[point][r]) / (2.0 * h);
                    assert!((jac[(r, j)] - fd).abs() < 1e-8, "point {point}, row {r}, column {j}");
                }
            }
        }
    }
}

#[test]
fn arm_base_at_rest_without_control_stays_at_rest() {
    let model = ArmBase::default();
    let mut x = Vector::<10>::zeros();
    x[2] = 0.3;
    x[3] = 1.0;
    x[4] = -2.0;
    assert_eq!(model.step(&x, &Vector::zeros()), x);
    // A pure base force on a symmetric configuration accelerates everything together.
    let qdd = model.acceleration(&Vector::zeros(), &Vector::<5>::new(1.2, 0.0, 0.0, 0.0, 0.0));
    assert!((qdd[0] - 1.2 / model.total_mass()).abs() < 1e-15);
}
