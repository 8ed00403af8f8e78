"""The simulation's Foxglove logs read back with the official MCAP reader and protobuf decoding
(``mcap`` + ``mcap-protobuf-support``), and ``SimResult.plot()``."""

from __future__ import annotations

import pathlib

import pytest
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

import ddpkit
from ddpkit import sim

SCENARIO = """
name = "log-12m"
[route]
points = [[0.0, 0.0], [12.0, 0.0]]
[[obstacles]]
type = "box"
center = [6.0, 0.8]
size = [2.0, 2.0]
"""

TOPICS = {
    "/tf": "foxglove.FrameTransforms",
    "/robot/pose": "foxglove.PoseInFrame",
    "/robot/footprint": "foxglove.SceneUpdate",
    "/costmap": "foxglove.Grid",
    "/lidar": "foxglove.LaserScan",
    "/plan": "foxglove.SceneUpdate",
    "/astar": "foxglove.SceneUpdate",
    "/subgoals": "foxglove.SceneUpdate",
    "/goal": "foxglove.PoseInFrame",
    "/world": "foxglove.SceneUpdate",
}


def test_every_topic_decodes_and_transforms_chain(tmp_path: pathlib.Path) -> None:
    log = tmp_path / "run.mcap"
    r = sim.run_scenario(SCENARIO, planner="ddp-astar", seed=1, max_time=4.0, log=log)
    assert r.outcome == "timeout"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.mcap"]  # no partial file left
    counts: dict[str, int] = {}
    with open(log, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None
        channels = {c.topic: c for c in summary.channels.values()}
        # A channel is written with its first message: DDP + A* guides with an A* path, so the
        # log has no sub-goals.
        assert set(channels) == (set(TOPICS) - {"/subgoals"}) | {"/stats"}
        for topic, name in TOPICS.items():
            if topic == "/subgoals":
                continue
            assert summary.schemas[channels[topic].schema_id].name == name
            assert summary.schemas[channels[topic].schema_id].encoding == "protobuf"
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            if channel.topic == "/tf":
                chain = [(t.parent_frame_id, t.child_frame_id) for t in decoded.transforms]
                assert chain == [("map", "base_link"), ("base_link", "laser")]
                assert decoded.transforms[0].timestamp.ToNanoseconds() == message.log_time
            elif channel.topic == "/costmap":
                assert decoded.column_count == 200 and len(decoded.data) == 200 * 200
                assert decoded.frame_id == "map"
            elif channel.topic == "/lidar":
                assert decoded.frame_id == "laser" and len(decoded.ranges) > 0
            elif channel.topic == "/stats":
                assert decoded.speed >= 0.0 and decoded.cycle_ms > 0.0
    # Every topic decoded, at the documented rates: 40 control steps of 0.1 s, a costmap every
    # second.
    assert set(counts) == (set(TOPICS) - {"/subgoals"}) | {"/stats"}
    assert counts["/tf"] == counts["/robot/pose"] == counts["/stats"] == len(r.t) == 40
    assert counts["/costmap"] == counts["/lidar"] == 4


def test_bad_log_paths_fail_before_the_run_and_failed_runs_leave_nothing(tmp_path: pathlib.Path) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    with pytest.raises(ddpkit.InvalidInputError) as info:
        sim.run_scenario(SCENARIO, max_time=1.0, log=blocker / "run.mcap")
    assert info.value.field == "log"
    assert "a-file" in str(info.value)
    # A run that fails after the log was opened (a bad max_time) removes it.
    with pytest.raises(ddpkit.InvalidInputError):
        sim.run_scenario(SCENARIO, max_time=-1.0, log=tmp_path / "bad.mcap")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a-file"]


def test_plot_draws_the_binaries_figure(tmp_path: pathlib.Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    r = sim.run_scenario(SCENARIO, planner="ddp", seed=0, max_time=5.0)
    png = tmp_path / "top.png"
    ax = r.plot(path=png)
    assert png.read_bytes()[1:4] == b"PNG"
    assert ax.get_xlabel() == "x (m)" and ax.get_ylabel() == "y (m)"
    assert "log-12m" in ax.get_title() and "ddp" in ax.get_title()
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    for want in ("route", "route points", "obstacles", "ddp", "start", "end", "stopped (local minimum)"):
        assert want in labels, labels
    # Ticks carry numbers in metres.
    assert len(ax.get_xticks()) >= 3
    assert r.route.shape == (2, 2) and len(r.obstacles) == 1 and r.obstacles[0].shape[1] == 2
