"""A saved mission view as an MCAP file of ROS 2 messages (Foxglove, Lichtblick, ``ros2 bag``).

:func:`export_mcap` reads the saved world recording (``world.rrd``) back with Rerun's own reader
(``rerun.chunk.RrdReader``) and writes one MCAP file, profile ``ros2``: every schema is a ROS 2 message
definition (``ros2msg``) and every message is CDR, stamped with the robot clock.

| topic | type | from |
| --- | --- | --- |
| ``/odom`` | ``nav_msgs/msg/Odometry`` | the base pose and measured twist |
| ``/cmd_vel`` | ``geometry_msgs/msg/Twist`` | the commanded twist |
| ``/tf`` | ``tf2_msgs/msg/TFMessage`` | ``map`` -> ``base_link`` and ``map`` -> ``camera_optical`` |
| ``/camera/image`` | ``sensor_msgs/msg/Image`` (rgb8) | the perceived frames |
| ``/camera/depth`` | ``sensor_msgs/msg/Image`` (16UC1, mm) | their depth |
| ``/camera/camera_info`` | ``sensor_msgs/msg/CameraInfo`` | the pinhole |
| ``/map`` | ``nav_msgs/msg/OccupancyGrid`` | the planner's map |
| ``/memory/markers`` | ``visualization_msgs/msg/MarkerArray`` | the topological memory and the subgoal |

Libraries, and why: ``mcap`` writes the container and ``mcap-ros2-support`` encodes CDR from a message
definition without ROS installed; the definitions themselves come from ``rosbags``' type store of ROS 2
Humble, so no message definition is written by hand here and each type is byte-for-byte the
distribution's (``ros2 bag`` reads CDR by type name and needs exactly that layout).
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from semexp_bt.app.viewer import world as entities
from semexp_bt.app.viewer.recording import open_recording

#: The ROS 2 distribution whose message definitions the file carries.
ROS_DISTRO = "humble"
MAP_FRAME = "map"
BASE_FRAME = "base_link"
CAMERA_FRAME = "camera_optical"
#: Topic -> message type.
TOPICS = {
    "/odom": "nav_msgs/msg/Odometry",
    "/cmd_vel": "geometry_msgs/msg/Twist",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/camera/image": "sensor_msgs/msg/Image",
    "/camera/depth": "sensor_msgs/msg/Image",
    "/camera/camera_info": "sensor_msgs/msg/CameraInfo",
    "/map": "nav_msgs/msg/OccupancyGrid",
    "/memory/markers": "visualization_msgs/msg/MarkerArray",
}
# visualization_msgs/Marker constants (the type's own).
_SPHERE, _LINE_LIST, _TEXT = 2, 5, 9
_ADD, _DELETEALL = 0, 3


@dataclass
class ExportSummary:
    """What an export wrote: messages per topic."""

    path: Path
    messages: dict[str, int] = field(default_factory=dict)


@dataclass(frozen=True)
class _Row:
    tick: int
    stamp_ns: int
    values: dict[str, Any]


def _read_world(world_path: Path) -> dict[str, list[_Row]]:
    """Every timed row of the recording by entity path, in tick order (Rerun's own reader)."""
    import pyarrow as pa
    import rerun.chunk as rrc

    by_entity: dict[str, list[_Row]] = defaultdict(list)
    for chunk in rrc.RrdReader(str(world_path)).store().stream():
        if chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        names = [n for n in batch.schema.names if not n.startswith("rerun.controls")]
        if entities.TICK_TIMELINE not in names or entities.SIM_TIME_TIMELINE not in names:
            continue
        ticks = batch.column(entities.TICK_TIMELINE).to_pylist()
        stamps = batch.column(entities.SIM_TIME_TIMELINE).cast(pa.int64()).to_pylist()
        components = {
            n: batch.column(n).to_pylist()
            for n in names
            if n not in (entities.TICK_TIMELINE, entities.SIM_TIME_TIMELINE)
        }
        for i, tick in enumerate(ticks):
            values = {n: column[i] for n, column in components.items() if column[i] is not None}
            by_entity[chunk.entity_path.lstrip("/")].append(_Row(int(tick), int(stamps[i]), values))
    for rows in by_entity.values():
        rows.sort(key=lambda row: row.tick)
    return by_entity


def _stamp(ns: int) -> dict[str, int]:
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def _header(ns: int, frame: str) -> dict[str, Any]:
    return {"stamp": _stamp(ns), "frame_id": frame}


def _vector(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> dict[str, float]:
    return {"x": float(x), "y": float(y), "z": float(z)}


def _quaternion(xyzw: Any) -> dict[str, float]:
    x, y, z, w = (float(v) for v in xyzw)
    return {"x": x, "y": y, "z": z, "w": w}


def _rotation_to_quaternion(m: np.ndarray) -> tuple[float, float, float, float]:
    """A rotation matrix as a unit quaternion ``(x, y, z, w)`` (Shepperd's method)."""
    trace = float(np.trace(m))
    if trace > 0.0:
        s = 2.0 * math.sqrt(trace + 1.0)
        return ((m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s)
    i = int(np.argmax(np.diag(m)))
    j, k = (i + 1) % 3, (i + 2) % 3
    s = 2.0 * math.sqrt(max(1.0 + m[i, i] - m[j, j] - m[k, k], 1e-12))
    q = [0.0, 0.0, 0.0, 0.0]
    q[i] = 0.25 * s
    q[j] = (m[j, i] + m[i, j]) / s
    q[k] = (m[k, i] + m[i, k]) / s
    q[3] = (m[k, j] - m[j, k]) / s
    return (q[0], q[1], q[2], q[3])


def _rgba(packed: int) -> dict[str, float]:
    """Rerun's packed 0xRRGGBBAA colour as ``std_msgs/ColorRGBA``."""
    return {
        "r": ((packed >> 24) & 0xFF) / 255.0,
        "g": ((packed >> 16) & 0xFF) / 255.0,
        "b": ((packed >> 8) & 0xFF) / 255.0,
        "a": (packed & 0xFF) / 255.0,
    }


def _twist(scalars: list[float]) -> dict[str, Any]:
    vx, vy, wz = (float(v) for v in scalars[:3])
    return {"linear": _vector(vx, vy), "angular": _vector(0.0, 0.0, wz)}


def _marker(ns_ns: int, namespace: str, marker_id: int, kind: int, **fields: Any) -> dict[str, Any]:
    marker = {
        "header": _header(ns_ns, MAP_FRAME),
        "ns": namespace,
        "id": marker_id,
        "type": kind,
        "action": _ADD,
        "pose": {"position": _vector(), "orientation": _quaternion((0, 0, 0, 1))},
        "scale": _vector(1.0, 1.0, 1.0),
        "color": {"r": 1.0, "g": 1.0, "b": 1.0, "a": 1.0},
        "lifetime": {"sec": 0, "nanosec": 0},
        "frame_locked": False,
        "points": [],
        "colors": [],
        "texture_resource": "",
        "texture": {"header": _header(0, ""), "format": "", "data": b""},
        "uv_coordinates": [],
        "text": "",
        "mesh_resource": "",
        "mesh_file": {"filename": "", "data": b""},
        "mesh_use_embedded_materials": False,
    }
    marker.update(fields)
    return marker


def _memory_markers(
    stamp_ns: int, nodes: _Row | None, edges: _Row | None, subgoal: _Row | None
) -> dict[str, Any]:
    """The memory as markers: DELETEALL, then a sphere (size from C_f, colour from P_explore) and a label
    per node, the edges as one line list, and the subgoal."""
    markers = [_marker(stamp_ns, "", 0, _SPHERE, action=_DELETEALL)]
    if nodes is not None:
        v = nodes.values
        positions = v.get("Points3D:positions", [])
        radii = v.get("Points3D:radii", [0.1] * len(positions))
        colours = v.get("Points3D:colors", [0xFFFFFFFF] * len(positions))
        ids = v.get("node_id", list(range(len(positions))))
        labels = v.get("label", [""] * len(positions))
        confidence = v.get("confidence", [0.0] * len(positions))
        potential = v.get("potential", [0.0] * len(positions))
        for i, position in enumerate(positions):
            pose = {"position": _vector(*position), "orientation": _quaternion((0, 0, 0, 1))}
            diameter = 2.0 * float(radii[i] if i < len(radii) else radii[-1])
            colour = colours[i] if i < len(colours) else colours[-1]
            markers.append(
                _marker(stamp_ns, "memory/nodes", int(ids[i]), _SPHERE, pose=pose,
                        scale=_vector(diameter, diameter, diameter), color=_rgba(colour))
            )  # fmt: skip
            text_pose = {
                "position": _vector(position[0], position[1], position[2] + 0.35),
                "orientation": pose["orientation"],
            }
            markers.append(
                _marker(stamp_ns, "memory/labels", int(ids[i]), _TEXT, pose=text_pose, scale=_vector(0.0, 0.0, 0.15),
                        text=f"{ids[i]} {labels[i]} C_f {confidence[i]:.2f} P {potential[i]:.2f}")
            )  # fmt: skip
    if edges is not None:
        points = [_vector(*p) for strip in edges.values.get("LineStrips3D:strips", []) for p in strip[:2]]
        if points:
            markers.append(
                _marker(stamp_ns, "memory/edges", 0, _LINE_LIST, points=points, scale=_vector(0.02, 0.0, 0.0),
                        color={"r": 0.6, "g": 0.6, "b": 0.6, "a": 1.0})
            )  # fmt: skip
    if subgoal is not None and subgoal.values.get("Points3D:positions"):
        position = subgoal.values["Points3D:positions"][0]
        markers.append(
            _marker(stamp_ns, "subgoal", 0, _SPHERE,
                    pose={"position": _vector(*position), "orientation": _quaternion((0, 0, 0, 1))},
                    scale=_vector(0.3, 0.3, 0.3), color={"r": 0.9, "g": 0.16, "b": 0.78, "a": 1.0},
                    text=(subgoal.values.get("Points3D:labels") or [""])[0])
        )  # fmt: skip
    return {"markers": markers}


def _latest(rows: list[_Row], tick: int) -> _Row | None:
    """The last row at or before ``tick`` (latest-at, as Rerun shows it); a Clear row counts as none."""
    found = None
    for row in rows:
        if row.tick > tick:
            break
        found = row
    if found is None or "Clear:is_recursive" in found.values:
        return None
    return found


def _messages(world: dict[str, list[_Row]]) -> Iterator[tuple[str, int, dict[str, Any]]]:
    """``(topic, stamp_ns, message)`` in the recording's order, per topic."""
    twist_at = {row.tick: row.values["Scalars:scalars"] for row in world.get(entities.BASE_TWIST, [])}
    for row in world.get(entities.ROBOT, []):
        translation = row.values.get("Transform3D:translation", [[0.0, 0.0, 0.0]])[0]
        rotation = row.values.get("Transform3D:quaternion", [[0.0, 0.0, 0.0, 1.0]])[0]
        pose = {"position": _vector(*translation), "orientation": _quaternion(rotation)}
        twist = twist_at.get(row.tick, [0.0, 0.0, 0.0])
        yield (
            "/odom",
            row.stamp_ns,
            {
                "header": _header(row.stamp_ns, MAP_FRAME),
                "child_frame_id": BASE_FRAME,
                "pose": {"pose": pose, "covariance": [0.0] * 36},
                "twist": {"twist": _twist(twist), "covariance": [0.0] * 36},
            },
        )
        yield (
            "/tf",
            row.stamp_ns,
            {
                "transforms": [
                    {
                        "header": _header(row.stamp_ns, MAP_FRAME),
                        "child_frame_id": BASE_FRAME,
                        "transform": {
                            "translation": _vector(*translation),
                            "rotation": _quaternion(rotation),
                        },
                    }
                ]
            },
        )
    for row in world.get(entities.COMMAND, []):
        yield "/cmd_vel", row.stamp_ns, _twist(row.values["Scalars:scalars"])
    for row in world.get(entities.CAMERA, []):
        matrix = np.array(row.values["Transform3D:mat3x3"][0], dtype=float).reshape(3, 3, order="F")
        translation = row.values["Transform3D:translation"][0]
        yield (
            "/tf",
            row.stamp_ns,
            {
                "transforms": [
                    {
                        "header": _header(row.stamp_ns, MAP_FRAME),
                        "child_frame_id": CAMERA_FRAME,
                        "transform": {
                            "translation": _vector(*translation),
                            "rotation": _quaternion(_rotation_to_quaternion(matrix)),
                        },
                    }
                ]
            },
        )
    for row in world.get(entities.CAMERA_IMAGE, []):
        k = np.array(row.values["Pinhole:image_from_camera"][0], dtype=float).reshape(3, 3, order="F")
        width, height = (int(v) for v in row.values["Pinhole:resolution"][0])
        yield (
            "/camera/camera_info",
            row.stamp_ns,
            {
                "header": _header(row.stamp_ns, CAMERA_FRAME),
                "height": height,
                "width": width,
                "distortion_model": "plumb_bob",
                "d": [0.0] * 5,
                "k": k.flatten().tolist(),
                "r": [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
                "p": [k[0, 0], 0.0, k[0, 2], 0.0, 0.0, k[1, 1], k[1, 2], 0.0, 0.0, 0.0, 1.0, 0.0],
                "binning_x": 0,
                "binning_y": 0,
                "roi": {"x_offset": 0, "y_offset": 0, "height": 0, "width": 0, "do_rectify": False},
            },
        )
    for row in world.get(entities.CAMERA_RGB, []):
        yield "/camera/image", row.stamp_ns, _rgb_image(row)
    for row in world.get(entities.CAMERA_DEPTH, []):
        fmt = row.values["DepthImage:format"][0]
        yield (
            "/camera/depth",
            row.stamp_ns,
            {
                "header": _header(row.stamp_ns, CAMERA_FRAME),
                "height": int(fmt["height"]),
                "width": int(fmt["width"]),
                "encoding": "16UC1",
                "is_bigendian": 0,
                "step": 2 * int(fmt["width"]),
                "data": bytes(row.values["DepthImage:buffer"][0]),
            },
        )
    for row in world.get(entities.MAP, []):
        fmt = row.values["GridMap:format"][0]
        width, height = int(fmt["width"]), int(fmt["height"])
        # The logger flipped the rows for Rerun (see WorldLogger._log_map); ROS wants them from the origin.
        cells = np.frombuffer(bytes(row.values["GridMap:data"][0]), dtype=np.int8).reshape(height, width)[
            ::-1
        ]
        ox, oy, _ = row.values["GridMap:translation"][0]
        yield (
            "/map",
            row.stamp_ns,
            {
                "header": _header(row.stamp_ns, MAP_FRAME),
                "info": {
                    "map_load_time": _stamp(row.stamp_ns),
                    "resolution": float(row.values["GridMap:cell_size"][0]),
                    "width": width,
                    "height": height,
                    "origin": {"position": _vector(ox, oy, 0.0), "orientation": _quaternion((0, 0, 0, 1))},
                },
                "data": cells.flatten().tolist(),
            },
        )
    nodes = world.get(entities.MEMORY_NODES, [])
    edges = world.get(entities.MEMORY_EDGES, [])
    subgoals = world.get(entities.SUBGOAL, [])
    changes = sorted({(row.tick, row.stamp_ns) for row in (*nodes, *subgoals)})
    for tick, stamp_ns in changes:
        yield (
            "/memory/markers",
            stamp_ns,
            _memory_markers(stamp_ns, _latest(nodes, tick), _latest(edges, tick), _latest(subgoals, tick)),
        )


def _rgb_image(row: _Row) -> dict[str, Any]:
    import cv2

    blob = np.frombuffer(bytes(row.values["EncodedImage:blob"][0]), dtype=np.uint8)
    bgr = cv2.imdecode(blob, cv2.IMREAD_COLOR)
    if bgr is None:
        raise ValueError(f"tick {row.tick}: the camera image in the recording is not a readable JPEG")
    rgb = np.ascontiguousarray(bgr[..., ::-1])
    height, width = rgb.shape[:2]
    return {
        "header": _header(row.stamp_ns, CAMERA_FRAME),
        "height": height,
        "width": width,
        "encoding": "rgb8",
        "is_bigendian": 0,
        "step": 3 * width,
        "data": rgb.tobytes(),
    }


def export_mcap(directory: Path, out_path: Path) -> ExportSummary:
    """Write the saved recording in ``directory`` as an MCAP file at ``out_path``.

    Raises:
        RecordingError: when the recording is unreadable or holds no world recording.
    """
    from semexp_bt.app.viewer.recording import RecordingError

    # The recording is checked before the optional imports: a wrong directory is named as such
    # on a machine without the viewer extra too.
    recording = open_recording(directory)
    if recording.world_path is None:
        raise RecordingError(
            f"{directory}: no world recording (world.rrd) to export; record with the viewer extra"
        )
    from mcap_ros2.writer import Writer
    from rosbags.typesys import Stores, get_typestore

    world = _read_world(recording.world_path)
    store = get_typestore(Stores.ROS2_HUMBLE)
    out_path = Path(out_path)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    summary = ExportSummary(path=out_path, messages={topic: 0 for topic in TOPICS})
    pending = sorted(_messages(world), key=lambda item: item[1])
    with open(out_path, "wb") as handle:
        writer = Writer(handle)
        schemas = {}
        for datatype in sorted(set(TOPICS.values())):
            text, _ = store.generate_msgdef(datatype, ros_version=2)
            schemas[datatype] = writer.register_msgdef(datatype, text)
        for sequence, (topic, stamp_ns, message) in enumerate(pending):
            writer.write_message(
                topic=topic, schema=schemas[TOPICS[topic]], message=message, log_time=stamp_ns,
                publish_time=stamp_ns, sequence=sequence,
            )  # fmt: skip
            summary.messages[topic] += 1
        writer.add_metadata(
            "semexp_bt",
            {
                "recording_id": str(recording.manifest.get("recording_id", "")),
                "title": str(recording.manifest.get("title", "")),
                "ros_distro": ROS_DISTRO,
            },
        )
        writer.finish()
    return summary
