"""Utility-driven subgoal decision, Eq. 8-10."""

from __future__ import annotations

import math
import random
from collections.abc import Mapping, Sequence

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from semexp_bt.core.config import DecisionConfig
from semexp_bt.core.decision import (
    REASON_ALL_ZERO,
    REASON_EMPTY,
    REASON_OK,
    REASON_TIE,
    candidate_set,
    decide,
    utilities,
    utility,
)
from semexp_bt.core.relevance import CachedRelevance, LexicalRelevance
from semexp_bt.core.types import InvalidInputError, NodeState

INSTRUCTION = "find the fire extinguisher"
unit = st.floats(min_value=0.0, max_value=1.0, allow_nan=False)
cost = st.floats(min_value=0.0, max_value=1e4, allow_nan=False)
exponent = st.floats(min_value=0.0, max_value=10.0, allow_nan=False)


class TableRelevance:
    """Relevance from a fixed label -> score table (0 for unknown labels)."""

    def __init__(self, table: Mapping[str, float]) -> None:
        self.table = dict(table)

    def score(self, *, instruction: str, label: str) -> float:
        return self.table.get(label, 0.0)

    def scores(self, *, instruction: str, labels: Sequence[str]) -> np.ndarray:
        return np.array([self.table.get(lb, 0.0) for lb in labels], dtype=float)


def node(node_id: int, label: str, confidence: float, potential: float, *, master: bool = False) -> NodeState:
    return NodeState(
        node_id=node_id,
        position_m=(float(node_id), 0.0, 0.0),
        label=label,
        confidence=confidence,
        potential=potential,
        is_master=master,
    )


# ----------------------------------------------------------------------------------------------
# Eq. 9
# ----------------------------------------------------------------------------------------------


def test_utility_hand_worked() -> None:
    cfg = DecisionConfig(alpha=1.0, beta=0.5, eta=1.0, gamma=0.15)
    # 0.8 * sqrt(0.64) * 0.5 * exp(-0.15 * 2) = 0.8 * 0.8 * 0.5 * 0.7408182 = 0.2370618
    u = utility(relevance=0.8, confidence=0.64, potential=0.5, travel_cost_m=2.0, config=cfg)
    assert u == pytest.approx(0.32 * math.exp(-0.3))
    assert u == pytest.approx(0.2370618, abs=1e-7)
    cfg2 = DecisionConfig(alpha=2.0, beta=1.0, eta=0.0, gamma=0.5)
    # 0.5^2 * 0.9 * 0.1^0 * exp(-0.5 * 4) = 0.225 * e^-2
    assert utility(
        relevance=0.5, confidence=0.9, potential=0.1, travel_cost_m=4.0, config=cfg2
    ) == pytest.approx(0.225 * math.exp(-2.0))


def test_utility_zero_exponent_ignores_its_factor_even_at_zero() -> None:
    cfg = DecisionConfig(alpha=0.0, beta=0.0, eta=0.0, gamma=0.0)
    assert utility(relevance=0.0, confidence=0.0, potential=0.0, travel_cost_m=3.0, config=cfg) == 1.0


@pytest.mark.parametrize("gamma", [0.0, 0.15])
def test_unreachable_node_has_zero_utility(gamma: float) -> None:
    cfg = DecisionConfig(gamma=gamma)
    assert utility(relevance=1.0, confidence=1.0, potential=1.0, travel_cost_m=math.inf, config=cfg) == 0.0


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"relevance": math.nan}, "relevance"),
        ({"confidence": 1.2}, "confidence"),
        ({"potential": -0.1}, "potential"),
        ({"travel_cost_m": math.nan}, "travel_cost_m"),
        ({"travel_cost_m": -1.0}, "travel_cost_m"),
    ],
)
def test_utility_rejects_bad_input(kwargs: dict[str, float], name: str) -> None:
    args = {"relevance": 0.5, "confidence": 0.5, "potential": 0.5, "travel_cost_m": 1.0} | kwargs
    with pytest.raises(InvalidInputError, match=name):
        utility(**args, config=DecisionConfig())


def test_utilities_matches_scalar_and_checks_shapes() -> None:
    cfg = DecisionConfig()
    rng = np.random.default_rng(7)
    s, c, p = rng.random(50), rng.random(50), rng.random(50)
    d = rng.uniform(0.0, 20.0, 50)
    vec = utilities(relevance=s, confidence=c, potential=p, travel_cost_m=d, config=cfg)
    scalar = [utility(relevance=a, confidence=b, potential=e, travel_cost_m=f, config=cfg) for a, b, e, f in
              zip(s, c, p, d, strict=True)]  # fmt: skip
    np.testing.assert_allclose(vec, scalar, rtol=1e-12)
    with pytest.raises(InvalidInputError, match="shape"):
        utilities(relevance=s, confidence=c, potential=p[:3], travel_cost_m=d, config=cfg)


@settings(max_examples=200, deadline=None)
@given(s=unit, c=unit, p=unit, d1=cost, d2=cost, alpha=exponent, beta=exponent, eta=exponent,
       gamma=st.floats(min_value=0.0, max_value=10.0, allow_nan=False))  # fmt: skip
def test_utility_properties(s, c, p, d1, d2, alpha, beta, eta, gamma) -> None:
    cfg = DecisionConfig(alpha=alpha, beta=beta, eta=eta, gamma=gamma)
    near, far = sorted((d1, d2))
    u_near = utility(relevance=s, confidence=c, potential=p, travel_cost_m=near, config=cfg)
    u_far = utility(relevance=s, confidence=c, potential=p, travel_cost_m=far, config=cfg)
    u_inf = utility(relevance=s, confidence=c, potential=p, travel_cost_m=math.inf, config=cfg)
    assert 0.0 <= u_far <= u_near <= 1.0
    assert u_inf == 0.0 <= u_far


# ----------------------------------------------------------------------------------------------
# Eq. 8
# ----------------------------------------------------------------------------------------------


def test_candidate_set_filters_by_potential_and_excludes_master() -> None:
    nodes = [node(5, "a", 0.5, 0.2), node(1, "b", 0.5, 0.19), node(0, "start", 1.0, 1.0, master=True),
             node(3, "c", 0.5, 0.9)]  # fmt: skip
    assert [n.node_id for n in candidate_set(nodes, tau_p=0.2)] == [3, 5]  # >= tau_p, sorted by id
    assert [n.node_id for n in candidate_set(nodes, tau_p=0.2, include_master=True)] == [0, 3, 5]
    assert candidate_set([], tau_p=0.2) == []
    with pytest.raises(InvalidInputError, match="tau_p"):
        candidate_set(nodes, tau_p=math.nan)


def test_candidate_set_rejects_nan_and_duplicates() -> None:
    with pytest.raises(InvalidInputError, match="node 4 .*potential"):
        candidate_set([node(1, "a", 0.5, 0.5), node(4, "b", 0.5, math.nan)], tau_p=0.2)
    with pytest.raises(InvalidInputError, match="node 2 .*confidence"):
        candidate_set([node(2, "b", 1.5, 0.5)], tau_p=0.2)
    with pytest.raises(InvalidInputError, match="node 1 appears more than once"):
        candidate_set([node(1, "a", 0.5, 0.5), node(1, "b", 0.5, 0.5)], tau_p=0.2)
    bad_position = NodeState(
        node_id=9, position_m=(0.0, math.nan, 0.0), label="x", confidence=0.5, potential=0.5
    )
    with pytest.raises(InvalidInputError, match="node 9 .*position_m"):
        candidate_set([bad_position], tau_p=0.2)


# ----------------------------------------------------------------------------------------------
# Eq. 10
# ----------------------------------------------------------------------------------------------


def test_decide_hand_worked() -> None:
    cfg = DecisionConfig(tau_p=0.2, alpha=1.0, beta=0.5, eta=1.0, gamma=0.15, relevance_floor=0.0)
    relevance = TableRelevance({"extinguisher": 1.0, "fire hydrant": 0.6, "sofa": 0.0})
    nodes = [
        node(0, "start", 1.0, 1.0, master=True),
        node(1, "extinguisher", 0.49, 0.5),  # 1 * 0.7 * 0.5 * e^-1.5 = 0.0781
        node(2, "fire hydrant", 0.81, 0.9),  # 0.6 * 0.9 * 0.9 * e^-0.3 = 0.3600
        node(3, "sofa", 1.0, 1.0),  # relevance 0 -> 0
        node(4, "extinguisher", 1.0, 0.1),  # below tau_p: not a candidate
    ]
    costs = {0: 0.0, 1: 10.0, 2: 2.0, 3: 1.0, 4: 0.5}
    result = decide(nodes=nodes, instruction=INSTRUCTION, relevance=relevance, travel_costs=costs, config=cfg)
    assert result.reason == REASON_OK and not result.tie
    assert result.subgoal is not None
    assert result.subgoal.node_id == 2
    assert result.subgoal.position_m == (2.0, 0.0, 0.0)
    assert result.subgoal.label == "fire hydrant"
    assert result.subgoal.utility == pytest.approx(0.6 * 0.9 * 0.9 * math.exp(-0.3))
    assert [c.node_id for c in result.candidates] == [1, 2, 3]
    first = result.candidates[0]
    assert (first.label, first.position_m, first.relevance, first.confidence, first.potential,
            first.travel_cost_m) == ("extinguisher", (1.0, 0.0, 0.0), 1.0, 0.49, 0.5, 10.0)  # fmt: skip
    assert first.utility == pytest.approx(0.7 * 0.5 * math.exp(-1.5))
    assert [c.node_id for c in result.ranked()] == [2, 1, 3]

    # Bring the true extinguisher close and raise its potential: 1 * 0.7 * 0.9 * e^0 = 0.63 > 0.36.
    nodes[1] = node(1, "extinguisher", 0.49, 0.9)
    costs[1] = 0.0
    result = decide(nodes=nodes, instruction=INSTRUCTION, relevance=relevance, travel_costs=costs, config=cfg)
    assert result.subgoal is not None and result.subgoal.node_id == 1
    assert result.subgoal.utility == pytest.approx(0.63)


def test_decide_empty_candidate_set() -> None:
    cfg = DecisionConfig(tau_p=0.5)
    nodes = [node(0, "start", 1.0, 1.0, master=True), node(1, "sofa", 1.0, 0.4)]
    result = decide(nodes=nodes, instruction=INSTRUCTION, relevance=TableRelevance({}), travel_costs={},
                    config=cfg)  # fmt: skip
    assert (result.subgoal, result.candidates, result.reason, result.tie) == (None, (), REASON_EMPTY, False)
    result = decide(
        nodes=[], instruction=INSTRUCTION, relevance=TableRelevance({}), travel_costs={}, config=cfg
    )
    assert result.reason == REASON_EMPTY


def test_decide_all_zero_and_unreachable() -> None:
    cfg = DecisionConfig(relevance_floor=0.0)
    relevance = TableRelevance({"extinguisher": 1.0})
    nodes = [node(1, "extinguisher", 1.0, 1.0), node(2, "sofa", 1.0, 1.0), node(3, "extinguisher", 1.0, 1.0)]
    # node 1 missing from the costs (unreachable), node 3 at infinity, node 2 irrelevant.
    result = decide(nodes=nodes, instruction=INSTRUCTION, relevance=relevance, travel_costs={2: 1.0, 3: math.inf},
                    config=cfg)  # fmt: skip
    assert result.subgoal is None and result.reason == REASON_ALL_ZERO
    assert [c.travel_cost_m for c in result.candidates] == [math.inf, 1.0, math.inf]
    assert all(c.utility == 0.0 for c in result.candidates)


def test_decide_tie_broken_by_lowest_node_id() -> None:
    cfg = DecisionConfig(tie_tolerance=1e-6)
    relevance = TableRelevance({"extinguisher": 1.0})
    nodes = [
        node(7, "extinguisher", 0.5, 0.5),
        node(3, "extinguisher", 0.5, 0.5),
        node(9, "extinguisher", 0.5, 0.4),
    ]
    costs = {7: 1.0, 3: 1.0 + 1e-9, 9: 1.0}  # 3 is a hair worse, but within the relative tolerance
    result = decide(nodes=nodes, instruction=INSTRUCTION, relevance=relevance, travel_costs=costs, config=cfg)
    assert result.subgoal is not None and result.subgoal.node_id == 3
    assert result.tie and result.reason == REASON_TIE
    strict = decide(nodes=nodes, instruction=INSTRUCTION, relevance=relevance, travel_costs=costs,
                    config=DecisionConfig(tie_tolerance=0.0))  # fmt: skip
    assert strict.subgoal is not None and strict.subgoal.node_id == 7 and not strict.tie


def test_decide_rejects_nan_everywhere() -> None:
    cfg = DecisionConfig()
    nodes = [node(1, "extinguisher", 1.0, 1.0), node(2, "sofa", 1.0, 1.0)]
    good = TableRelevance({"extinguisher": 1.0})
    with pytest.raises(InvalidInputError, match="travel cost of node 2"):
        decide(
            nodes=nodes,
            instruction=INSTRUCTION,
            relevance=good,
            travel_costs={1: 1.0, 2: math.nan},
            config=cfg,
        )
    with pytest.raises(InvalidInputError, match="travel cost of node 2"):
        decide(
            nodes=nodes, instruction=INSTRUCTION, relevance=good, travel_costs={1: 1.0, 2: -3.0}, config=cfg
        )
    with pytest.raises(InvalidInputError, match="label 'sofa'"):
        decide(nodes=nodes, instruction=INSTRUCTION, relevance=TableRelevance({"sofa": math.nan}),
               travel_costs={1: 1.0, 2: 1.0}, config=cfg)  # fmt: skip
    with pytest.raises(InvalidInputError, match="node 2 .*confidence"):
        decide(nodes=[nodes[0], node(2, "sofa", math.nan, 1.0)], instruction=INSTRUCTION, relevance=good,
               travel_costs={1: 1.0, 2: 1.0}, config=cfg)  # fmt: skip


def test_decide_batches_relevance_once_per_distinct_label() -> None:
    cached = CachedRelevance(LexicalRelevance())
    nodes = [node(i, ("extinguisher", "sofa", "fire extinguisher")[i % 3], 0.5, 0.5) for i in range(30)]
    costs = {i: float(i) for i in range(30)}
    first = decide(nodes=nodes, instruction=INSTRUCTION, relevance=cached, travel_costs=costs,
                   config=DecisionConfig())  # fmt: skip
    assert cached.misses == 3 and cached.hits == 0
    second = decide(nodes=nodes, instruction=INSTRUCTION, relevance=cached, travel_costs=costs,
                    config=DecisionConfig())  # fmt: skip
    assert cached.misses == 3 and cached.hits == 3
    assert first == second
    # node 0 ("extinguisher", closest, relevance 1) wins.
    assert first.subgoal is not None and first.subgoal.node_id == 0


node_lists = st.lists(
    st.tuples(st.sampled_from(["extinguisher", "fire extinguisher", "sofa", "chair", "trash can"]), unit, unit,
              st.one_of(cost, st.just(math.inf)), st.booleans()),
    min_size=0, max_size=12,
)  # fmt: skip


@settings(max_examples=150, deadline=None)
@given(rows=node_lists, seed=st.integers(0, 2**32 - 1), tau_p=unit)
def test_decide_is_deterministic_and_order_free(rows, seed: int, tau_p: float) -> None:
    nodes = [node(i, label, c, p, master=(i == 0)) for i, (label, c, p, _, _) in enumerate(rows)]
    costs = {i: d for i, (_, _, _, d, known) in enumerate(rows) if known}
    cfg = DecisionConfig(tau_p=tau_p)
    relevance = LexicalRelevance()
    base = decide(nodes=nodes, instruction=INSTRUCTION, relevance=relevance, travel_costs=costs, config=cfg)
    shuffled = list(nodes)
    random.Random(seed).shuffle(shuffled)
    again = decide(
        nodes=shuffled, instruction=INSTRUCTION, relevance=relevance, travel_costs=costs, config=cfg
    )
    assert again == base
    # Invariants: the subgoal is a candidate with the best utility, candidates respect Eq. 8.
    assert all(c.potential >= tau_p for c in base.candidates)
    assert all(0.0 <= c.utility <= 1.0 for c in base.candidates)
    if base.subgoal is None:
        assert base.reason in (REASON_EMPTY, REASON_ALL_ZERO)
        assert all(c.utility == 0.0 for c in base.candidates)
    else:
        best = max(c.utility for c in base.candidates)
        assert best > 0.0
        assert base.subgoal.utility >= best * (1.0 - cfg.tie_tolerance)
        assert base.subgoal.node_id in {c.node_id for c in base.candidates}
        assert base.subgoal.node_id != 0  # the master node is never chosen by default


def test_relevance_floor_keeps_unrelated_nodes_rankable() -> None:
    """With the floor, an unexplored direction is still a subgoal; without it, nothing is."""
    relevance = TableRelevance({"extinguisher": 1.0})
    nodes = [node(1, "open corridor", 0.8, 0.9), node(2, "doorway", 0.6, 0.9)]
    costs = {1: 2.0, 2: 2.0}
    literal = decide(nodes=nodes, instruction=INSTRUCTION, relevance=relevance, travel_costs=costs,
                     config=DecisionConfig(relevance_floor=0.0))  # fmt: skip
    assert literal.subgoal is None and literal.reason == REASON_ALL_ZERO
    floored = decide(nodes=nodes, instruction=INSTRUCTION, relevance=relevance, travel_costs=costs,
                     config=DecisionConfig(relevance_floor=0.1))  # fmt: skip
    assert floored.subgoal is not None and floored.subgoal.node_id == 1  # higher confidence wins
    assert all(c.relevance == 0.1 for c in floored.candidates)
