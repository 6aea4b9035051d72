"""Scoring one simulated episode against the scene's ground truth: success, path, L*, collisions, clearance.

Two callers score episodes: the in-process episode (``semexp_bt.app.episode``, which also adds the
executive's own record) and the ROS 2 simulation bridge (``sims.ros2_bridge``, which sees the executive
only through its topics). Both need exactly the same definitions (docs/metrics.md), so they live here,
below both. Nothing here reads anything the executive could not have reported: the inputs are the path the
robot took, its safety log, the mission's declared outcome and its confirmed targets.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from semexp_bt.core.scene import SceneObject, SceneSpec
from semexp_bt.core.types import Pose2D, SafetyState
from sims.episodes import Episode
from sims.geodesic import GeodesicOracle


def snap_to_free(
    oracle: GeodesicOracle, xy: tuple[float, float], *, max_m: float
) -> tuple[float, float] | None:
    """The free cell centre nearest ``xy`` within ``max_m`` (memory nodes sit on object surfaces, inside
    the inflated obstacles; the place the robot would stand to reach them is the nearest free cell)."""
    if oracle.is_free(xy):
        return xy
    geometry = oracle.occupancy.geometry
    free = oracle.occupancy.free
    row, col = geometry.cell_of(xy)
    reach = int(math.ceil(max_m / geometry.resolution_m))
    r0, r1 = max(row - reach, 0), min(row + reach + 1, free.shape[0])
    c0, c1 = max(col - reach, 0), min(col + reach + 1, free.shape[1])
    rows, cols = np.nonzero(free[r0:r1, c0:c1])
    if rows.size == 0:
        return None
    centres = geometry.centre_of(rows + r0, cols + c0)
    dist = np.hypot(centres[:, 0] - xy[0], centres[:, 1] - xy[1])
    best = int(np.argmin(dist))
    return (float(centres[best, 0]), float(centres[best, 1])) if dist[best] <= max_m else None


def reached_object(
    scene: SceneSpec, anchor: tuple[float, float], final_xy: tuple[float, float], success_radius_m: float
) -> SceneObject | None:
    """The scene object nearest ``anchor`` (the confirmed target, or the final position), if the robot ended
    within the success radius of it."""
    candidates = [o for o in scene.objects if o.role != "wall"]
    reached = min(candidates, key=lambda o: o.boundary_distance_m(anchor), default=None)
    if reached is not None and reached.boundary_distance_m(final_xy) > success_radius_m:
        return None
    return reached


def path_length_m(positions: Sequence[np.ndarray]) -> float:
    """Length (m) of the polyline through the base positions."""
    path = np.asarray(positions, dtype=float)
    return float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum()) if len(path) > 1 else 0.0


def score_episode(
    *,
    scene: SceneSpec,
    episode: Episode,
    outcome: str,
    found_objects: Sequence[dict[str, Any]],
    positions: Sequence[np.ndarray],
    final_pose: Pose2D,
    safety: SafetyState,
    success_radius_m: float,
    clearance_m: float,
) -> dict[str, Any]:
    """The ground-truth part of an episode record (JSON-serialisable), keys in the record's order.

    Args:
        scene: the scene.
        episode: its sampled start and L*.
        outcome: the mission's declared outcome (``success`` declares success).
        found_objects: the confirmed targets as the executive recorded them (``position_m``, ``robot_xy``).
        positions: the base position after every tick (or control step), the start first.
        final_pose: where the base ended.
        safety: the robot's safety log (collision and clearance events).
        success_radius_m: r_s.
        clearance_m: the clearance threshold for OASR.
    """
    goal = scene.goal
    final_xy = (final_pose.x_m, final_pose.y_m)
    collisions = [e for e in safety.events if e.kind == "collision"]
    breaches = [e for e in safety.events if e.kind == "clearance" and e.distance_m < clearance_m]
    anchor = tuple(found_objects[-1]["position_m"][:2]) if found_objects else final_xy
    reached = reached_object(scene, (anchor[0], anchor[1]), final_xy, success_radius_m)
    declared = outcome == "success"
    # For missions that move on after confirming (search, then return), success is judged where the
    # robot stood when it confirmed the goal object; for the paper's mission that is the final position.
    judged_xy = final_xy
    for entry in found_objects:
        if entry.get("robot_xy") and goal.boundary_distance_m(tuple(entry["robot_xy"])) <= success_radius_m:
            judged_xy = tuple(entry["robot_xy"])
    judged_distance = goal.boundary_distance_m(judged_xy)
    return {
        "goal": {
            "object_id": goal.object_id,
            "name": goal.name,
            "label": goal.label,
            "category": goal.category,
            "position_m": list(goal.position_m),
        },
        "start_pose": {"x_m": episode.start.x_m, "y_m": episode.start.y_m, "yaw_rad": episode.start.yaw_rad},
        "outcome": outcome,
        "success_declared": declared,
        "success": bool(declared and judged_distance <= success_radius_m),
        "success_radius_m": success_radius_m,
        "final_pose": {"x_m": final_pose.x_m, "y_m": final_pose.y_m, "yaw_rad": final_pose.yaw_rad},
        "distance_to_goal_m": goal.boundary_distance_m(final_xy),
        "path_length_m": path_length_m(positions),
        "geodesic_length_m": float(episode.geodesic_length_m),
        "collision": bool(collisions or breaches),
        "collisions": len(collisions),
        "clearance_breaches": len(breaches),
        "min_clearance_m": float(safety.min_clearance_m) if math.isfinite(safety.min_clearance_m) else None,
        "reached_object": None
        if reached is None
        else {"name": reached.name, "label": reached.label, "category": reached.category},
        "reached_category": None if reached is None else reached.category,
        "goal_category": goal.category,
    }


__all__ = ["path_length_m", "reached_object", "score_episode", "snap_to_free"]
