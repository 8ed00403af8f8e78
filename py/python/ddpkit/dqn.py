"""A deep Q-network that shapes a spline through waypoints and picks the sigmoid steepness ``m``
(after Queen Elizabeth's School (2022)), and the comparison against Catmull-Rom and the direct
optimiser.

The paper's formulation, and what this module does with it:

==========================  ===================================================================
paper                       here
==========================  ===================================================================
state ``s``: the control    the waypoint set's shape (turn angle and the two chord lengths at
points and ``m``            each waypoint: the set up to a rigid motion, which the cost does not
                            see), the offsets of the free control points from their Catmull-Rom
                            positions, ``m``, the steps left (the episode has a fixed length, so
                            this keeps the state Markov) and ``log(c / c0)`` (the current cost
                            relative to Catmull-Rom, which the network would otherwise have to
                            learn to compute)
actions: control points     move one free control point by ``+-delta`` along one axis of a grid
on a 0.001 grid in the      of ``(2 K + 1)^2`` positions around its Catmull-Rom position, change
1 x 1 space, ``m`` in       ``m`` by one step of its grid (``2, 4, ..., 20``), or do nothing:
0..100                      ``4 n + 3`` actions for ``n`` waypoints
reward ``1 / (J + K)``      ``reward="paper"``; the default ``reward="improvement"`` is
                            ``log(c_prev / c_new)`` (see below)
replay buffer, epsilon-     uniform replay, epsilon decayed linearly, a target network synced
greedy, ``Q(s, a) := r +    every ``target_sync`` updates, Adam and the Huber loss; the
gamma max Q(s', a)``        double-DQN target by default (``double=False``: the paper's max)
==========================  ===================================================================

The free control points are the handles of the C1 Hermite form: waypoint ``i`` with tangent
``d_i`` has handles ``w_i -+ d_i / 3`` on both sides, so moving the outgoing handle mirrors the
incoming one and the joint stays C1 (the paper's collinearity condition
``(j_b - w) x (j_a - w) = 0``). The cost ``c = J + 0.01 K`` is :func:`ddpkit.bezier.spline_cost`
(``J`` the full 2D jerk ``int |x'''|^2 dT`` of the trajectory with peak speed 1, ``K`` the sum of
``|curvature|`` at 100 uniform times) -- the objective of the direct optimiser too.

The grid's axes (``frame``): ``"local"`` (default) are along and across the Catmull-Rom tangent
at each waypoint, so "lengthen the handle at a sharp turn" is the same action in every set;
``"xy"`` are the paper's global axes, which make the network learn the rotation of every
waypoint's tangent as well (it learns far more slowly; the state then has the waypoints'
coordinates and tangent directions).

Why the improvement reward: ``1 / c`` depends on the waypoint set's scale (costs of held-out
sets span two orders of magnitude), so Q-values of different sets are not comparable and the
sum over an episode rewards reaching a low cost early more than reaching the lowest cost.
``log(c_prev / c_new)`` telescopes: the undiscounted return of an episode is ``log(c0 / c_T)``,
the improvement factor of the spline the episode ends with, on the same scale for every set. It
is potential-based shaping of the terminal objective, so it does not change which final spline
is best; and the logarithm keeps the rare catastrophic move (a handle pulled onto its waypoint
makes a near-cusp whose jerk integral can be ``1e13`` times Catmull-Rom's) from swamping the
loss. Costs are capped at ``1e3 c0``, so a reward is at most ``log(1e3) = 6.9`` in size.
``reward="paper"`` is kept for comparison.

The waypoint sets are random walks (``n`` points, steps of 0.6 to 1.4, turns of up to 1.2 rad)
rather than uniform points in the unit square: uniform points make sharp zig-zags whose
Catmull-Rom splines have near-cusps, where the jerk integral is astronomically large and slow
to evaluate.

torch is imported only inside the functions that need it, so ``import ddpkit.dqn`` (and
``import ddpkit``) work without it.

Example::

    from ddpkit import dqn
    result = dqn.train(dqn.TrainConfig(seed=0, episodes=300), out_dir="runs/dqn")
    policy = dqn.load_policy("runs/dqn")
    report = dqn.evaluate(policy, n_sets=100, seed=123)
    print(dqn.format_table(report))
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import os
import sys
import tempfile
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any, Callable, Optional, Union

import numpy as np

import ddpkit
from ddpkit import bezier

#: File name of the checkpoint inside the output directory.
CHECKPOINT = "dqn.pt"
#: File name of the training log (JSON) inside the output directory.
TRAIN_LOG = "train_log.json"
#: Format tag stored in the checkpoint.
FORMAT = "ddpkit-dqn/1"

# Independent random streams (numpy SeedSequence spawn keys): exploration and replay sampling,
# training waypoint sets, held-out evaluation sets. Distinct keys keep the held-out sets out of
# training even when the seeds coincide.
_STREAM_AGENT = 0
_STREAM_TRAIN_SETS = 1
_STREAM_EVAL_SETS = 2
#: Costs are capped at this multiple of the episode's Catmull-Rom cost.
_COST_CAP = 1e3


def _error(cls: type, field_name: str, message: str) -> Exception:
    """An exception of the ddpkit tree naming ``field_name`` (as the Rust bindings raise them)."""
    e = cls(message)
    e.field = field_name
    return e


# ------------------------------------------------------------------------------------------------
# Environment
# ------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class EnvConfig:
    """The spline-shaping task. Lengths are in the waypoints' units (metres)."""

    #: Waypoints per set (start, end and the ones between).
    n_waypoints: int = 5
    #: Random-walk step length range of the waypoint sets.
    step_min: float = 0.6
    step_max: float = 1.4
    #: Largest heading change (rad) between consecutive legs.
    turn_max: float = 1.2
    #: Grid step of a free control point (length units).
    delta: float = 0.1
    #: Axes of the grid: ``"local"`` (along and across the Catmull-Rom tangent at the
    #: waypoint) or ``"xy"`` (the paper's global axes). See the module docs.
    frame: str = "local"
    #: Offsets from the Catmull-Rom position are limited to ``[-K, K] * delta`` per axis.
    max_offset_steps: int = 4
    #: The values ``m`` may take (the paper: integers 0..100).
    m_values: tuple[float, ...] = (2.0, 4.0, 6.0, 8.0, 10.0, 12.0, 14.0, 16.0, 18.0, 20.0)
    #: ``m`` at the start of an episode (the Catmull-Rom baseline's).
    m_start: float = 10.0
    #: Steps per episode.
    episode_length: int = 24
    #: ``"improvement"`` (``log(c_prev / c_new)``) or ``"paper"`` (``1 / c_new``).
    reward: str = "improvement"
    #: Cost: ``jerk_weight * J + curvature_weight * K`` (see :func:`ddpkit.bezier.spline_cost`).
    jerk_weight: float = 1.0
    curvature_weight: float = 0.01
    max_speed: float = 1.0
    samples: int = 100
    jerk: str = "integral"

    def validate(self) -> None:
        """Raises ``ddpkit.InvalidInputError`` naming the first bad field."""
        checks = [
            ("n_waypoints", self.n_waypoints >= 2),
            ("step_min", 0 < self.step_min <= self.step_max),
            ("turn_max", 0 <= self.turn_max < math.pi),
            ("delta", self.delta > 0),
            ("max_offset_steps", self.max_offset_steps >= 1),
            ("m_values", len(self.m_values) >= 1 and all(m >= 0 for m in self.m_values)),
            ("m_start", self.m_start in self.m_values),
            ("episode_length", self.episode_length >= 1),
            ("reward", self.reward in ("improvement", "paper")),
            ("frame", self.frame in ("local", "xy")),
        ]
        for name, ok in checks:
            if not ok:
                raise _error(ddpkit.InvalidInputError, name, f"EnvConfig.{name} = {getattr(self, name)!r} is invalid")

    @property
    def n_actions(self) -> int:
        """``4 n`` control-point moves, ``m`` up and down, no-op."""
        return 4 * self.n_waypoints + 3

    @property
    def obs_dim(self) -> int:
        """Geometry (``"local"``: turn angle and the two chord lengths per waypoint, ``3 n``;
        ``"xy"``: coordinates and Catmull-Rom tangent directions, ``4 n``), offsets ``2 n``,
        ``m``, steps left, ``log(c / c0)``."""
        per_point = 5 if self.frame == "local" else 6
        return per_point * self.n_waypoints + 3

    def cost_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of :func:`ddpkit.bezier.spline_cost` (without ``m``)."""
        return dict(
            jerk_weight=self.jerk_weight,
            curvature_weight=self.curvature_weight,
            max_speed=self.max_speed,
            samples=self.samples,
            jerk=self.jerk,
        )


def random_waypoints(rng: np.random.Generator, config: EnvConfig = EnvConfig()) -> np.ndarray:
    """A waypoint set: a random walk from the origin heading along +x, shape ``(n, 2)``."""
    n = config.n_waypoints
    points = np.zeros((n, 2))
    heading = 0.0
    for i in range(1, n):
        if i > 1:
            heading += rng.uniform(-config.turn_max, config.turn_max)
        step = rng.uniform(config.step_min, config.step_max)
        points[i] = points[i - 1] + step * np.array([math.cos(heading), math.sin(heading)])
    return points


def waypoint_sets(n_sets: int, seed: int, config: EnvConfig = EnvConfig(), stream: int = _STREAM_EVAL_SETS) -> list[np.ndarray]:
    """``n_sets`` waypoint sets from ``seed`` (the held-out stream by default)."""
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(stream,)))
    return [random_waypoints(rng, config) for _ in range(n_sets)]


class SplineEnv:
    """One waypoint set at a time: the state, the actions and the reward of the module docs.

    ``reset(waypoints)`` starts an episode at Catmull-Rom with ``m = m_start``; ``step(a)``
    applies action ``a`` and returns ``(obs, reward, done, info)``. Costs are cached per episode
    (a no-op or a move against the grid's edge costs nothing).
    """

    def __init__(self, config: EnvConfig = EnvConfig()) -> None:
        config.validate()
        self.config = config
        self._m_values = np.asarray(config.m_values, dtype=float)
        self._m_start = int(config.m_values.index(config.m_start))
        n = config.n_waypoints
        # Action a in 1..4n: point (a - 1) // 4, direction (a - 1) % 4 along the grid axes
        # (+first, -first, +second, -second); 4n + 1, 4n + 2: m up, down; 0: no-op.
        self._moves = np.array([[1, 0], [-1, 0], [0, 1], [0, -1]], dtype=np.int64)
        # Grid axes per waypoint, (n, 2, 2): row 0 the first axis, row 1 the second; set by reset.
        self._axes = np.zeros((n, 2, 2))
        self.waypoints = np.zeros((n, 2))
        self.offsets = np.zeros((n, 2), dtype=np.int64)
        self.m_index = self._m_start
        self.steps_left = config.episode_length
        self.initial_cost = 1.0
        self.cost = 1.0
        self._base_tangents = np.zeros((n, 2))
        self._geometry = np.zeros(self.config.obs_dim - 2 * n - 3)
        self._cache: dict[bytes, float] = {}

    # -- the spline of a state --------------------------------------------------------------

    def tangents(self, offsets: Optional[np.ndarray] = None) -> np.ndarray:
        """The Hermite tangents ``(n, 2)`` of ``offsets`` (default: the current ones)."""
        o = self.offsets if offsets is None else offsets
        return self._base_tangents + (3.0 * self.config.delta) * np.einsum("ik,ikj->ij", o, self._axes)

    def spline(self, offsets: Optional[np.ndarray] = None) -> bezier.Spline:
        """The spline of ``offsets`` (default: the current state)."""
        return bezier.Spline.hermite(self.waypoints, self.tangents(offsets))

    @property
    def m(self) -> float:
        """The current steepness."""
        return float(self._m_values[self.m_index])

    def cost_of(self, offsets: np.ndarray, m_index: int) -> float:
        """``spline_cost`` of a state (cached for the episode)."""
        key = offsets.tobytes() + m_index.to_bytes(2, "little")
        c = self._cache.get(key)
        if c is None:
            m = float(self._m_values[m_index])
            c = bezier.spline_cost(self.spline(offsets), m=m, **self.config.cost_kwargs())
            if not c <= _COST_CAP * self.initial_cost:  # also NaN
                c = _COST_CAP * self.initial_cost
            self._cache[key] = c
        return c

    # -- episode ---------------------------------------------------------------------------

    def reset(self, waypoints: np.ndarray) -> np.ndarray:
        """Starts an episode on ``waypoints`` ``(n, 2)`` at Catmull-Rom, ``m = m_start``."""
        w = np.asarray(waypoints, dtype=float)
        n = self.config.n_waypoints
        if w.shape != (n, 2):
            raise _error(ddpkit.ShapeError, "waypoints", f"waypoints has shape {w.shape}, expected ({n}, 2)")
        if not np.all(np.isfinite(w)):
            raise _error(ddpkit.NotFiniteError, "waypoints", "waypoints has NaN or infinite entries")
        self.waypoints = w.copy()
        d = bezier.Spline.catmull_rom(w).tangents
        self._base_tangents = d
        legs = np.diff(w, axis=0)
        chords = np.linalg.norm(legs, axis=1)
        mean_chord = max(float(chords.mean()), 1e-12)
        norms = np.linalg.norm(d, axis=1)
        along = d / np.where(norms > 0, norms, 1.0)[:, None]
        along[norms == 0] = [1.0, 0.0]
        normal = np.stack([-along[:, 1], along[:, 0]], axis=1)
        if self.config.frame == "local":
            # Moving the outgoing handle w_i + d_i / 3 by delta along/across d_i (the incoming
            # one mirrors it) changes d_i by 3 delta along/across itself.
            self._axes = np.stack([along, normal], axis=1)
            heading = np.arctan2(legs[:, 1], legs[:, 0])
            turn = np.zeros(n)
            turn[1:-1] = np.angle(np.exp(1j * np.diff(heading)))
            c_in = np.concatenate([[0.0], chords]) / mean_chord
            c_out = np.concatenate([chords, [0.0]]) / mean_chord
            self._geometry = np.stack([turn / math.pi, c_in, c_out], axis=1).ravel()
        else:
            # The free control point is the outgoing handle w_i + d_i / 3, the last waypoint's
            # its incoming handle w_n - d_n / 3; moving it by delta in x or y changes d_i by
            # +-3 delta.
            sign = np.ones(n)
            sign[-1] = -1.0
            self._axes = sign[:, None, None] * np.eye(2)[None]
            scaled = (w - w[0]) / (mean_chord * (n - 1))
            self._geometry = np.concatenate([scaled, along], axis=1).ravel()
        self.offsets = np.zeros((n, 2), dtype=np.int64)
        self.m_index = self._m_start
        self.steps_left = self.config.episode_length
        self._cache = {}
        self.initial_cost = math.inf  # no cap for the Catmull-Rom cost itself
        self.initial_cost = self.cost_of(self.offsets, self.m_index)
        if not (math.isfinite(self.initial_cost) and self.initial_cost > 0):
            raise _error(
                ddpkit.InvalidInputError,
                "waypoints",
                f"the Catmull-Rom spline through these waypoints has cost {self.initial_cost}",
            )
        self.cost = self.initial_cost
        return self.observation()

    def observation(self) -> np.ndarray:
        """The state vector (float32, length ``obs_dim``)."""
        k = self.config.max_offset_steps
        n_m = len(self._m_values)
        m_feat = 2.0 * self.m_index / (n_m - 1) - 1.0 if n_m > 1 else 0.0
        rel = math.log(max(self.cost, 1e-300) / self.initial_cost)
        return np.concatenate(
            [
                self._geometry,
                self.offsets.ravel() / k,
                [m_feat, self.steps_left / self.config.episode_length, max(-5.0, min(5.0, rel))],
            ]
        ).astype(np.float32)

    def apply(self, action: int) -> tuple[np.ndarray, int]:
        """The state ``(offsets, m_index)`` that ``action`` leads to (clamped to the grid)."""
        n = self.config.n_waypoints
        k = self.config.max_offset_steps
        offsets, m_index = self.offsets, self.m_index
        if 1 <= action <= 4 * n:
            i, d = divmod(action - 1, 4)
            moved = offsets[i] + self._moves[d]
            if np.all(np.abs(moved) <= k):
                offsets = offsets.copy()
                offsets[i] = moved
        elif action == 4 * n + 1:
            m_index = min(m_index + 1, len(self._m_values) - 1)
        elif action == 4 * n + 2:
            m_index = max(m_index - 1, 0)
        elif action != 0:
            raise _error(ddpkit.InvalidInputError, "action", f"action {action} is not in 0..{self.config.n_actions - 1}")
        return offsets, m_index

    def step(self, action: int) -> tuple[np.ndarray, float, bool, dict[str, float]]:
        """Applies ``action``; returns ``(obs, reward, done, info)``."""
        offsets, m_index = self.apply(int(action))
        c_new = self.cost_of(offsets, m_index)
        if self.config.reward == "paper":
            reward = 1.0 / c_new
        else:
            reward = math.log(self.cost / c_new)
        self.offsets, self.m_index, self.cost = offsets, m_index, c_new
        self.steps_left -= 1
        done = self.steps_left <= 0
        return self.observation(), float(reward), done, {"cost": c_new}


# ------------------------------------------------------------------------------------------------
# Progress bar
# ------------------------------------------------------------------------------------------------


class _Bar:
    """A minimal progress bar on stderr (used when tqdm is not installed)."""

    def __init__(self, total: int, desc: str, disable: bool) -> None:
        self.total, self.desc, self.disable = total, desc, disable
        self.n = 0
        self.postfix = ""
        self._start = time.perf_counter()
        self._last = 0.0

    def update(self, k: int = 1) -> None:
        self.n += k
        now = time.perf_counter()
        if not self.disable and (now - self._last > 0.2 or self.n >= self.total):
            self._last = now
            frac = self.n / max(self.total, 1)
            bar = "#" * int(30 * frac) + "." * (30 - int(30 * frac))
            elapsed = now - self._start
            eta = elapsed / frac - elapsed if frac > 0 else 0.0
            sys.stderr.write(f"\r{self.desc} [{bar}] {self.n}/{self.total} {elapsed:.0f}s<{eta:.0f}s {self.postfix}")
            sys.stderr.flush()

    def set_postfix_str(self, s: str) -> None:
        self.postfix = s

    def close(self) -> None:
        if not self.disable:
            sys.stderr.write("\n")
            sys.stderr.flush()


def progress_bar(total: int, desc: str, disable: bool = False) -> Any:
    """``tqdm`` if installed, else a small built-in bar (same ``update``/``set_postfix_str``/``close``)."""
    try:
        from tqdm.auto import tqdm  # type: ignore[import-untyped, unused-ignore]
    except ImportError:
        return _Bar(total, desc, disable)
    return tqdm(total=total, desc=desc, disable=disable, dynamic_ncols=True, leave=True)


# ------------------------------------------------------------------------------------------------
# Training
# ------------------------------------------------------------------------------------------------


def _torch() -> Any:
    try:
        import torch
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("ddpkit.dqn needs torch for training and inference: pip install torch") from e
    return torch


@dataclass(frozen=True)
class TrainConfig:
    """Hyper-parameters of :func:`train` (the defaults train the README's model)."""

    seed: int = 0
    episodes: int = 3000
    env: EnvConfig = field(default_factory=EnvConfig)
    hidden: tuple[int, ...] = (128, 128)
    learning_rate: float = 1e-3
    gamma: float = 0.9
    batch_size: int = 64
    buffer_size: int = 50_000
    #: Transitions collected before the first update.
    warmup: int = 500
    #: Hard target-network sync period, in updates.
    target_sync: int = 250
    epsilon_start: float = 1.0
    epsilon_end: float = 0.05
    #: Fraction of all steps over which epsilon decays linearly.
    epsilon_decay: float = 0.6
    #: Gradient-norm clip.
    grad_clip: float = 10.0
    #: Rewards are clipped to ``[-reward_clip, reward_clip]`` in the replay (0, the default:
    #: no clipping; the capped log-ratio reward is bounded by ``log(1e3)`` already, and clipping
    #: it makes a catastrophic move look like a mildly bad one).
    reward_clip: float = 0.0
    #: Double DQN target ``Q_target(s', argmax_a Q(s', a))`` instead of the paper's
    #: ``max_a Q_target(s', a)`` (which over-estimates with 23 noisy actions).
    double: bool = True
    #: torch CPU threads during training (1 keeps runs bit-for-bit reproducible and is fastest
    #: for a network this small).
    threads: int = 1

    def validate(self) -> None:
        self.env.validate()
        checks = [
            ("episodes", self.episodes >= 1),
            ("hidden", len(self.hidden) >= 1 and all(h >= 1 for h in self.hidden)),
            ("learning_rate", self.learning_rate > 0),
            ("gamma", 0 <= self.gamma <= 1),
            ("batch_size", self.batch_size >= 1),
            ("buffer_size", self.buffer_size >= self.batch_size),
            ("warmup", self.warmup >= self.batch_size),
            ("target_sync", self.target_sync >= 1),
            ("epsilon_start", 0 <= self.epsilon_end <= self.epsilon_start <= 1),
            ("epsilon_decay", 0 < self.epsilon_decay <= 1),
            ("threads", self.threads >= 1),
            ("reward_clip", self.reward_clip >= 0),
            ("grad_clip", self.grad_clip > 0),
        ]
        for name, ok in checks:
            if not ok:
                raise _error(ddpkit.InvalidInputError, name, f"TrainConfig.{name} = {getattr(self, name)!r} is invalid")

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    @staticmethod
    def from_dict(d: dict[str, Any]) -> "TrainConfig":
        d = dict(d)
        env = dict(d.pop("env", {}))
        if "m_values" in env:
            env["m_values"] = tuple(float(m) for m in env["m_values"])
        if "hidden" in d:
            d["hidden"] = tuple(int(h) for h in d["hidden"])
        return TrainConfig(env=EnvConfig(**env), **d)


def build_qnet(obs_dim: int, n_actions: int, hidden: Sequence[int]) -> Any:
    """The Q-network: an MLP ``obs -> hidden... -> Q(s, .)`` with ReLU."""
    torch = _torch()
    layers: list[Any] = []
    width = obs_dim
    for h in hidden:
        layers += [torch.nn.Linear(width, h), torch.nn.ReLU()]
        width = h
    layers.append(torch.nn.Linear(width, n_actions))
    return torch.nn.Sequential(*layers)


class ReplayBuffer:
    """Uniform experience replay in preallocated numpy arrays (a ring of ``capacity``)."""

    def __init__(self, capacity: int, obs_dim: int) -> None:
        self.capacity = capacity
        self.obs = np.zeros((capacity, obs_dim), dtype=np.float32)
        self.next_obs = np.zeros((capacity, obs_dim), dtype=np.float32)
        self.actions = np.zeros(capacity, dtype=np.int64)
        self.rewards = np.zeros(capacity, dtype=np.float32)
        self.dones = np.zeros(capacity, dtype=np.float32)
        self.size = 0
        self._next = 0

    def push(self, obs: np.ndarray, action: int, reward: float, next_obs: np.ndarray, done: bool) -> None:
        i = self._next
        self.obs[i], self.actions[i], self.rewards[i] = obs, action, reward
        self.next_obs[i], self.dones[i] = next_obs, float(done)
        self._next = (i + 1) % self.capacity
        self.size = min(self.size + 1, self.capacity)

    def sample(self, rng: np.random.Generator, batch: int) -> tuple[np.ndarray, ...]:
        idx = rng.integers(0, self.size, size=batch)
        return self.obs[idx], self.actions[idx], self.rewards[idx], self.next_obs[idx], self.dones[idx]


@contextlib.contextmanager
def _deterministic_torch(threads: int) -> Iterator[None]:
    """Deterministic kernels and a fixed thread count, restored afterwards."""
    torch = _torch()
    old_threads = torch.get_num_threads()
    old_det = torch.are_deterministic_algorithms_enabled()
    torch.set_num_threads(threads)
    torch.use_deterministic_algorithms(True)
    try:
        yield
    finally:
        torch.use_deterministic_algorithms(old_det)
        torch.set_num_threads(old_threads)


@dataclass
class TrainResult:
    """What :func:`train` returns."""

    config: TrainConfig
    #: The trained Q-network (a ``torch.nn.Module``).
    qnet: Any
    #: Huber loss of every update.
    losses: np.ndarray
    #: Undiscounted return of every episode.
    returns: np.ndarray
    #: ``c_T / c0`` at the end of every (exploring) episode (the progress bar shows their
    #: geometric mean over the last 100 episodes).
    final_ratios: np.ndarray
    #: Wall time of the training loop (s).
    train_seconds: float
    #: The checkpoint written, if an output directory was given.
    checkpoint: Optional[str] = None


def _atomic_write(path: str, write: Callable[[str], None]) -> None:
    """Writes through a temporary file in the same directory, then renames: complete or absent."""
    directory = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=os.path.basename(path), dir=directory)
    os.close(fd)
    try:
        write(tmp)
        # mkstemp creates the file private (0600); give it the permissions of a plain open().
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def _write_json(path: str, obj: Any) -> None:
    def write(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8") as f:
            json.dump(obj, f, indent=2)
            f.write("\n")

    _atomic_write(path, write)


def train(
    config: TrainConfig = TrainConfig(),
    out_dir: Optional[Union[str, os.PathLike[str]]] = None,
    progress: bool = True,
) -> TrainResult:
    """Trains the DQN of the module docs; seeded, bit-for-bit reproducible on one machine.

    Every episode draws a new waypoint set (the training stream of ``config.seed``), so the
    policy learns to shape any set, as the paper intends. With ``out_dir`` the Q-network's
    ``state_dict`` and the config are saved to ``out_dir/dqn.pt`` and the learning curves to
    ``out_dir/train_log.json``, each written to a temporary file and renamed.
    """
    config.validate()
    torch = _torch()
    env_cfg = config.env
    env = SplineEnv(env_cfg)
    agent_rng = np.random.default_rng(np.random.SeedSequence(config.seed, spawn_key=(_STREAM_AGENT,)))
    sets_rng = np.random.default_rng(np.random.SeedSequence(config.seed, spawn_key=(_STREAM_TRAIN_SETS,)))
    total_steps = config.episodes * env_cfg.episode_length
    decay_steps = max(1, int(config.epsilon_decay * total_steps))

    with _deterministic_torch(config.threads), torch.random.fork_rng(devices=[]):
        torch.manual_seed(config.seed)
        qnet = build_qnet(env_cfg.obs_dim, env_cfg.n_actions, config.hidden)
        target = build_qnet(env_cfg.obs_dim, env_cfg.n_actions, config.hidden)
        target.load_state_dict(qnet.state_dict())
        target.eval()
        optimizer = torch.optim.Adam(qnet.parameters(), lr=config.learning_rate)
        buffer = ReplayBuffer(config.buffer_size, env_cfg.obs_dim)
        losses: list[float] = []
        returns: list[float] = []
        ratios: list[float] = []
        step = 0
        updates = 0
        bar = progress_bar(config.episodes, "dqn", disable=not progress)
        start = time.perf_counter()
        try:
            for _episode in range(config.episodes):
                obs = env.reset(random_waypoints(sets_rng, env_cfg))
                ep_return = 0.0
                done = False
                while not done:
                    eps = config.epsilon_start + (config.epsilon_end - config.epsilon_start) * min(1.0, step / decay_steps)
                    if agent_rng.random() < eps:
                        action = int(agent_rng.integers(env_cfg.n_actions))
                    else:
                        with torch.no_grad():
                            action = int(qnet(torch.from_numpy(obs)[None]).argmax(dim=1).item())
                    next_obs, reward, done, _ = env.step(action)
                    stored = reward if config.reward_clip == 0 else max(-config.reward_clip, min(config.reward_clip, reward))
                    buffer.push(obs, action, stored, next_obs, done)
                    obs = next_obs
                    ep_return += reward
                    step += 1
                    if buffer.size >= config.warmup:
                        losses.append(_update(torch, qnet, target, optimizer, buffer, agent_rng, config))
                        updates += 1
                        if updates % config.target_sync == 0:
                            target.load_state_dict(qnet.state_dict())
                returns.append(ep_return)
                ratios.append(env.cost / env.initial_cost)
                bar.update(1)
                recent = ratios[-100:]
                bar.set_postfix_str(
                    f"eps={eps:.2f} c/c0={np.exp(np.mean(np.log(recent))):.3f}" + (f" loss={np.mean(losses[-200:]):.2e}" if losses else "")
                )
        finally:
            bar.close()
        train_seconds = time.perf_counter() - start
        qnet.eval()

    result = TrainResult(
        config=config,
        qnet=qnet,
        losses=np.asarray(losses),
        returns=np.asarray(returns),
        final_ratios=np.asarray(ratios),
        train_seconds=train_seconds,
    )
    if out_dir is not None:
        result.checkpoint = save(result, out_dir)
    return result


def _update(torch: Any, qnet: Any, target: Any, optimizer: Any, buffer: ReplayBuffer, rng: np.random.Generator, config: TrainConfig) -> float:
    """One DQN step: Huber loss of ``Q(s, a)`` against ``r + gamma max_a' Q_target(s', a')``
    (or the double-DQN target)."""
    obs, actions, rewards, next_obs, dones = (torch.from_numpy(x) for x in buffer.sample(rng, config.batch_size))
    q = qnet(obs).gather(1, actions[:, None]).squeeze(1)
    with torch.no_grad():
        if config.double:
            best = qnet(next_obs).argmax(dim=1, keepdim=True)
            bootstrap = target(next_obs).gather(1, best).squeeze(1)
        else:
            bootstrap = target(next_obs).max(dim=1).values
        y = rewards + config.gamma * (1.0 - dones) * bootstrap
    loss = torch.nn.functional.smooth_l1_loss(q, y)
    optimizer.zero_grad(set_to_none=True)
    loss.backward()
    torch.nn.utils.clip_grad_norm_(qnet.parameters(), config.grad_clip)
    optimizer.step()
    return float(loss.item())


def save(result: TrainResult, out_dir: Union[str, os.PathLike[str]]) -> str:
    """Saves ``out_dir/dqn.pt`` (``state_dict`` and config) and ``out_dir/train_log.json``."""
    torch = _torch()
    os.makedirs(out_dir, exist_ok=True)
    path = os.path.join(out_dir, CHECKPOINT)
    payload = {
        "format": FORMAT,
        "config": result.config.to_dict(),
        "obs_dim": result.config.env.obs_dim,
        "n_actions": result.config.env.n_actions,
        "state_dict": result.qnet.state_dict(),
    }
    _atomic_write(path, lambda tmp: torch.save(payload, tmp))
    log = {
        "config": result.config.to_dict(),
        "train_seconds": result.train_seconds,
        "updates": int(len(result.losses)),
        "episodes": int(len(result.returns)),
        "returns": [float(r) for r in result.returns],
        "final_ratios": [float(r) for r in result.final_ratios],
        "loss_per_100_updates": [float(np.mean(result.losses[i : i + 100])) for i in range(0, len(result.losses), 100)],
    }
    _write_json(os.path.join(out_dir, TRAIN_LOG), log)
    return path


# ------------------------------------------------------------------------------------------------
# Inference
# ------------------------------------------------------------------------------------------------


@dataclass
class PolicyResult:
    """A spline shaped by the policy."""

    spline: bezier.Spline
    m: float
    cost: float
    initial_cost: float


class Policy:
    """A trained Q-network acting greedily on :class:`SplineEnv`."""

    def __init__(self, qnet: Any, config: TrainConfig) -> None:
        self.qnet = qnet
        self.config = config
        self.env = SplineEnv(config.env)

    def act(self, obs: np.ndarray) -> int:
        """``argmax_a Q(obs, a)``."""
        torch = _torch()
        with torch.no_grad():
            return int(self.qnet(torch.from_numpy(np.asarray(obs, dtype=np.float32))[None]).argmax(dim=1).item())

    def rollout(self, waypoints: np.ndarray) -> tuple[PolicyResult, PolicyResult]:
        """Runs one greedy episode from Catmull-Rom on ``waypoints``; returns the spline it ends
        with and the cheapest spline it visited (Catmull-Rom included)."""
        env = self.env
        obs = env.reset(waypoints)
        best = (env.cost, env.offsets, env.m_index)
        done = False
        while not done:
            obs, _, done, _ = env.step(self.act(obs))
            if env.cost < best[0]:
                best = (env.cost, env.offsets, env.m_index)
        final = PolicyResult(spline=env.spline(), m=env.m, cost=env.cost, initial_cost=env.initial_cost)
        m_best = float(env.config.m_values[best[2]])
        kept = PolicyResult(spline=env.spline(best[1]), m=m_best, cost=best[0], initial_cost=env.initial_cost)
        return final, kept

    def shape(self, waypoints: np.ndarray) -> PolicyResult:
        """Runs one greedy episode from Catmull-Rom on ``waypoints``; the spline it ends with."""
        return self.rollout(waypoints)[0]


def load_policy(path: Union[str, os.PathLike[str]]) -> Policy:
    """Loads ``dqn.pt`` (or the directory holding it) written by :func:`train`.

    Raises ``ddpkit.InvalidInputError`` naming ``model`` for a missing or unreadable file and
    naming the tensor for a missing tensor or a wrong shape.
    """
    torch = _torch()
    p = os.fspath(path)
    if os.path.isdir(p):
        p = os.path.join(p, CHECKPOINT)
    try:
        payload = torch.load(p, map_location="cpu", weights_only=True)
    except Exception as e:  # noqa: BLE001 - any failure to read is the same error for the user
        raise _error(ddpkit.InvalidInputError, "model", f"cannot read the DQN checkpoint {p!r}: {e}") from e
    if not isinstance(payload, dict) or payload.get("format") != FORMAT:
        raise _error(ddpkit.InvalidInputError, "model", f"{p!r} is not a {FORMAT} checkpoint")
    try:
        config = TrainConfig.from_dict(payload["config"])
        config.validate()
    except (TypeError, KeyError, ValueError) as e:
        raise _error(ddpkit.InvalidInputError, "model.config", f"{p!r} has an invalid config: {e}") from e
    qnet = build_qnet(config.env.obs_dim, config.env.n_actions, config.hidden)
    expected = qnet.state_dict()
    state = payload.get("state_dict", {})
    for name, tensor in expected.items():
        if name not in state:
            raise _error(ddpkit.InvalidInputError, f"model.{name}", f"{p!r} lacks the tensor {name!r}")
        if tuple(state[name].shape) != tuple(tensor.shape):
            raise _error(
                ddpkit.ShapeError,
                f"model.{name}",
                f"tensor {name!r} in {p!r} has shape {tuple(state[name].shape)}, expected {tuple(tensor.shape)}",
            )
    qnet.load_state_dict(state)
    qnet.eval()
    return Policy(qnet, config)


# ------------------------------------------------------------------------------------------------
# Baselines and evaluation
# ------------------------------------------------------------------------------------------------


def grid_search(waypoints: np.ndarray, config: EnvConfig = EnvConfig(), max_steps: int = 1000) -> PolicyResult:
    """Greedy descent in the DQN's own action space, without its step limit: from Catmull-Rom,
    repeatedly take the move (control point or ``m``) that lowers the cost most, until none does.
    A direct search over exactly the splines the DQN can reach."""
    env = SplineEnv(config)
    env.reset(waypoints)
    for _ in range(max_steps):
        best: tuple[float, Optional[tuple[np.ndarray, int]]] = (env.cost, None)
        for a in range(1, config.n_actions):
            offsets, m_index = env.apply(a)
            c = env.cost_of(offsets, m_index)
            if c < best[0]:
                best = (c, (offsets, m_index))
        if best[1] is None:
            break
        env.offsets, env.m_index = best[1]
        env.cost = best[0]
    return PolicyResult(spline=env.spline(), m=env.m, cost=env.cost, initial_cost=env.initial_cost)


#: Rows of the comparison, in table order.
METHODS = (
    ("catmull_rom", "Catmull-Rom (m = 10)"),
    ("catmull_rom_best_m", "Catmull-Rom, best m on the grid"),
    ("dqn", "DQN (greedy episode, its last spline)"),
    ("dqn_best", "DQN (greedy episode, its cheapest spline)"),
    ("grid_search", "Greedy grid search in the DQN's action space"),
    ("optimizer", "Direct optimiser (BFGS on all tangents, m = 10)"),
)
#: Their keys.
METHOD_KEYS = tuple(key for key, _ in METHODS)


def evaluate(
    policy: Optional[Policy],
    n_sets: int = 100,
    seed: int = 123,
    config: Optional[EnvConfig] = None,
    methods: Sequence[str] = METHOD_KEYS,
    optimizer_iterations: int = 100,
    progress: bool = True,
) -> dict[str, Any]:
    """Mean cost of each method on ``n_sets`` held-out waypoint sets drawn from ``seed``.

    Every method is scored with the same :func:`ddpkit.bezier.spline_cost` at the ``m`` it chose
    (Catmull-Rom and the direct optimiser use ``m_start = 10``). Returns a JSON-ready dict:
    ``{"sets", "seed", "env", "methods": {key: {"label", "costs", "lengths", "mean", "median",
    "mean_ratio", "geo_mean_ratio", "wins", "median_length_ratio", "max_length_ratio", "mean_m",
    "seconds"}}}``: ratios are per set against Catmull-Rom (``m = 10``), ``wins`` counts the sets
    where the method beats it, ``seconds`` is the time per set.
    """
    if config is None:
        config = policy.config.env if policy is not None else EnvConfig()
    if n_sets < 1:
        raise _error(ddpkit.InvalidInputError, "n_sets", f"n_sets must be >= 1, got {n_sets}")
    labels = dict(METHODS)
    for mth in methods:
        if mth not in labels:
            raise _error(ddpkit.InvalidInputError, "methods", f"unknown method {mth!r}; known: {sorted(labels)}")
        if mth in ("dqn", "dqn_best") and policy is None:
            raise _error(ddpkit.InvalidInputError, "policy", "the dqn method needs a policy")
    sets = waypoint_sets(n_sets, seed, config)
    kw = config.cost_kwargs()
    costs: dict[str, list[float]] = {m: [] for m in methods}
    lengths: dict[str, list[float]] = {m: [] for m in methods}
    ms: dict[str, list[float]] = {m: [] for m in methods}
    seconds = {m: 0.0 for m in methods}
    base_lengths: list[float] = []
    bar = progress_bar(n_sets * len(methods), "eval", disable=not progress)
    try:
        for w in sets:
            cr = bezier.Spline.catmull_rom(w)
            base_lengths.append(cr.arclen())
            rollout: Optional[tuple[PolicyResult, PolicyResult]] = None
            rollout_seconds = 0.0
            for mth in methods:
                t0 = time.perf_counter()
                if mth == "catmull_rom":
                    spline, m = cr, config.m_start
                    c = bezier.spline_cost(cr, m=m, **kw)
                elif mth == "catmull_rom_best_m":
                    c, m = min((bezier.spline_cost(cr, m=m, **kw), m) for m in config.m_values)
                    spline = cr
                elif mth in ("dqn", "dqn_best"):
                    assert policy is not None
                    if rollout is None:  # one episode serves both rows
                        rollout = policy.rollout(w)
                        rollout_seconds = time.perf_counter() - t0
                    t0 = time.perf_counter() - rollout_seconds
                    r = rollout[0] if mth == "dqn" else rollout[1]
                    spline, m, c = r.spline, r.m, r.cost
                elif mth == "grid_search":
                    r = grid_search(w, config)
                    spline, m, c = r.spline, r.m, r.cost
                else:
                    res = bezier.optimize_spline(w, m=config.m_start, max_iterations=optimizer_iterations, **kw)
                    spline, m, c = res.spline, config.m_start, res.cost
                seconds[mth] += time.perf_counter() - t0
                costs[mth].append(float(c))
                lengths[mth].append(spline.arclen())
                ms[mth].append(float(m))
                bar.update(1)
    finally:
        bar.close()
    base = np.asarray(costs["catmull_rom"]) if "catmull_rom" in costs else None
    if base is None:
        kw_base = [bezier.spline_cost(bezier.Spline.catmull_rom(w), m=config.m_start, **kw) for w in sets]
        base = np.asarray(kw_base)
    out: dict[str, Any] = {"sets": n_sets, "seed": seed, "env": dataclasses.asdict(config), "methods": {}}
    for mth in methods:
        arr = np.asarray(costs[mth])
        length_ratio = np.asarray(lengths[mth]) / np.asarray(base_lengths)
        out["methods"][mth] = {
            "label": labels[mth],
            "costs": [float(x) for x in arr],
            "lengths": [float(x) for x in lengths[mth]],
            "mean": float(arr.mean()),
            "median": float(np.median(arr)),
            "mean_ratio": float(np.mean(arr / base)),
            "geo_mean_ratio": float(np.exp(np.mean(np.log(arr / base)))),
            "wins": int(np.sum(arr < base * (1 - 1e-12))),
            "median_length_ratio": float(np.median(length_ratio)),
            "max_length_ratio": float(np.max(length_ratio)),
            "mean_m": float(np.mean(ms[mth])),
            "seconds": seconds[mth] / n_sets,
        }
    return out


def format_table(report: dict[str, Any]) -> str:
    """The comparison as a Markdown table (the README's)."""
    lines = [
        f"Held-out waypoint sets: {report['sets']} (seed {report['seed']}); cost = jerk + 0.01 curvature sum "
        "(`ddpkit.bezier.spline_cost`), lower is better.",
        "",
        "| method | mean cost | median cost | cost / Catmull-Rom (geometric mean) | beats Catmull-Rom "
        "| path length / Catmull-Rom, median (max) | mean m | time per set |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for row in report["methods"].values():
        lines.append(
            f"| {row['label']} | {row['mean']:.2f} | {row['median']:.2f} | {row['geo_mean_ratio']:.3f} | "
            f"{row['wins']}/{report['sets']} | {row['median_length_ratio']:.2f} ({row['max_length_ratio']:.3g}) | "
            f"{row['mean_m']:.1f} | {1e3 * row['seconds']:.1f} ms |"
        )
    return "\n".join(lines)
