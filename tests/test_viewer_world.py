"""The world view of a MuJoCo mission, read back: the Rerun recording through Rerun's own reader, the
MCAP export through the ``mcap`` reader with two independent ROS 2 decoders (``mcap-ros2-support``'s and
``rosbags``'). Needs the viewer extra: ``make viewer-test`` (marker ``viewer``).

The mission is the README's (road, seed 0, lexical relevance), cut at 40 s of robot time: the panoramic
scan, the first decisions and the first walk.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from semexp_bt.app.episode import EpisodeOptions, run_episode
from semexp_bt.app.viewer import world as entities
from semexp_bt.app.viewer.observer import ViewOptions
from semexp_bt.app.viewer.recording import open_recording
from semexp_bt.cli import main
from tests.viewer_support import timed_rows, written_at

pytestmark = pytest.mark.viewer

MISSION = Path(__file__).resolve().parents[1] / "trees" / "object_search.yaml"
#: Robot time the recorded mission runs (s).
RECORDED_SIM_S = 40.0


def record_mujoco_view(directory: Path) -> dict[str, Any]:
    """Run the README's mission for :data:`RECORDED_SIM_S` with the view saved to ``directory``."""
    import torch

    torch.set_num_threads(1)
    return run_episode(
        EpisodeOptions(
            mission_path=MISSION,
            scene="road",
            seed=0,
            relevance="lexical",
            max_sim_s=RECORDED_SIM_S,
            view=ViewOptions(record_dir=directory, mission={"scene": "road", "seed": 0}),
        )
    )


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any]]:
    directory = tmp_path_factory.mktemp("view") / "road-0"
    return directory, record_mujoco_view(directory)


def test_the_rerun_recording_holds_each_entity_at_the_expected_ticks(
    recorded: tuple[Path, dict[str, Any]],
) -> None:
    directory, record = recorded
    saved = open_recording(directory)
    assert saved.complete and saved.world_path is not None
    assert saved.manifest["frames"]["dropped"] == 0 and saved.manifest["worker_errors"] == []
    rows = timed_rows(saved.world_path)
    print({entity: len(ticks) for entity, ticks in sorted(rows.items())})
    ticks = record["ticks"]
    # The pose at 10 Hz of robot time (every 5th tick), from before the first tick to the last one.
    robot = rows[entities.ROBOT]
    assert robot[0] == 0 and robot[-1] == ticks and set(np.diff(robot[1:-1])) == {5}
    assert rows[entities.COMMAND] and rows[entities.BASE_TWIST] == robot
    # Each perceived frame: the camera pose, pinhole, RGB and depth at the tick `observation` was written.
    observed = written_at(saved.tick_lines, "/observation")
    assert observed
    for entity in (entities.CAMERA, entities.CAMERA_IMAGE, entities.CAMERA_RGB, entities.CAMERA_DEPTH):
        assert rows[entity] == observed, entity
    # The models' answers arrive later: proposals (or a clear) at each `scene_evidence` write, after the frame.
    answered = written_at(saved.tick_lines, "/scene_evidence")
    assert set(answered) <= set(rows[entities.PROPOSALS]) and answered[0] > observed[0]
    # One explanation per decision, at the tick Decide wrote it.
    decided = written_at(saved.tick_lines, "/decision")
    assert len(decided) == len(record["decisions"]) > 0
    assert rows[entities.EXPLANATION] == decided and set(decided) <= set(rows[entities.CANDIDATES])
    # The memory whenever a memory writer finished (SeedMaster on the first tick); the graph view with it
    # and whenever the subgoal changed (it is highlighted); the map at most once a second.
    assert rows[entities.MEMORY_NODES][0] == 1 and len(rows[entities.MEMORY_NODES]) > 3
    assert set(rows[entities.MEMORY_NODES]) | set(rows[entities.SUBGOAL]) == set(rows[entities.MEMORY_GRAPH])
    assert min(np.diff(rows[entities.MAP])) >= 50 and len(rows[entities.MAP]) >= RECORDED_SIM_S / 4
    assert rows[entities.PLAN_TRAJECTORY] and rows[entities.PLAN_PATH] and rows[entities.TRAJECTORY][0] == 0


def test_the_mcap_export_has_each_channel_and_decodes_as_ros2(
    recorded: tuple[Path, dict[str, Any]], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from rosbags.typesys import Stores, get_typestore

    from semexp_bt.app.viewer.mcap_export import TOPICS

    directory, _ = recorded
    out = tmp_path / "road-0.mcap"
    assert main(["export", str(directory), "--mcap", str(out)]) == 0
    print(capsys.readouterr().out)
    rows = timed_rows(directory / "world.rrd")
    store = get_typestore(Stores.ROS2_HUMBLE)
    with open(out, "rb") as handle:
        reader = make_reader(handle, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        assert summary is not None
        channels = {
            c.topic: (summary.schemas[c.schema_id].name, c.message_encoding)
            for c in summary.channels.values()
        }
        assert channels == {topic: (kind, "cdr") for topic, kind in TOPICS.items()}
        counts: Counter[str] = Counter()
        last_stamp: dict[str, int] = {}
        first: dict[str, Any] = {}
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            counts[channel.topic] += 1
            assert message.log_time >= last_stamp.get(channel.topic, 0)
            last_stamp[channel.topic] = message.log_time
            assert schema is not None
            store.deserialize_cdr(message.data, schema.name)  # the distribution's own layout decodes it too
            first.setdefault(channel.topic, decoded)
    expected = {
        "/odom": len(rows[entities.ROBOT]),
        "/cmd_vel": len(rows[entities.COMMAND]),
        "/tf": len(rows[entities.ROBOT]) + len(rows[entities.CAMERA]),
        "/camera/image": len(rows[entities.CAMERA_RGB]),
        "/camera/depth": len(rows[entities.CAMERA_DEPTH]),
        "/camera/camera_info": len(rows[entities.CAMERA_IMAGE]),
        "/map": len(rows[entities.MAP]),
        "/memory/markers": len(set(rows[entities.MEMORY_NODES]) | set(rows.get(entities.SUBGOAL, []))),
    }
    assert dict(counts) == expected
    image = first["/camera/image"]
    assert (image.encoding, image.width * 3) == ("rgb8", image.step) and len(
        image.data
    ) == image.step * image.height
    grid = first["/map"]
    # OccupancyGrid values as Nav2's costmap publisher writes them: -1 unknown, 0 free, 1-98 inflation,
    # 99 inscribed, 100 lethal.
    assert len(grid.data) == grid.info.width * grid.info.height and set(grid.data) <= set(range(-1, 101))
    markers = first["/memory/markers"].markers
    assert markers[0].action == 3 and any(m.ns == "memory/nodes" for m in markers)
