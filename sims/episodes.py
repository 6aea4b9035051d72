"""Episode sampler: a start pose for a scene, drawn from a seed, with its geodesic L*.

A start is valid when the robot centre stands on a free cell of the inflated occupancy grid (see
:mod:`sims.occupancy`) at least :data:`~sims.robot_footprint.START_CLEARANCE_M` from every obstacle
(so no start yaw puts the body in contact), the goal's success region is reachable from it, and deeper than its
rim (:data:`~sims.scenes.placement.GOAL_APPROACH_MARGIN_M` inside the success radius, as the scene's layout
rule asks), and its L* (the oracle's
:meth:`~sims.geodesic.GeodesicOracle.distance_to_object` with the success radius) is at least the
minimum geodesic distance. The minimum is the scene's ``min_geodesic_m`` (``scene.extra``, from its
YAML data: 3.0 m for the large simulation scenes, less for the 30-50 m^2 real-world analogues) unless
the caller passes one.

Seed rule: episode ``seed`` of a scene draws from
``numpy.random.default_rng(SeedSequence([crc32(scene.name), scene.seed, seed]))``: a cell uniformly among
the free, roomy, reachable cells whose distance-field value is at least the minimum, a uniform position within
that cell, and a uniform yaw in [-pi, pi). A draw whose smoothed L* falls below the minimum is redrawn,
up to ``max_tries`` times, then :class:`EpisodeSamplingError` is raised.
"""

from __future__ import annotations

import math
import zlib
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from semexp_bt.core.scene import SceneSpec
from semexp_bt.core.types import InvalidInputError, Pose2D
from sims.geodesic import GeodesicOracle
from sims.robot_footprint import START_CLEARANCE_M
from sims.scenes.placement import DEFAULT_MIN_GEODESIC_M, GOAL_APPROACH_MARGIN_M, GOAL_SUCCESS_RADIUS_M

__all__ = [
    "GOAL_SUCCESS_RADIUS_M",
    "Episode",
    "EpisodeSamplingError",
    "sample_episode",
    "scene_min_geodesic_m",
]


class EpisodeSamplingError(RuntimeError):
    """No valid start was found within the try budget."""


@dataclass(frozen=True)
class Episode:
    """One search episode.

    Attributes:
        scene_name: the scene's key.
        scene_seed: the seed the scene's layout was built from.
        seed: the episode seed the start was drawn from.
        start: the robot's start pose in ``map``.
        goal_object_id: the goal object's id in the scene.
        goal_category: the category SA compares with.
        instruction: the instruction given to the robot.
        geodesic_length_m: L*, the oracle's distance from the start into the success region.
        success_radius_m: the success radius around the goal's footprint that L* used.
        scene_bounds_m: ``(x_min, y_min, x_max, y_max)`` of the scene.
    """

    scene_name: str
    scene_seed: int
    seed: int
    start: Pose2D
    goal_object_id: int
    goal_category: str
    instruction: str
    geodesic_length_m: float
    success_radius_m: float
    scene_bounds_m: tuple[float, float, float, float]

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dictionary."""
        out = asdict(self)
        out["scene_bounds_m"] = list(self.scene_bounds_m)
        return out


def scene_min_geodesic_m(scene: SceneSpec) -> float:
    """The scene's documented minimum start-to-goal geodesic (m)."""
    return float(scene.extra.get("min_geodesic_m", DEFAULT_MIN_GEODESIC_M))  # type: ignore[arg-type]


def sample_episode(
    scene: SceneSpec,
    *,
    seed: int,
    min_geodesic_m: float | None = None,
    max_tries: int = 200,
    success_radius_m: float = GOAL_SUCCESS_RADIUS_M,
    oracle: GeodesicOracle | None = None,
) -> Episode:
    """Draw a start pose for ``scene`` from ``seed``.

    Args:
        scene: the scene.
        seed: the episode seed (non-negative).
        min_geodesic_m: the minimum L*; None uses the scene's own (:func:`scene_min_geodesic_m`).
        max_tries: draws before giving up.
        success_radius_m: the success radius L* is measured to.
        oracle: a ready oracle for ``scene`` (saves rebuilding the grid graph).

    Returns:
        The episode.

    Raises:
        InvalidInputError: a negative seed, minimum, radius or try budget.
        EpisodeSamplingError: no start at least ``min_geodesic_m`` from the goal was found.
    """
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise InvalidInputError(f"seed must be a non-negative integer, got {seed!r}")
    minimum = scene_min_geodesic_m(scene) if min_geodesic_m is None else float(min_geodesic_m)
    if not math.isfinite(minimum) or minimum < 0.0:
        raise InvalidInputError(f"min_geodesic_m must be finite and >= 0, got {min_geodesic_m}")
    if max_tries < 1:
        raise InvalidInputError(f"max_tries must be >= 1, got {max_tries}")
    if oracle is None:
        oracle = GeodesicOracle(scene)
    elif oracle.scene is not scene and oracle.scene != scene:
        raise InvalidInputError("oracle was built for a different scene")
    field = oracle.object_distance_field(scene.goal_object_id, success_radius_m=success_radius_m)
    approach_m = success_radius_m - GOAL_APPROACH_MARGIN_M
    # A start cut off from all but the success region's rim is redrawn (checked per draw, after the draw, so
    # that the draws of every other start stay what they were).
    approach = (
        oracle.object_distance_field(scene.goal_object_id, success_radius_m=approach_m)
        if approach_m > 0
        else field
    )
    # Field values over-estimate the smoothed L* by < 3 %, so this pre-filter loses almost no starts
    # and the exact check below keeps the guarantee.
    roomy = oracle.occupancy.clearance_m >= START_CLEARANCE_M
    rows, cols = np.nonzero(np.isfinite(field) & (field >= minimum) & roomy)
    if rows.size == 0:
        raise EpisodeSamplingError(
            f"scene '{scene.name}' (seed {scene.seed}): no free cell {START_CLEARANCE_M} m from obstacles "
            f"is {minimum:.2f} m or more from the goal"
        )
    rng = np.random.default_rng(
        np.random.SeedSequence([zlib.crc32(scene.name.encode()), scene.seed, int(seed)])
    )
    geometry = oracle.occupancy.geometry
    for _ in range(max_tries):
        index = int(rng.integers(rows.size))
        corner = geometry.centre_of(rows[index], cols[index]) - 0.5 * geometry.resolution_m
        # Stay a hair inside the cell so floor() maps the point back to it.
        xy = np.round(corner + rng.uniform(0.01, 0.99, size=2) * geometry.resolution_m, 4)
        yaw = float(rng.uniform(-math.pi, math.pi))
        length = oracle.distance_to_object(xy, scene.goal_object_id, success_radius_m=success_radius_m)
        approachable = math.isfinite(oracle.field_value(approach, xy))
        if oracle.is_free(xy) and math.isfinite(length) and length >= minimum and approachable:
            return Episode(
                scene_name=scene.name,
                scene_seed=scene.seed,
                seed=int(seed),
                start=Pose2D(float(xy[0]), float(xy[1]), round(yaw, 5)),
                goal_object_id=scene.goal_object_id,
                goal_category=scene.goal_category,
                instruction=scene.instruction,
                geodesic_length_m=length,
                success_radius_m=float(success_radius_m),
                scene_bounds_m=scene.bounds_m,
            )
    raise EpisodeSamplingError(
        f"scene '{scene.name}' (seed {scene.seed}), episode seed {seed}: no start with L* >= {minimum:.2f} m "
        f"in {max_tries} tries"
    )
