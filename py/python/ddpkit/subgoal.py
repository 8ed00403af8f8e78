"""DDPEN sub-goals after Gamayunov et al. (2023): the synthetic dataset the sub-goal network
learns from, and the network itself running in Rust.

The dataset (§II-D): random obstacle maps (rectangles, circles, L and U shapes under random affine
transforms, a free centre, inflation as in the simulator's perception), A* from the centre to a
goal near the border, the path cells at steps 30, 50, 70 as sub-goals. Generated in Rust, in
parallel, deterministic for a seed whatever the thread count.

Example::

    from ddpkit import subgoal

    info = subgoal.generate_dataset("/tmp/sg", samples=20000, seed=1, shard_size=5000)
    data = subgoal.load_shards("/tmp/sg")             # numpy memory maps, no copy
    costmap, goal, subgoals = data[0]                  # (200, 200) u8, (2,) f32, (3, 2) f32
    same = subgoal.sample(1, 0)                        # the same sample, generated on demand

Frame: metres relative to the map centre, ``x`` along the column index, ``y`` along the row index
(``costmap[iy, ix]``); a cell stands for its centre, ``(i - 100 + 0.5) * 0.05``.
"""

from __future__ import annotations

import os
from typing import Any, Optional, Union

import numpy as np

from ddpkit._ddpkit import SubgoalModel, subgoal_generate_dataset, subgoal_sample
from ddpkit.subgoal_data import Shards, load_shards, read_shard

__all__ = ["Shards", "SubgoalModel", "generate_dataset", "load_shards", "read_shard", "sample"]


def generate_dataset(
    out_dir: Union[str, "os.PathLike[str]"],
    samples: int,
    seed: int = 0,
    shard_size: int = 5000,
    threads: Optional[int] = None,
) -> dict[str, Any]:
    """Writes ``samples`` samples of ``seed`` to ``out_dir`` as ``shard-NNNNN.safetensors`` of
    ``shard_size`` samples and a ``manifest.json`` (last). ``threads=None``: every core; the
    bytes are the same for any thread count. Returns ``{"dir", "samples", "shards", "manifest",
    "seconds"}``. Releases the GIL; bad arguments raise :class:`ddpkit.InvalidInputError` naming
    them (``samples``, ``shard_size``, ``threads``, ``seed``, ``out_dir``)."""
    return subgoal_generate_dataset(os.fspath(out_dir), samples, seed, shard_size, threads)


def sample(seed: int, index: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sample ``index`` of ``seed``, byte for byte as :func:`generate_dataset` stores it:
    ``(costmap uint8 (200, 200), goal float32 (2,), subgoals float32 (3, 2))``."""
    return subgoal_sample(seed, index)
