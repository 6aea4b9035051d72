"""Decision baselines (HOV-SG-style, nearest frontier, oracle) on small hand-built node sets."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from semexp_bt.app.strategies import resolve_strategy
from semexp_bt.core.config import DecisionConfig
from semexp_bt.core.decision import REASON_EMPTY, REASON_OK, REASON_TIE
from semexp_bt.core.decision_baselines import (
    BASELINE_DECISIONS,
    REASON_UNREACHABLE,
    BaselineParams,
    select_subgoal,
)
from semexp_bt.core.types import InvalidInputError, NodeState

INSTRUCTION = "find the fire extinguisher"
#: No relevance floor, so the hand-worked relevance means are the table's values.
CONFIG = DecisionConfig(relevance_floor=0.0)


class TableRelevance:
    """Relevance from a fixed label -> score table (0 for unknown labels)."""

    def __init__(self, table: Mapping[str, float]) -> None:
        self.table = dict(table)

    def score(self, *, instruction: str, label: str) -> float:
        return self.table.get(label, 0.0)

    def scores(self, *, instruction: str, labels: Sequence[str]) -> np.ndarray:
        return np.array([self.table.get(lb, 0.0) for lb in labels], dtype=float)


def node(node_id: int, x: float, y: float, label: str, *, confidence: float = 0.8, potential: float = 1.0,
         master: bool = False) -> NodeState:  # fmt: skip
    return NodeState(node_id=node_id, position_m=(x, y, 0.0), label=label, confidence=confidence,
                     potential=potential, is_master=master)  # fmt: skip


RELEVANCE = TableRelevance({"extinguisher": 0.9, "hose": 0.6, "chair": 0.1, "door": 0.3})


def choose(kind: str, nodes: list[NodeState], costs: Mapping[int, float], **kwargs: object):  # type: ignore[no-untyped-def]
    return select_subgoal(kind, nodes=nodes, instruction=INSTRUCTION, relevance=RELEVANCE, travel_costs=costs,
                          config=CONFIG, **kwargs)  # type: ignore[arg-type]  # fmt: skip


# ----------------------------------------------------------------------------------------------
# HOV-SG-style: region first, then object
# ----------------------------------------------------------------------------------------------


def test_hovsg_picks_the_region_with_the_best_mean_relevance_not_the_best_single_node() -> None:
    # Region (0, 0) (x, y in [0, 3)): extinguisher 0.9 and chair 0.1 -> mean 0.5.
    # Region (1, 0) (x in [3, 6)): hose 0.6 and door 0.3 -> mean 0.45... so make it hose alone: mean 0.6.
    nodes = [node(1, 0.5, 0.5, "extinguisher"), node(2, 1.5, 0.5, "chair"), node(3, 4.0, 0.5, "hose")]
    result = choose("hovsg", nodes, {1: 1.0, 2: 1.0, 3: 9.0})
    assert result.subgoal is not None and result.subgoal.node_id == 3
    assert result.subgoal.utility == pytest.approx(0.6 * 0.8)  # the node score S * C_f
    assert result.reason == REASON_OK


def test_hovsg_inside_the_region_takes_the_highest_relevance_times_confidence() -> None:
    # One region; extinguisher S*C = 0.9*0.2 = 0.18, hose 0.6*0.9 = 0.54.
    nodes = [node(1, 0.5, 0.5, "extinguisher", confidence=0.2), node(2, 1.0, 1.0, "hose", confidence=0.9)]
    result = choose("hovsg", nodes, {1: 1.0, 2: 50.0})  # travel cost plays no part
    assert result.subgoal is not None and result.subgoal.node_id == 2


def test_hovsg_region_size_changes_the_grouping() -> None:
    nodes = [node(1, 0.5, 0.5, "extinguisher"), node(2, 1.5, 0.5, "chair"), node(3, 4.0, 0.5, "hose")]
    # With 10 m regions all three share one region: best S*C is the extinguisher.
    result = choose("hovsg", nodes, {1: 1.0, 2: 1.0, 3: 1.0}, params=BaselineParams(region_size_m=10.0))
    assert result.subgoal is not None and result.subgoal.node_id == 1


def test_hovsg_never_picks_an_unreachable_node() -> None:
    nodes = [node(1, 0.5, 0.5, "extinguisher"), node(2, 4.0, 0.5, "chair")]
    result = choose("hovsg", nodes, {1: math.inf, 2: 3.0})
    assert result.subgoal is not None and result.subgoal.node_id == 2


# ----------------------------------------------------------------------------------------------
# Nearest frontier
# ----------------------------------------------------------------------------------------------


def test_nearest_frontier_ignores_semantics_and_takes_the_nearest_high_potential_node() -> None:
    nodes = [
        node(1, 5.0, 0.0, "extinguisher", potential=1.0),
        node(2, 1.0, 0.0, "chair", potential=0.3),  # nearest, but below the frontier potential 0.5
        node(3, 2.0, 0.0, "door", potential=0.7),
    ]
    result = choose("nearest_frontier", nodes, {1: 5.0, 2: 1.0, 3: 2.0})
    assert result.subgoal is not None and result.subgoal.node_id == 3
    assert result.subgoal.utility == 2.0  # the travel cost


def test_nearest_frontier_falls_back_to_all_candidates_when_none_is_a_frontier() -> None:
    nodes = [node(1, 5.0, 0.0, "door", potential=0.3), node(2, 1.0, 0.0, "chair", potential=0.25)]
    result = choose("nearest_frontier", nodes, {1: 5.0, 2: 1.0})
    assert result.subgoal is not None and result.subgoal.node_id == 2


def test_nearest_frontier_tie_goes_to_the_lowest_id_and_is_reported() -> None:
    nodes = [node(7, 1.0, 0.0, "door"), node(4, -1.0, 0.0, "chair")]
    result = choose("nearest_frontier", nodes, {7: 1.0, 4: 1.0})
    assert result.subgoal is not None and result.subgoal.node_id == 4
    assert result.tie and result.reason == REASON_TIE


def test_nearest_frontier_with_nothing_reachable_gives_no_subgoal() -> None:
    result = choose("nearest_frontier", [node(1, 1.0, 0.0, "door")], {1: math.inf})
    assert result.subgoal is None and result.reason == REASON_UNREACHABLE
    assert len(result.candidates) == 1


# ----------------------------------------------------------------------------------------------
# Oracle (privileged)
# ----------------------------------------------------------------------------------------------


def test_oracle_minimises_travel_plus_true_goal_distance() -> None:
    nodes = [node(1, 1.0, 0.0, "extinguisher"), node(2, 2.0, 0.0, "chair"), node(3, 3.0, 0.0, "door")]
    # totals: 1 + 9 = 10, 4 + 2 = 6, 2 + 5 = 7 -> node 2
    result = choose("oracle", nodes, {1: 1.0, 2: 4.0, 3: 2.0}, goal_distances_m={1: 9.0, 2: 2.0, 3: 5.0})
    assert result.subgoal is not None and result.subgoal.node_id == 2
    assert result.subgoal.utility == 6.0


def test_oracle_treats_a_missing_goal_distance_as_unreachable() -> None:
    nodes = [node(1, 1.0, 0.0, "door"), node(2, 2.0, 0.0, "chair")]
    result = choose("oracle", nodes, {1: 1.0, 2: 30.0}, goal_distances_m={2: 1.0})
    assert result.subgoal is not None and result.subgoal.node_id == 2


def test_oracle_rejects_nan_goal_distance_and_needs_distances() -> None:
    nodes = [node(1, 1.0, 0.0, "door")]
    with pytest.raises(InvalidInputError, match="node 1"):
        choose("oracle", nodes, {1: 1.0}, goal_distances_m={1: math.nan})
    with pytest.raises(ValueError, match="goal_distances_m"):
        choose("oracle", nodes, {1: 1.0})


# ----------------------------------------------------------------------------------------------
# Shared behaviour
# ----------------------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", BASELINE_DECISIONS)
def test_master_node_and_low_potential_nodes_are_never_candidates(kind: str) -> None:
    nodes = [node(0, 0.0, 0.0, "extinguisher", master=True), node(1, 4.0, 0.0, "door", potential=0.1)]
    result = choose(kind, nodes, {0: 0.0, 1: 4.0}, goal_distances_m={0: 0.0, 1: 1.0})
    assert result.subgoal is None and result.reason == REASON_EMPTY and result.candidates == ()


def test_unknown_kind_and_bad_params_are_clear_errors() -> None:
    with pytest.raises(ValueError, match="unknown baseline decision 'greedy'"):
        choose("greedy", [node(1, 1.0, 0.0, "door")], {1: 1.0})
    with pytest.raises(InvalidInputError, match="region_size_m"):
        BaselineParams(region_size_m=0.0)
    with pytest.raises(InvalidInputError, match="frontier_potential"):
        BaselineParams(frontier_potential=1.5)


def test_strategies_name_the_baselines_as_decision_switches() -> None:
    for name in BASELINE_DECISIONS:
        assert resolve_strategy(name).switches["decision"] == name


node_sets = st.lists(
    st.tuples(
        st.floats(-20, 20, allow_nan=False),
        st.floats(-20, 20, allow_nan=False),
        st.sampled_from(["extinguisher", "hose", "chair", "door"]),
        st.floats(0.0, 1.0, allow_nan=False),
        st.floats(0.0, 1.0, allow_nan=False),
        st.one_of(st.floats(0.0, 100.0, allow_nan=False), st.just(math.inf)),
        st.floats(0.0, 100.0, allow_nan=False),
    ),
    min_size=0,
    max_size=12,
)


@settings(max_examples=80, deadline=None)
@given(entries=node_sets, kind=st.sampled_from(BASELINE_DECISIONS))
def test_the_choice_is_always_a_reachable_candidate(entries: list[tuple], kind: str) -> None:  # type: ignore[type-arg]
    nodes = [node(i, x, y, lb, confidence=c, potential=p) for i, (x, y, lb, c, p, _, _) in enumerate(entries)]
    costs = {i: e[5] for i, e in enumerate(entries)}
    goal = {i: e[6] for i, e in enumerate(entries)}
    result = choose(kind, nodes, costs, goal_distances_m=goal)
    candidate_ids = {n.node_id for n in nodes if n.potential >= CONFIG.tau_p}
    assert {c.node_id for c in result.candidates} == candidate_ids
    if result.subgoal is None:
        assert all(math.isinf(costs[i]) for i in candidate_ids)
        return
    chosen = result.subgoal.node_id
    assert chosen in candidate_ids and math.isfinite(costs[chosen])
    if kind == "nearest_frontier":
        reachable = [i for i in candidate_ids if math.isfinite(costs[i])]
        frontier = [i for i in reachable if nodes[i].potential >= 0.5] or reachable
        assert costs[chosen] == min(costs[i] for i in frontier)
    if kind == "oracle":
        assert costs[chosen] + goal[chosen] == min(costs[i] + goal[i] for i in candidate_ids)
