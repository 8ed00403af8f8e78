"""The DDPEN sub-goal network: torch model, training, export, and the Rust inference behind
``ddpkit.subgoal.SubgoalModel`` compared with torch (within 1e-4 m), including a full
EfficientNet-B0 encoder."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

import ddpkit

torch = pytest.importorskip("torch", reason="torch is in requirements-test.txt")
pytest.importorskip("safetensors", reason="safetensors is in requirements-test.txt")

from ddpkit import subgoal_model as sm  # noqa: E402


def model_class() -> type:
    """``ddpkit.subgoal.SubgoalModel`` (the public name), else the extension's class."""
    try:
        from ddpkit import subgoal

        return subgoal.SubgoalModel  # type: ignore[no-any-return]
    except (ImportError, AttributeError):
        return ddpkit._ddpkit.SubgoalModel  # type: ignore[no-any-return]


def costmaps(n: int, seed: int) -> np.ndarray:
    """Random rectangles of lethal cost with inflation-like ramps, a free centre."""
    rng = np.random.default_rng(seed)
    maps = np.zeros((n, 200, 200), np.uint8)
    yy, xx = np.mgrid[0:200, 0:200]
    for i in range(n):
        for _ in range(5):
            x0, y0 = rng.integers(0, 180, 2)
            w, h = rng.integers(4, 40, 2)
            d = np.maximum(np.maximum(x0 - xx, xx - (x0 + w)), np.maximum(y0 - yy, yy - (y0 + h)))
            maps[i] = np.maximum(maps[i], np.clip(252 - 25 * d, 0, 252).astype(np.uint8))
            maps[i][d <= 0] = 254
        maps[i][90:110, 90:110] = 0
    return maps


def goals(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    a = rng.uniform(-np.pi, np.pi, n)
    r = rng.uniform(3.0, 4.9, n)
    return np.stack([r * np.cos(a), r * np.sin(a)], -1).astype(np.float32)


def randomise_batch_norms(model: torch.nn.Module, seed: int) -> None:
    gen = torch.Generator().manual_seed(seed)
    with torch.no_grad():
        for m in model.modules():
            if isinstance(m, torch.nn.BatchNorm2d):
                n = m.num_features
                m.weight.copy_(0.5 + torch.rand(n, generator=gen))
                m.bias.copy_(0.2 * torch.randn(n, generator=gen))
                m.running_mean.copy_(0.2 * torch.randn(n, generator=gen))
                m.running_var.copy_(0.5 + torch.rand(n, generator=gen))


def torch_reference(model: torch.nn.Module, maps: np.ndarray, g: np.ndarray) -> np.ndarray:
    """torch's prediction in float64."""
    m = model.double().eval()
    with torch.no_grad():
        out = m(torch.from_numpy(maps).double(), torch.from_numpy(g).double()).numpy()
    model.float()
    return out


def assert_rust_matches_torch(model: torch.nn.Module, path: str, n: int = 2) -> None:
    sm.export(model, path)
    rust = model_class()(path)
    maps, g = costmaps(n, seed=3), goals(n, seed=4)
    want = torch_reference(model, maps, g)
    got = rust.predict(maps, g)
    assert got.shape == want.shape == (n, model.config.num_subgoals, 2)
    np.testing.assert_allclose(got, want, rtol=0.0, atol=1e-4)
    # One costmap at a time gives the same numbers.
    np.testing.assert_array_equal(rust.predict(maps[0], g[0]), got[0])


def test_default_cnn_rust_matches_torch(tmp_path: os.PathLike[str]) -> None:
    torch.manual_seed(0)
    model = sm.build_model(sm.SubgoalConfig()).eval()
    randomise_batch_norms(model, 1)
    assert sum(p.numel() for p in model.parameters()) * 4 < 2 * 1024 * 1024, "the default model stays small"
    assert_rust_matches_torch(model, os.path.join(tmp_path, "cnn.safetensors"), n=3)


def test_full_efficientnet_b0_rust_matches_torch(tmp_path: os.PathLike[str]) -> None:
    pytest.importorskip("torchvision", reason="torchvision is in requirements-test.txt")
    from torchvision.models import efficientnet_b0

    torch.manual_seed(0)
    model = sm.build_model(sm.SubgoalConfig(arch="efficientnet")).eval()
    randomise_batch_norms(model, 2)
    # The encoder is torchvision's B0 (same tensors as efficientnet_b0's features, 1-channel stem).
    ours = {k[len("encoder.features.") :]: v.shape for k, v in model.state_dict().items() if k.startswith("encoder.")}
    ref = {k[len("features.") :]: v.shape for k, v in efficientnet_b0(weights=None).state_dict().items() if k.startswith("features.")}
    assert ours.keys() == ref.keys()
    assert ours.pop("0.0.weight") == (32, 1, 3, 3) and ref.pop("0.0.weight") == (32, 3, 3, 3)
    assert ours == ref
    assert_rust_matches_torch(model, os.path.join(tmp_path, "b0.safetensors"), n=1)


def test_pre_norm_gelu_decoder_matches_torch(tmp_path: os.PathLike[str]) -> None:
    torch.manual_seed(5)
    config = sm.SubgoalConfig(
        cnn=[{"channels": 8, "kernel": 5, "stride": 4}, {"channels": 16, "kernel": 3, "stride": 2}],
        d_model=24,
        nhead=3,
        num_layers=3,
        dim_feedforward=40,
        activation="gelu",
        norm_first=True,
    )
    model = sm.build_model(config).eval()
    randomise_batch_norms(model, 3)
    assert_rust_matches_torch(model, os.path.join(tmp_path, "prenorm.safetensors"))


def test_default_model_is_shipped() -> None:
    model = model_class().default()
    assert model.num_subgoals == 3 and model.arch == "cnn" and model.in_size == 200
    out = model.predict(costmaps(1, seed=9)[0], [4.0, 1.0])
    assert out.shape == (3, 2) and out.dtype == np.float64 and np.all(np.isfinite(out))


def test_bad_weights_and_inputs_are_named_errors(tmp_path: os.PathLike[str]) -> None:
    from safetensors.torch import load_file, save_file

    torch.manual_seed(0)
    path = os.path.join(tmp_path, "m.safetensors")
    sm.export(sm.build_model(sm.SubgoalConfig()), path)
    tensors = load_file(path)
    meta = sm.read_metadata(path)

    del tensors["decoder.layers.1.linear2.weight"]
    bad = os.path.join(tmp_path, "bad.safetensors")
    save_file(tensors, bad, metadata=meta)
    with pytest.raises(ddpkit.InvalidInputError, match=r"decoder\.layers\.1\.linear2\.weight"):
        model_class()(bad)

    tensors = load_file(path)
    tensors["input_proj.weight"] = tensors["input_proj.weight"][:, :10].contiguous()
    save_file(tensors, bad, metadata=meta)
    with pytest.raises(ddpkit.InvalidInputError, match=r"input_proj\.weight.*shape") as e:
        model_class()(bad)
    assert "input_proj.weight" in e.value.field

    save_file(load_file(path), bad, metadata={"format": "pt"})
    with pytest.raises(ddpkit.DdpError, match="ddpkit.subgoal"):
        model_class()(bad)
    with open(bad, "wb") as f:
        f.write(b"\x10\x00\x00\x00\x00\x00\x00\x00{not a header}")
    with pytest.raises(ddpkit.DdpError, match="safetensors"):
        model_class()(bad)
    with pytest.raises(ddpkit.DdpError, match="path"):
        model_class()(os.path.join(tmp_path, "absent.safetensors"))
    with open(path, "rb") as f:
        model = model_class().from_bytes(f.read())

    maps = costmaps(1, seed=0)
    with pytest.raises(ddpkit.InvalidInputError, match="costmap"):
        model.predict(maps[0].astype(np.float32), [1.0, 0.0])
    with pytest.raises(ddpkit.ShapeError, match="costmap"):
        model.predict(maps[0, :100], [1.0, 0.0])
    with pytest.raises(ddpkit.NotFiniteError, match="goal"):
        model.predict(maps[0], [np.nan, 0.0])
    with pytest.raises(ddpkit.ShapeError, match="goal"):
        model.predict(maps, np.zeros((2, 2)))


# ------------------------------------------------------------------------------------------------
# Training
# ------------------------------------------------------------------------------------------------

TINY = sm.SubgoalConfig(
    cnn=[
        {"channels": 8, "kernel": 5, "stride": 4},
        {"channels": 8, "kernel": 3, "stride": 2},
        {"channels": 16, "kernel": 3, "stride": 2},
        {"channels": 16, "kernel": 3, "stride": 2},
    ],
    d_model=16,
    nhead=2,
    num_layers=1,
    dim_feedforward=32,
)


def write_dataset(directory: str, n: int) -> None:
    """A dataset in the ``subgoal-dataset`` format: ``ddpkit.subgoal.generate_dataset`` when the
    wheel has it, else synthetic shards whose sub-goals are fixed fractions of the goal."""
    try:
        from ddpkit import subgoal

        subgoal.generate_dataset(directory, n, seed=0, shard_size=n // 2)
        return
    except (ImportError, AttributeError):
        pass
    from safetensors.numpy import save_file

    os.makedirs(directory, exist_ok=True)
    for s in range(2):
        m, g = costmaps(n // 2, seed=10 + s), goals(n // 2, seed=20 + s)
        sub = (g[:, None, :] * np.array([0.35, 0.6, 0.85], np.float32)[None, :, None]).astype(np.float32)
        save_file(
            {"costmaps": m, "goals": g, "subgoals": sub, "path_lengths": np.full(n // 2, 80, np.int32)},
            os.path.join(directory, f"shard-{s:05d}.safetensors"),
        )


@pytest.fixture(scope="module")
def tiny_dataset(tmp_path_factory: pytest.TempPathFactory) -> str:
    d = str(tmp_path_factory.mktemp("subgoal-data"))
    write_dataset(d, 192)
    return d


def train_tiny(data: str, out: str, seed: int = 0) -> sm.TrainResult:
    return sm.train(
        sm.TrainConfig(
            data=data, out=out, epochs=4, seed=seed, batch_size=32, lr=3e-3, val_fraction=0.2,
            threads=2, progress=False, model=TINY,
        )
    )


def test_training_lowers_the_loss_and_the_export_runs_in_rust(tiny_dataset: str, tmp_path: os.PathLike[str]) -> None:
    out = os.path.join(tmp_path, "tiny.safetensors")
    result = train_tiny(tiny_dataset, out)
    assert len(result.epoch_losses) == 4 and len(result.val_errors[-1]) == 3
    assert result.epoch_losses[-1] < 0.8 * result.epoch_losses[0], result.epoch_losses
    assert result.train_samples + result.val_samples == 192
    # The file: architecture and training summary in the header, weights that torch and Rust agree on.
    meta = sm.read_metadata(out)
    assert json.loads(meta[sm.METADATA_KEY])["d_model"] == 16
    summary = json.loads(meta[sm.TRAIN_KEY])
    assert summary["val_mean_displacement_m"] == result.val_errors[-1]
    torch_model = sm.load(out)
    maps, g = costmaps(2, seed=7), goals(2, seed=8)
    np.testing.assert_allclose(model_class()(out).predict(maps, g), torch_reference(torch_model, maps, g), atol=1e-4)
    # Held-out error is what evaluate() says for the saved model.
    shards = sm.Shards(tiny_dataset)
    val = np.arange(192 - result.val_samples, 192)
    np.testing.assert_allclose(sm.evaluate(torch_model, shards, val), result.val_errors[-1], rtol=1e-5)


def test_training_is_seeded(tiny_dataset: str, tmp_path: os.PathLike[str]) -> None:
    a, b, c = (os.path.join(tmp_path, f"{k}.safetensors") for k in "abc")
    ra = sm.train(sm.TrainConfig(data=tiny_dataset, out=a, epochs=1, seed=3, batch_size=32, threads=1, progress=False, model=TINY))
    rb = sm.train(sm.TrainConfig(data=tiny_dataset, out=b, epochs=1, seed=3, batch_size=32, threads=1, progress=False, model=TINY))
    rc = sm.train(sm.TrainConfig(data=tiny_dataset, out=c, epochs=1, seed=4, batch_size=32, threads=1, progress=False, model=TINY))
    assert ra.epoch_losses == rb.epoch_losses and ra.val_errors == rb.val_errors
    assert ra.epoch_losses != rc.epoch_losses
    from safetensors.torch import load_file

    ta, tb = load_file(a), load_file(b)
    assert all(torch.equal(ta[k], tb[k]) for k in ta)


def test_dihedral_augmentation_moves_points_with_the_map() -> None:
    # An obstacle cell and a point on it stay together under all 8 symmetries.
    c = torch.zeros(1, 200, 200, dtype=torch.uint8)
    iy, ix = 30, 150
    c[0, iy, ix] = 254
    p = torch.tensor([[(ix - 100 + 0.5) * 0.05, (iy - 100 + 0.5) * 0.05]])
    for t in range(8):
        c2, (p2,) = sm._dihedral(c, [p], t)
        jy, jx = (c2[0] == 254).nonzero()[0].tolist()
        assert torch.allclose(p2, torch.tensor([[(jx - 100 + 0.5) * 0.05, (jy - 100 + 0.5) * 0.05]]), atol=1e-6), t


def test_train_command(tiny_dataset: str, tmp_path: os.PathLike[str]) -> None:
    out = os.path.join(tmp_path, "cli.safetensors")
    js = os.path.join(tmp_path, "cli.json")
    args = [sys.executable, "-m", "ddpkit.train", "subgoal", "--data", tiny_dataset, "--out", out, "--epochs", "1",
            "--batch-size", "64", "--threads", "1", "--no-progress", "--json", js, "--val-fraction", "0.25"]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    r = subprocess.run(args, capture_output=True, text=True, timeout=600, env=env)
    assert r.returncode == 0, r.stderr
    assert "mean displacement error" in r.stdout and os.path.exists(out)
    assert json.load(open(js))["val_samples"] == 48
    # The default architecture was trained (not TINY): the file says so.
    assert json.loads(sm.read_metadata(out)[sm.METADATA_KEY])["cnn"][0]["channels"] == sm.DEFAULT_CNN[0][0]
    r = subprocess.run(args[:5] + [os.path.join(tmp_path, "nowhere"), "--out", out], capture_output=True, text=True, env=env)
    assert r.returncode == 2 and "data" in r.stderr
