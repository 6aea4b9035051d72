"""Utility-driven subgoal decision on the topological memory (paper Sec. III-E, Eq. 8-10).

- Eq. 8, candidate set: ``V_c = {v in V | P_explore(v) >= tau_p}`` (the master node excluded, see
  :func:`candidate_set`).
- Eq. 9, semantic utility: ``U(v) = S(v)^alpha * C_f(v)^beta * P_explore(v)^eta * exp(-gamma * d(v))``.
- Eq. 10, greedy choice: ``v* = argmax_{v in V_c} U(v)``; the subgoal is ``P_{v*}``.

Choices where the paper is silent (see ``docs/decision.md``): an unreachable node (infinite or missing
travel cost) has utility 0; ``0^0 = 1`` (an exponent of 0 switches its factor off); utilities within
``tie_tolerance`` (relative) of the best are a tie, broken by the lowest node id and reported; when every
utility is 0 there is no subgoal (the executive falls back, e.g. to a panoramic rescan) instead of an
arbitrary argmax; any NaN is an :class:`InvalidInputError`, never a NaN subgoal.

This is a core module: standard library and numpy only.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from semexp_bt.core.config import DecisionConfig
from semexp_bt.core.relevance import RelevanceScorer
from semexp_bt.core.types import InvalidInputError, NodeState, Subgoal

FloatArray = npt.NDArray[np.float64]

#: Reasons a :class:`DecisionResult` gives.
REASON_OK = "ok"
REASON_EMPTY = "empty candidate set"
REASON_ALL_ZERO = "all utilities zero"
REASON_TIE = "tie broken by lowest node id"


class CandidateScore(NamedTuple):
    """One candidate's terms of Eq. 9 and its utility.

    A named tuple rather than a frozen dataclass: the decision builds one per candidate every tick,
    and a tuple is built several times faster (it dominated the 10k-candidate profile).

    Attributes:
        node_id: the memory node.
        label: its semantic label L_v.
        position_m: the node's ``(x, y, z)`` in ``map``.
        relevance: S_LLM(instruction, L_v) in [0, 1].
        confidence: fused confidence C_f in [0, 1].
        potential: exploration potential P_explore in [0, 1].
        travel_cost_m: d(P_robot, P_v); ``inf`` when unreachable (or absent from the travel costs).
        utility: U(v) in [0, 1].
    """

    node_id: int
    label: str
    position_m: tuple[float, float, float]
    relevance: float
    confidence: float
    potential: float
    travel_cost_m: float
    utility: float


@dataclass(frozen=True)
class DecisionResult:
    """The outcome of one decision (Eq. 10).

    Attributes:
        subgoal: the selected node as a :class:`Subgoal`, or None (empty candidate set, all utilities 0).
        candidates: every candidate of Eq. 8 with its scores, ordered by ascending node id (independent
            of the order the memory listed its nodes in). :meth:`ranked` orders them by utility.
        reason: one of :data:`REASON_OK`, :data:`REASON_EMPTY`, :data:`REASON_ALL_ZERO`,
            :data:`REASON_TIE`.
        tie: more than one candidate was within the tie tolerance of the best utility.
    """

    subgoal: Subgoal | None
    candidates: tuple[CandidateScore, ...]
    reason: str
    tie: bool = False

    def ranked(self) -> tuple[CandidateScore, ...]:
        """Candidates by descending utility, then ascending node id."""
        return tuple(sorted(self.candidates, key=lambda c: (-c.utility, c.node_id)))


def candidate_set(
    nodes: Sequence[NodeState], *, tau_p: float, include_master: bool = False
) -> list[NodeState]:
    """Eq. 8: the nodes whose exploration potential is at least ``tau_p``, by ascending node id.

    The master node v_m (the initial viewpoint) is excluded by default: the robot starts there and its
    panoramic scan already observed its surroundings, so returning to it is never a useful subgoal.
    Pass ``include_master=True`` for the paper's literal set.

    Raises:
        InvalidInputError: on a NaN or out-of-range potential or ``tau_p``, or a duplicate node id.
    """
    _require_tau(tau_p)
    _validate_nodes(nodes)
    chosen = [n for n in nodes if n.potential >= tau_p and (include_master or not n.is_master)]
    return sorted(chosen, key=lambda n: n.node_id)


def utility(
    *, relevance: float, confidence: float, potential: float, travel_cost_m: float, config: DecisionConfig
) -> float:
    """Eq. 9 for one node: ``S^alpha * C^beta * P^eta * exp(-gamma * d)``.

    Args:
        relevance: S_LLM in [0, 1].
        confidence: C_f in [0, 1].
        potential: P_explore in [0, 1].
        travel_cost_m: d >= 0 in metres; ``inf`` means unreachable and gives 0.
        config: exponents alpha, beta, eta and rate gamma.

    Raises:
        InvalidInputError: naming the argument, on NaN or out-of-range input.
    """
    return float(
        utilities(
            relevance=np.array([relevance], dtype=float),
            confidence=np.array([confidence], dtype=float),
            potential=np.array([potential], dtype=float),
            travel_cost_m=np.array([travel_cost_m], dtype=float),
            config=config,
        )[0]
    )


def utilities(
    *,
    relevance: npt.ArrayLike,
    confidence: npt.ArrayLike,
    potential: npt.ArrayLike,
    travel_cost_m: npt.ArrayLike,
    config: DecisionConfig,
) -> FloatArray:
    """Eq. 9 over arrays of equal shape (vectorised :func:`utility`).

    Raises:
        InvalidInputError: naming the argument, on NaN, out-of-range values or mismatched shapes.
    """
    s = _unit_array("relevance", relevance)
    c = _unit_array("confidence", confidence)
    p = _unit_array("potential", potential)
    d = np.asarray(travel_cost_m, dtype=float)
    if np.isnan(d).any():
        raise InvalidInputError(f"travel_cost_m must not be NaN, got {_first_bad(d, np.isnan(d))}")
    if (d < 0.0).any():
        raise InvalidInputError(f"travel_cost_m must be >= 0 (or inf), got {_first_bad(d, d < 0.0)}")
    if not (s.shape == c.shape == p.shape == d.shape):
        raise InvalidInputError(
            f"relevance, confidence, potential and travel_cost_m must share a shape, got "
            f"{s.shape}, {c.shape}, {p.shape}, {d.shape}"
        )
    reachable = np.isfinite(d)
    # exp(-gamma * inf) is 0 for gamma > 0 but NaN for gamma = 0; an unreachable node is never a
    # subgoal, whatever gamma says, so it gets 0 explicitly.
    decay = np.exp(-config.gamma * np.where(reachable, d, 0.0))
    u = np.power(s, config.alpha) * np.power(c, config.beta) * np.power(p, config.eta) * decay
    return np.where(reachable, u, 0.0)


def decide(
    *,
    nodes: Sequence[NodeState],
    instruction: str,
    relevance: RelevanceScorer,
    travel_costs: Mapping[int, float],
    config: DecisionConfig,
    include_master: bool = False,
) -> DecisionResult:
    """Eq. 8-10: filter candidates, score them, pick the greedy subgoal.

    Args:
        nodes: the memory's nodes (any order; the result does not depend on it).
        instruction: the user's instruction, passed to the relevance scorer.
        relevance: S_LLM; batched once over the candidates' distinct labels (wrap it in
            ``CachedRelevance`` so repeated decisions cost dictionary lookups).
        travel_costs: d(P_robot, P_v) per node id in metres (``TopologicalMemory.travel_costs``). A
            candidate missing from it, or with ``inf``, is unreachable: utility 0.
        config: tau_p, exponents, gamma, tie tolerance.
        include_master: keep the master node in the candidate set (see :func:`candidate_set`).

    Returns:
        A :class:`DecisionResult`; ``subgoal`` is None when the candidate set is empty or every
        utility is 0.

    Raises:
        InvalidInputError: on NaN or out-of-range node fields, travel costs or relevance scores, or
            duplicate node ids; the message names the node.
    """
    candidates = candidate_set(nodes, tau_p=config.tau_p, include_master=include_master)
    if not candidates:
        return DecisionResult(subgoal=None, candidates=(), reason=REASON_EMPTY, tie=False)

    ids = np.array([n.node_id for n in candidates], dtype=np.int64)
    labels = [n.label for n in candidates]
    positions = list(map(tuple, np.array([n.position_m for n in candidates], dtype=float).tolist()))
    conf = np.array([n.confidence for n in candidates], dtype=float)
    pot = np.array([n.potential for n in candidates], dtype=float)
    inf = float("inf")
    _check_travel_costs(travel_costs)
    dist = np.array([travel_costs.get(n.node_id, inf) for n in candidates], dtype=float)

    unique_labels = sorted(set(labels))
    label_scores = np.asarray(relevance.scores(instruction=instruction, labels=unique_labels), dtype=float)
    if label_scores.shape != (len(unique_labels),):
        raise InvalidInputError(
            f"relevance scorer returned shape {label_scores.shape} for {len(unique_labels)} labels"
        )
    bad = ~(np.isfinite(label_scores) & (label_scores >= 0.0) & (label_scores <= 1.0))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InvalidInputError(
            f"relevance for label {unique_labels[i]!r} must be finite and in [0, 1], got {label_scores[i]!r}"
        )
    by_label = dict(zip(unique_labels, label_scores.tolist(), strict=True))
    # A label that says nothing about the instruction ("open corridor") still marks a place worth
    # exploring: the floor keeps such nodes rankable by confidence, potential and cost instead of all
    # collapsing to utility 0. The recorded relevance is the floored value the utility used.
    rel = np.maximum(np.array([by_label[lb] for lb in labels], dtype=float), config.relevance_floor)

    u = utilities(relevance=rel, confidence=conf, potential=pot, travel_cost_m=dist, config=config)
    rows = tuple(
        map(CandidateScore._make, zip(ids.tolist(), labels, positions, rel.tolist(), conf.tolist(),
                                      pot.tolist(), dist.tolist(), u.tolist(), strict=True))
    )  # fmt: skip

    best = float(u.max())
    if best <= 0.0:
        return DecisionResult(subgoal=None, candidates=rows, reason=REASON_ALL_ZERO, tie=False)
    # Candidates are sorted by node id, so the first index within tolerance is the lowest id.
    within = np.flatnonzero(u >= best - config.tie_tolerance * best)
    chosen = int(within[0])
    tie = within.size > 1
    node = candidates[chosen]
    subgoal = Subgoal(
        node_id=node.node_id,
        position_m=positions[chosen],
        label=node.label,
        utility=float(u[chosen]),
    )
    return DecisionResult(subgoal=subgoal, candidates=rows, reason=REASON_TIE if tie else REASON_OK, tie=tie)


# --------------------------------------------------------------------------------------------------
# Validation helpers
# --------------------------------------------------------------------------------------------------


def _require_tau(tau_p: float) -> None:
    if not (np.isfinite(tau_p) and 0.0 <= tau_p <= 1.0):
        raise InvalidInputError(f"tau_p must be finite and in [0, 1], got {tau_p!r}")


def _unit_array(name: str, values: npt.ArrayLike) -> FloatArray:
    arr = np.asarray(values, dtype=float)
    bad = ~(np.isfinite(arr) & (arr >= 0.0) & (arr <= 1.0))
    if bad.any():
        raise InvalidInputError(f"{name} must be finite and in [0, 1], got {_first_bad(arr, bad)}")
    return arr


def _first_bad(arr: FloatArray, bad: npt.NDArray[np.bool_]) -> str:
    idx = np.argwhere(bad)[0]
    where = f" at index {tuple(int(i) for i in idx)}" if arr.ndim else ""
    return f"{arr[tuple(idx)]!r}{where}"


def _validate_nodes(nodes: Sequence[NodeState]) -> None:
    if not nodes:
        return
    conf = np.array([n.confidence for n in nodes], dtype=float)
    pot = np.array([n.potential for n in nodes], dtype=float)
    for field_name, values in (("confidence", conf), ("potential", pot)):
        bad = ~(np.isfinite(values) & (values >= 0.0) & (values <= 1.0))
        if bad.any():
            node = nodes[int(np.flatnonzero(bad)[0])]
            raise InvalidInputError(
                f"node {node.node_id} ({node.label!r}): {field_name} must be finite and in [0, 1], "
                f"got {getattr(node, field_name)!r}"
            )
    ids = [n.node_id for n in nodes]
    if len(set(ids)) != len(ids):
        dup = next(i for i, count in Counter(ids).items() if count > 1)
        raise InvalidInputError(f"node ids must be unique, node {dup} appears more than once")
    try:
        positions = np.array([n.position_m for n in nodes], dtype=float)
    except ValueError as exc:
        raise InvalidInputError(f"node position_m must be (x, y, z) numbers: {exc}") from exc
    if positions.shape != (len(nodes), 3) or not np.isfinite(positions).all():
        bad_rows = np.flatnonzero(~np.isfinite(positions).all(axis=1)) if positions.ndim == 2 else [0]
        node = nodes[int(bad_rows[0])] if len(bad_rows) else nodes[0]
        raise InvalidInputError(
            f"node {node.node_id} ({node.label!r}): position_m must be 3 finite numbers, got {node.position_m!r}"
        )


def _check_travel_costs(travel_costs: Mapping[int, float]) -> None:
    if not travel_costs:
        return
    try:
        dist = np.fromiter(travel_costs.values(), dtype=float, count=len(travel_costs))
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"travel costs must be numbers (metres): {exc}") from exc
    bad = np.isnan(dist) | (dist < 0.0)
    if bad.any():
        node_id = list(travel_costs)[int(np.flatnonzero(bad)[0])]
        raise InvalidInputError(f"travel cost of node {node_id} must be >= 0 or inf, got {dist[bad][0]!r}")
