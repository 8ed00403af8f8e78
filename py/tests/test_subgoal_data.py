"""The DDPEN sub-goal dataset from Python: generation (Rust), memory-mapped reading (numpy only),
agreement with safetensors' own reader and with on-demand samples, and errors naming the field."""

from __future__ import annotations

import json
import threading
from pathlib import Path

import numpy as np
import pytest

import ddpkit
from ddpkit import subgoal


def _bytes(directory: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(directory.iterdir())}


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("subgoal") / "data"
    info = subgoal.generate_dataset(out, samples=12, seed=4, shard_size=5, threads=2)
    assert info["samples"] == 12
    assert info["shards"] == ["shard-00000.safetensors", "shard-00001.safetensors", "shard-00002.safetensors"]
    assert Path(info["manifest"]).name == "manifest.json"
    return out


def test_same_bytes_for_any_thread_count(dataset: Path, tmp_path: Path) -> None:
    other = tmp_path / "one-thread"
    subgoal.generate_dataset(str(other), samples=12, seed=4, shard_size=5, threads=1)
    assert _bytes(other) == _bytes(dataset)
    third = tmp_path / "seed-5"
    subgoal.generate_dataset(third, samples=12, seed=5, shard_size=5)
    assert _bytes(third)["shard-00000.safetensors"] != _bytes(dataset)["shard-00000.safetensors"]


def test_load_shards_memory_maps_and_matches_samples(dataset: Path) -> None:
    data = subgoal.load_shards(dataset)
    assert len(data) == 12
    assert data.metadata["seed"] == "4" and data.metadata["map_cells"] == "200"
    assert data.manifest["subgoal_steps"] == [30, 50, 70]
    for maps in data.tensor("costmaps"):
        assert isinstance(maps, np.memmap) and not maps.flags.writeable
    assert [m.shape[0] for m in data.tensor("goals")] == [5, 5, 2]
    for i in range(12):
        costmap, goal, subgoals = data[i]
        want = subgoal.sample(4, i)
        assert costmap.dtype == np.uint8 and costmap.shape == (200, 200)
        assert goal.dtype == np.float32 and goal.shape == (2,)
        assert subgoals.dtype == np.float32 and subgoals.shape == (3, 2)
        np.testing.assert_array_equal(costmap, want[0])
        np.testing.assert_array_equal(goal, want[1])
        np.testing.assert_array_equal(subgoals, want[2])
    batch = data.take("subgoals", [11, 0, 6])
    np.testing.assert_array_equal(batch[0], data[11][2])
    np.testing.assert_array_equal(batch[2], data[6][2])
    np.testing.assert_array_equal(data[-1][1], data[11][1])


def test_samples_keep_the_frame(dataset: Path) -> None:
    data = subgoal.load_shards(dataset)
    lengths = np.concatenate(data.tensor("path_lengths"))
    for i in range(len(data)):
        costmap, goal, subgoals = data[i]
        # The robot's cell (100, 100) is passable; the goal lies within 0.5 m of the border.
        assert costmap[100, 100] < 253
        assert np.abs(goal).max() >= 4.5
        # Cell centres: (i - 100 + 0.5) * 0.05, so every coordinate is an odd multiple of 0.025.
        for p in np.vstack([goal[None], subgoals]):
            cells = p / 0.05 + 100 - 0.5
            np.testing.assert_allclose(cells, np.round(cells), atol=1e-4)
            ix, iy = np.round(cells).astype(int)
            assert costmap[iy, ix] < 253, "a sub-goal or goal on a blocked cell"
        # Step k of an 8-connected path is at most k cells (Chebyshev) from the start.
        for k, s in zip((30, 50, 70), subgoals):
            assert np.abs(s / 0.05 + 100 - 0.5 - 100).max() <= k + 1e-4
        assert lengths[i] > 70


def test_agrees_with_the_safetensors_reader(dataset: Path) -> None:
    st = pytest.importorskip("safetensors.numpy", reason="safetensors is in requirements-test.txt")
    data = subgoal.load_shards(dataset)
    for k, name in enumerate(sorted(p.name for p in dataset.glob("shard-*.safetensors"))):
        tensors = st.load_file(str(dataset / name))
        assert set(tensors) == {"costmaps", "goals", "subgoals", "path_lengths", "traps"}
        for key, value in tensors.items():
            np.testing.assert_array_equal(value, data.parts[k][key])
        assert tensors["path_lengths"].dtype == np.int32


def test_torch_reads_the_shards(dataset: Path) -> None:
    torch = pytest.importorskip("torch")
    safe_open = pytest.importorskip("safetensors").safe_open
    with safe_open(str(dataset / "shard-00000.safetensors"), framework="pt") as f:
        assert f.metadata()["first_index"] == "0"
        goals = f.get_tensor("goals")
        assert goals.dtype == torch.float32 and tuple(goals.shape) == (5, 2)
        np.testing.assert_array_equal(goals.numpy(), subgoal.load_shards(dataset).take("goals", range(5)))


def test_generation_releases_the_gil(tmp_path: Path) -> None:
    done = threading.Event()

    def run() -> None:
        subgoal.generate_dataset(tmp_path / "gil", samples=60, seed=0, shard_size=60, threads=1)
        done.set()

    worker = threading.Thread(target=run)
    worker.start()
    spins = 0
    while not done.is_set() and worker.is_alive():
        spins += 1
    worker.join()
    # Holding the GIL for the whole generation would leave this thread (almost) no turn.
    assert spins > 100


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"samples": 0}, "samples"),
        ({"samples": -3}, "samples"),
        ({"samples": 5, "shard_size": 0}, "shard_size"),
        ({"samples": 5, "threads": 0}, "threads"),
        ({"samples": 5, "seed": -1}, "seed"),
    ],
)
def test_bad_arguments_name_the_field(tmp_path: Path, kwargs: dict[str, int], field: str) -> None:
    with pytest.raises(ddpkit.InvalidInputError) as err:
        subgoal.generate_dataset(tmp_path / "bad", **kwargs)
    assert err.value.field == field
    assert not (tmp_path / "bad" / "manifest.json").exists()


def test_unwritable_out_dir_and_unreadable_data(tmp_path: Path, dataset: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(ddpkit.InvalidInputError) as err:
        subgoal.generate_dataset(blocker / "sub", samples=2)
    assert err.value.field == "out_dir"
    with pytest.raises(ddpkit.DdpError) as err2:
        subgoal.load_shards(tmp_path)
    assert err2.value.field == "directory"
    with pytest.raises(ddpkit.DdpError) as err3:
        subgoal.sample(-1, 0)
    assert err3.value.field == "seed"
    # A truncated shard and a manifest that does not add up.
    broken = tmp_path / "broken"
    broken.mkdir()
    for p in dataset.iterdir():
        (broken / p.name).write_bytes(p.read_bytes())
    shard = broken / "shard-00001.safetensors"
    shard.write_bytes(shard.read_bytes()[:-100])
    with pytest.raises(ddpkit.DdpError) as err4:
        subgoal.load_shards(broken)
    assert err4.value.field in ("costmaps", "traps")
    manifest = json.loads((dataset / "manifest.json").read_text())
    manifest["samples"] = 13
    (broken / "manifest.json").write_text(json.dumps(manifest))
    (broken / "shard-00001.safetensors").write_bytes((dataset / "shard-00001.safetensors").read_bytes())
    with pytest.raises(ddpkit.DdpError) as err5:
        subgoal.load_shards(broken)
    assert err5.value.field == "manifest.samples"
