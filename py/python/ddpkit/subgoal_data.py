"""Reading the DDPEN sub-goal dataset with numpy only: every tensor of every shard is a read-only
``numpy.memmap`` of the file (no copy, no ``safetensors`` package needed; ``torch.from_numpy``
shares the memory too).

A dataset directory, written by ``subgoal-dataset`` or :func:`ddpkit.subgoal.generate_dataset`,
holds ``shard-00000.safetensors``, ... and ``manifest.json`` (written last: a directory without
it holds no complete dataset). Each shard has

==================  =========  ===============  ==================================================
tensor              dtype      shape            what
==================  =========  ===============  ==================================================
``costmaps``        uint8      ``(n, 200, 200)``  inflated costs, indexed ``[k, iy, ix]``
``goals``           float32    ``(n, 2)``       goal (m), relative to the map centre
``subgoals``        float32    ``(n, 3, 2)``    A* path cells at steps 30, 50, 70 (m)
``path_lengths``    int32      ``(n,)``         cells on the A* path, start and goal included
``traps``           uint8      ``(n,)``         1 when a U/L trap blocks the line to the goal
==================  =========  ===============  ==================================================

Frame: ``x`` along the column index ``ix``, ``y`` along the row index ``iy``; a cell stands for
its centre, ``x = (ix - 100 + 0.5) * 0.05``; the robot starts in cell ``(100, 100)``.

Example::

    from ddpkit.subgoal import load_shards

    data = load_shards("/data/subgoal")
    print(len(data), data.metadata["seed"])
    costmap, goal, subgoals = data[12345]          # views into the memory maps
    batch = data.take("costmaps", [3, 7, 11])       # (3, 200, 200) uint8, a copy
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from typing import Any, Sequence, Union

import numpy as np

__all__ = ["FORMAT_NAME", "FORMAT_VERSION", "Shards", "load_shards", "read_shard"]

#: ``format`` entry of the shard metadata and of the manifest.
FORMAT_NAME = "ddpkit-subgoal-dataset"
#: Version of the shard layout this reader understands.
FORMAT_VERSION = 1

_DTYPES = {"U8": np.uint8, "I32": np.int32, "F32": np.float32}
_TENSORS = {
    "costmaps": ("U8", 3),
    "goals": ("F32", 2),
    "subgoals": ("F32", 3),
    "path_lengths": ("I32", 1),
    "traps": ("U8", 1),
}


def _error(field_name: str, message: str) -> Exception:
    """A :class:`ddpkit.InvalidInputError` naming ``field_name``."""
    from ddpkit._ddpkit import InvalidInputError

    err = InvalidInputError(f"{field_name} is invalid: {message}")
    err.field = field_name
    return err


def read_shard(path: Union[str, "os.PathLike[str]"]) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """The tensors of one shard as read-only memory maps, and its header metadata.

    Raises :class:`ddpkit.InvalidInputError` (``field`` ``"path"``, or the tensor or metadata
    entry at fault) for a missing, truncated or foreign file.
    """
    path = os.fspath(path)
    try:
        size = os.path.getsize(path)
        with open(path, "rb") as f:
            n = int.from_bytes(f.read(8), "little")
            if size < 8 or n <= 0 or 8 + n > size:
                raise _error("header", f"{path}: bad header length {n} for a file of {size} bytes")
            header = json.loads(f.read(n))
    except OSError as e:
        raise _error("path", f"{path}: {e}") from e
    except (ValueError, UnicodeDecodeError) as e:
        raise _error("header", f"{path}: {e}") from e
    meta = header.get("__metadata__") or {}
    if meta.get("format") != FORMAT_NAME:
        raise _error("metadata.format", f"{path}: expected {FORMAT_NAME}, got {meta.get('format')!r}")
    if meta.get("format_version") != str(FORMAT_VERSION):
        raise _error(
            "metadata.format_version", f"{path}: expected {FORMAT_VERSION}, got {meta.get('format_version')!r}"
        )
    data_len = size - 8 - n
    out: dict[str, np.ndarray] = {}
    for name, (dtype, ndim) in _TENSORS.items():
        info = header.get(name)
        if not isinstance(info, dict):
            raise _error(name, f"{path}: missing")
        shape = tuple(int(d) for d in info.get("shape", []))
        start, end = (int(x) for x in info.get("data_offsets", (0, -1)))
        np_dtype = _DTYPES[dtype]
        want = int(np.prod(shape, dtype=np.int64)) * np.dtype(np_dtype).itemsize
        if info.get("dtype") != dtype or len(shape) != ndim or end - start != want or start < 0 or end > data_len:
            raise _error(name, f"{path}: {info.get('dtype')} {list(shape)} at {start}..{end}, expected {dtype}, {ndim} dims")
        if want == 0:
            out[name] = np.zeros(shape, np_dtype)
        else:
            out[name] = np.memmap(path, dtype=np_dtype, mode="r", offset=8 + n + start, shape=shape)
    return out, dict(meta)


@dataclass
class Shards:
    """A dataset directory's shards as memory maps (see the module docs). ``data[i]`` is sample
    ``i`` of the whole dataset as ``(costmap, goal, subgoals)`` views; :meth:`take` gathers many."""

    directory: str
    #: The parsed ``manifest.json``.
    manifest: dict[str, Any]
    #: Per shard: its tensors as memory maps.
    parts: list[dict[str, np.ndarray]]
    #: Header metadata of the first shard (format, seed, resolution, ...).
    metadata: dict[str, str]
    #: Global index of each shard's first sample, and the total at the end.
    offsets: np.ndarray = field(repr=False)

    def __len__(self) -> int:
        return int(self.offsets[-1])

    def _locate(self, i: int) -> tuple[int, int]:
        if not -len(self) <= i < len(self):
            raise IndexError(f"sample {i} out of range for {len(self)} samples")
        i %= len(self)
        s = int(np.searchsorted(self.offsets, i, side="right")) - 1
        return s, i - int(self.offsets[s])

    def __getitem__(self, i: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        s, j = self._locate(int(i))
        p = self.parts[s]
        return p["costmaps"][j], p["goals"][j], p["subgoals"][j]

    def tensor(self, name: str) -> list[np.ndarray]:
        """The memory maps of tensor ``name`` (e.g. ``"costmaps"``), one per shard."""
        if name not in _TENSORS:
            raise _error("name", f"expected one of {sorted(_TENSORS)}, got {name!r}")
        return [p[name] for p in self.parts]

    def take(self, name: str, indices: Union[Sequence[int], np.ndarray]) -> np.ndarray:
        """Tensor ``name`` of the samples ``indices`` (global), gathered into a new array."""
        maps = self.tensor(name)
        idx = np.asarray(indices, dtype=np.int64)
        if idx.ndim != 1 or (idx.size and (idx.min() < 0 or idx.max() >= len(self))):
            raise _error("indices", f"must be a 1-D array of indices in [0, {len(self)})")
        out = np.empty((idx.size,) + maps[0].shape[1:], maps[0].dtype)
        shard = np.searchsorted(self.offsets, idx, side="right") - 1
        for s in np.unique(shard):
            sel = np.nonzero(shard == s)[0]
            out[sel] = maps[s][idx[sel] - self.offsets[s]]
        return out


def load_shards(directory: Union[str, "os.PathLike[str]"]) -> Shards:
    """Opens a dataset directory: its ``manifest.json`` and every shard it lists, memory-mapped.

    Raises :class:`ddpkit.InvalidInputError` naming ``directory`` (no manifest: the dataset is
    missing or incomplete), a manifest entry, or a shard's tensor.
    """
    directory = os.fspath(directory)
    path = os.path.join(directory, "manifest.json")
    try:
        with open(path, encoding="utf-8") as f:
            manifest = json.load(f)
    except OSError as e:
        raise _error("directory", f"{path}: {e} (no complete dataset here)") from e
    except ValueError as e:
        raise _error("manifest", f"{path}: {e}") from e
    if manifest.get("format") != FORMAT_NAME or manifest.get("format_version") != FORMAT_VERSION:
        raise _error("manifest.format", f"{path}: not a {FORMAT_NAME} v{FORMAT_VERSION} manifest")
    parts, sizes, metadata = [], [], {}
    for k, entry in enumerate(manifest.get("shards", [])):
        name = str(entry.get("file", ""))
        if not name or os.sep in name or "/" in name or name.startswith("."):
            raise _error(f"manifest.shards[{k}].file", f"{path}: expected a file name, got {name!r}")
        tensors, meta = read_shard(os.path.join(directory, name))
        if k == 0:
            metadata = meta
        n = tensors["goals"].shape[0]
        if n != entry.get("samples") or int(meta.get("first_index", -1)) != entry.get("first_index"):
            raise _error(f"manifest.shards[{k}]", f"{name} holds samples {meta.get('first_index')}.. ({n}), "
                         f"the manifest says {entry.get('first_index')}.. ({entry.get('samples')})")
        parts.append(tensors)
        sizes.append(n)
    if sum(sizes) != manifest.get("samples"):
        raise _error("manifest.samples", f"{path}: shards hold {sum(sizes)}, manifest says {manifest.get('samples')}")
    offsets = np.concatenate([[0], np.cumsum(sizes, dtype=np.int64)]).astype(np.int64)
    return Shards(directory=directory, manifest=manifest, parts=parts, metadata=metadata, offsets=offsets)
