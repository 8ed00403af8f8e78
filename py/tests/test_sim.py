"""ddpkit.sim: sim2d scenario runs and the Safe-CDDP Turtlebot experiment from Python."""

from __future__ import annotations

import json
import pathlib

import numpy as np
import pytest

import ddpkit
from ddpkit import sim

FREE = """
name = "free-12m"
[route]
points = [[0.0, 0.0], [12.0, 0.0]]
"""

CYLINDER = FREE.replace('"free-12m"', '"cylinder-12m"') + """
[[obstacles]]
type = "cylinder"
center = [6.0, 0.4]
radius = 1.0
"""


def test_free_run_reaches_the_goal_and_metrics_agree_with_arrays() -> None:
    r = sim.run_scenario(FREE, planner="ddp", seed=0)
    assert isinstance(r, sim.SimResult)
    assert r.scenario == "free-12m" and r.planner == "ddp" and r.direction == "forward"
    assert r.outcome == "completed" and r.completed
    assert r.collisions == 0 and r.contact_time == 0.0
    t, x, y, theta, v, w = r.t, r.x, r.y, r.theta, r.v, r.w
    n = len(t)
    assert n > 10
    for a in (x, y, theta, v, w):
        assert a.shape == (n,) and a.dtype == np.float64
    # One row per control step of 0.1 s, starting at the route's start.
    np.testing.assert_allclose(np.diff(t), 0.1, atol=1e-9)
    assert t[0] == 0.0 and abs(x[0]) < 1e-6 and abs(y[0]) < 1e-6
    # Ends within the goal tolerance (1 m) of the route's end; the time is the steps driven.
    assert np.hypot(r.final_pose[0] - 12.0, r.final_pose[1]) <= 1.0
    assert r.time == pytest.approx(n * 0.1, abs=1e-6)
    # 11+ m at up to 1.5 m/s: at least 7.3 s; the commands respect the limits.
    assert 7.3 <= r.time < 20.0
    assert np.all(np.abs(v) <= 1.5 + 1e-9) and np.all(np.abs(w) <= 0.5 + 1e-9)
    # Distance and progress agree with the path.
    path = float(np.sum(np.hypot(np.diff(x), np.diff(y))))
    assert r.distance == pytest.approx(path + np.hypot(r.final_pose[0] - x[-1], r.final_pose[1] - y[-1]), rel=0.05)
    assert r.route_length == pytest.approx(12.0)
    assert 11.0 - 1e-6 <= r.progress <= 12.0
    # Four optimisation epochs per control step (a plan every step).
    assert r.epoch_ms.shape == (4 * n,) and np.all(r.epoch_ms > 0.0)
    assert r.goals.shape == (n, 2)
    # Kept plans: one every 10 cycles, each horizon + 1 states.
    assert len(r.plans) == len(r.plan_times) == len(r.plan_lengths) == (n + 9) // 10
    assert all(p.shape == (k, 2) for p, k in zip(r.plans, r.plan_lengths))
    data = json.loads(r.to_json())
    assert data["time_s"] == r.time and data["collisions"] == 0 and len(data["trajectory"]) == n


def test_paths_text_and_seeds(tmp_path: pathlib.Path) -> None:
    f = tmp_path / "cyl.toml"
    f.write_text(CYLINDER)
    a = sim.run_scenario(f, seed=3)
    b = sim.run_scenario(str(f), seed=3)
    c = sim.run_scenario(CYLINDER, seed=3)
    # Deterministic per seed, whatever way the scenario was given.
    for other in (b, c):
        np.testing.assert_array_equal(a.x, other.x)
        np.testing.assert_array_equal(a.theta, other.theta)
    assert a.completed and a.collisions == 0
    # The robot went round the cylinder (centre 0.4 m above the route, radius 1 m).
    i = int(np.argmin(np.abs(a.x - 6.0)))
    assert np.hypot(a.x[i] - 6.0, a.y[i] - 0.4) > 1.0
    d = sim.run_scenario(f, seed=4)
    assert not np.array_equal(a.x, d.x)
    back = sim.run_scenario(f, seed=3, direction="backward")
    assert back.direction == "backward" and back.completed
    assert back.x[0] == pytest.approx(12.0, abs=1e-6)


def test_max_time_stops_the_run() -> None:
    r = sim.run_scenario(FREE, seed=0, max_time=2.0)
    assert r.outcome == "timeout" and not r.completed
    assert r.time == pytest.approx(2.0, abs=1e-6)
    assert r.t[-1] == pytest.approx(1.9, abs=1e-6)


@pytest.mark.parametrize(
    ("kwargs", "field", "exc"),
    [
        ({"planner": "rrt"}, "planner", ddpkit.InvalidInputError),
        ({"direction": "sideways"}, "direction", ddpkit.InvalidInputError),
        ({"seed": -1}, "seed", ddpkit.InvalidInputError),
        ({"max_time": -1.0}, "max_time", ddpkit.InvalidInputError),
        ({"horizon": 0}, "horizon", ddpkit.InvalidInputError),
    ],
)
def test_bad_arguments_name_the_field(kwargs: dict, field: str, exc: type) -> None:
    with pytest.raises(exc) as info:
        sim.run_scenario(FREE, **kwargs)
    assert info.value.field == field
    assert field in str(info.value)
    assert isinstance(info.value, ddpkit.DdpError)


def test_bad_scenarios_name_the_field(tmp_path: pathlib.Path) -> None:
    bad = FREE + '[[obstacles]]\ntype = "cylinder"\ncenter = [1.0, 1.0]\nradius = -1.0\n'
    with pytest.raises(ddpkit.InvalidInputError) as info:
        sim.run_scenario(bad)
    assert info.value.field == "obstacles[0].radius"
    with pytest.raises(ddpkit.InvalidInputError) as info:
        sim.run_scenario(FREE.replace("points", "pointz"))
    assert info.value.field == "scenario"
    assert "points" in str(info.value) or "pointz" in str(info.value)
    with pytest.raises(ddpkit.InvalidInputError) as info:
        sim.run_scenario(tmp_path / "missing.toml")
    assert info.value.field == "scenario" and "missing.toml" in str(info.value)
    with pytest.raises(ddpkit.InvalidInputError) as info:
        sim.run_scenario(42)  # type: ignore[arg-type]
    assert info.value.field == "scenario"


def test_safe_turtlebot_keeps_more_clearance_than_cddp(tmp_path: pathlib.Path) -> None:
    e = sim.safe_turtlebot(runs=3, seed=5)
    assert e.runs == 3 and e.seed == 5 and e.beta == 0.8
    c, s = e.min_clearance("cddp"), e.min_clearance("safe-cddp")
    assert c.shape == s.shape == (3,)
    assert e.reached("cddp").dtype == np.bool_ and e.reached("safe-cddp").all()
    assert e.collisions("cddp").dtype == np.int64
    # The same noise in each pair: Safe-CDDP's margins keep it further off the first disc.
    assert s.mean() > c.mean() + 0.005
    assert e.safe_wider == int(np.sum(s > c)) and e.safe_wider >= 2
    data = json.loads(e.to_json())
    assert data["summary"]["cddp"]["min_clearance"]["mean"] == pytest.approx(c.mean())
    assert [ep["min_clearance"] for ep in data["episodes"]["safe_cddp"]] == s.tolist()
    poses = e.poses("safe-cddp", 0)
    assert poses.shape[1] == 3 and np.hypot(poses[-1, 0] - 1.4, poses[-1, 1] - 0.6) < 0.1
    png = tmp_path / "fig.png"
    e.write_png(png)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(ddpkit.InvalidInputError) as info:
        e.min_clearance("mpc")
    assert info.value.field == "controller"


def test_safe_turtlebot_bad_input_names_the_field() -> None:
    for kwargs, field in [({"runs": 0}, "runs"), ({"beta": 1.5}, "beta"), ({"sigma_xy": -0.1}, "sigma_xy")]:
        with pytest.raises(ddpkit.InvalidInputError) as info:
            sim.safe_turtlebot(**kwargs)  # type: ignore[arg-type]
        assert info.value.field == field
