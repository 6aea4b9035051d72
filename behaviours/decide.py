"""Decide: utility-driven subgoal selection on the topological memory (paper Eq. 8-10).

Semantics (it never returns RUNNING):

- SUCCESS: a subgoal was chosen and written to ``subgoal``.
- FAILURE: the candidate set is empty or every utility is zero (the feedback says which); ``subgoal`` is
  then None, so a recovery branch can act.
- Halted: nothing to undo; the relaxed choices (below) are kept over the mission.

Reads ``memory``, ``instruction`` and ``local_map`` (for ``travel_cost: costmap`` only); writes ``subgoal``
and ``decision`` (the whole DecisionResult).
Every decision step, with all candidates and utilities, also goes to the episode record
(``services.decision_log``).

It filters memory nodes by exploration potential (Eq. 8), scores each candidate with
U = S^alpha C^beta P^eta exp(-gamma d) (Eq. 9) where S is the instruction relevance of the node's label and
d the travel cost from the robot (graph shortest path, Euclidean, or the shortest way on the costmap, per
config ``decision.travel_cost``), and takes the greedy
argmax (Eq. 10). A strategy (``services.strategy["decision"]``) may replace Eq. 8-10 with a baseline
(``semexp_bt.core.decision_baselines``); the oracle baseline reads the privileged goal the runner hands it
and raises ``RuntimeError`` without one.

When Eq. 8 leaves no candidate (every node's potential has decayed under tau_p) and
``relax_when_exhausted`` is set, it decides once more over the nodes the robot has never reached, with
tau_p = 0, and says so in the reason ("relaxed: ..."). In a small room the decay of Eq. 7 can otherwise
empty the candidate set while places the robot only glimpsed remain; the paper does not say what to do
then, and turning on the spot until the budget runs out is the worst answer. Each node is chosen this
way at most once per mission: a relaxed choice the robot failed to reach (its potential was lowered by
the recovery, never raised) would otherwise be chosen again and again, and the sweep showed robots
spending half their budget shuttling toward one unreachable node. Once every never-reached node has
had its chance, Decide fails and the tree looks around instead.

Example:
    - type: Decide
      name: Decide
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Mapping, Sequence
from typing import Any, Literal

import numpy as np
import py_trees

from behaviours.base import SemExpBehaviour
from behaviours.spec import param
from semexp_bt.core.config import DecisionConfig
from semexp_bt.core.decision import REASON_EMPTY, DecisionResult, decide
from semexp_bt.core.decision_baselines import BASELINE_DECISIONS, select_subgoal
from semexp_bt.core.memory import TopologicalMemory
from semexp_bt.core.types import NodeState, Pose2D, Subgoal
from semexp_bt.nav.global_planner import GlobalPlanner


class Decide(SemExpBehaviour):
    READS = ("memory", "instruction", "local_map")
    WRITES = ("subgoal", "decision")

    relax_when_exhausted: bool = param(
        "bool",
        doc="when no node passes tau_p, decide again over the never-reached nodes with tau_p = 0 "
        "(each node at most once per mission)",
        default=True,
    )

    def __init__(self, name: str, **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        # Per tree, so per mission: a new mission builds a new tree.
        self._relaxed_choices: set[int] = set()
        self._planner = GlobalPlanner()

    def update(self) -> py_trees.common.Status:
        memory = self.read("memory")
        pose = self.services.robot.base_pose()
        config = self.services.config.decision
        instruction = self.read("instruction")
        with self.timed("decision"):
            nodes = memory.nodes()
            costs = self._travel_costs(memory, nodes, pose, config.travel_cost)
            result = self._choose(nodes=nodes, instruction=instruction, costs=costs, config=config)
            if result.subgoal is None and result.reason == REASON_EMPTY and self.relax_when_exhausted:
                unreached = [
                    n
                    for n in nodes
                    if n.visits == 0
                    and not n.is_master
                    and n.potential > 0.0
                    and n.node_id not in self._relaxed_choices
                ]
                relaxed = self._choose(
                    nodes=unreached,
                    instruction=instruction,
                    costs=costs,
                    config=dataclasses.replace(config, tau_p=0.0),
                )
                result = dataclasses.replace(relaxed, reason=f"relaxed: {relaxed.reason}")
                if result.subgoal is not None:
                    self._relaxed_choices.add(result.subgoal.node_id)
        self.write("decision", result)
        self.write("subgoal", result.subgoal)
        self.services.decision_log.append(
            {
                "stamp_s": round(self.now_s(), 3),
                "robot_xy": [round(pose.x_m, 3), round(pose.y_m, 3)],
                "selected_node_id": None if result.subgoal is None else result.subgoal.node_id,
                "reason": result.reason,
                "candidates": [
                    {
                        "node_id": c.node_id,
                        "label": c.label,
                        "position_m": [round(v, 3) for v in c.position_m],
                        "relevance": round(c.relevance, 4),
                        "confidence": round(c.confidence, 4),
                        "potential": round(c.potential, 4),
                        "travel_cost_m": round(c.travel_cost_m, 3),
                        "utility": round(c.utility, 6),
                    }
                    for c in result.candidates
                ],
            }
        )
        if result.subgoal is None:
            self.feedback_message = f"no subgoal: {result.reason}"
            return py_trees.common.Status.FAILURE
        sg = result.subgoal
        self.feedback_message = f"node {sg.node_id} {sg.label!r} U={sg.utility:.3f}"
        return py_trees.common.Status.SUCCESS

    def _travel_costs(
        self,
        memory: TopologicalMemory,
        nodes: Sequence[NodeState],
        pose: Pose2D,
        mode: Literal["graph", "euclidean", "costmap"],
    ) -> dict[int, float]:
        """d(P_robot, P_v) of Eq. 9 for every node, in the config's ``travel_cost`` mode."""
        robot = (pose.x_m, pose.y_m, 0.0)
        if mode != "costmap":
            return memory.travel_costs(from_position_m=robot, mode=mode)
        costmap = self.read("local_map")
        distances = None
        if costmap is not None and nodes:
            targets = np.asarray([n.position_m[:2] for n in nodes], dtype=float)
            distances = self._planner.travel_distances(
                costmap, start_xy=(pose.x_m, pose.y_m), targets_xy=targets
            )
        if distances is None:  # no costmap yet, or the robot stands inside the inflation
            return memory.travel_costs(from_position_m=robot, mode="graph")
        return {n.node_id: float(d) for n, d in zip(nodes, distances, strict=True)}

    def _choose(
        self,
        *,
        nodes: Sequence[NodeState],
        instruction: str,
        costs: Mapping[int, float],
        config: DecisionConfig,
    ) -> DecisionResult:
        """Eq. 8-10, or the strategy's baseline choice (``services.strategy["decision"]``).

        The Eq. 9 weightings (utility, bayesian, llm_relevance, vlfm) are configs of :func:`decide`; the
        other baselines (HOV-SG, nearest frontier, oracle) choose differently over the same candidates.
        """
        kind = self.services.strategy.get("decision", "utility")
        if kind == "oracle_nav":
            return self._privileged_goal()
        if kind not in BASELINE_DECISIONS:
            return decide(nodes=nodes, instruction=instruction, relevance=self.services.relevance,
                          travel_costs=costs, config=config)  # fmt: skip
        goal_distances = None
        if kind == "oracle":
            # Privileged: the runner hands the true goal to the oracle strategy only.
            distance = self.services.privileged_goal_distance
            if distance is None:
                goal_xy = self.services.privileged_goal_xy
                if goal_xy is None:
                    raise RuntimeError(
                        "strategy 'oracle' needs services.privileged_goal_xy (set by the runner)"
                    )
                distance = functools.partial(_straight_line_distance, goal_xy=goal_xy)
            goal_distances = {n.node_id: distance((n.position_m[0], n.position_m[1])) for n in nodes}
        return select_subgoal(kind, nodes=nodes, instruction=instruction, relevance=self.services.relevance,
                              travel_costs=costs, config=config, goal_distances_m=goal_distances)  # fmt: skip

    def _privileged_goal(self) -> DecisionResult:
        """``oracle_nav`` (PRIVILEGED, the execution layer's ceiling): the true goal is the subgoal."""
        goal_xy = self.services.privileged_goal_xy
        if goal_xy is None:
            raise RuntimeError("strategy 'oracle_nav' needs services.privileged_goal_xy (set by the runner)")
        subgoal = Subgoal(node_id=PRIVILEGED_GOAL_NODE_ID, position_m=(goal_xy[0], goal_xy[1], 0.0),
                          label="goal (privileged)", utility=1.0)  # fmt: skip
        return DecisionResult(subgoal=subgoal, candidates=(), reason="privileged goal")


#: ``node_id`` of the privileged goal subgoal of ``oracle_nav`` (no memory node holds it).
PRIVILEGED_GOAL_NODE_ID = -1


def _straight_line_distance(xy: tuple[float, float], *, goal_xy: tuple[float, float]) -> float:
    """The oracle's fallback when no geodesic distance is given: straight to the goal."""
    return math.hypot(xy[0] - goal_xy[0], xy[1] - goal_xy[1])
