"""Evaluation metrics of the paper (Sec. IV-A) over episode records: SR, SPL, OASR, SA, GNSA.

One definition each, fixed across every comparison (``docs/metrics.md``):

- SR: ``mean_i 1[success declared_i and ||P_i - G_i|| < r_s]``. The paper's formula has only the
  distance; we also require the robot's own declaration, as the design card does, so a robot that
  wanders past the goal without recognising it does not score.
- SPL: ``mean_i S_i * L*_i / max(L_i, L*_i)`` with S_i the SR indicator and L* the geodesic length.
- OASR: ``1 - mean_i 1[collision_i]``, a collision being any contact or clearance breach
  (closer than :data:`DEFAULT_CLEARANCE_M`).
- SA: ``mean_i 1[reached category_i == instructed category_i]`` (no reached object counts as wrong).
- GNSA: ``sum_{i,t} 1[v*_{i,t} == v^oracle_{i,t}] / sum_i T_i`` over all decision steps.

Plus :func:`oracle_node` (GNSA's oracle) and 95% confidence intervals (:func:`wilson_interval`,
:func:`bootstrap_interval`).

This is a core module: standard library and numpy only.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from statistics import NormalDist
from typing import Any

import numpy as np

from semexp_bt.core.types import InvalidInputError

#: Success radius r_s (m). The paper does not state it; 1.0 m is the usual object-navigation choice
#: (Habitat ObjectNav) and about two Go1 body lengths.
DEFAULT_SUCCESS_RADIUS_M = 1.0

#: Clearance threshold (m): a robot-to-obstacle distance below it is a clearance breach, which counts
#: as a collision for OASR. The harness applies it when it fills ``EpisodeRecord.collision``.
DEFAULT_CLEARANCE_M = 0.1

#: Confidence level of every interval the summary reports.
CI_LEVEL = 0.95

#: Resamples of the percentile bootstrap.
BOOTSTRAP_RESAMPLES = 2000


@dataclass(frozen=True)
class DecisionStep:
    """One subgoal decision of an episode, for GNSA.

    Attributes:
        selected_node_id: v*_t, the node the strategy chose.
        oracle_node_id: v^oracle_t, the candidate minimising true geodesic robot->node + node->goal
            (:func:`oracle_node`) over the same candidate set.
    """

    selected_node_id: int
    oracle_node_id: int


@dataclass(frozen=True)
class EpisodeRecord:
    """What the benchmark harness records for one episode.

    Attributes:
        scene: scene key (e.g. ``"office"``).
        seed: the episode's seed.
        strategy: the decision strategy (e.g. ``"ours"``, ``"confidence"``, ``"llm"``).
        success_declared: the robot stopped and declared the target found.
        final_position_m: ``(x, y)`` of the base at the end, in ``map``.
        goal_position_m: ``(x, y)`` of the goal object, in ``map``: the point of the goal object's
            footprint nearest to ``final_position_m`` (so r_s means the same for a bin and a bus stop).
        goal_category: the instructed category c_i.
        reached_category: the category of the object the robot stopped at, ĉ_i; None if it reached none.
        path_length_m: executed base path length L_i (>= 0).
        geodesic_length_m: geodesic shortest path length L*_i from the start to the goal (>= 0) on the
            inflated occupancy grid.
        collision: any collision or clearance breach during the episode.
        decisions: the episode's decision steps (stored as a tuple).
        reached_named: whether the reached object is one the instruction names (the simulator's ground
            truth of naming, ``sims.naming``: a paraphrase of the goal names it, a distractor's name does
            not); None for records written before it was kept, which SA then judges by category.
    """

    scene: str
    seed: int
    strategy: str
    success_declared: bool
    final_position_m: tuple[float, float]
    goal_position_m: tuple[float, float]
    goal_category: str
    reached_category: str | None
    path_length_m: float
    geodesic_length_m: float
    collision: bool
    decisions: Sequence[DecisionStep] = field(default_factory=tuple)
    reached_named: bool | None = None

    def __post_init__(self) -> None:
        where = f"episode record ({self.scene!r}, seed {self.seed}, {self.strategy!r})"
        for name in ("final_position_m", "goal_position_m"):
            value = getattr(self, name)
            try:
                xy = tuple(float(v) for v in value)
            except (TypeError, ValueError) as exc:
                raise InvalidInputError(f"{where}: {name} must be (x, y) numbers, got {value!r}") from exc
            if len(xy) != 2 or not all(math.isfinite(v) for v in xy):
                raise InvalidInputError(f"{where}: {name} must be 2 finite numbers, got {value!r}")
            object.__setattr__(self, name, xy)
        for name in ("path_length_m", "geodesic_length_m"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0.0):
                raise InvalidInputError(f"{where}: {name} must be a finite number >= 0, got {value!r}")
        for name in ("success_declared", "collision"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise InvalidInputError(f"{where}: {name} must be a bool, got {getattr(self, name)!r}")
        steps = tuple(DecisionStep(**s) if isinstance(s, Mapping) else s for s in self.decisions)
        for step in steps:
            if not isinstance(step, DecisionStep):
                raise InvalidInputError(f"{where}: decisions must hold DecisionStep, got {step!r}")
        object.__setattr__(self, "decisions", steps)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-ready dict (tuples become lists)."""
        data = asdict(self)
        data["final_position_m"] = list(self.final_position_m)
        data["goal_position_m"] = list(self.goal_position_m)
        data["decisions"] = [asdict(s) for s in self.decisions]
        return data

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> EpisodeRecord:
        """Inverse of :meth:`to_dict`.

        Raises:
            InvalidInputError: on a missing or unknown key.
        """
        names = {f for f in cls.__dataclass_fields__}
        unknown = set(data) - names
        if unknown:
            raise InvalidInputError(f"episode record: unknown keys {sorted(unknown)}")
        try:
            return cls(**data)
        except TypeError as exc:
            raise InvalidInputError(f"episode record: {exc}") from exc


def _require_records(records: Sequence[EpisodeRecord], metric: str) -> None:
    if len(records) == 0:
        raise ValueError(f"{metric}: needs at least one episode record, got none")


def _require_radius(success_radius_m: float) -> None:
    if not (math.isfinite(success_radius_m) and success_radius_m > 0.0):
        raise ValueError(f"success_radius_m must be a finite number > 0, got {success_radius_m!r}")


def goal_distance_m(record: EpisodeRecord) -> float:
    """``||P_i - G_i||_2`` in the ground plane."""
    (px, py), (gx, gy) = record.final_position_m, record.goal_position_m
    return math.hypot(px - gx, py - gy)


def success(record: EpisodeRecord, *, success_radius_m: float = DEFAULT_SUCCESS_RADIUS_M) -> bool:
    """SR indicator S_i: success declared and the final base position strictly within r_s of the goal."""
    _require_radius(success_radius_m)
    return bool(record.success_declared) and goal_distance_m(record) < success_radius_m


def sr(records: Sequence[EpisodeRecord], *, success_radius_m: float = DEFAULT_SUCCESS_RADIUS_M) -> float:
    """Success Rate: share of episodes with :func:`success`."""
    _require_records(records, "SR")
    return sum(success(r, success_radius_m=success_radius_m) for r in records) / len(records)


def spl_value(record: EpisodeRecord, *, success_radius_m: float = DEFAULT_SUCCESS_RADIUS_M) -> float:
    """One episode's SPL term ``S_i * L*_i / max(L_i, L*_i)``; 1 for a success with L = L* = 0."""
    if not success(record, success_radius_m=success_radius_m):
        return 0.0
    longest = max(record.path_length_m, record.geodesic_length_m)
    return 1.0 if longest == 0.0 else record.geodesic_length_m / longest


def spl(records: Sequence[EpisodeRecord], *, success_radius_m: float = DEFAULT_SUCCESS_RADIUS_M) -> float:
    """Success weighted by Path Length (mean of :func:`spl_value`)."""
    _require_records(records, "SPL")
    return sum(spl_value(r, success_radius_m=success_radius_m) for r in records) / len(records)


def oasr(records: Sequence[EpisodeRecord]) -> float:
    """Obstacle Avoidance Success Rate: ``1 - share of episodes with a collision or clearance breach``."""
    _require_records(records, "OASR")
    return 1.0 - sum(bool(r.collision) for r in records) / len(records)


def _category(text: str) -> str:
    return " ".join(text.casefold().split())


def semantic_match(record: EpisodeRecord) -> bool:
    """SA indicator: the robot reached an object the instruction names, whatever its wording
    (``reached_named``); for older records, the reached category equals the instructed one (case and
    spacing ignored)."""
    if record.reached_named is not None:
        return bool(record.reached_named)
    return record.reached_category is not None and _category(record.reached_category) == _category(
        record.goal_category
    )


def sa(records: Sequence[EpisodeRecord]) -> float:
    """Semantic Accuracy: share of episodes whose reached category is the instructed one."""
    _require_records(records, "SA")
    return sum(semantic_match(r) for r in records) / len(records)


def decision_counts(records: Sequence[EpisodeRecord]) -> tuple[int, int]:
    """``(matches, steps)``: decision steps whose selected node is the oracle node, and all steps."""
    matches = sum(s.selected_node_id == s.oracle_node_id for r in records for s in r.decisions)
    steps = sum(len(r.decisions) for r in records)
    return matches, steps


def gnsa(records: Sequence[EpisodeRecord]) -> float:
    """Global Node Selection Accuracy over every decision step of every episode.

    Raises:
        ValueError: with no records, or when the records hold no decision step at all.
    """
    _require_records(records, "GNSA")
    matches, steps = decision_counts(records)
    if steps == 0:
        raise ValueError("GNSA: the episode records hold no decision step")
    return matches / steps


def oracle_node(candidates: Mapping[int, tuple[float, float]]) -> int | None:
    """GNSA's oracle: the candidate minimising ``d(robot, node) + d(node, goal)`` (true geodesics).

    Args:
        candidates: node id -> ``(d_robot_node_m, d_node_goal_m)``; ``inf`` marks an unreachable leg.

    Returns:
        The minimising node id, the lowest id on ties; None when every candidate is unreachable.

    Raises:
        ValueError: on an empty mapping.
        InvalidInputError: on a NaN or negative distance.
    """
    if not candidates:
        raise ValueError("oracle_node: needs at least one candidate")
    best_id: int | None = None
    best = math.inf
    for node_id in sorted(candidates):
        legs = candidates[node_id]
        if len(legs) != 2:
            raise InvalidInputError(
                f"oracle_node: node {node_id} needs (d_robot_node, d_node_goal), got {legs!r}"
            )
        for leg in legs:
            if math.isnan(leg) or leg < 0.0:
                raise InvalidInputError(f"oracle_node: node {node_id} has distance {leg!r}; need >= 0 or inf")
        total = float(legs[0]) + float(legs[1])
        if total < best:
            best, best_id = total, node_id
    return best_id


def wilson_interval(successes: int, n: int, *, confidence: float = CI_LEVEL) -> tuple[float, float]:
    """Wilson score interval for a binomial proportion ``successes / n``.

    Raises:
        ValueError: if ``n < 1``, ``successes`` is outside [0, n] or ``confidence`` outside (0, 1).
    """
    if n < 1:
        raise ValueError(f"wilson_interval: n must be >= 1, got {n}")
    if not 0 <= successes <= n:
        raise ValueError(f"wilson_interval: successes must lie in [0, {n}], got {successes}")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"wilson_interval: confidence must lie in (0, 1), got {confidence}")
    z = NormalDist().inv_cdf(0.5 + confidence / 2.0)
    p = successes / n
    denom = 1.0 + z * z / n
    centre = (p + z * z / (2.0 * n)) / denom
    half = z * math.sqrt(p * (1.0 - p) / n + z * z / (4.0 * n * n)) / denom
    # The bounds at 0 and n are exactly 0 and 1; rounding would otherwise leave 1e-17 there.
    lo = 0.0 if successes == 0 else max(0.0, centre - half)
    hi = 1.0 if successes == n else min(1.0, centre + half)
    return lo, hi


def bootstrap_interval(
    values: Sequence[float],
    *,
    seed: int,
    weights: Sequence[float] | None = None,
    confidence: float = CI_LEVEL,
    n_resamples: int = BOOTSTRAP_RESAMPLES,
) -> tuple[float, float]:
    """Percentile bootstrap interval of the (weighted) mean, resampling episodes.

    With ``weights`` the statistic is ``sum(v * w) / sum(w)`` (e.g. per-episode GNSA weighted by its
    number of steps gives the pooled GNSA); resamples whose weights sum to 0 are dropped.

    Raises:
        ValueError: on empty or non-finite values, mismatched or negative weights, or a bad level.
    """
    v = np.asarray(values, dtype=float)
    if v.ndim != 1 or v.size == 0:
        raise ValueError("bootstrap_interval: needs a non-empty 1-D sequence of values")
    if not np.isfinite(v).all():
        raise ValueError("bootstrap_interval: values must be finite")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"bootstrap_interval: confidence must lie in (0, 1), got {confidence}")
    w = np.ones_like(v) if weights is None else np.asarray(weights, dtype=float)
    if w.shape != v.shape or not np.isfinite(w).all() or (w < 0).any() or w.sum() <= 0:
        raise ValueError("bootstrap_interval: weights must be finite, >= 0, not all 0, one per value")
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, v.size, size=(n_resamples, v.size))
    total_w = w[idx].sum(axis=1)
    keep = total_w > 0
    stats = (v[idx] * w[idx]).sum(axis=1)[keep] / total_w[keep]
    tail = (1.0 - confidence) / 2.0
    lo, hi = np.quantile(stats, [tail, 1.0 - tail])
    return float(lo), float(hi)


def summarize(
    records: Sequence[EpisodeRecord],
    *,
    success_radius_m: float = DEFAULT_SUCCESS_RADIUS_M,
    bootstrap_seed: int = 0,
) -> dict[str, Any]:
    """Every metric with its 95% interval, as a JSON-ready dict.

    Keys: ``n_episodes``, ``success_radius_m``, ``sr``, ``spl``, ``oasr``, ``sa``, ``gnsa`` (None when
    no decision step was recorded), ``decision_steps``, ``mean_path_length_m``, and ``<metric>_ci95``
    as ``[lo, hi]``: Wilson intervals for the proportions SR, OASR, SA; percentile bootstrap over
    episodes (seeded) for SPL and for GNSA (steps within an episode are not independent).

    Raises:
        ValueError: on an empty record list.
    """
    _require_records(records, "summarize")
    _require_radius(success_radius_m)
    n = len(records)
    n_success = sum(success(r, success_radius_m=success_radius_m) for r in records)
    n_safe = sum(not r.collision for r in records)
    n_match = sum(semantic_match(r) for r in records)
    spl_values = [spl_value(r, success_radius_m=success_radius_m) for r in records]
    matches, steps = decision_counts(records)
    out: dict[str, Any] = {
        "n_episodes": n,
        "success_radius_m": success_radius_m,
        "sr": n_success / n,
        "sr_ci95": list(wilson_interval(n_success, n)),
        "spl": sum(spl_values) / n,
        "spl_ci95": list(bootstrap_interval(spl_values, seed=bootstrap_seed)),
        "oasr": n_safe / n,
        "oasr_ci95": list(wilson_interval(n_safe, n)),
        "sa": n_match / n,
        "sa_ci95": list(wilson_interval(n_match, n)),
        "decision_steps": steps,
        "gnsa": None,
        "gnsa_ci95": None,
        "mean_path_length_m": sum(r.path_length_m for r in records) / n,
    }
    if steps > 0:
        with_steps = [r for r in records if r.decisions]
        per_episode = [sum(s.selected_node_id == s.oracle_node_id for s in r.decisions) / len(r.decisions)
                       for r in with_steps]  # fmt: skip
        out["gnsa"] = matches / steps
        out["gnsa_ci95"] = list(
            bootstrap_interval(
                per_episode, weights=[len(r.decisions) for r in with_steps], seed=bootstrap_seed
            )
        )
    return out
