#!/usr/bin/env bash
# Runs every test of ddpkit: the Rust workspace (cargo test) and the Python wheel (pytest).
# Installs what it needs on a fresh machine; caches the virtualenv and build outputs under
# ~/.cache/ddpkit (override with DDPKIT_CACHE) so repeated runs are fast.
set -euo pipefail
cd "$(dirname "$0")/.."

CACHE="${DDPKIT_CACHE:-$HOME/.cache/ddpkit}"
VENV="$CACHE/venv"
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$CACHE/target}"
mkdir -p "$CACHE"

echo "== Python environment ($VENV)"
if [ ! -x "$VENV/bin/python" ]; then
    python3 -m venv "$VENV"
fi
"$VENV/bin/python" -m pip install -q --upgrade pip
"$VENV/bin/python" -m pip install -q -r py/requirements-test.txt

echo "== cargo test (workspace default members)"
cargo test --workspace --quiet

echo "== cargo test -p sim2d --features live (the live view's WebSocket test on 127.0.0.1)"
cargo test -p sim2d --features live --quiet --test live

echo "== the experiment binaries py/tests/test_experiments*.py compare the sweeps with"
cargo build --release --quiet -p safe-cddp --bin safe-cddp-table -p subgoal-infer --bin subgoal-dataset -p idnp --bin idnp-experiment \
    -p sim2d --bin ddpen-table --bin trap-bench --bin safe-turtlebot

echo "== build the wheel and install it"
rm -rf "$CACHE/wheels"
"$VENV/bin/maturin" build --release -m py/Cargo.toml --out "$CACHE/wheels" --quiet
"$VENV/bin/python" -m pip install -q --force-reinstall --no-deps "$CACHE"/wheels/*.whl

echo "== pytest"
"$VENV/bin/python" -m pytest -q py/tests tests/python
