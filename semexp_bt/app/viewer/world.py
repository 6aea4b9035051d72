"""The robot's world through Rerun: camera, detections, depth, pose, map, plan, memory and decisions.

:class:`WorldLogger` turns each :class:`~semexp_bt.app.viewer.frames.WorldFrame` into Rerun log calls on
two timelines, ``tick`` (sequence) and ``sim_time`` (robot clock), to a file (``world.rrd`` of a saved
recording), to a gRPC server that a browser's Rerun viewer connects to (the live view), or both. It runs
in the view's world process (``world_process.py``), never in the mission's.

What is logged where (the entity paths are named once, here, and read back by the MCAP export):

- ``world/robot`` the base pose (``Transform3D``), with the body as a box; ``world/trajectory`` the path.
- ``world/camera`` the camera pose; ``world/camera/image`` its pinhole, with ``rgb`` (JPEG), ``depth``
  (uint16 mm), ``detections`` (the detector's boxes), ``proposals`` (the VLM's points and regions) and
  ``target`` (the arbitration's winner t* with its Eq. 2 score).
- ``world/map`` the costmap as a ``GridMap`` (``nav_msgs/OccupancyGrid`` values with the inflation
  gradient, RViz colours), through the one adapter :func:`semexp_bt.app.viewer.maps.map_layer`;
  ``world/plan/path`` the global path planned on it; ``world/plan/trajectory`` the controller's commanded
  trajectory of the last cycle.
- ``world/memory/nodes`` the topological memory (radius from C_f, colour from P_explore; every node's
  id, label, C_f, P_explore and visits as extra components), ``world/memory/edges``; ``memory_graph`` the
  same memory as a graph (Rerun's graph view), the chosen subgoal highlighted.
- ``world/decision/candidates`` the candidates of the last decision, labelled with their utility,
  ``world/decision/subgoal`` the chosen node; ``decision/explanation`` why this node: the terms of Eq. 9
  for the winner and the runners-up (markdown).
- ``command`` the commanded twist, ``robot/base_twist`` the measured one (time series); ``events`` the
  mission's events (text log).

The streams that come at the pose rate (the pose, the trajectory, both twists, the controller's
trajectory) are held as rows and sent as columns (``rr.send_columns``) at :meth:`WorldLogger.flush`,
after each batch of frames: one native call per entity and batch instead of one per row, which costs the
world process less CPU, and on two cores that CPU is taken beside the mission. The rows are the same
ones, at the same ticks, either way.
"""

from __future__ import annotations

import io
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from semexp_bt.app.viewer.frames import MapLayer, MemoryFrame, ModelAnswer, WorldFrame
from semexp_bt.core.config import DecisionConfig
from semexp_bt.core.types import Observation, Pose2D, Subgoal, Twist

#: Rerun application id of every semexp-bt recording.
APPLICATION_ID = "semexp_bt"
#: The two timelines: ticks (sequence) and the robot clock (duration, s).
TICK_TIMELINE = "tick"
SIM_TIME_TIMELINE = "sim_time"

ROBOT = "world/robot"
ROBOT_BODY = "world/robot/body"
TRAJECTORY = "world/trajectory"
CAMERA = "world/camera"
CAMERA_IMAGE = "world/camera/image"
CAMERA_RGB = "world/camera/image/rgb"
CAMERA_DEPTH = "world/camera/image/depth"
DETECTIONS = "world/camera/image/detections"
PROPOSALS = "world/camera/image/proposals"
TARGET = "world/camera/image/target"
MAP = "world/map"
PLAN_TRAJECTORY = "world/plan/trajectory"
PLAN_PATH = "world/plan/path"
MEMORY_NODES = "world/memory/nodes"
MEMORY_EDGES = "world/memory/edges"
MEMORY_GRAPH = "memory_graph"
CANDIDATES = "world/decision/candidates"
SUBGOAL = "world/decision/subgoal"
EXPLANATION = "decision/explanation"
COMMAND = "command"
BASE_TWIST = "robot/base_twist"
EVENTS = "events"

#: The series of ``command`` and ``robot/base_twist``, in order.
TWIST_SERIES = ("linear_x_mps", "linear_y_mps", "angular_z_radps")
#: Depth is stored as uint16 millimetres (0: invalid or not measured), as ``sensor_msgs/Image`` 16UC1.
DEPTH_UNITS_PER_M = 1000.0
#: JPEG quality of the camera images (the recording's largest stream).
JPEG_QUALITY = 85
#: The Go1's trunk, for drawing (half sizes, m) and how high its centre stands.
BODY_HALF_SIZES_M = (0.325, 0.15, 0.1)
BODY_HEIGHT_M = 0.3
#: The trajectory is redrawn when the robot has moved this far since the last point (m).
TRAJECTORY_STEP_M = 0.1
#: How many candidates the explanation lists (the winner and the runners-up).
EXPLAINED_CANDIDATES = 5
#: Colours (RGB).
SUBGOAL_COLOUR = (230, 40, 200)
CANDIDATE_COLOUR = (255, 200, 0)
DETECTION_COLOUR = (0, 200, 255)
OBJECT_PROPOSAL_COLOUR = (255, 140, 0)
DIRECTION_PROPOSAL_COLOUR = (140, 255, 120)
TARGET_COLOUR = (255, 40, 40)
ROBOT_COLOUR = (200, 200, 220)
TRAJECTORY_COLOUR = (90, 170, 255)
CONTROL_COLOUR = (60, 230, 120)
PATH_COLOUR = (255, 255, 255)
EDGE_COLOUR = (150, 150, 150)


@dataclass
class _Rows:
    """Rows of one entity held for one ``rr.send_columns`` call: their times and values."""

    ticks: list[int] = field(default_factory=list)
    stamps_s: list[float] = field(default_factory=list)
    values: list[Any] = field(default_factory=list)

    def add(self, tick: int, stamp_s: float, value: Any) -> None:
        """Hold one row."""
        self.ticks.append(tick)
        self.stamps_s.append(stamp_s)
        self.values.append(value)

    def take(self) -> tuple[list[int], list[float], list[Any]]:
        """The ticks, robot times and values held; the rows are emptied."""
        taken = (self.ticks, self.stamps_s, self.values)
        self.ticks, self.stamps_s, self.values = [], [], []
        return taken


def potential_colours(potential: npt.ArrayLike) -> npt.NDArray[np.uint8]:
    """Colour of P_explore in [0, 1]: dull blue (explored, 0) to bright orange (worth exploring, 1)."""
    p = np.clip(np.asarray(potential, dtype=float), 0.0, 1.0)[:, None]
    low, high = np.array([60.0, 80.0, 140.0]), np.array([255.0, 150.0, 20.0])
    return (low + p * (high - low)).astype(np.uint8)


def confidence_radii(confidence: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Drawn radius (m) of a memory node from its C_f in [0, 1]."""
    return 0.08 + 0.17 * np.clip(np.asarray(confidence, dtype=float), 0.0, 1.0)


def explain_decision(
    entry: Mapping[str, Any], config: DecisionConfig, *, top: int = EXPLAINED_CANDIDATES
) -> str:
    """Why this node: a markdown table of Eq. 9's terms for the winner and the runners-up.

    Args:
        entry: one decision-log entry (``Decide``: candidates with relevance S (floored, as the utility
            used it), confidence C_f, potential P, travel cost d and utility U; the selected node; the reason).
        config: the decision's exponents alpha, beta, eta and rate gamma.
        top: how many candidates to list, best utility first.
    """
    candidates = sorted(entry.get("candidates", ()), key=lambda c: (-c["utility"], c["node_id"]))
    chosen = entry.get("selected_node_id")
    head = (
        f"### Decision at t = {entry.get('stamp_s', 0.0):.2f} s: "
        + (f"node {chosen}" if chosen is not None else "no subgoal")
        + f" ({entry.get('reason', '')})\n\n"
        f"U = S^{config.alpha:g} · C_f^{config.beta:g} · P^{config.eta:g} · exp(-{config.gamma:g} d)"
        f" over {len(candidates)} candidates (Eq. 9).\n\n"
    )
    if not candidates:
        return head + "No node passed Eq. 8's filter (P_explore ≥ τ_p).\n"
    rows = [
        "| | node | label | S | C_f | P | d (m) | S^α | C_f^β | P^η | e^(-γd) | U |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for rank, c in enumerate(candidates[:top], start=1):
        d = float(c["travel_cost_m"])
        decay = math.exp(-config.gamma * d) if math.isfinite(d) else 0.0
        mark = "**★**" if c["node_id"] == chosen else str(rank)
        rows.append(
            f"| {mark} | {c['node_id']} | {c['label']} | {c['relevance']:.3f} | {c['confidence']:.3f}"
            f" | {c['potential']:.3f} | {d:.2f} | {c['relevance'] ** config.alpha:.3f}"
            f" | {c['confidence'] ** config.beta:.3f} | {c['potential'] ** config.eta:.3f}"
            f" | {decay:.3f} | {c['utility']:.4f} |"
        )
    if len(candidates) > top:
        rows.append(f"| | … {len(candidates) - top} more | | | | | | | | | | |")
    return head + "\n".join(rows) + "\n"


def yaw_quaternion_xyzw(yaw_rad: float) -> tuple[float, float, float, float]:
    """The rotation about +z by ``yaw_rad`` as a quaternion ``(x, y, z, w)``."""
    return (0.0, 0.0, math.sin(0.5 * yaw_rad), math.cos(0.5 * yaw_rad))


def default_blueprint() -> Any:
    """The layout the viewer opens with: the 3D world; the camera with the models' marks (the depth in a
    tab beside it); the memory graph and the decision; the twist over time; the time panel on ``tick``."""
    import rerun.blueprint as rrb

    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial3DView(name="World", origin="world"),
            rrb.Vertical(
                rrb.Tabs(
                    rrb.Spatial2DView(
                        name="Camera", origin=CAMERA_IMAGE, contents=["+ $origin/**", f"- {CAMERA_DEPTH}"]
                    ),
                    rrb.Spatial2DView(
                        name="Depth", origin=CAMERA_IMAGE, contents=["+ $origin", f"+ {CAMERA_DEPTH}"]
                    ),
                ),
                rrb.Tabs(
                    rrb.GraphView(name="Memory graph", origin=MEMORY_GRAPH),
                    rrb.TextDocumentView(name="Decision", origin=EXPLANATION),
                ),
                rrb.TimeSeriesView(name="Twist", origin="/", contents=[COMMAND, BASE_TWIST]),
                row_shares=[3, 3, 2],
            ),
            column_shares=[3, 2],
        ),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(timeline=TICK_TIMELINE, state="expanded"),
    )


class WorldLogger:
    """Logs :class:`WorldFrame` s to Rerun (see the module docstring for what goes where).

    Args:
        recording_id: the Rerun recording id (the saved recording's manifest names it).
        decision_config: the exponents of Eq. 9, for the decision's explanation.
        file_path: write the recording here (``.rrd``), or None.
        grpc_port: serve the recording to viewers on this loopback port, or None; 0 picks a free one.
        cors_origin: the page origin allowed to read the gRPC stream (the tree page's), when serving.
    """

    def __init__(
        self,
        *,
        recording_id: str,
        decision_config: DecisionConfig,
        file_path: Path | None = None,
        grpc_port: int | None = None,
        cors_origin: str | None = None,
    ) -> None:
        import rerun as rr

        self._rr = rr
        self.decision_config = decision_config
        self.grpc_url: str | None = None
        self.recording = rr.RecordingStream(APPLICATION_ID, recording_id=recording_id)
        self.recording.set_log_time_enabled(False)
        self.recording.set_log_tick_enabled(False)
        sinks: list[Any] = []
        if file_path is not None:
            sinks.append(rr.FileSink(str(file_path)))
        if grpc_port is not None:
            port = grpc_port or _free_port()
            sinks.append(
                rr.GrpcServerSink(
                    bind_ip="127.0.0.1",
                    port=port,
                    server_memory_limit="512MiB",
                    cors_allow_origin=[cors_origin] if cors_origin else None,
                )
            )
            self.grpc_url = f"rerun+http://127.0.0.1:{port}/proxy"
        if not sinks:
            raise ValueError("WorldLogger needs a file_path, a grpc_port or both")
        self.recording.set_sinks(*sinks, default_blueprint=default_blueprint())
        self._trajectory: list[tuple[float, float, float]] = []
        self._last_pose: Pose2D | None = None
        self._tick = 0
        self._stamp_s = 0.0
        self._time_set = False
        self._to_columns = self._column_builders()
        self._rows: dict[str, _Rows] = {entity: _Rows() for entity in self._to_columns}
        self._memory: MemoryFrame | None = None
        self._subgoal_id: int | None = None
        self._log_static()

    def _log_static(self) -> None:
        rr, rec = self._rr, self.recording
        rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        rec.log(
            ROBOT_BODY,
            rr.Boxes3D(
                half_sizes=[BODY_HALF_SIZES_M],
                centers=[(0.0, 0.0, BODY_HEIGHT_M)],
                colors=[ROBOT_COLOUR],
                fill_mode="solid",
            ),
            static=True,
        )
        for entity in (COMMAND, BASE_TWIST):
            rec.log(entity, rr.SeriesLines(names=[f"{entity} {name}" for name in TWIST_SERIES]), static=True)

    def _column_builders(self) -> dict[str, Callable[[list[Any]], Any]]:
        """How the held rows of each pose-rate entity become columns (the values are as :meth:`_hold`
        gets them)."""
        rr = self._rr

        def twists(values: list[Any]) -> Any:
            return rr.Scalars.columns(scalars=np.asarray(values, dtype=float).ravel()).partition(
                [len(TWIST_SERIES)] * len(values)
            )

        return {
            ROBOT: lambda values: rr.Transform3D.columns(
                translation=[v[0] for v in values], quaternion=[v[1] for v in values]
            ),
            TRAJECTORY: lambda values: rr.LineStrips3D.columns(
                strips=values, colors=[TRAJECTORY_COLOUR] * len(values), radii=[0.03] * len(values)
            ),
            COMMAND: twists,
            BASE_TWIST: twists,
            PLAN_TRAJECTORY: lambda values: rr.LineStrips3D.columns(
                strips=[v[0] for v in values],
                colors=[CONTROL_COLOUR] * len(values),
                radii=[0.025] * len(values),
                labels=[v[1] for v in values],
            ),
        }

    def _hold(self, entity: str, value: Any) -> None:
        """Hold one row of a pose-rate entity at the current frame's times (sent by :meth:`flush`)."""
        self._rows[entity].add(self._tick, self._stamp_s, value)

    def flush(self) -> None:
        """Send the held rows, one ``rr.send_columns`` call per entity (the worker calls this after each
        batch of frames)."""
        rr = self._rr
        for entity, to_columns in self._to_columns.items():
            if not self._rows[entity].ticks:
                continue
            ticks, stamps_s, values = self._rows[entity].take()
            rr.send_columns(
                entity,
                indexes=[
                    rr.TimeColumn(TICK_TIMELINE, sequence=ticks),
                    rr.TimeColumn(SIM_TIME_TIMELINE, duration=stamps_s),
                ],
                columns=to_columns(values),
                recording=self.recording,
            )

    def log(self, frame: WorldFrame) -> None:
        """Log one frame at its tick and robot time (the pose-rate rows wait for :meth:`flush`)."""
        self._tick, self._stamp_s = frame.tick, frame.stamp_s
        self._time_set = False
        if frame.pose is not None:
            self._log_pose(frame.pose, frame.base_twist, frame.command)
        if frame.map is not None:
            self._log_map(frame.map)
        if frame.plan is not None:
            self._log_plan(frame.plan)
        if frame.observation is not None:
            self._log_observation(frame.observation)
        if frame.answer is not None:
            self._log_answer(frame.answer)
        if frame.arbitration is not None:
            self._log_target(frame.arbitration)
        if frame.memory is not None:
            self._log_memory(frame.memory)
        if frame.decision is not None:
            self._log_decision(frame.decision)
        if frame.subgoal_changed:
            self._log_subgoal(frame.subgoal)
        for event in frame.events:
            details = ", ".join(f"{k}={v}" for k, v in event.items() if k not in ("kind", "stamp_s"))
            self._log(EVENTS, self._rr.TextLog(f"{event.get('kind', 'event')}: {details}", level="INFO"))
        if frame.outcome is not None:
            self._log(EVENTS, self._rr.TextLog(f"mission ended: {frame.outcome}", level="WARN"))

    def _log(self, entity: str, *archetypes: Any) -> None:
        """``rr.log`` at the current frame's tick and robot time (set on the first call of a frame: most
        frames hold only pose-rate rows and need no time set at all)."""
        if not self._time_set:
            self.recording.set_time(TICK_TIMELINE, sequence=self._tick)
            self.recording.set_time(SIM_TIME_TIMELINE, duration=self._stamp_s)
            self._time_set = True
        self.recording.log(entity, *archetypes)

    # ------------------------------------------------------------------ the parts
    def _log_pose(self, pose: Pose2D, base_twist: Twist | None, command: Twist | None) -> None:
        self._hold(ROBOT, ((pose.x_m, pose.y_m, 0.0), yaw_quaternion_xyzw(pose.yaw_rad)))
        self._last_pose = pose
        point = (pose.x_m, pose.y_m, 0.05)
        if not self._trajectory or math.dist(point[:2], self._trajectory[-1][:2]) >= TRAJECTORY_STEP_M:
            self._trajectory.append(point)
            self._hold(TRAJECTORY, np.array(self._trajectory))
        for entity, twist in ((COMMAND, command), (BASE_TWIST, base_twist)):
            if twist is not None:
                self._hold(entity, (twist.linear_x_mps, twist.linear_y_mps, twist.angular_z_radps))

    def _log_map(self, layer: MapLayer) -> None:
        rr = self._rr
        height, width = layer.cells.shape
        # Rerun draws a grid map's first row at its far (+y) edge, as an image's top row; ROS (and
        # MapLayer) put the first row at the origin: flip the rows (checked by eye in the browser).
        self._log(
            MAP,
            rr.GridMap(
                data=layer.cells[::-1].tobytes(),
                format=rr.components.ImageFormat(
                    width=width, height=height, color_model="L", channel_datatype="U8"
                ),
                cell_size=layer.resolution_m,
                translation=(layer.origin_xy[0], layer.origin_xy[1], -0.01),
                colormap=rr.components.Colormap.RvizMap,
            ),
        )
        if layer.path_xy is not None and len(layer.path_xy) > 1:
            path = np.column_stack([layer.path_xy, np.full(len(layer.path_xy), 0.05)])
            self._log(PLAN_PATH, rr.LineStrips3D([path], colors=[PATH_COLOUR], radii=[0.03]))

    def _log_plan(self, plan: Any) -> None:
        """The controller's last cycle (``semexp_bt.nav.controller.ControlResult``): its trajectory in
        ``map``, labelled with the status and the command."""
        trajectory = np.asarray(getattr(plan, "trajectory", np.zeros((0, 3))), dtype=float).reshape(-1, 3)
        label = f"{getattr(plan, 'status', '')} v={plan.twist.linear_x_mps:.2f} w={plan.twist.angular_z_radps:.2f}"
        if len(trajectory) < 2:
            self._log(PLAN_TRAJECTORY, self._rr.Clear(recursive=False))
            return
        strip = np.column_stack([trajectory[:, :2], np.full(len(trajectory), 0.06)])
        self._hold(PLAN_TRAJECTORY, (strip, label))

    def _log_observation(self, obs: Observation) -> None:
        # Pillow, not OpenCV: Rerun has imported it already, and importing cv2 at the first perceived
        # frame took the worker (and the interpreter lock) a quarter of a second in the mission.
        from PIL import Image

        rr = self._rr
        k = obs.intrinsics
        transform = np.asarray(obs.camera_to_world, dtype=float)
        self._log(CAMERA, rr.Transform3D(translation=transform[:3, 3], mat3x3=transform[:3, :3]))
        self._log(
            CAMERA_IMAGE,
            rr.Pinhole(
                image_from_camera=k.matrix(),
                resolution=(k.width_px, k.height_px),
                camera_xyz=rr.ViewCoordinates.RDF,
                image_plane_distance=1.0,
            ),
        )
        jpeg = io.BytesIO()
        Image.fromarray(np.ascontiguousarray(obs.rgb, dtype=np.uint8)).save(
            jpeg, format="JPEG", quality=JPEG_QUALITY
        )
        self._log(CAMERA_RGB, rr.EncodedImage(contents=jpeg.getvalue(), media_type="image/jpeg"))
        # In float32 and in place: one buffer the size of the image instead of five float64 ones.
        depth = np.multiply(obs.depth_m, DEPTH_UNITS_PER_M, dtype=np.float32)
        np.nan_to_num(depth, copy=False, nan=0.0)
        np.clip(depth, 0, np.iinfo(np.uint16).max, out=depth)
        self._log(CAMERA_DEPTH, rr.DepthImage(depth.astype(np.uint16), meter=DEPTH_UNITS_PER_M))
        # The models have not answered about this frame yet: what they said about the last one goes.
        for entity in (DETECTIONS, PROPOSALS, TARGET):
            self._log(entity, rr.Clear(recursive=False))

    def _log_answer(self, answer: ModelAnswer) -> None:
        rr = self._rr
        detections = answer.detections or ()
        if detections:
            self._log(
                DETECTIONS,
                rr.Boxes2D(
                    array=np.array([d.box_xyxy_px for d in detections], dtype=float),
                    array_format=rr.Box2DFormat.XYXY,
                    labels=[f"{d.label} {d.confidence:.2f}" for d in detections],
                    colors=[DETECTION_COLOUR],
                ),
            )
        else:
            self._log(DETECTIONS, rr.Clear(recursive=False))
        proposals = answer.scene_evidence.proposals if answer.scene_evidence is not None else ()
        if proposals:
            self._log(
                PROPOSALS,
                rr.Points2D(
                    [p.point_px for p in proposals],
                    labels=[f"{p.label} ({p.kind})" for p in proposals],
                    colors=[
                        DIRECTION_PROPOSAL_COLOUR if p.kind == "direction" else OBJECT_PROPOSAL_COLOUR
                        for p in proposals
                    ],
                    radii=[6.0],
                ),
            )
        else:
            self._log(PROPOSALS, rr.Clear(recursive=False))

    def _log_target(self, arbitration: Any) -> None:
        rr = self._rr
        winner = getattr(arbitration, "winner", None)
        if winner is None:
            self._log(TARGET, rr.Clear(recursive=False))
            return
        self._log(
            TARGET,
            rr.Points2D(
                [winner.pixel_px],
                labels=[f"t* {winner.label} S={winner.score:.3f} ({winner.source})"],
                colors=[TARGET_COLOUR],
                radii=[9.0],
            ),
        )

    def _log_memory(self, memory: MemoryFrame) -> None:
        rr = self._rr
        self._memory = memory
        nodes = memory.nodes
        if not nodes:
            return
        positions = np.array([n.position_m for n in nodes], dtype=float)
        confidence = np.array([n.confidence for n in nodes], dtype=float)
        potential = np.array([n.potential for n in nodes], dtype=float)
        labels = [f"{n.node_id} {n.label}" for n in nodes]
        colours = potential_colours(potential)
        self._log(
            MEMORY_NODES,
            rr.Points3D(positions, radii=confidence_radii(confidence), colors=colours, labels=labels),
            rr.AnyValues(
                node_id=[n.node_id for n in nodes],
                label=[n.label for n in nodes],
                confidence=confidence,
                potential=potential,
                visits=[n.visits for n in nodes],
                is_master=[n.is_master for n in nodes],
            ),
        )
        where = {n.node_id: n.position_m for n in nodes}
        strips = [[where[u], where[v]] for u, v in memory.edges if u in where and v in where]
        self._log(
            MEMORY_EDGES,
            rr.LineStrips3D(strips, colors=[EDGE_COLOUR], radii=[0.01])
            if strips
            else rr.Clear(recursive=False),
        )
        self._log_graph()

    def _log_graph(self) -> None:
        """The memory as a graph (x right, y up, 1 m = 100 units), the chosen subgoal highlighted."""
        rr = self._rr
        if self._memory is None or not self._memory.nodes:
            return
        nodes = self._memory.nodes
        positions = np.array([n.position_m[:2] for n in nodes], dtype=float)
        confidence = np.array([n.confidence for n in nodes], dtype=float)
        colours = potential_colours([n.potential for n in nodes])
        colours[[n.node_id == self._subgoal_id for n in nodes]] = SUBGOAL_COLOUR
        self._log(
            MEMORY_GRAPH,
            rr.GraphNodes(
                [str(n.node_id) for n in nodes],
                positions=positions * np.array([100.0, -100.0]),
                labels=[f"{n.node_id} {n.label} C_f {n.confidence:.2f} P {n.potential:.2f}" for n in nodes],
                colors=colours,
                radii=confidence_radii(confidence) * 100.0,
            ),
            rr.GraphEdges([(str(u), str(v)) for u, v in self._memory.edges], graph_type="undirected"),
        )

    def _log_decision(self, entry: Mapping[str, Any]) -> None:
        rr = self._rr
        self._log(
            EXPLANATION,
            rr.TextDocument(explain_decision(entry, self.decision_config), media_type="text/markdown"),
        )
        candidates: Sequence[Mapping[str, Any]] = entry.get("candidates", ())
        if not candidates:
            self._log(CANDIDATES, rr.Clear(recursive=False))
            return
        self._log(
            CANDIDATES,
            rr.Points3D(
                [(c["position_m"][0], c["position_m"][1], c["position_m"][2] + 0.4) for c in candidates],
                labels=[f"{c['node_id']} U={c['utility']:.3f}" for c in candidates],
                colors=[CANDIDATE_COLOUR],
                radii=[0.06],
            ),
            rr.AnyValues(
                node_id=[c["node_id"] for c in candidates],
                relevance=[c["relevance"] for c in candidates],
                confidence=[c["confidence"] for c in candidates],
                potential=[c["potential"] for c in candidates],
                travel_cost_m=[c["travel_cost_m"] for c in candidates],
                utility=[c["utility"] for c in candidates],
            ),
        )

    def _log_subgoal(self, subgoal: Subgoal | None) -> None:
        rr = self._rr
        self._subgoal_id = None if subgoal is None else subgoal.node_id
        self._log_graph()
        if subgoal is None:
            self._log(SUBGOAL, rr.Clear(recursive=False))
            return
        x, y, z = subgoal.position_m
        self._log(
            SUBGOAL,
            rr.Points3D(
                [(x, y, z + 0.4)],
                labels=[f"subgoal {subgoal.node_id} {subgoal.label} U={subgoal.utility:.3f}"],
                colors=[SUBGOAL_COLOUR],
                radii=[0.15],
            ),
        )

    def close(self) -> None:
        """Send the held rows and flush everything to the sinks (the file is complete after this)."""
        self.flush()
        self.recording.flush(timeout_sec=30.0)

    def disconnect(self) -> None:
        """Stop the gRPC server and close the file (after :meth:`close`)."""
        self.recording.disconnect()


def _free_port() -> int:
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])
