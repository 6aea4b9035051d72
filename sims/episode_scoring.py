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
from sims.naming import named_objects


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


def _distance_to_any(objects: Sequence[SceneObject], xy: tuple[float, float]) -> float:
    return min((o.boundary_distance_m(xy) for o in objects), default=math.inf)


def judged_success(
    *,
    instructions: Sequence[str],
    named: dict[str, tuple[SceneObject, ...]],
    found_objects: Sequence[dict[str, Any]],
    final_xy: tuple[float, float],
    success_radius_m: float,
) -> bool:
    """Whether every instruction's object was reached: for each instruction, the robot stood within r_s of
    an object the instruction names (``sims.naming.named_objects``, the ground truth of naming) where it
    confirmed an object for that instruction, or, for the last instruction, where the mission ended. An
    instruction that names nothing in the scene never succeeds."""
    for index, instruction in enumerate(instructions):
        spots = [
            tuple(e["robot_xy"])
            for e in found_objects
            if e.get("robot_xy") and e.get("instruction", instruction) == instruction
        ]
        if index == len(instructions) - 1:
            spots.append(final_xy)
        if not any(_distance_to_any(named[instruction], (s[0], s[1])) <= success_radius_m for s in spots):
            return False
    return True


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
    instructions: Sequence[str] | None = None,
) -> dict[str, Any]:
    """The ground-truth part of an episode record (JSON-serialisable), keys in the record's order.

    Success is judged at the objects the instructions name (any wording of the goal names the goal; a
    distractor's name names the distractor; an absent object's name names nothing), not at the scene's
    goal only.

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
        instructions: the mission's instructions, in order (None: the scene's own).
    """
    goal = scene.goal
    instructions = list(instructions) if instructions else [scene.instruction]
    named = {instruction: named_objects(scene, instruction) for instruction in dict.fromkeys(instructions)}
    last_named = named[instructions[-1]]
    final_xy = (final_pose.x_m, final_pose.y_m)
    collisions = [e for e in safety.events if e.kind == "collision"]
    breaches = [e for e in safety.events if e.kind == "clearance" and e.distance_m < clearance_m]
    anchor = tuple(found_objects[-1]["position_m"][:2]) if found_objects else final_xy
    reached = reached_object(scene, (anchor[0], anchor[1]), final_xy, success_radius_m)
    declared = outcome == "success"
    success = declared and judged_success(
        instructions=instructions,
        named=named,
        found_objects=found_objects,
        final_xy=final_xy,
        success_radius_m=success_radius_m,
    )
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
        "success": bool(success),
        "success_radius_m": success_radius_m,
        "final_pose": {"x_m": final_pose.x_m, "y_m": final_pose.y_m, "yaw_rad": final_pose.yaw_rad},
        "distance_to_goal_m": _distance_to_any(last_named, final_xy)
        if last_named
        else goal.boundary_distance_m(final_xy),
        "path_length_m": path_length_m(positions),
        "geodesic_length_m": float(episode.geodesic_length_m),
        "collision": bool(collisions or breaches),
        "collisions": len(collisions),
        "clearance_breaches": len(breaches),
        # Over the whole episode: the last step's distance says nothing of a breach a minute earlier.
        "min_clearance_m": float(safety.least_clearance_m)
        if math.isfinite(safety.least_clearance_m)
        else None,
        "reached_object": None
        if reached is None
        else {
            "name": reached.name,
            "label": reached.label,
            "category": reached.category,
            "role": reached.role,
        },
        "reached_category": None if reached is None else reached.category,
        "reached_named": reached is not None and reached in last_named,
        "named_objects": {i: [o.name for o in objects] for i, objects in named.items()},
        "goal_category": goal.category,
    }


__all__ = ["judged_success", "path_length_m", "reached_object", "score_episode", "snap_to_free"]
