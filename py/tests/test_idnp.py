"""ddpkit.idnp: IDNP with adaptive grid refinement after Richter et al. (2023), through the wheel.

The results are checked independently of the Rust side: the trajectory is re-simulated with
``ddpkit.ArmBase``, the tool-centre point (TCP) is computed by its forward kinematics, and the
waypoints are compared with the scene's geometry.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import ddpkit
from ddpkit import idnp

UPPER_START = [2.0, 2.5]  # above the wall's middle: only the narrow passage leads to the goal in time


@pytest.fixture(scope="module")
def scene() -> dict:
    return idnp.scene()


@pytest.fixture(scope="module")
def q0() -> np.ndarray:
    return idnp.configuration(UPPER_START)


@pytest.fixture(scope="module")
def adaptive(q0: np.ndarray) -> idnp.Run:
    return idnp.run(q0, variant="adaptive")


def rectangles(scene: dict) -> list[tuple[np.ndarray, np.ndarray]]:
    return [(o.min(axis=0), o.max(axis=0)) for o in scene["obstacles"]]


def test_scene_has_four_rectangles_and_a_passage_narrower_than_the_grid(scene: dict) -> None:
    assert len(scene["obstacles"]) == 4
    for o in scene["obstacles"]:
        assert o.shape == (4, 2)
        # Axis-aligned rectangle: two distinct x and two distinct y values.
        assert len(np.unique(np.round(o[:, 0], 12))) == 2 and len(np.unique(np.round(o[:, 1], 12))) == 2
    lo, hi = scene["passage"]
    assert hi[1] - lo[1] < scene["cell_size"]
    # The passage is free, and walls are directly below and above it.
    mid = 0.5 * (lo + hi)
    for a, b in rectangles(scene):
        assert not (np.all(mid >= a) and np.all(mid <= b))
    assert any(np.isclose(b[1], lo[1]) for _, b in rectangles(scene))
    assert any(np.isclose(a[1], hi[1]) for a, _ in rectangles(scene))


def test_configuration_puts_the_tcp_on_the_point(q0: np.ndarray, scene: dict) -> None:
    model = ddpkit.ArmBase(dt=scene["dt"])
    x = np.concatenate([q0, np.zeros(5)])
    np.testing.assert_allclose(model.tcp_position(x), UPPER_START, atol=1e-6)


def test_adaptive_run_goes_through_the_passage(adaptive: idnp.Run, q0: np.ndarray, scene: dict) -> None:
    run = adaptive
    assert run.success and run.termination == "solved"
    assert 2 <= run.iterations <= 15
    # Iteration 1 on the coarse grid crosses a wall; refinement adds cells, fewer than a uniform
    # grid one level finer (4x the coarse cells).
    assert run.cells[0] == 8 * 6 * 13
    assert run.cells == sorted(run.cells) and run.final_cells > run.cells[0]
    assert run.final_cells < 4 * run.cells[0]
    assert len(run.waypoints) == run.iterations
    for w in run.waypoints:
        assert w.shape == (13, 2)
        np.testing.assert_allclose(w[0], UPPER_START, atol=1e-6)
    assert run.inverse_failures and all(f[0] < run.iterations for f in run.inverse_failures)
    first = {f[1]: f[2] for f in run.inverse_failures if f[0] == 1}
    for stage, z in first.items():
        np.testing.assert_allclose(run.waypoints[0][stage], z)
    # The trajectory: re-simulated with ArmBase it matches, starts at q0, ends at rest in the goal.
    xs, us = run.xs, run.us
    assert xs is not None and us is not None
    assert xs.shape == (49, 10) and us.shape == (48, 5)
    np.testing.assert_allclose(xs[0, :5], q0, atol=1e-12)
    model = ddpkit.ArmBase(dt=scene["dt"])
    x = xs[0]
    for k in range(len(us)):
        x = model.step(x, us[k])
        np.testing.assert_allclose(x, xs[k + 1], atol=1e-9)
    tcp = np.array([model.tcp_position(x) for x in xs])
    goal = np.linalg.norm(tcp[-1] - scene["goal_center"])
    assert goal <= scene["goal_radius"] + 0.02
    assert np.abs(xs[-1, 5:]).max() <= 0.1
    # Through the passage: some TCP between the walls at the passage's height.
    lo, hi = scene["passage"]
    assert np.any(np.all((tcp > lo) & (tcp < hi), axis=1))
    # The TCP never enters an obstacle.
    for a, b in rectangles(scene):
        assert not np.any(np.all((tcp > a) & (tcp < b), axis=1))
    # Final grids: leaves of the refined time indices are smaller than the coarse cells.
    sizes = np.concatenate([run.grid(j)[:, 2] for j in range(13)])
    assert sizes.min() < scene["cell_size"] and sizes.max() == pytest.approx(scene["cell_size"])
    assert sum(len(run.grid(j)) for j in range(13)) == run.final_cells


def test_fixed_grid_cannot_resolve_the_passage(q0: np.ndarray, scene: dict) -> None:
    run = idnp.run(q0, variant="fixed", max_iterations=3)
    assert not run.success and run.iterations == 3
    assert run.cells == [run.cells[0]] * 3 and run.final_cells == run.cells[0]
    assert run.xs is None and run.us is None
    # Every reported waypoint lies in (or at the safety band of) an obstacle.
    for _, stage, z, reason in run.inverse_failures:
        assert "Collision" in reason
        assert any(np.all(np.array(z) > a - 0.15) and np.all(np.array(z) < b + 0.15) for a, b in rectangles(scene))


def test_bad_input_names_the_field(q0: np.ndarray) -> None:
    with pytest.raises(ddpkit.ShapeError) as e:
        idnp.run([0.0, 1.0, 2.0])
    assert e.value.field == "q0"
    bad = q0.copy()
    bad[1] = np.nan
    with pytest.raises(ddpkit.NotFiniteError) as e:
        idnp.run(bad)
    assert e.value.field == "q0"
    with pytest.raises(ddpkit.InvalidInputError) as e:
        idnp.run([4.8, 0.0, 0.0, 0.3, -0.6])  # the base inside the wall
    assert e.value.field == "x0" and "collides" in str(e.value)
    with pytest.raises(ddpkit.InvalidInputError) as e:
        idnp.run(q0, variant="uniform")
    assert e.value.field == "variant"
    with pytest.raises(ddpkit.InvalidInputError) as e:
        idnp.run(q0, max_iterations=0)
    assert e.value.field == "max_iterations"
    with pytest.raises(ddpkit.InvalidInputError) as e:
        idnp.configuration([4.8, 0.0])  # inside the wall
    assert e.value.field == "tcp"
    with pytest.raises(ddpkit.InvalidInputError) as e:
        idnp.experiment(n=0)
    assert e.value.field == "initial_conditions"


def test_small_experiment_is_deterministic_and_adaptive_never_solves_fewer() -> None:
    a = idnp.experiment(n=3, seed=5, max_iterations=3, optimizer_iterations=5)
    b = idnp.experiment(n=3, seed=5, max_iterations=3, optimizer_iterations=5)
    assert a.cases == 3 and a.initial_tcp.shape == (3, 2)
    np.testing.assert_array_equal(a.initial_tcp, b.initial_tcp)
    assert (a.fixed_success, a.adaptive_success, a.optimizer_success) == (
        b.fixed_success,
        b.adaptive_success,
        b.optimizer_success,
    )
    assert a.solved_fixed == sum(a.fixed_success) and a.solved_adaptive == sum(a.adaptive_success)
    assert a.fixed_not_adaptive == [i for i in range(3) if a.fixed_success[i] and not a.adaptive_success[i]] == []
    assert a.coarse_cells == 8 * 6 * 13 and a.solved_uniform is None
    assert a.uniform_cells == 4 * a.coarse_cells
    assert "163 / 254" in a.table()
    data = json.loads(a.to_json())
    assert len(data["cases"]) == 3 and data["summary"]["solved_adaptive"] == a.solved_adaptive
