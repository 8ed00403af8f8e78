"""The DDPEN sub-goal network in torch (Gamayunov et al. (2023), §II-C, Fig. 2): training, export
and loading.

``x_s = SG_theta(map, x_goal)``: a costmap encoder, a linear goal embedding and a transformer
decoder with one learned query per sub-goal, trained to imitate the A* sub-goals of the
``subgoal-dataset`` shards. The exported safetensors file runs in Rust (``subgoal_infer::SubgoalModel``,
``ddpkit.subgoal.SubgoalModel``) without torch.

===================  ==========================================================================
stage                torch (``state_dict`` names)
===================  ==========================================================================
input                ``costmap * input_scale`` (``u8`` 200 x 200, row ``iy``, column ``ix``)
encoder ``cnn``      ``encoder.layers.{i}.conv`` / ``.bn``: strided conv-BN-ReLU (default:
                     5x5/4 -> 3x3/2 -> 3x3/2 -> 3x3/2, 24-32-48-64 channels, 7 x 7 tokens)
encoder              ``encoder.features``: torchvision ``efficientnet_b0(weights=None)`` features
``efficientnet``     with a one-channel stem (as the paper), or a smaller stage list
tokens               ``input_proj`` (linear) + ``pos_embed`` (learned)
goal                 ``goal_embed``: linear of ``goal / goal_scale``, added to every query
decoder              ``decoder``: ``nn.TransformerDecoder`` (batch-first), queries ``queries``
head                 ``head``: linear to ``(x, y)``, times ``output_scale`` (metres)
===================  ==========================================================================

Frame: goal and sub-goals are metres relative to the map centre in map axes (``x`` along the
column index, ``y`` along the row index), as the dataset writes them.

Example::

    from ddpkit import subgoal_model as sm

    model = sm.build_model(sm.SubgoalConfig())          # the default small CNN
    sm.export(model, "model.safetensors")               # architecture in the header metadata
    same = sm.load("model.safetensors")

Training: ``python -m ddpkit.train subgoal --data DIR --out model.safetensors`` (:func:`train`).
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import time
from dataclasses import dataclass, field
from typing import Any, Optional

import numpy as np

#: Key of the architecture JSON in the safetensors header metadata (read by the Rust loader).
METADATA_KEY = "ddpkit.subgoal"
#: Header metadata key of the training summary (JSON), written by :func:`train`.
TRAIN_KEY = "ddpkit.subgoal.train"
FORMAT = "ddpkit-subgoal"
VERSION = 1

#: The default small CNN: (channels, kernel, stride) per conv-BN-ReLU layer.
DEFAULT_CNN: list[tuple[int, int, int]] = [(24, 5, 4), (32, 3, 2), (48, 3, 2), (64, 3, 2)]

#: torchvision's EfficientNet-B0 stages: (expand ratio, kernel, stride, in, out, layers).
B0_STAGES: list[tuple[float, int, int, int, int, int]] = [
    (1.0, 3, 1, 32, 16, 1),
    (6.0, 3, 2, 16, 24, 2),
    (6.0, 5, 2, 24, 40, 2),
    (6.0, 3, 2, 40, 80, 3),
    (6.0, 5, 1, 80, 112, 3),
    (6.0, 5, 2, 112, 192, 4),
    (6.0, 3, 1, 192, 320, 1),
]


@dataclass
class SubgoalConfig:
    """The architecture; every field is written to the exported file's metadata."""

    arch: str = "cnn"
    in_size: int = 200
    input_scale: float = 1.0 / 254.0
    goal_scale: float = 5.0
    output_scale: float = 5.0
    d_model: int = 64
    nhead: int = 4
    num_layers: int = 2
    dim_feedforward: int = 128
    activation: str = "relu"
    norm_first: bool = False
    layer_norm_eps: float = 1e-5
    bn_eps: float = 1e-5
    num_subgoals: int = 3
    #: ``arch == "cnn"``: layers as ``{"channels", "kernel", "stride"}``.
    cnn: Optional[list[dict[str, int]]] = None
    #: ``arch == "efficientnet"``: ``{"variant", "stages": [{...MBConvConfig fields}], "last_channel"}``.
    efficientnet: Optional[dict[str, Any]] = None
    #: Training only: dropout of the decoder, stochastic depth of EfficientNet.
    dropout: float = 0.0
    stochastic_depth_prob: float = 0.2
    format: str = FORMAT
    version: int = VERSION

    def __post_init__(self) -> None:
        if self.arch == "cnn" and self.cnn is None:
            self.cnn = [{"channels": c, "kernel": k, "stride": s} for c, k, s in DEFAULT_CNN]
        if self.arch == "efficientnet" and self.efficientnet is None:
            self.efficientnet = efficientnet_spec("b0")
        if self.arch not in ("cnn", "efficientnet"):
            raise ValueError(f"arch: must be 'cnn' or 'efficientnet', got {self.arch!r}")
        if self.d_model % self.nhead:
            raise ValueError(f"nhead: must divide d_model = {self.d_model}, got {self.nhead}")
        if self.activation not in ("relu", "gelu"):
            raise ValueError(f"activation: must be 'relu' or 'gelu', got {self.activation!r}")

    def to_json(self) -> str:
        """The metadata JSON (only the fields of the chosen encoder)."""
        d = dataclasses.asdict(self)
        if self.arch == "cnn":
            d.pop("efficientnet")
        else:
            d.pop("cnn")
        return json.dumps(d, sort_keys=True)

    @classmethod
    def from_json(cls, text: str) -> "SubgoalConfig":
        d = json.loads(text)
        known = {f.name for f in dataclasses.fields(cls)}
        return cls(**{k: v for k, v in d.items() if k in known})


def efficientnet_spec(
    variant: str = "b0",
    stages: Optional[list[tuple[float, int, int, int, int, int]]] = None,
    last_channel: int = 1280,
) -> dict[str, Any]:
    """The ``efficientnet`` field: B0's stages, or ``stages`` (channels multiples of 8, as torchvision rounds them)."""
    rows = B0_STAGES if stages is None else stages
    return {
        "variant": variant,
        "stages": [
            {"expand_ratio": float(e), "kernel": k, "stride": s, "input_channels": i, "out_channels": o, "num_layers": n}
            for e, k, s, i, o, n in rows
        ],
        "last_channel": last_channel,
    }


def _torch() -> Any:
    import torch

    return torch


def build_model(config: SubgoalConfig) -> Any:
    """A fresh :class:`SubgoalNet` (torch ``nn.Module``) for ``config``, initialised from torch's RNG."""
    return _module_classes()["SubgoalNet"](config)


_CLASSES: dict[str, Any] = {}


def _module_classes() -> dict[str, Any]:
    """Defines the torch modules on first use, so importing this file does not need torch."""
    if _CLASSES:
        return _CLASSES
    torch = _torch()
    nn = torch.nn

    class CnnEncoder(nn.Module):  # type: ignore[misc, name-defined]
        def __init__(self, config: SubgoalConfig) -> None:
            super().__init__()
            layers = []
            cin = 1
            for spec in config.cnn or []:
                c, k, s = int(spec["channels"]), int(spec["kernel"]), int(spec["stride"])
                block = nn.Module()
                block.conv = nn.Conv2d(cin, c, k, stride=s, padding=(k - 1) // 2, bias=False)
                block.bn = nn.BatchNorm2d(c, eps=config.bn_eps)
                layers.append(block)
                cin = c
            self.layers = nn.ModuleList(layers)
            self.out_channels = cin

        def forward(self, x: Any) -> Any:
            for block in self.layers:
                x = torch.relu(block.bn(block.conv(x)))
            return x

    class EfficientNetEncoder(nn.Module):  # type: ignore[misc, name-defined]
        def __init__(self, config: SubgoalConfig) -> None:
            super().__init__()
            from torchvision.models import efficientnet as tv_eff

            spec = config.efficientnet or efficientnet_spec("b0")
            rows = [
                (s["expand_ratio"], s["kernel"], s["stride"], s["input_channels"], s["out_channels"], s["num_layers"])
                for s in spec["stages"]
            ]
            last = int(spec["last_channel"])
            if spec.get("variant") == "b0" and [tuple(r) for r in rows] == [tuple(r) for r in B0_STAGES] and last == 1280:
                net = tv_eff.efficientnet_b0(weights=None, stochastic_depth_prob=config.stochastic_depth_prob)
            else:
                setting = [tv_eff.MBConvConfig(e, k, s, i, o, n) for e, k, s, i, o, n in rows]
                for cnf, (_, _, _, i, o, _) in zip(setting, rows):
                    if (cnf.input_channels, cnf.out_channels) != (i, o):
                        raise ValueError(f"efficientnet.stages: channels must be multiples of 8 (>= 8), got {i}, {o}")
                net = tv_eff.EfficientNet(
                    setting, dropout=0.0, stochastic_depth_prob=config.stochastic_depth_prob, last_channel=last
                )
            features = net.features
            stem = features[0][0]
            # One input channel (a costmap), as the paper; no downloaded weights.
            features[0][0] = nn.Conv2d(1, stem.out_channels, 3, stride=2, padding=1, bias=False)
            for m in features.modules():
                if isinstance(m, nn.BatchNorm2d):
                    m.eps = config.bn_eps
            self.features = features
            self.out_channels = last

        def forward(self, x: Any) -> Any:
            return self.features(x)

    class SubgoalNet(nn.Module):  # type: ignore[misc, name-defined]
        """``SG_theta(map, x_goal)``: ``forward(costmaps [B, H, W] (u8 or float), goals [B, 2] m) -> [B, S, 2] m``."""

        def __init__(self, config: SubgoalConfig) -> None:
            super().__init__()
            self.config = config
            d = config.d_model
            self.encoder = CnnEncoder(config) if config.arch == "cnn" else EfficientNetEncoder(config)
            with torch.no_grad():
                side = self.encoder(torch.zeros(1, 1, config.in_size, config.in_size)).shape[-1]
            self.tokens = int(side * side)
            self.input_proj = nn.Linear(self.encoder.out_channels, d)
            self.pos_embed = nn.Parameter(0.02 * torch.randn(self.tokens, d))
            self.goal_embed = nn.Linear(2, d)
            self.queries = nn.Parameter(0.02 * torch.randn(config.num_subgoals, d))
            layer = nn.TransformerDecoderLayer(
                d,
                config.nhead,
                dim_feedforward=config.dim_feedforward,
                dropout=config.dropout,
                activation=config.activation,
                layer_norm_eps=config.layer_norm_eps,
                batch_first=True,
                norm_first=config.norm_first,
            )
            norm = nn.LayerNorm(d, eps=config.layer_norm_eps) if config.norm_first else None
            self.decoder = nn.TransformerDecoder(layer, config.num_layers, norm=norm)
            self.head = nn.Linear(d, 2)

        def forward(self, costmaps: Any, goals: Any) -> Any:
            c = self.config
            dtype = self.head.weight.dtype
            x = costmaps.to(dtype).unsqueeze(1) * c.input_scale
            f = self.encoder(x)  # [B, C, h, w]
            tokens = f.flatten(2).transpose(1, 2)  # [B, h w, C], token index iy * w + ix
            memory = self.input_proj(tokens) + self.pos_embed
            g = self.goal_embed(goals.to(dtype) / c.goal_scale)  # [B, d]
            tgt = self.queries.unsqueeze(0) + g.unsqueeze(1)  # [B, S, d]
            h = self.decoder(tgt, memory)
            return self.head(h) * c.output_scale

    _CLASSES.update(CnnEncoder=CnnEncoder, EfficientNetEncoder=EfficientNetEncoder, SubgoalNet=SubgoalNet)
    return _CLASSES


# ------------------------------------------------------------------------------------------------
# Export and loading
# ------------------------------------------------------------------------------------------------


def export(model: Any, path: str, extra_metadata: Optional[dict[str, str]] = None) -> None:
    """Writes ``model``'s ``state_dict`` as safetensors with the architecture JSON under
    :data:`METADATA_KEY` (and ``extra_metadata``): the whole file or nothing (temp file + rename)."""
    from safetensors.torch import save_file

    from ddpkit.dqn import _atomic_write

    tensors = {k: v.detach().to("cpu").contiguous() for k, v in model.state_dict().items()}
    metadata = {"format": "pt", METADATA_KEY: model.config.to_json()}
    metadata.update(extra_metadata or {})
    _atomic_write(path, lambda tmp: save_file(tensors, tmp, metadata=metadata))


def read_metadata(path: str) -> dict[str, str]:
    """The header metadata of a safetensors file (no tensor is read)."""
    with open(path, "rb") as f:
        n = int.from_bytes(f.read(8), "little")
        header = json.loads(f.read(n))
    meta = header.get("__metadata__", {})
    return dict(meta)


def load(path: str, device: str = "cpu") -> Any:
    """The :class:`SubgoalNet` saved by :func:`export`, in eval mode."""
    from safetensors.torch import load_file

    meta = read_metadata(path)
    if METADATA_KEY not in meta:
        raise ValueError(f"{path}: metadata {METADATA_KEY} is missing; not a ddpkit sub-goal model")
    model = build_model(SubgoalConfig.from_json(meta[METADATA_KEY]))
    model.load_state_dict(load_file(path, device="cpu"), strict=True)
    return model.to(device).eval()


# ------------------------------------------------------------------------------------------------
# Dataset shards
# ------------------------------------------------------------------------------------------------

_DTYPES = {"U8": np.uint8, "F32": np.float32, "U32": np.uint32, "I32": np.int32, "I64": np.int64, "F64": np.float64}


def _memmap_safetensors(path: str) -> dict[str, np.ndarray]:
    """The tensors of one safetensors file as read-only memory maps (no copy)."""
    with open(path, "rb") as f:
        n = int.from_bytes(f.read(8), "little")
        header = json.loads(f.read(n))
    out: dict[str, np.ndarray] = {}
    for name, info in header.items():
        if name == "__metadata__":
            continue
        dtype = _DTYPES[info["dtype"]]
        start, end = info["data_offsets"]
        shape = tuple(info["shape"])
        if end == start:
            out[name] = np.zeros(shape, dtype)
            continue
        out[name] = np.memmap(path, dtype=dtype, mode="r", offset=8 + n + start, shape=shape)
    return out


class Shards:
    """The ``shard-*.safetensors`` of a dataset directory as memory maps, indexed globally.

    ``costmaps(idx)`` / ``goals(idx)`` / ``subgoals(idx)`` gather the samples ``idx`` (an int
    array) into in-memory arrays: ``u8 [n, H, W]``, ``f32 [n, 2]``, ``f32 [n, S, 2]``.
    """

    def __init__(self, directory: str) -> None:
        if not os.path.isdir(directory):
            raise ValueError(f"data: {directory} is not a directory")
        names = sorted(n for n in os.listdir(directory) if n.startswith("shard-") and n.endswith(".safetensors"))
        if not names:
            raise ValueError(f"data: no shard-*.safetensors in {directory}")
        self.parts = [_memmap_safetensors(os.path.join(directory, n)) for n in names]
        for n, p in zip(names, self.parts):
            for key in ("costmaps", "goals", "subgoals"):
                if key not in p:
                    raise ValueError(f"data: {n} has no tensor {key!r}")
        sizes = np.array([p["goals"].shape[0] for p in self.parts])
        self.offsets = np.concatenate([[0], np.cumsum(sizes)])
        self.size = int(self.offsets[-1])

    def __len__(self) -> int:
        return self.size

    def preload(self, keys: tuple[str, ...] = ("costmaps", "goals", "subgoals")) -> None:
        """Reads ``keys`` of every shard into memory, sequentially: random batches then come from
        RAM instead of random reads of the memory maps (60 000 samples are 2.4 GB)."""
        for part in self.parts:
            for key in keys:
                part[key] = np.array(part[key])

    def _gather(self, key: str, idx: np.ndarray) -> np.ndarray:
        idx = np.asarray(idx, dtype=np.int64)
        shard = np.searchsorted(self.offsets, idx, side="right") - 1
        first = self.parts[0][key]
        out = np.empty((len(idx),) + first.shape[1:], first.dtype)
        for s in np.unique(shard):
            sel = np.nonzero(shard == s)[0]
            local = idx[sel] - self.offsets[s]
            order = np.argsort(local)  # sequential reads from the memory map
            out[sel[order]] = self.parts[s][key][local[order]]
        return out

    def costmaps(self, idx: np.ndarray) -> np.ndarray:
        return self._gather("costmaps", idx)

    def goals(self, idx: np.ndarray) -> np.ndarray:
        return self._gather("goals", idx)

    def subgoals(self, idx: np.ndarray) -> np.ndarray:
        return self._gather("subgoals", idx)


# ------------------------------------------------------------------------------------------------
# Training
# ------------------------------------------------------------------------------------------------


@dataclass
class TrainConfig:
    """Options of :func:`train` (the ``subgoal`` command's flags)."""

    data: str
    out: str
    epochs: int = 10
    seed: int = 0
    device: str = "cpu"
    batch_size: int = 64
    lr: float = 2e-3
    weight_decay: float = 1e-4
    val_fraction: float = 0.05
    max_samples: Optional[int] = None
    augment: bool = True
    #: Read the shards into memory first (else batches are gathered from the memory maps).
    preload: bool = True
    threads: Optional[int] = None
    progress: bool = True
    model: SubgoalConfig = field(default_factory=SubgoalConfig)


@dataclass
class TrainResult:
    """What :func:`train` did: losses per epoch, held-out errors per sub-goal, the baseline."""

    epoch_losses: list[float]
    val_errors: list[list[float]]
    baseline_errors: list[float]
    train_samples: int
    val_samples: int
    train_seconds: float
    out: str


def _dihedral(costmaps: Any, points: list[Any], t: int) -> tuple[Any, list[Any]]:
    """One of the 8 symmetries of the square: transpose (``x <-> y``), then mirror ``x``, ``y``.
    ``costmaps [B, H, W]`` (row ``y``, column ``x``); ``points [..., 2]`` metres about the centre."""
    if t & 1:
        costmaps = costmaps.transpose(-1, -2)
        points = [p.flip(-1) for p in points]
    if t & 2:
        costmaps = costmaps.flip(-1)
        points = [p * p.new_tensor([-1.0, 1.0]) for p in points]
    if t & 4:
        costmaps = costmaps.flip(-2)
        points = [p * p.new_tensor([1.0, -1.0]) for p in points]
    return costmaps, points


def displacement_errors(pred: Any, target: Any) -> Any:
    """``|pred - target|`` per sample and sub-goal (metres), ``[B, S]``."""
    return (pred - target).norm(dim=-1)


def _straight_line(goals: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """Baseline: sub-goal ``k`` at distance ``min(radii[k], |goal|)`` along the goal direction."""
    norm = np.linalg.norm(goals, axis=-1, keepdims=True)
    unit = goals / np.maximum(norm, 1e-9)
    r = np.minimum(radii[None, :], norm)  # [B, S]
    return unit[:, None, :] * r[..., None]


def evaluate(model: Any, shards: Shards, idx: np.ndarray, batch_size: int = 256, device: str = "cpu") -> np.ndarray:
    """Mean displacement error (metres) per sub-goal of ``model`` on samples ``idx``."""
    torch = _torch()
    model.eval()
    total = None
    with torch.no_grad():
        for b in range(0, len(idx), batch_size):
            sel = idx[b : b + batch_size]
            c = torch.from_numpy(shards.costmaps(sel)).to(device)
            g = torch.from_numpy(shards.goals(sel)).to(device)
            s = torch.from_numpy(shards.subgoals(sel)).to(device)
            e = displacement_errors(model(c, g), s).sum(0).cpu().numpy().astype(np.float64)
            total = e if total is None else total + e
    assert total is not None
    return total / len(idx)


def train(config: TrainConfig) -> TrainResult:
    """Trains the sub-goal network on the shards in ``config.data`` and exports it to ``config.out``.

    The last ``val_fraction`` of the samples (whole maps the model never sees) are held out.
    Seeded: on CPU the same seed gives the same weights (``torch.use_deterministic_algorithms``).
    The loss is the mean Euclidean distance to the A* sub-goals (the reported metric); AdamW with
    a one-cycle learning rate; random symmetries of the square as augmentation.
    """
    from ddpkit.dqn import progress_bar

    torch = _torch()
    if config.threads is not None:
        torch.set_num_threads(config.threads)
    torch.manual_seed(config.seed)
    if config.device == "cpu":
        torch.use_deterministic_algorithms(True)
    rng = np.random.default_rng(config.seed)
    shards = Shards(config.data)
    if config.preload:
        shards.preload()
    n = len(shards) if config.max_samples is None else min(len(shards), config.max_samples)
    n_val = max(1, int(round(n * config.val_fraction)))
    if n - n_val < 1:
        raise ValueError(f"data: {n} samples leave none for training with val_fraction {config.val_fraction}")
    train_idx = np.arange(n - n_val)
    val_idx = np.arange(n - n_val, n)

    mcfg = config.model
    if mcfg.num_subgoals != shards.parts[0]["subgoals"].shape[1]:
        mcfg = dataclasses.replace(mcfg, num_subgoals=int(shards.parts[0]["subgoals"].shape[1]))
    model = build_model(mcfg).to(config.device)
    opt = torch.optim.AdamW(model.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    steps_per_epoch = math.ceil(len(train_idx) / config.batch_size)
    sched = torch.optim.lr_scheduler.OneCycleLR(
        opt, max_lr=config.lr, total_steps=config.epochs * steps_per_epoch, pct_start=0.15
    )
    start = time.perf_counter()
    epoch_losses: list[float] = []
    val_errors: list[list[float]] = []
    bar = progress_bar(config.epochs * steps_per_epoch, "subgoal", disable=not config.progress)
    for epoch in range(config.epochs):
        model.train()
        perm = rng.permutation(train_idx)
        total, count = 0.0, 0
        for b in range(steps_per_epoch):
            sel = np.sort(perm[b * config.batch_size : (b + 1) * config.batch_size])
            c = torch.from_numpy(shards.costmaps(sel))
            g = torch.from_numpy(shards.goals(sel))
            s = torch.from_numpy(shards.subgoals(sel))
            if config.augment:
                c, (g, s) = _dihedral(c, [g, s], int(rng.integers(8)))
            c, g, s = c.to(config.device), g.to(config.device), s.to(config.device)
            loss = displacement_errors(model(c, g), s).mean()
            opt.zero_grad(set_to_none=True)
            loss.backward()
            torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
            opt.step()
            sched.step()
            total += loss.item() * len(sel)
            count += len(sel)
            bar.update(1)
            bar.set_postfix_str(f"epoch {epoch + 1} loss {total / count:.3f} m")
        epoch_losses.append(total / count)
        err = evaluate(model, shards, val_idx, device=config.device)
        val_errors.append([float(e) for e in err])
        bar.set_postfix_str(f"epoch {epoch + 1} loss {total / count:.3f} m val " + " ".join(f"{e:.3f}" for e in err))
    bar.close()
    seconds = time.perf_counter() - start

    # Baseline: the straight line to the goal at the training set's mean sub-goal radii.
    probe = train_idx[: min(len(train_idx), 5000)]
    radii = np.linalg.norm(shards.subgoals(probe), axis=-1).mean(0)
    base = displacement_errors_np(_straight_line(shards.goals(val_idx), radii), shards.subgoals(val_idx)).mean(0)

    result = TrainResult(
        epoch_losses=epoch_losses,
        val_errors=val_errors,
        baseline_errors=[float(b) for b in base],
        train_samples=len(train_idx),
        val_samples=len(val_idx),
        train_seconds=seconds,
        out=config.out,
    )
    summary = {
        "epochs": config.epochs,
        "seed": config.seed,
        "batch_size": config.batch_size,
        "lr": config.lr,
        "train_samples": len(train_idx),
        "val_samples": len(val_idx),
        "val_mean_displacement_m": val_errors[-1],
        "straight_line_baseline_m": result.baseline_errors,
        "train_seconds": round(seconds, 1),
        "device": config.device,
        "torch": torch.__version__,
    }
    export(model.cpu().eval(), config.out, {TRAIN_KEY: json.dumps(summary, sort_keys=True)})
    return result


def displacement_errors_np(pred: np.ndarray, target: np.ndarray) -> np.ndarray:
    """``|pred - target|`` per sample and sub-goal (numpy)."""
    return np.linalg.norm(pred - target, axis=-1)


def result_dict(result: TrainResult) -> dict[str, Any]:
    """``result`` as plain JSON-able data."""
    return dataclasses.asdict(result)


def format_result(result: TrainResult) -> str:
    """A short table: held-out mean displacement error per sub-goal, and the straight-line baseline."""
    last = result.val_errors[-1] if result.val_errors else []
    lines = [
        f"trained on {result.train_samples} maps for {len(result.epoch_losses)} epochs in "
        f"{result.train_seconds:.0f} s; held-out maps: {result.val_samples}; saved {result.out}",
        "mean displacement error on held-out maps (m):",
        "  sub-goal   model   straight line",
    ]
    for k, (e, b) in enumerate(zip(last, result.baseline_errors)):
        lines.append(f"  {k + 1:>8}   {e:5.3f}   {b:13.3f}")
    return "\n".join(lines)
