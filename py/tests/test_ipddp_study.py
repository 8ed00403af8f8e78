"""bench/peers/ipddp_study.py: the interior-point DDP prototype reaches the closed-form optimum of
an unconstrained linear-quadratic problem and ddpkit's optimum on a constrained family problem."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

PEERS = Path(__file__).resolve().parents[2] / "bench" / "peers"
sys.path.insert(0, str(PEERS))

import family  # noqa: E402
import ipddp_study  # noqa: E402
from problem_file import parse  # noqa: E402


def test_without_rows_it_is_ilqr_and_reaches_the_least_squares_optimum() -> None:
    # The point robot is linear and the cost quadratic: the optimum is a linear least-squares
    # problem in the controls, x_N = A^N x0 + sum_k A^(N-1-k) B u_k.
    p = parse(
        {
            "model": "point",
            "dt": 0.1,
            "N": 30,
            "x0": [0.0, 0.0, 0.0, 0.0],
            "cost": {"kind": "quad_goal", "x_goal": [1.0, 2.0, 0.0, 0.0], "R": [0.1, 0.3], "Qf": [100.0, 50.0, 10.0, 10.0]},
            "obstacles": [],
        }
    )
    a, b = ipddp_study.jacobians(p, np.zeros(4), np.zeros(2))
    n = p.N
    reach = np.hstack([np.linalg.matrix_power(a, n - 1 - k) @ b for k in range(n)])
    # 0.5 |sqrt(R) u|^2 + 0.5 |sqrt(Qf) (reach u - g)|^2 (x0 = 0)
    lhs = np.vstack([np.diag(np.sqrt(np.tile(p.R, n))), np.diag(np.sqrt(p.Qf)) @ reach])
    rhs = np.concatenate([np.zeros(2 * n), np.sqrt(p.Qf) * p.x_goal])
    u_star = np.linalg.lstsq(lhs, rhs, rcond=None)[0]
    xs_star = ipddp_study._rollout(p, u_star.reshape(n, 2))
    optimum = p.objective(xs_star, u_star.reshape(n, 2))
    r = ipddp_study.solve(p)
    assert r["status"] == "converged"
    assert p.objective(r["xs"], r["us"]) == pytest.approx(optimum, rel=1e-10)
    assert np.allclose(r["us"], u_star.reshape(n, 2), atol=1e-7)


def test_on_a_family_problem_it_reaches_ddpkits_optimum() -> None:
    from solve import DdpkitSolver

    _, spec, _ = family.first_valid("car", 1, 0)
    p = parse(spec)
    sol = DdpkitSolver(p, obstacles="constrained").constrained.solve()
    assert sol.status == "converged"
    r = ipddp_study.solve(p)
    assert r["status"] == "converged"
    assert p.max_violation(r["xs"], r["us"]) <= 1e-6
    assert p.objective(r["xs"], r["us"]) == pytest.approx(sol.cost, rel=1e-6)
    # The rows are active: without them the optimum passes through the obstacle.
    assert p.max_violation(sol.xs, sol.us) <= 1e-6 and len(p.obstacles) >= 1


def test_the_command_line_judges_against_the_recorded_peers(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _, spec, _ = family.first_valid("point", 1, 0)
    p = parse(spec)
    r = ipddp_study.solve(p)
    cost = p.objective(r["xs"], r["us"])
    # A record as family.py writes it, with a peer 1 % below and one above that optimum.
    record = {
        "id": spec["name"],
        "spec": spec,
        "best_peer_cost": cost * 0.99,
        "rel_gap": 0.5,
        "solvers": {"ddpkit": {"starts": []}},
    }
    path = tmp_path / "results.json"
    path.write_text(json.dumps({"problems": [record]}))
    assert ipddp_study.main([str(path)]) == 0
    out = capsys.readouterr().out
    assert "MISS" in out and "1 problems: 0 match, 1 within 5 % (the portfolio's recorded: 0, the better of the two: 1)" in out
    # Bad input: a clear error, not a traceback.
    with pytest.raises(SystemExit):
        ipddp_study.main([str(path), "--mu0", "0"])
    assert "--mu0 must be positive" in capsys.readouterr().err
    path.write_text("{}")
    assert ipddp_study.main([str(path)]) == 2
    assert "not a family.py --json output" in capsys.readouterr().err
