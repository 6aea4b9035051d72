"""Decision baselines that are not hyperparameter settings of Eq. 9: HOV-SG, nearest frontier, oracle.

Every baseline sees exactly what the paper's decision sees: the candidate set of Eq. 8 with each
candidate's relevance S (floored as in :func:`semexp_bt.core.decision.decide`), fused confidence C_f,
exploration potential P_explore and travel cost d. Only the choice differs (Table II isolates the
decision criterion on the same memory):

- ``hovsg`` (HOV-SG-style hierarchical choice, region first, then object): candidates are grouped
  into square regions of :attr:`BaselineParams.region_size_m` on the ground plane (HOV-SG groups
  objects into rooms; our scenes have no room labels, so a grid cell stands in for a room). The region
  with the highest mean relevance wins, then the node with the highest ``S * C_f`` inside it. Travel
  cost plays no part, as in HOV-SG's language query; unreachable nodes are never chosen.
- ``nearest_frontier`` (geometry only): the reachable candidate with the smallest travel cost among
  those whose potential is at least :attr:`BaselineParams.frontier_potential` (all candidates when
  none is). Semantics are ignored.
- ``oracle`` (privileged): the candidate minimising ``d(robot, node) + d(node, goal)`` where
  ``d(node, goal)`` comes from the true goal position (the caller passes it per node). It is the
  GNSA oracle used as a policy, an upper bound on decision quality and a practical upper bound on SPL
  for this tree (the robot still moves node to node; the SPL of a geodesic-following robot is 1).

Ties go to the lowest node id, as in the paper's decision. The result is a
:class:`~semexp_bt.core.decision.DecisionResult` whose candidates keep their Eq. 9 scores (so the episode
record has one format for every strategy) and whose subgoal's ``utility`` is the baseline's own score.

This is a core module: standard library and numpy only (plus the core decision module).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from semexp_bt.core.config import DecisionConfig
from semexp_bt.core.decision import (
    REASON_EMPTY,
    REASON_OK,
    REASON_TIE,
    CandidateScore,
    DecisionResult,
    decide,
)
from semexp_bt.core.relevance import RelevanceScorer
from semexp_bt.core.types import InvalidInputError, NodeState, Subgoal

#: Decision kinds this module implements (``services.strategy["decision"]``).
BASELINE_DECISIONS = ("hovsg", "nearest_frontier", "oracle")

#: Reason when no candidate is reachable (every travel cost infinite).
REASON_UNREACHABLE = "no reachable candidate"


@dataclass(frozen=True)
class BaselineParams:
    """Parameters of the baselines (fixed across every comparison).

    Attributes:
        region_size_m: side of the square regions HOV-SG's region-first choice groups candidates into.
            3 m is about the size of a small room or a warehouse aisle bay in our scenes.
        frontier_potential: a candidate with at least this exploration potential counts as a frontier
            for ``nearest_frontier`` (a fresh node starts at potential 1 and decays with visits).
    """

    region_size_m: float = 3.0
    frontier_potential: float = 0.5

    def __post_init__(self) -> None:
        if not (math.isfinite(self.region_size_m) and self.region_size_m > 0.0):
            raise InvalidInputError(f"region_size_m must be a finite number > 0, got {self.region_size_m!r}")
        if not (math.isfinite(self.frontier_potential) and 0.0 <= self.frontier_potential <= 1.0):
            raise InvalidInputError(f"frontier_potential must lie in [0, 1], got {self.frontier_potential!r}")


def hovsg_choice(candidates: Sequence[CandidateScore], *, region_size_m: float) -> tuple[int, float] | None:
    """HOV-SG-style region-then-object choice.

    Args:
        candidates: scored candidates (ascending node id, as :func:`decide` returns them).
        region_size_m: side of the square regions.

    Returns:
        ``(index into candidates, node score S * C_f)`` or None when no candidate is reachable.
    """
    reachable = [i for i, c in enumerate(candidates) if math.isfinite(c.travel_cost_m)]
    if not reachable:
        return None
    regions: dict[tuple[int, int], list[int]] = {}
    for i in reachable:
        x, y = candidates[i].position_m[0], candidates[i].position_m[1]
        regions.setdefault((math.floor(x / region_size_m), math.floor(y / region_size_m)), []).append(i)
    # Region score: mean relevance; ties go to the region holding the lowest node id (deterministic).
    best_region = max(
        regions.values(),
        key=lambda members: (float(np.mean([candidates[i].relevance for i in members])), -min(members)),
    )
    best = max(best_region, key=lambda i: (candidates[i].relevance * candidates[i].confidence, -i))
    return best, candidates[best].relevance * candidates[best].confidence


def nearest_frontier_choice(
    candidates: Sequence[CandidateScore], *, frontier_potential: float
) -> tuple[int, float] | None:
    """The nearest reachable frontier candidate, semantics ignored.

    Returns:
        ``(index into candidates, travel cost in metres)`` or None when no candidate is reachable.
    """
    reachable = [i for i, c in enumerate(candidates) if math.isfinite(c.travel_cost_m)]
    frontier = [i for i in reachable if candidates[i].potential >= frontier_potential] or reachable
    if not frontier:
        return None
    best = min(frontier, key=lambda i: (candidates[i].travel_cost_m, i))
    return best, candidates[best].travel_cost_m


def oracle_choice(
    candidates: Sequence[CandidateScore], *, goal_distances_m: Mapping[int, float]
) -> tuple[int, float] | None:
    """The candidate minimising travel cost plus its true distance to the goal (privileged).

    Args:
        candidates: scored candidates.
        goal_distances_m: node id -> distance from the node to the goal in metres (``inf`` when the goal
            cannot be reached from there; a missing node counts as ``inf``).

    Returns:
        ``(index into candidates, total distance in metres)`` or None when no candidate has a finite total.

    Raises:
        InvalidInputError: on a NaN or negative goal distance.
    """
    best: int | None = None
    best_total = math.inf
    for i, c in enumerate(candidates):
        to_goal = float(goal_distances_m.get(c.node_id, math.inf))
        if math.isnan(to_goal) or to_goal < 0.0:
            raise InvalidInputError(f"goal distance of node {c.node_id} must be >= 0 or inf, got {to_goal!r}")
        total = c.travel_cost_m + to_goal
        if total < best_total:  # strict: on ties the lower index (lower node id) stays
            best, best_total = i, total
    return None if best is None else (best, best_total)


def select_subgoal(
    kind: str,
    *,
    nodes: Sequence[NodeState],
    instruction: str,
    relevance: RelevanceScorer,
    travel_costs: Mapping[int, float],
    config: DecisionConfig,
    goal_distances_m: Mapping[int, float] | None = None,
    params: BaselineParams | None = None,
) -> DecisionResult:
    """Run baseline ``kind`` on the memory's nodes.

    Args:
        kind: one of :data:`BASELINE_DECISIONS`.
        nodes: the memory's nodes.
        instruction: the user's instruction (for relevance).
        relevance: S_LLM.
        travel_costs: d(P_robot, P_v) per node id (as for :func:`decide`).
        config: the decision config (tau_p, relevance floor and the Eq. 9 terms recorded per candidate).
        goal_distances_m: node id -> true distance to the goal; required by ``oracle`` only.
        params: baseline parameters (defaults when None).

    Returns:
        A :class:`DecisionResult`: the candidates of Eq. 8 with their Eq. 9 scores, and the baseline's
        subgoal (None when the candidate set is empty or nothing is reachable).

    Raises:
        ValueError: on an unknown kind, or ``oracle`` without goal distances.
        InvalidInputError: on malformed nodes, costs or scores (as :func:`decide`).
    """
    if kind not in BASELINE_DECISIONS:
        raise ValueError(f"unknown baseline decision {kind!r}; expected one of {list(BASELINE_DECISIONS)}")
    if kind == "oracle" and goal_distances_m is None:
        raise ValueError("the oracle decision needs goal_distances_m (privileged goal position)")
    params = params or BaselineParams()
    scored = decide(nodes=nodes, instruction=instruction, relevance=relevance, travel_costs=travel_costs,
                    config=config)  # fmt: skip
    candidates = scored.candidates
    if not candidates:
        return DecisionResult(subgoal=None, candidates=(), reason=REASON_EMPTY, tie=False)
    if kind == "hovsg":
        choice = hovsg_choice(candidates, region_size_m=params.region_size_m)
    elif kind == "nearest_frontier":
        choice = nearest_frontier_choice(candidates, frontier_potential=params.frontier_potential)
    else:
        assert goal_distances_m is not None
        choice = oracle_choice(candidates, goal_distances_m=goal_distances_m)
    if choice is None:
        return DecisionResult(subgoal=None, candidates=candidates, reason=REASON_UNREACHABLE, tie=False)
    index, score = choice
    chosen = candidates[index]
    tie = _is_tie(kind, candidates, index, score, goal_distances_m, params)
    subgoal = Subgoal(node_id=chosen.node_id, position_m=chosen.position_m, label=chosen.label,
                      utility=float(score))  # fmt: skip
    return DecisionResult(
        subgoal=subgoal, candidates=candidates, reason=REASON_TIE if tie else REASON_OK, tie=tie
    )


def _is_tie(
    kind: str,
    candidates: Sequence[CandidateScore],
    index: int,
    score: float,
    goal_distances_m: Mapping[int, float] | None,
    params: BaselineParams,
) -> bool:
    """Whether another candidate scored exactly as the chosen one (reported, broken by node id)."""
    reachable = [c for c in candidates if math.isfinite(c.travel_cost_m)]
    if kind == "nearest_frontier":
        pool = [c for c in reachable if c.potential >= params.frontier_potential] or reachable
        return sum(c.travel_cost_m == score for c in pool) > 1
    others = [c for i, c in enumerate(candidates) if i != index and math.isfinite(c.travel_cost_m)]
    if kind == "oracle":
        assert goal_distances_m is not None
        return any(c.travel_cost_m + goal_distances_m.get(c.node_id, math.inf) == score for c in others)
    return False  # HOV-SG's two-level choice breaks ties inside its max; not reported
