"""What behaviours need besides the blackboard: the robot, perception, scorers, config, planner, gait.

A :class:`MissionServices` is built once per mission by the runner and handed to every behaviour's
constructor by the tree loader. Behaviours read time only from ``services.clock()`` (the backend's
clock), never from the wall.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from robots.interface import Robot
from semexp_bt.core.config import SemExpConfig
from semexp_bt.core.relevance import RelevanceScorer
from semexp_bt.nav.controller import PathController
from semexp_bt.perception.interface import PerceptionSource


@dataclass
class StageTimings:
    """Wall-clock seconds spent per stage (arbitration, memory update, decision, planner, ...)."""

    samples: dict[str, list[float]] = field(default_factory=lambda: defaultdict(list))

    def add(self, stage: str, seconds: float) -> None:
        self.samples[stage].append(seconds)

    def summary(self) -> dict[str, dict[str, float]]:
        out: dict[str, dict[str, float]] = {}
        for stage, values in self.samples.items():
            arr = np.asarray(values)
            out[stage] = {
                "count": int(arr.size),
                "median_ms": float(np.median(arr) * 1e3),
                "p95_ms": float(np.percentile(arr, 95) * 1e3),
                "total_s": float(arr.sum()),
            }
        return out


@dataclass
class MissionServices:
    """Everything a behaviour may call.

    Attributes:
        robot: the backend (MuJoCo or ROS 2), through the Robot interface only.
        perception: the evidence source (emulator, real adapters, or a fake).
        relevance: the semantic relevance scorer S in [0, 1] (cached).
        config: the method's hyperparameters.
        planner: the path-following controller (``semexp_bt.app.components.PLANNERS``).
        gait: a callable ``(robot, twist) -> None`` that realises a twist (joint targets from the RL policy
            in dynamic fidelity); None means the backend executes the twist itself.
        rng: the mission's random generator (seeded by the runner).
        timings: per-stage wall-clock timings for the episode record.
        decision_log: one entry per decision step (candidates, utilities, chosen node) for the record.
        events: notable events (confirmations, recoveries, guard trips) with their backend stamps.
        strategy: named switches the benchmark harness sets (e.g. ``{"decision": "utility"}``).
        budget_s: the mission's time budget (its ``budget_s`` setting), on the backend clock.
        place_labels: labels the memory has received as unexplored directions or frontiers (places, not
            objects); the map-based Eq. 7 decay applies to nodes with these labels only.
        privileged_goal_xy: PRIVILEGED, the true goal position ``(x, y)`` in ``map``; the runner sets it
            for the ``oracle`` strategy only (an upper bound, never a method), None otherwise.
        privileged_goal_distance: PRIVILEGED, ``(x, y) -> true geodesic distance (m)`` to the goal's
            success region; set with ``privileged_goal_xy`` when the simulator can provide it.
        privileged_standpoint_xy: PRIVILEGED, for ``oracle_nav``: a free point within the success radius of
            the goal object, at the end of the true shortest path from the start.
    """

    robot: Robot
    perception: PerceptionSource
    relevance: RelevanceScorer
    config: SemExpConfig
    planner: PathController
    gait: Callable[[Robot, Any], None] | None = None
    rng: np.random.Generator = field(default_factory=lambda: np.random.default_rng(0))
    timings: StageTimings = field(default_factory=StageTimings)
    decision_log: list[dict[str, Any]] = field(default_factory=list)
    events: list[dict[str, Any]] = field(default_factory=list)
    strategy: dict[str, str] = field(default_factory=dict)
    budget_s: float = 300.0
    place_labels: set[str] = field(default_factory=set)
    privileged_goal_xy: tuple[float, float] | None = None
    privileged_goal_distance: Callable[[tuple[float, float]], float] | None = None
    privileged_standpoint_xy: tuple[float, float] | None = None

    def clock(self) -> float:
        """The backend clock (sim time in MuJoCo, ROS time on ROS 2)."""
        return self.robot.now_s()

    def log_event(self, kind: str, **details: Any) -> None:
        self.events.append({"stamp_s": round(self.clock(), 3), "kind": kind, **details})


#: The key under which the runner puts the :class:`MissionServices` into ``BuildContext.services``.
SERVICES_KEY = "mission"


def mission_services(context: Any) -> MissionServices:
    """The :class:`MissionServices` a BuildContext carries; a clear error when a tree is built without them."""
    services = getattr(context, "services", {}).get(SERVICES_KEY)
    if not isinstance(services, MissionServices):
        raise RuntimeError(
            "this behaviour needs a robot and perception: build the tree through semexp_bt.app.runner "
            f"(BuildContext.services['{SERVICES_KEY}'] is missing)"
        )
    return services
