"""Training commands: ``python -m ddpkit.train <command> [options]``.

Commands:

- ``dqn``: train the spline-shaping DQN of :mod:`ddpkit.dqn` (after Queen Elizabeth's School
  (2022)) and save it::

      python -m ddpkit.train dqn --seed 0 --episodes 3000 --out runs/dqn

- ``dqn-eval``: compare the saved DQN with the direct optimiser and Catmull-Rom on held-out
  random waypoint sets and print the table (and ``--json`` it)::

      python -m ddpkit.train dqn-eval --model runs/dqn --sets 100 --seed 123 --json eval.json

- ``subgoal``: train the DDPEN sub-goal network of :mod:`ddpkit.subgoal_model` (after Gamayunov
  et al. (2023)) on the shards of ``subgoal-dataset`` and export it as safetensors for the Rust
  inference::

      python -m ddpkit.train subgoal --data DIR --out model.safetensors --epochs 2 --seed 0

Each command is a :class:`Command` in :data:`COMMANDS`; add one with the :func:`command`
decorator (a function that adds its options to an ``argparse`` parser, and one that runs it).
Heavy imports (torch) happen inside ``run``, so ``--help`` stays fast and works without them.
Errors of the ddpkit tree are printed as ``error: <field>: <message>`` with exit status 2.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Callable, Optional

import ddpkit


@dataclass(frozen=True)
class Command:
    """One subcommand: its name, a one-line help, how to add its options and how to run it."""

    name: str
    help: str
    add_arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], int]


#: The registered subcommands, by name, in registration order.
COMMANDS: dict[str, Command] = {}


def command(name: str, help: str, add_arguments: Callable[[argparse.ArgumentParser], None]) -> Callable[[Callable[[argparse.Namespace], int]], Callable[[argparse.Namespace], int]]:
    """Registers the decorated ``run(args) -> exit status`` as subcommand ``name``."""

    def register(run: Callable[[argparse.Namespace], int]) -> Callable[[argparse.Namespace], int]:
        if name in COMMANDS:
            raise ValueError(f"command {name!r} is registered twice")
        COMMANDS[name] = Command(name, help, add_arguments, run)
        return run

    return register


def _positive_int(text: str) -> int:
    v = int(text)
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {v}")
    return v


# ------------------------------------------------------------------------------------------------
# dqn
# ------------------------------------------------------------------------------------------------


def _dqn_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--seed", type=int, default=0, help="seed of everything random (default 0)")
    p.add_argument("--episodes", type=_positive_int, default=3000, help="training episodes (default 3000)")
    p.add_argument("--out", required=True, help="output directory for dqn.pt and train_log.json")
    p.add_argument("--waypoints", type=_positive_int, default=5, help="waypoints per set (default 5)")
    p.add_argument("--episode-length", type=_positive_int, default=24, help="steps per episode (default 24)")
    p.add_argument(
        "--reward",
        choices=("improvement", "paper"),
        default="improvement",
        help="log(c_prev / c_new) (default) or the paper's 1 / c",
    )
    p.add_argument("--frame", choices=("local", "xy"), default="local", help="axes of the control-point grid")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


@command("dqn", "train the spline-shaping DQN of Queen Elizabeth's School (2022)", _dqn_arguments)
def _dqn(args: argparse.Namespace) -> int:
    import numpy as np

    from ddpkit import dqn

    env = dqn.EnvConfig(
        n_waypoints=args.waypoints, episode_length=args.episode_length, reward=args.reward, frame=args.frame
    )
    config = dqn.TrainConfig(seed=args.seed, episodes=args.episodes, env=env)
    result = dqn.train(config, out_dir=args.out, progress=not args.no_progress)
    tail = result.final_ratios[-100:]
    print(
        f"trained {config.episodes} episodes ({len(result.losses)} updates) in {result.train_seconds:.1f} s; "
        f"the last 100 (exploring) episodes end at {float(np.exp(np.mean(np.log(tail)))):.3f} x the "
        f"Catmull-Rom cost (geometric mean); saved {result.checkpoint}"
    )
    return 0


# ------------------------------------------------------------------------------------------------
# dqn-eval
# ------------------------------------------------------------------------------------------------


def _dqn_eval_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--model", required=True, help="directory (or dqn.pt) written by the dqn command")
    p.add_argument("--sets", type=_positive_int, default=100, help="held-out waypoint sets (default 100)")
    p.add_argument("--seed", type=int, default=123, help="seed of the held-out sets (default 123)")
    p.add_argument("--json", metavar="PATH", help="also write the full results (per-set costs) as JSON")
    p.add_argument(
        "--optimizer-iterations", type=_positive_int, default=100, help="BFGS iteration limit (default 100)"
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


@command("dqn-eval", "compare a trained DQN with the direct optimiser and Catmull-Rom", _dqn_eval_arguments)
def _dqn_eval(args: argparse.Namespace) -> int:
    from ddpkit import dqn

    policy = dqn.load_policy(args.model)
    start = time.perf_counter()
    report = dqn.evaluate(
        policy,
        n_sets=args.sets,
        seed=args.seed,
        optimizer_iterations=args.optimizer_iterations,
        progress=not args.no_progress,
    )
    report["model"] = str(args.model)
    report["eval_seconds"] = time.perf_counter() - start
    print(dqn.format_table(report))
    if args.json:
        dqn._write_json(args.json, report)
        print(f"wrote {args.json}")
    return 0


# ------------------------------------------------------------------------------------------------
# subgoal
# ------------------------------------------------------------------------------------------------


def _positive_float(text: str) -> float:
    v = float(text)
    if not v > 0.0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {v}")
    return v


def _subgoal_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--data", required=True, help="dataset directory with shard-*.safetensors (subgoal-dataset)")
    p.add_argument("--out", required=True, help="output safetensors file (written whole or not at all)")
    p.add_argument("--epochs", type=_positive_int, default=2, help="passes over the training maps (default 2)")
    p.add_argument("--seed", type=int, default=0, help="seed of the initialisation and shuffling (default 0)")
    p.add_argument(
        "--arch",
        choices=("cnn", "efficientnet_b0"),
        default="cnn",
        help="encoder: the small CNN (default) or torchvision EfficientNet-B0 with one input channel",
    )
    p.add_argument("--device", default="cpu", help="torch device: cpu (default) or cuda")
    p.add_argument("--batch-size", type=_positive_int, default=64, help="samples per step (default 64)")
    p.add_argument("--lr", type=_positive_float, default=2e-3, help="peak learning rate of the one-cycle schedule")
    p.add_argument("--val-fraction", type=_positive_float, default=0.05, help="held-out share of the maps (default 0.05)")
    p.add_argument("--max-samples", type=_positive_int, help="use only the first N samples of the dataset")
    p.add_argument("--threads", type=_positive_int, help="torch CPU threads (default: torch's choice)")
    p.add_argument("--no-augment", action="store_true", help="no random symmetries of the square")
    p.add_argument("--no-preload", action="store_true", help="gather batches from the memory-mapped shards (less RAM)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--json", metavar="PATH", help="also write the training summary as JSON")


@command("subgoal", "train the DDPEN sub-goal network of Gamayunov et al. (2023) and export it as safetensors", _subgoal_arguments)
def _subgoal(args: argparse.Namespace) -> int:
    from ddpkit import subgoal_model as sm

    if not 0.0 < args.val_fraction < 1.0:
        print(f"error: --val-fraction: must be in (0, 1), got {args.val_fraction}", file=sys.stderr)
        return 2
    if args.arch == "cnn":
        model_config = sm.SubgoalConfig()
    else:
        model_config = sm.SubgoalConfig(arch="efficientnet", efficientnet=sm.efficientnet_spec("b0"))
    config = sm.TrainConfig(
        data=args.data,
        out=args.out,
        epochs=args.epochs,
        seed=args.seed,
        device=args.device,
        batch_size=args.batch_size,
        lr=args.lr,
        val_fraction=args.val_fraction,
        max_samples=args.max_samples,
        augment=not args.no_augment,
        preload=not args.no_preload,
        threads=args.threads,
        progress=not args.no_progress,
        model=model_config,
    )
    try:
        result = sm.train(config)
    except (ValueError, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(sm.format_result(result))
    if args.json:
        from ddpkit import dqn

        dqn._write_json(args.json, sm.result_dict(result))
        print(f"wrote {args.json}")
    return 0


# ------------------------------------------------------------------------------------------------
# Entry point
# ------------------------------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    """The ``argparse`` parser with one subparser per registered command."""
    parser = argparse.ArgumentParser(
        prog="python -m ddpkit.train", description="ddpkit training commands", allow_abbrev=False
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for cmd in COMMANDS.values():
        p = sub.add_parser(cmd.name, help=cmd.help, description=cmd.help, allow_abbrev=False)
        cmd.add_arguments(p)
        p.set_defaults(_run=cmd.run)
    return parser


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Parses ``argv`` (default ``sys.argv[1:]``) and runs the command; returns the exit status."""
    args = build_parser().parse_args(argv)
    try:
        return int(args._run(args))
    except ddpkit.DdpError as e:
        print(f"error: {getattr(e, 'field', '')}: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
