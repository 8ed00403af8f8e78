"""Traces the P1 unicycle and the 12-state quadrotor in Python, exactly as ddp-core's built-in
models compute them, and saves the tapes that `cargo run --release -p ddp-tape --example
traced_vs_builtin` times against the built-in analytic models (the traced-model target: time per
iteration at most 1.5x the built-in one).

    python bench/own_robot/make_fixtures.py   # writes crates/tape/tests/data/{unicycle,quadrotor}.json
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import ddpkit

OUT = Path(__file__).resolve().parents[2] / "crates" / "tape" / "tests" / "data"


def unicycle(x, u, dt=0.1):
    """ddp_core::models::Unicycle (Crocoddyl's order of operations)."""
    s, c = np.sin(x[2]), np.cos(x[2])
    return np.array([x[0] + c * u[0] * dt, x[1] + s * u[0] * dt, x[2] + u[1] * dt])


def quadrotor(x, u, dt=0.02, mass=0.468, inertia=(4.856e-3, 4.856e-3, 8.801e-3), gravity=9.81):
    """ddp_core::models::Quadrotor: Euler angles (roll, pitch, yaw), body rates, explicit Euler."""
    jx, jy, jz = inertia
    g = ((jy - jz) / jx, (jz - jx) / jy, (jx - jy) / jz)
    sf, cf = np.sin(x[3]), np.cos(x[3])
    st, ct = np.sin(x[4]), np.cos(x[4])
    sp, cp = np.sin(x[5]), np.cos(x[5])
    p, q, r = x[9], x[10], x[11]
    tan_t = st / ct
    a = sf * q + cf * r
    r3 = (cp * st * cf + sp * sf, sp * st * cf - cp * sf, ct * cf)
    k = u[0] / mass
    return np.array(
        [
            x[0] + dt * x[6],
            x[1] + dt * x[7],
            x[2] + dt * x[8],
            x[3] + dt * (p + a * tan_t),
            x[4] + dt * (cf * q - sf * r),
            x[5] + dt * (a / ct),
            x[6] + dt * (k * r3[0]),
            x[7] + dt * (k * r3[1]),
            x[8] + dt * (k * r3[2] - gravity),
            x[9] + dt * (u[1] / jx + g[0] * q * r),
            x[10] + dt * (u[2] / jy + g[1] * r * p),
            x[11] + dt * (u[3] / jz + g[2] * p * q),
        ]
    )


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    uni = ddpkit.Dynamics.from_function(unicycle, nx=3, nu=2)
    quad = ddpkit.Dynamics.from_function(quadrotor, nx=12, nu=4)
    # The traced models are the built-in ones.
    rng = np.random.default_rng(0)
    for traced, builtin, nx, nu in [(uni, ddpkit.Unicycle(0.1), 3, 2), (quad, ddpkit.Quadrotor(0.02), 12, 4)]:
        for _ in range(5):
            x, u = 0.3 * rng.standard_normal(nx), rng.standard_normal(nu)
            assert np.allclose(traced.step(x, u), builtin.step(x, u), rtol=1e-13, atol=1e-15)
            for a, b in zip(traced.jacobians(x, u), builtin.jacobians(x, u)):
                assert np.allclose(a, b, rtol=1e-12, atol=1e-14)
    uni.save(OUT / "unicycle.json")
    quad.save(OUT / "quadrotor.json")
    print(f"unicycle: {uni.n_nodes} nodes, quadrotor: {quad.n_nodes} nodes -> {OUT}")


if __name__ == "__main__":
    main()
