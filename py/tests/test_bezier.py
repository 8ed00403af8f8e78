"""ddpkit.bezier through Python: closed forms, vectorised = per-point, round trips, errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

import ddpkit
from ddpkit import bezier

#: y = x^2 on [0, 1] as a quadratic Bezier: x(t) = t, y(t) = t^2.
PARABOLA = np.array([[0.0, 0.0], [0.5, 0.0], [1.0, 1.0]])


def parabola_length(a: float) -> float:
    """Length of y = x^2 from x = 0 to x = a."""
    return 0.5 * a * math.sqrt(1.0 + 4.0 * a * a) + 0.25 * math.asinh(2.0 * a)


def curves() -> list[bezier.Bezier]:
    """A quadratic, a cubic (the specialised type), a quintic (the general one)."""
    return [
        bezier.Bezier(PARABOLA),
        bezier.Bezier([[0.0, 0.0], [0.3, 0.9], [0.7, 0.9], [1.0, 0.0]]),
        bezier.Bezier([[0.0, 0.0], [1.0, 3.0], [2.0, -3.0], [3.0, 1.0], [4.0, 0.0], [5.0, 2.0]]),
    ]


# --- closed forms ---------------------------------------------------------------------------


@pytest.mark.parametrize("degree", [1, 2, 3, 4, 6])
def test_straight_line_length(degree: int) -> None:
    # Collinear control points with increasing x: the curve is the segment, whatever the spacing.
    x = np.concatenate([[0.0], np.sort(np.random.default_rng(degree).uniform(0.0, 3.0, degree - 1)), [3.0]])
    c = bezier.Bezier(np.stack([x, 0.75 * x + 1.0], axis=1))
    assert c.degree == degree
    exact = 3.0 * math.hypot(1.0, 0.75)
    assert abs(c.arclen(1e-12) - exact) < 1e-11
    assert abs(c.arclen_simpson(1e-11) - exact) < 1e-9
    assert abs(c.arclen_range(0.0, 1.0, 1e-12) - exact) < 1e-11


def test_parabola_length() -> None:
    exact = parabola_length(1.0)
    c = bezier.Bezier(PARABOLA)
    # The same parabola as a cubic and a quartic (exact degree elevation) has the same length.
    for curve in (c, c.elevate(), c.elevate().elevate()):
        assert abs(curve.arclen(1e-12) - exact) < 1e-11, curve
        assert abs(curve.arclen_simpson(1e-11) - exact) < 1e-9, curve
    # x(t) = t, so the length up to parameter a is the length up to x = a.
    for a in (0.1, 0.37, 0.5, 0.9):
        assert abs(c.arclen_range(0.0, a, 1e-12) - parabola_length(a)) < 1e-11
        assert abs(c.arclen_range(a, 0.0, 1e-12) + parabola_length(a)) < 1e-11


def test_arclen_batch_equals_per_curve() -> None:
    rng = np.random.default_rng(7)
    for n in (3, 4, 6):
        pts = rng.uniform(-1.0, 1.0, (50, n, 2))
        batch = bezier.arclen_batch(pts, 1e-10)
        assert batch.shape == (50,)
        for i in range(50):
            assert abs(batch[i] - bezier.Bezier(pts[i]).arclen(1e-10)) < 1e-12
        simpson = bezier.arclen_batch(pts, 1e-8, method="simpson")
        np.testing.assert_allclose(simpson, batch, atol=1e-6)


def test_cubic_arclen_batch_is_bit_identical_in_every_layout() -> None:
    """Cubics take the in-place batch path (C-contiguous float64) or the converting one (other
    layouts and types); both equal the one-by-one lengths exactly, across the batch's groups of 4
    and its 256-curve chunks, near-cusps included."""
    rng = np.random.default_rng(11)
    pts = rng.uniform(-1.0, 1.0, (600, 4, 2))
    pts[::7, 2] = pts[::7, 1] + rng.uniform(-1e-6, 1e-6, (86, 2))  # near-cusps every 7th curve
    want = np.array([bezier.Bezier(p).arclen(1e-11) for p in pts])
    strided = np.zeros((600, 4, 3))[:, :, :2]  # not contiguous
    strided[...] = pts
    for layout in (pts, np.asfortranarray(pts), strided, pts.tolist()):
        np.testing.assert_array_equal(bezier.arclen_batch(layout, 1e-11), want)
    for m in (0, 1, 3, 4, 5, 255, 256, 257):
        np.testing.assert_array_equal(bezier.arclen_batch(pts[:m], 1e-11), want[:m])


def test_simd_levels_agree_and_the_environment_narrows_them() -> None:
    """``DDPKIT_SIMD`` picks the sums (read once per process, so each level runs in its own
    interpreter); every level gives the same lengths to a few ulps."""
    import json
    import os
    import subprocess
    import sys

    assert bezier.simd_level() in ("avx512", "avx2+fma", "portable")
    pts = np.random.default_rng(5).uniform(-1.0, 1.0, (64, 4, 2))
    code = (
        "import json, sys, numpy as np; from ddpkit import bezier; "
        "pts = np.array(json.loads(sys.stdin.read())); "
        "print(json.dumps([bezier.simd_level(), bezier.arclen_batch(pts, 1e-12).tolist()]))"
    )
    here = bezier.arclen_batch(pts, 1e-12)
    for limit, allowed in (("off", {"portable"}), ("avx2", {"avx2+fma", "portable"})):
        env = dict(os.environ, DDPKIT_SIMD=limit)
        out = subprocess.run(
            [sys.executable, "-c", code], input=json.dumps(pts.tolist()), env=env, capture_output=True, text=True, check=True
        )
        level, lengths = json.loads(out.stdout)
        assert level in allowed
        np.testing.assert_allclose(lengths, here, rtol=1e-14)


def test_cubic_arclen_batch_rejects_non_finite_naming_the_index() -> None:
    pts = np.zeros((10, 4, 2))
    pts[6, 2, 1] = np.nan
    with pytest.raises(ddpkit.NotFiniteError, match=r"control_points\[53\]"):
        bezier.arclen_batch(pts)


# --- vectorised = per point -------------------------------------------------------------------


def cubic_length_reference(p: np.ndarray) -> float:
    """Length of a cubic to about 1e-14 relative: 16-point Gauss-Legendre on 200 pieces, also cut at
    the real part of every complex root of the hodograph x'(t) + i y'(t) (near-cusps sit at a piece
    end) and graded toward it."""
    d = np.diff(p, axis=0)
    q = np.array([3 * (d[0] - 2 * d[1] + d[2]), 6 * (d[1] - d[0]), 3 * d[0]])
    z = q[:, 0] + 1j * q[:, 1]
    cuts = np.linspace(0.0, 1.0, 201)
    if abs(z[0]) > 1e-14 * np.abs(z).max():
        roots = np.roots(z).real
        grading = np.concatenate([[0.0], 10.0 ** -np.arange(3.0, 15.0)])
        near = (roots[:, None] + np.concatenate([grading, -grading])).ravel()
        cuts = np.union1d(cuts, near[(near > 0.0) & (near < 1.0)])
    x, w = np.polynomial.legendre.leggauss(16)
    a, b = cuts[:-1, None], cuts[1:, None]
    t = 0.5 * (a + b) + 0.5 * (b - a) * x
    v = (q[0] * t[..., None] + q[1]) * t[..., None] + q[2]
    return float(np.sum(0.5 * (b - a) * w * np.hypot(v[..., 0], v[..., 1])))


def adversarial_cubics() -> np.ndarray:
    """Exact and near cusps (the hodograph's root 1e-12 to 1e-1 off the real axis, moved along the
    curve), loops, coincident control points, lines that reverse, and a scaled copy of each."""
    base = [
        [[0, 0], [1, 1], [0, 1], [1, 0]],
        [[0, 0], [2, 1], [-1, 1], [1, 0]],
        [[0, 0], [0, 0], [1, 1], [2, 0]],
        [[0, 0], [1, 1], [2, 0], [2, 0]],
        [[0, 0], [0, 0], [1, 0], [1, 0]],
        [[0, 0], [3, 0], [-1, 0], [2, 0]],
        [[0, 0], [2, 2], [-1, 2], [1, 0]],
    ]
    for delta in (1e-12, 1e-8, 1e-5, 1e-3, 1e-1):
        for shift in (0.0, 0.3, -0.45):
            base.append([[0, 0], [1 + shift, 1], [shift, 1 + delta], [1, 0]])
    pts = np.array(base, dtype=float)
    return np.concatenate([pts, 1e3 * pts])


@pytest.mark.parametrize("accuracy", [1e-3, 1e-6, 1e-9, 1e-12])
def test_near_cusps_and_degenerate_cubics_meet_the_accuracy(accuracy: float) -> None:
    pts = adversarial_cubics()
    want = np.array([cubic_length_reference(p) for p in pts])
    got = bezier.arclen_batch(pts, accuracy)
    # Requests below ~1e-15 of the length are raised to it (round-off).
    np.testing.assert_array_less(np.abs(got - want), accuracy + 1e-14 * want)
    for p, g in zip(pts, got):
        assert bezier.Bezier(p).arclen(accuracy) == g


@pytest.mark.parametrize("index", [0, 1, 2])
def test_vectorised_equals_per_point(index: int) -> None:
    c = curves()[index]
    t = np.random.default_rng(index).uniform(0.0, 1.0, (3, 4))
    methods = [c.eval, c.eval_de_casteljau, c.velocity, c.acceleration, c.jerk]
    for f in methods:
        out = f(t)
        assert out.shape == (3, 4, 2)
        for i, j in np.ndindex(3, 4):
            np.testing.assert_array_equal(out[i, j], f(float(t[i, j])))
    for order in range(6):
        out = c.derivative(t, order)
        for i, j in np.ndindex(3, 4):
            np.testing.assert_array_equal(out[i, j], c.derivative(float(t[i, j]), order))
    for g in (c.curvature, c.speed):
        out = g(t)
        assert out.shape == (3, 4)
        for i, j in np.ndindex(3, 4):
            v = g(float(t[i, j]))
            assert isinstance(v, float)
            assert out[i, j] == v
    # Lists work like arrays; a 0-d array gives a 0-d result.
    np.testing.assert_array_equal(c.eval(list(t[0])), c.eval(t[0]))
    assert c.curvature(np.float32(0.5)).shape == ()


def test_derivatives_match_finite_differences() -> None:
    for c in curves():
        t, h = 0.37, 1e-5
        for order in (1, 2):
            fd = (c.derivative(t + h, order - 1) - c.derivative(t - h, order - 1)) / (2 * h)
            np.testing.assert_allclose(c.derivative(t, order), fd, rtol=1e-6, atol=1e-6)
        v, a = c.velocity(t), c.acceleration(t)
        assert abs(c.curvature(t) - (v[0] * a[1] - v[1] * a[0]) / np.hypot(*v) ** 3) < 1e-12
        assert abs(c.speed(t) - np.hypot(*v)) < 1e-14


def test_spline_trajectory_profile_vectorised() -> None:
    w = np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 0.0], [3.0, 1.0]])
    s = bezier.Spline.catmull_rom(w)
    u = np.linspace(0.0, 3.0, 13)
    np.testing.assert_array_equal(s.eval(u), np.array([s.eval(float(x)) for x in u]))
    np.testing.assert_array_equal(s.curvature(u), np.array([s.curvature(float(x)) for x in u]))
    traj = bezier.Trajectory.with_sigmoid(s, m=10.0, max_speed=1.0)
    times = np.linspace(0.0, traj.duration, 9)
    np.testing.assert_array_equal(traj.position(times), np.array([traj.position(float(x)) for x in times]))
    samples = traj.sample(times)
    assert len(samples) == 9
    np.testing.assert_array_equal(samples.position, traj.position(times))
    p = traj.profile
    np.testing.assert_array_equal(p.distance(times), np.array([p.distance(float(x)) for x in times]))
    d = p.derivatives(times)
    for k, x in enumerate(times):
        assert tuple(col[k] for col in d) == p.derivatives(float(x))


def test_memory_layouts_and_dtypes_agree() -> None:
    # Regression: Fortran-ordered input once took the C-order fast path and was read transposed.
    p = np.array([[0.0, 0.0], [0.3, 0.9], [0.7, 0.9], [1.0, 0.0]])
    t = np.linspace(0.0, 1.0, 12).reshape(3, 4)
    want = bezier.Bezier(p).eval(t)
    variants = [np.asfortranarray(p), p[::-1][::-1], np.ascontiguousarray(p.T).T, p.tolist()]
    for q in variants:
        c = bezier.Bezier(q)
        np.testing.assert_array_equal(c.points, p)
        np.testing.assert_array_equal(c.eval(t), want)
    np.testing.assert_array_equal(bezier.Bezier((10 * p).astype(np.int32)).points, np.round(10 * p))
    c = bezier.Bezier(p)
    for u in (np.asfortranarray(t), t[::-1][::-1], t.T.copy().T, t.tolist()):
        np.testing.assert_array_equal(c.eval(u), want)
    batch = np.stack([p, 2 * p])
    np.testing.assert_array_equal(bezier.arclen_batch(np.asfortranarray(batch)), bezier.arclen_batch(batch))


# --- inverse arc length, resampling -------------------------------------------------------------


@pytest.mark.parametrize("index", [0, 1, 2])
def test_inverse_arclen_round_trip(index: int) -> None:
    c = curves()[index]
    total = c.arclen(1e-12)
    s = np.linspace(0.0, total, 41)
    t = c.inv_arclen(s, 1e-11)
    assert t.shape == s.shape
    assert np.all(np.diff(t) > 0)
    assert t[0] == 0.0 and t[-1] == 1.0
    for si, ti in zip(s, t):
        assert abs(c.arclen_range(0.0, float(ti), 1e-12) - si) < 1e-9
        assert c.inv_arclen(float(si), 1e-11) == ti
    # Clamped outside [0, L].
    assert c.inv_arclen(-1.0) == 0.0 and c.inv_arclen(total + 1.0) == 1.0


def test_resample_uniform_equal_lengths() -> None:
    for c in curves():
        t = c.resample_uniform(11, 1e-11)
        pieces = [c.arclen_range(float(a), float(b), 1e-12) for a, b in zip(t[:-1], t[1:])]
        np.testing.assert_allclose(pieces, np.full(10, c.arclen(1e-12) / 10), atol=1e-9)
        np.testing.assert_array_equal(c.resample_points(11, 1e-11), c.eval(t))


# --- geometry ---------------------------------------------------------------------------------


def test_bounding_box_subdivision_elevation() -> None:
    for c in curves():
        x0, y0, x1, y1 = c.bounding_box()
        pts = c.eval(np.linspace(0.0, 1.0, 2001))
        assert np.all(pts >= [x0 - 1e-12, y0 - 1e-12]) and np.all(pts <= [x1 + 1e-12, y1 + 1e-12])
        # Tight: the sampled extremes are within the sampling error of the box.
        assert np.allclose([pts[:, 0].min(), pts[:, 1].min(), pts[:, 0].max(), pts[:, 1].max()], [x0, y0, x1, y1], atol=1e-5)
        for t in c.extrema():
            assert 0.0 < t < 1.0
        left, right = c.subdivide(0.3)
        u = np.linspace(0.0, 1.0, 7)
        np.testing.assert_allclose(left.eval(u), c.eval(0.3 * u), atol=1e-14)
        np.testing.assert_allclose(right.eval(u), c.eval(0.3 + 0.7 * u), atol=1e-14)
        np.testing.assert_allclose(c.subsegment(0.2, 0.6).eval(u), c.eval(0.2 + 0.4 * u), atol=1e-14)
        e = c.elevate()
        assert e.degree == c.degree + 1
        np.testing.assert_allclose(e.eval(u), c.eval(u), atol=1e-14)
        assert c.hodograph().degree == c.degree - 1
        np.testing.assert_allclose(c.hodograph().eval(u), c.velocity(u), atol=1e-13)


def test_splines_continuity_and_waypoints() -> None:
    w = np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 0.0], [3.0, 1.0], [4.0, 0.5]])
    cr = bezier.Spline.catmull_rom(w)
    c2 = bezier.Spline.c2_natural(w)
    cl = bezier.Spline.c2_clamped(w, [1.0, 0.0], [1.0, 0.0])
    assert (cr.continuity(), c2.continuity(), cl.continuity()) == ("C1", "C2", "C2")
    for s in (cr, c2, cl):
        assert len(s) == 4
        np.testing.assert_allclose(s.waypoints, w, atol=1e-15)
        np.testing.assert_allclose(s.eval(np.arange(5.0)), w, atol=1e-15)
        assert s.segments.shape == (4, 4, 2)
    np.testing.assert_allclose(cl.tangents[[0, -1]], [[1.0, 0.0], [1.0, 0.0]], atol=1e-12)
    h = bezier.Spline.hermite(w, cr.tangents)
    np.testing.assert_allclose(h.segments, cr.segments, atol=1e-15)
    rebuilt = bezier.Spline(cr.segments)
    np.testing.assert_array_equal(rebuilt.segments, cr.segments)
    np.testing.assert_array_equal(cr.segment(-1).points, cr.segments[-1])
    assert abs(cr.arclen() - cr.segment_lengths().sum()) < 1e-12
    assert c2.jerk_cost_param() < cr.jerk_cost_param()


def test_profile_and_unicycle_reference() -> None:
    p = bezier.SigmoidProfile.with_max_speed(10.0, 8.0, max_speed=2.0)
    assert abs(p.peak_speed - 2.0) < 1e-12
    assert abs(p.distance(p.duration) - 10.0) < 1e-12
    assert abs(p.time_at_distance(p.distance(1.234)) - 1.234) < 1e-9
    m = bezier.SigmoidProfile.max_steepness(10.0, p.duration, 2.0)
    assert abs(m - 8.0) < 1e-9

    w = np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 3.0]])
    traj = bezier.Trajectory.with_sigmoid(bezier.Spline.catmull_rom(w), m=10.0, max_speed=1.5)
    dt = 0.05
    xs, us = traj.unicycle(dt)
    assert xs.shape[1] == 3 and us.shape == (xs.shape[0] - 1, 2)
    np.testing.assert_allclose(xs[-1, :2], w[-1], atol=1e-6)
    assert np.all(us[:, 0] <= 1.5 + 1e-6)
    # The controls reproduce the heading exactly, and the position up to the Euler step's chord
    # error (v omega dt^2 / 2 for a constant turn; twice that for the curvature changing within
    # the step), plus the speed change over the step.
    model = ddpkit.Unicycle(dt=dt)
    xc, uc = traj.car(dt)
    for k in range(len(us)):
        nxt = model.step(xs[k], us[k])
        assert abs(nxt[2] - xs[k + 1, 2]) < 1e-12
        bound = abs(us[k, 0] * us[k, 1]) * dt**2 + abs(xc[k + 1, 3] - xc[k, 3]) * dt + 1e-12
        assert np.linalg.norm(nxt[:2] - xs[k + 1, :2]) <= bound
    assert xc.shape == (xs.shape[0], 4) and uc.shape == us.shape
    grid = traj.sample_grid(dt)
    np.testing.assert_allclose(grid.heading, xs[:, 2])
    np.testing.assert_allclose(grid.speed, xc[:, 3])


def test_costs_and_direct_optimiser() -> None:
    w = np.array([[0.0, 0.0], [1.0, 0.6], [2.0, 0.0], [3.0, 0.6]])
    cr = bezier.Spline.catmull_rom(w)
    traj = bezier.Trajectory.with_sigmoid(cr, m=10.0)
    expected = traj.jerk_cost_integral(1e-8) + 0.01 * traj.curvature_sum(100)
    assert abs(bezier.spline_cost(cr) - expected) < 1e-9 * expected
    assert traj.jerk_cost_discrete(100) > 0
    res = bezier.optimize_spline(w, max_iterations=8)
    assert res.status in ("converged", "max_iterations", "line_search_failed")
    assert abs(res.initial_cost - bezier.spline_cost(cr)) < 1e-9 * res.initial_cost
    assert res.cost < res.initial_cost
    assert abs(bezier.spline_cost(res.spline) - res.cost) < 1e-9 * res.cost
    np.testing.assert_allclose(res.spline.waypoints, w, atol=1e-15)
    assert res.spline.continuity() == "C1"


# --- errors -----------------------------------------------------------------------------------


def raises(cls: type, field: str, f, *args, **kwargs) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(cls, match=field.replace("[", r"\[").replace("]", r"\]")) as e:
        f(*args, **kwargs)
    assert e.value.field == field
    assert isinstance(e.value, ddpkit.DdpError) and isinstance(e.value, ValueError)


def test_errors_name_the_field() -> None:
    c = curves()[1]
    w = np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 0.0]])
    s = bezier.Spline.catmull_rom(w)
    traj = bezier.Trajectory.with_sigmoid(s)
    raises(ddpkit.NotFiniteError, "points", bezier.Bezier, [[0.0, 0.0], [1.0, np.nan]])
    raises(ddpkit.ShapeError, "points", bezier.Bezier, np.zeros((0, 2)))
    raises(ddpkit.ShapeError, "points", bezier.Bezier, np.zeros((3, 3)))
    raises(ddpkit.ShapeError, "points", bezier.Bezier, np.zeros((1001, 2)))
    raises(ddpkit.InvalidInputError, "points", bezier.Bezier(np.zeros((1000, 2))).elevate)
    raises(ddpkit.InvalidInputError, "points", bezier.Bezier, [["a", "b"]])
    raises(ddpkit.NotFiniteError, "t", c.eval, np.nan)
    raises(ddpkit.NotFiniteError, "t", c.curvature, [0.5, np.inf])
    raises(ddpkit.NotFiniteError, "s", c.inv_arclen, [np.nan])
    raises(ddpkit.InvalidInputError, "accuracy", c.arclen, 0.0)
    raises(ddpkit.InvalidInputError, "accuracy", c.arclen_simpson, -1e-9)
    raises(ddpkit.NotFiniteError, "accuracy", c.inv_arclen, 0.5, np.nan)
    raises(ddpkit.InvalidInputError, "n", c.resample_uniform, -1)
    raises(ddpkit.InvalidInputError, "n", c.resample_points, 10**18)
    raises(ddpkit.InvalidInputError, "order", c.derivative, 0.5, -1)
    raises(ddpkit.ShapeError, "control_points", bezier.arclen_batch, np.zeros((3, 4)))
    raises(ddpkit.InvalidInputError, "method", bezier.arclen_batch, np.zeros((3, 4, 2)), 1e-9, "trapezoid")
    raises(ddpkit.ShapeError, "waypoints", bezier.Spline.catmull_rom, [[0.0, 0.0]])
    raises(ddpkit.NotFiniteError, "waypoints", bezier.Spline.c2_natural, [[0.0, 0.0], [np.inf, 1.0]])
    raises(ddpkit.ShapeError, "tangents", bezier.Spline.hermite, w, np.zeros((2, 2)))
    raises(ddpkit.ShapeError, "start_tangent", bezier.Spline.c2_clamped, w, [1.0], [1.0, 0.0])
    gap = np.array([[[0, 0], [1, 0], [2, 0], [3, 0]], [[4, 0], [5, 0], [6, 0], [7, 0]]], dtype=float)
    raises(ddpkit.InvalidInputError, "segments[1]", bezier.Spline, gap)
    raises(ddpkit.InvalidInputError, "index", s.segment, 5)
    raises(ddpkit.InvalidInputError, "m", bezier.SigmoidProfile, 1.0, -1.0, 1.0)
    raises(ddpkit.InvalidInputError, "duration", bezier.SigmoidProfile, 1.0, 1.0, 0.0)
    raises(ddpkit.InvalidInputError, "max_speed", bezier.SigmoidProfile.with_max_speed, 1.0, 1.0, 0.0)
    raises(ddpkit.NotFiniteError, "length", bezier.SigmoidProfile, np.nan, 1.0, 1.0)
    raises(ddpkit.InvalidInputError, "profile.length", bezier.Trajectory, s, bezier.SigmoidProfile(1.0, 1.0, 1.0))
    raises(ddpkit.InvalidInputError, "dt", traj.unicycle, 0.0)
    raises(ddpkit.InvalidInputError, "dt", traj.car, 1e-300)
    raises(ddpkit.InvalidInputError, "steps", traj.sample_grid, 0.1, -3)
    raises(ddpkit.ShapeError, "times", traj.sample, np.zeros((2, 2)))
    raises(ddpkit.InvalidInputError, "samples", traj.curvature_sum, -1)
    raises(ddpkit.InvalidInputError, "samples", bezier.spline_cost, s, samples=3)
    raises(ddpkit.InvalidInputError, "curvature_weight", bezier.spline_cost, s, curvature_weight=-1.0)
    raises(ddpkit.InvalidInputError, "jerk", bezier.spline_cost, s, jerk="l2")
    raises(ddpkit.InvalidInputError, "continuity", bezier.optimize_spline, w, continuity="C0")
    raises(ddpkit.InvalidInputError, "max_iterations", bezier.optimize_spline, w, max_iterations=-1)
    raises(ddpkit.ShapeError, "waypoints", bezier.optimize_spline, [[0.0, 0.0]])
