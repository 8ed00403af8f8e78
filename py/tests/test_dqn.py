"""The spline-shaping DQN (ddpkit.dqn) and its commands: a seconds-long training that is
reproducible bit for bit and beats Catmull-Rom on held-out waypoint sets."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import ddpkit

torch = pytest.importorskip("torch", reason="the DQN needs torch (in requirements-test.txt)")

from ddpkit import dqn, train  # noqa: E402 - after the importorskip

#: A small task (3 waypoints, 15 actions, 8-step episodes) that trains in a few seconds.
SMALL = dqn.TrainConfig(seed=0, episodes=200, warmup=200, env=dqn.EnvConfig(n_waypoints=3, episode_length=8))


@pytest.fixture(scope="module")
def trained(tmp_path_factory: pytest.TempPathFactory) -> tuple[dqn.TrainResult, Path]:
    out = tmp_path_factory.mktemp("dqn")
    return dqn.train(SMALL, out_dir=out, progress=False), out


def geometric_mean_ratio(report: dict[str, Any], method: str) -> float:
    c = np.asarray(report["methods"][method]["costs"])
    base = np.asarray(report["methods"]["catmull_rom"]["costs"])
    return float(np.exp(np.mean(np.log(c / base))))


def test_training_is_deterministic(trained: tuple[dqn.TrainResult, Path]) -> None:
    first, _ = trained
    again = dqn.train(SMALL, progress=False)
    assert len(first.losses) > 1000
    np.testing.assert_array_equal(first.losses, again.losses)
    np.testing.assert_array_equal(first.returns, again.returns)
    a, b = first.qnet.state_dict(), again.qnet.state_dict()
    assert list(a) == list(b)
    for name in a:
        assert torch.equal(a[name], b[name]), name
    # The seed matters (so the equality above is not vacuous).
    short = dataclasses.replace(SMALL, episodes=20, warmup=64)
    l0 = dqn.train(short, progress=False).losses
    l1 = dqn.train(dataclasses.replace(short, seed=1), progress=False).losses
    assert len(l0) > 0 and not np.array_equal(l0, l1)


def test_trained_policy_beats_catmull_rom(trained: tuple[dqn.TrainResult, Path]) -> None:
    _, out = trained
    policy = dqn.load_policy(out)  # through the checkpoint on disk
    report = dqn.evaluate(policy, n_sets=12, seed=123, methods=("catmull_rom", "dqn"), progress=False)
    dqn_row = report["methods"]["dqn"]
    assert geometric_mean_ratio(report, "dqn") < 0.8
    assert dqn_row["mean"] < report["methods"]["catmull_rom"]["mean"]
    assert dqn_row["wins"] >= 9
    # The same network untrained does not: the assertion above measures the training.
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(SMALL.seed)
        untrained = dqn.build_qnet(SMALL.env.obs_dim, SMALL.env.n_actions, SMALL.hidden)
    before = dqn.evaluate(dqn.Policy(untrained, SMALL), n_sets=12, seed=123, methods=("catmull_rom", "dqn"), progress=False)
    assert geometric_mean_ratio(before, "dqn") > 0.8


def test_checkpoint_files(trained: tuple[dqn.TrainResult, Path]) -> None:
    result, out = trained
    assert sorted(os.listdir(out)) == [dqn.CHECKPOINT, dqn.TRAIN_LOG]  # no temporary files left
    policy = dqn.load_policy(out / dqn.CHECKPOINT)
    assert policy.config == SMALL
    for name, tensor in result.qnet.state_dict().items():
        assert torch.equal(policy.qnet.state_dict()[name], tensor)
    log = json.loads((out / dqn.TRAIN_LOG).read_text())
    assert log["episodes"] == SMALL.episodes and log["updates"] == len(result.losses)


def test_bad_checkpoints(tmp_path: Path, trained: tuple[dqn.TrainResult, Path]) -> None:
    with pytest.raises(ddpkit.InvalidInputError) as e:
        dqn.load_policy(tmp_path / "missing")
    assert e.value.field == "model"
    garbage = tmp_path / "garbage.pt"
    garbage.write_bytes(b"not a checkpoint")
    with pytest.raises(ddpkit.InvalidInputError) as e:
        dqn.load_policy(garbage)
    assert e.value.field == "model"
    payload = torch.load(trained[1] / dqn.CHECKPOINT, weights_only=True)
    good = payload["state_dict"]["0.weight"]
    payload["state_dict"]["0.weight"] = torch.zeros(3, 3)
    wrong = tmp_path / "wrong.pt"
    torch.save(payload, wrong)
    with pytest.raises(ddpkit.ShapeError, match="0.weight") as e:
        dqn.load_policy(wrong)
    assert e.value.field == "model.0.weight"
    payload["state_dict"]["0.weight"] = good
    del payload["state_dict"]["2.bias"]
    torch.save(payload, wrong)
    with pytest.raises(ddpkit.InvalidInputError, match="2.bias"):
        dqn.load_policy(wrong)


def test_environment() -> None:
    config = dqn.EnvConfig(n_waypoints=4, episode_length=6)
    env = dqn.SplineEnv(config)
    w = dqn.waypoint_sets(1, 5, config)[0]
    obs = env.reset(w)
    assert obs.shape == (config.obs_dim,) and obs.dtype == np.float32
    assert env.cost == env.initial_cost == pytest.approx(ddpkit.bezier.spline_cost(ddpkit.bezier.Spline.catmull_rom(w)))
    rewards = []
    actions = [1, 1, 4 * config.n_waypoints + 1, 0, 7, 4 * config.n_waypoints + 2]
    for a in actions:
        obs, r, done, info = env.step(a)
        rewards.append(r)
    assert done
    # The improvement reward telescopes to log(c0 / c_T).
    assert sum(rewards) == pytest.approx(math.log(env.initial_cost / env.cost))
    assert env.offsets[0].tolist() == [2, 0] and env.offsets[1].tolist() == [0, 1]
    assert env.m == config.m_start
    # Moving a handle changes its tangent by 3 delta along the Catmull-Rom tangent (C1 kept).
    base = ddpkit.bezier.Spline.catmull_rom(w).tangents
    d = env.tangents()
    along = base[0] / np.linalg.norm(base[0])
    np.testing.assert_allclose(d[0], base[0] + 6 * config.delta * along)
    assert env.spline().continuity() == "C1"
    # The grid's edge clamps.
    env.reset(w)
    for _ in range(config.max_offset_steps + 3):
        env.step(3)
    assert env.offsets[0].tolist() == [0, config.max_offset_steps]
    with pytest.raises(ddpkit.InvalidInputError) as e:
        env.step(config.n_actions)
    assert e.value.field == "action"
    with pytest.raises(ddpkit.ShapeError):
        env.reset(np.zeros((3, 2)))
    with pytest.raises(ddpkit.InvalidInputError) as e:
        dqn.SplineEnv(dqn.EnvConfig(reward="square"))
    assert e.value.field == "reward"


def test_grid_search_is_a_lower_bound_for_short_episodes() -> None:
    config = dqn.EnvConfig(n_waypoints=3)
    for w in dqn.waypoint_sets(3, 9, config):
        r = dqn.grid_search(w, config)
        assert r.cost < r.initial_cost
        assert r.spline.continuity() == "C1"


def test_cli_train_and_eval(tmp_path: Path) -> None:
    out = tmp_path / "run"
    args = ["dqn", "--seed", "3", "--episodes", "12", "--out", str(out), "--waypoints", "3", "--episode-length", "8"]
    assert train.main(args + ["--no-progress"]) == 0
    assert (out / dqn.CHECKPOINT).is_file()
    report_path = tmp_path / "eval.json"
    code = train.main(["dqn-eval", "--model", str(out), "--sets", "2", "--seed", "5", "--json", str(report_path), "--no-progress", "--optimizer-iterations", "5"])
    assert code == 0
    report = json.loads(report_path.read_text())
    assert report["sets"] == 2 and set(report["methods"]) == set(dqn.METHOD_KEYS)
    for row in report["methods"].values():
        assert len(row["costs"]) == 2 and all(math.isfinite(c) for c in row["costs"])
    # A missing model is an error naming it, not a traceback.
    assert train.main(["dqn-eval", "--model", str(tmp_path / "nothing"), "--no-progress"]) == 2


def test_import_without_torch() -> None:
    # ddpkit, ddpkit.dqn and the command parser import without torch (blocked here).
    code = (
        "import sys; sys.modules['torch'] = None\n"
        "import ddpkit, ddpkit.dqn, ddpkit.train\n"
        "ddpkit.train.build_parser().parse_args(['dqn', '--out', 'x'])\n"
        "env = ddpkit.dqn.SplineEnv(); env.reset(ddpkit.dqn.waypoint_sets(1, 0)[0])\n"
        "try:\n    ddpkit.dqn.build_qnet(3, 3, (4,))\nexcept ImportError as e:\n    print('ok', e)\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("ok")
