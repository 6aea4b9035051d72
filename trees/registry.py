"""The explicit table of node types a mission file may use, and how each is built.

A mission file names node types; it never names Python paths and nothing in it is evaluated. Every
type is a :class:`NodeSpec` here: its factory, its children arity and its parameters
(:class:`~behaviours.spec.ParamSpec`). :func:`default_registry` returns the py_trees composites,
decorators and a few test behaviours, plus the product's behaviours listed in ONE table,
:func:`product_behaviours` below: that is where a new behaviour gets its row.

A behaviour class declares its parameters and blackboard keys (``PARAMS`` and ``BLACKBOARD_KEYS``, which
``behaviours.base.SemExpBehaviour`` derives from its ``param()`` attributes and ``READS`` / ``WRITES``);
:func:`behaviour_spec` turns the class into a :class:`NodeSpec`, so the loader's validation and the
generated ``docs/node_reference.md`` come from the same declaration. :func:`key_uses` turns the
registry's declared keys into who writes and who reads each blackboard key.
"""

from __future__ import annotations

import dataclasses
import difflib
import inspect
import operator
from collections.abc import Callable, Collection, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal, Protocol

import py_trees
from py_trees.common import Access, ComparisonExpression, OneShotPolicy, ParallelPolicy, Status

from behaviours.spec import REQUIRED, BlackboardKey, BuildContext, ParamSpec

__all__ = [
    "REQUIRED",
    "Arity",
    "BlackboardKey",
    "BuildContext",
    "KeyUse",
    "NodeFactory",
    "NodeRegistry",
    "NodeSpec",
    "ParamSpec",
    "behaviour_spec",
    "default_registry",
    "key_uses",
    "product_behaviours",
]

Arity = Literal["none", "one", "many"]
Group = Literal["composite", "decorator", "behaviour"]

#: Cross-parameter check: (validated params, names of the direct children) -> [(param or None, problem)].
CrossCheck = Callable[[Mapping[str, Any], Sequence[str]], list[tuple[str | None, str]]]


class NodeFactory(Protocol):
    """Builds one py_trees behaviour from validated, converted parameters and already-built children.

    ``remap`` maps the node's logical blackboard keys to board keys (validated against
    ``NodeSpec.blackboard_keys``); a factory for a type that declares no keys receives ``{}``.
    """

    def __call__(
        self,
        *,
        name: str,
        params: dict[str, Any],
        children: list[py_trees.behaviour.Behaviour],
        context: BuildContext,
        remap: dict[str, str],
    ) -> py_trees.behaviour.Behaviour: ...


@dataclass(frozen=True)
class NodeSpec:
    """One node type a mission file may use.

    Attributes:
        type_name: the ``type:`` a mission file writes (CamelCase, unique in a registry).
        factory: builds the behaviour (see :class:`NodeFactory`).
        summary: one sentence for ``tree show`` and the node reference.
        arity: children it takes: ``none`` (a leaf), ``one`` (a decorator) or ``many`` (a composite, >= 1).
        params: the parameters a mission file may set, by name.
        blackboard_keys: logical blackboard keys the behaviour registers, which ``remap:`` may redirect.
        group: the section of the node reference.
        source: where the implementation lives, for the reference.
        cross_check: optional check across parameters and child names (e.g. Parallel's ``selected``).
    """

    type_name: str
    factory: NodeFactory
    summary: str
    arity: Arity
    params: Mapping[str, ParamSpec] = field(default_factory=dict)
    blackboard_keys: Mapping[str, BlackboardKey] = field(default_factory=dict)
    group: Group = "behaviour"
    source: str = ""
    cross_check: CrossCheck | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        if not self.type_name.isidentifier():
            raise ValueError(f"node type name must be an identifier, got {self.type_name!r}")
        if self.arity not in ("none", "one", "many"):
            raise ValueError(f"{self.type_name}: arity must be 'none', 'one' or 'many', got {self.arity!r}")
        reserved = {"name", "child", "children", "context"}
        clash = reserved & set(self.params)
        if clash:
            raise ValueError(f"{self.type_name}: parameter names {sorted(clash)} are reserved")


class NodeRegistry:
    """A set of :class:`NodeSpec` by type name.

    Args:
        specs: the node types.
        board_keys: the blackboard keys a ``remap:`` may point to (``None``: any well-formed key).
    """

    def __init__(self, specs: Iterable[NodeSpec] = (), *, board_keys: Collection[str] | None = None) -> None:
        self._specs: dict[str, NodeSpec] = {}
        self.board_keys: frozenset[str] | None = None if board_keys is None else frozenset(board_keys)
        for spec in specs:
            self.register(spec)

    def register(self, spec: NodeSpec) -> NodeSpec:
        """Add a node type.

        Raises:
            ValueError: if the type name is already registered.
        """
        if spec.type_name in self._specs:
            raise ValueError(f"node type '{spec.type_name}' is already registered")
        self._specs[spec.type_name] = spec
        return spec

    def get(self, type_name: str) -> NodeSpec | None:
        """The spec of a type, or ``None``."""
        return self._specs.get(type_name)

    def __contains__(self, type_name: object) -> bool:
        return type_name in self._specs

    def __iter__(self) -> Iterator[NodeSpec]:
        return iter(sorted(self._specs.values(), key=lambda s: s.type_name))

    def __len__(self) -> int:
        return len(self._specs)

    def suggest(self, type_name: str) -> str | None:
        """The registered type closest to a misspelt one (case-insensitive first), or ``None``."""
        return did_you_mean(type_name, self._specs)


def did_you_mean(word: str, candidates: Iterable[str]) -> str | None:
    """The candidate closest to ``word`` (an exact case-insensitive match wins), or ``None``."""
    options = list(candidates)
    for option in options:
        if option.lower() == word.lower():
            return option
    matches = difflib.get_close_matches(word, options, n=1, cutoff=0.6)
    return matches[0] if matches else None


@dataclass(frozen=True)
class KeyUse:
    """Who uses one blackboard key, from the node types' declared keys.

    Attributes:
        writers: node types (and other writers, e.g. ``runner``) that write the key, others first.
        readers: node types that read it.
    """

    writers: tuple[str, ...] = ()
    readers: tuple[str, ...] = ()


def key_uses(
    registry: Iterable[NodeSpec], *, other_writers: Mapping[str, Iterable[str]] | None = None
) -> dict[str, KeyUse]:
    """Every blackboard key some node type declares (or another writer writes), with its writers and readers.

    Args:
        registry: the node types (their ``blackboard_keys``: ``write`` and ``read_write`` write the key,
            ``read`` and ``read_write`` read it).
        other_writers: writers that are not node types, with the keys they write (the mission runner's
            initial board: ``{"runner": semexp_bt.app.executive.RUNNER_KEYS}``).
    """
    writers: dict[str, list[str]] = {}
    readers: dict[str, list[str]] = {}
    for writer, keys in (other_writers or {}).items():
        for key in keys:
            writers.setdefault(key, []).append(writer)
    for spec in registry:
        for key, declared in spec.blackboard_keys.items():
            if declared.access != "read":
                writers.setdefault(key, []).append(spec.type_name)
            if declared.access != "write":
                readers.setdefault(key, []).append(spec.type_name)
    return {
        key: KeyUse(writers=tuple(writers.get(key, ())), readers=tuple(readers.get(key, ())))
        for key in dict.fromkeys((*writers, *readers))
    }


# ---------------------------------------------------------------------------------------------------
# Building specs from behaviour classes
# ---------------------------------------------------------------------------------------------------


def _summary(cls: type) -> str:
    """First paragraph of the class's own docstring, else of its module's (never an inherited one)."""
    own = cls.__dict__.get("__doc__")
    if not own:
        own = getattr(inspect.getmodule(cls), "__doc__", None) or ""
    paragraph = inspect.cleandoc(own).split("\n\n")[0]
    return " ".join(paragraph.split()).replace("``", "`")


def behaviour_spec(
    cls: type[py_trees.behaviour.Behaviour],
    *,
    type_name: str | None = None,
    summary: str | None = None,
    params: Mapping[str, ParamSpec] | None = None,
    blackboard_keys: Mapping[str, BlackboardKey] | None = None,
    cross_check: CrossCheck | None = None,
) -> NodeSpec:
    """A :class:`NodeSpec` for a behaviour class whose constructor takes its parameters as keywords.

    The factory calls ``cls(name=..., **params)`` and adds ``child=`` for a decorator, ``children=``
    for a composite, ``context=`` when the constructor has a ``context`` parameter and ``remap=`` when
    it has a ``remap`` parameter (otherwise a remap is applied to the behaviour's blackboard clients
    after construction, see :func:`remap_clients`); a :class:`behaviours.base.SemExpBehaviour` always
    gets both. Parameters default to the class attribute ``PARAMS`` and blackboard keys to
    ``BLACKBOARD_KEYS`` (which a ``SemExpBehaviour`` derives from its declarations).

    Raises:
        ValueError: if the constructor does not accept a declared parameter (caught when the registry
            is built, not when a mission runs).
    """
    if issubclass(cls, py_trees.decorators.Decorator):
        arity: Arity = "one"
        group: Group = "decorator"
    elif issubclass(cls, py_trees.composites.Composite):
        arity, group = "many", "composite"
    else:
        arity, group = "none", "behaviour"
    from behaviours.base import SemExpBehaviour  # lazily, as product_behaviours: the module stays light

    declared = dict(getattr(cls, "PARAMS", {}) if params is None else params)
    keys = dict(getattr(cls, "BLACKBOARD_KEYS", {}) if blackboard_keys is None else blackboard_keys)
    if issubclass(cls, SemExpBehaviour):
        # The base class takes every declared parameter, the build context and the remap.
        wants_context = wants_remap = True
    else:
        signature = inspect.signature(cls.__init__)
        accepts_any = any(p.kind is inspect.Parameter.VAR_KEYWORD for p in signature.parameters.values())
        missing = [p for p in declared if p not in signature.parameters and not accepts_any]
        if missing:
            raise ValueError(f"{cls.__qualname__}.__init__ does not accept declared parameters {missing}")
        wants_context = "context" in signature.parameters
        wants_remap = "remap" in signature.parameters

    def factory(
        *,
        name: str,
        params: dict[str, Any],
        children: list[py_trees.behaviour.Behaviour],
        context: BuildContext,
        remap: dict[str, str],
    ) -> py_trees.behaviour.Behaviour:
        kwargs: dict[str, Any] = dict(params)
        if arity == "one":
            kwargs["child"] = children[0]
        elif arity == "many":
            kwargs["children"] = children
        if wants_context:
            kwargs["context"] = context
        if wants_remap:
            kwargs["remap"] = dict(remap)
        behaviour = cls(name=name, **kwargs)
        if remap and not wants_remap:
            remap_clients(behaviour, remap)
        return behaviour

    return NodeSpec(
        type_name=type_name or cls.__name__,
        factory=factory,
        summary=summary if summary is not None else _summary(cls),
        arity=arity,
        params=declared,
        blackboard_keys=keys,
        group=group,
        source=f"{cls.__module__}.{cls.__qualname__}",
        cross_check=cross_check,
    )


def remap_clients(behaviour: py_trees.behaviour.Behaviour, remap: Mapping[str, str]) -> None:
    """Point a built behaviour's blackboard clients at remapped keys (py_trees ``remap_to``).

    For behaviours that register their keys in ``__init__`` but take no ``remap`` argument.

    Raises:
        ValueError: if the behaviour did not register a key named in ``remap``.
    """
    separator = py_trees.blackboard.Blackboard.separator
    for logical, target in remap.items():
        absolute_target = target if target.startswith(separator) else separator + target
        found = False
        for client in behaviour.blackboards:
            key = py_trees.blackboard.Blackboard.absolute_name(client.namespace, logical)
            if key not in client.remappings:
                continue
            found = True
            required = key in client.required
            accesses = [
                access
                for access, keys in (
                    (Access.READ, client.read),
                    (Access.WRITE, client.write),
                    (Access.EXCLUSIVE_WRITE, client.exclusive),
                )
                if key in keys
            ]
            client.unregister_key(key, clear=False)
            for access in accesses:
                client.register_key(key=key, access=access, required=required, remap_to=absolute_target)
        if not found:
            raise ValueError(f"'{behaviour.name}' did not register blackboard key '{logical}' in __init__")


# ---------------------------------------------------------------------------------------------------
# py_trees composites, decorators and behaviours
# ---------------------------------------------------------------------------------------------------

_MEMORY = ParamSpec(
    "bool",
    doc="true: resume from the running child on the next tick; false: restart from the first child "
    "every tick (reactive)",
)
_STATUS_NAMES = ("SUCCESS", "FAILURE", "RUNNING")
_OPERATORS: dict[str, Callable[[Any, Any], bool]] = {
    "eq": operator.eq,
    "ne": operator.ne,
    "lt": operator.lt,
    "le": operator.le,
    "gt": operator.gt,
    "ge": operator.ge,
}
_COMPARISON_PARAMS: dict[str, ParamSpec] = {
    "operator": ParamSpec(
        "enum", doc="comparison: eq, ne, lt, le, gt or ge", choices=tuple(_OPERATORS), default="eq"
    ),
    "value": ParamSpec("any", doc="the value the blackboard variable is compared with"),
}


def _status(name: str) -> Status:
    return Status[name]


def _parallel_factory(
    *,
    name: str,
    params: dict[str, Any],
    children: list[py_trees.behaviour.Behaviour],
    context: BuildContext,
    remap: dict[str, str],
) -> py_trees.behaviour.Behaviour:
    policy_name = params["policy"]
    synchronise = params["synchronise"]
    policy: ParallelPolicy.Base
    if policy_name == "SuccessOnAll":
        policy = ParallelPolicy.SuccessOnAll(synchronise=synchronise)
    elif policy_name == "SuccessOnOne":
        policy = ParallelPolicy.SuccessOnOne()
    else:
        by_name = {child.name: child for child in children}
        policy = ParallelPolicy.SuccessOnSelected(
            children=[by_name[n] for n in params["selected"]], synchronise=synchronise
        )
    return py_trees.composites.Parallel(name=name, policy=policy, children=children)


def _parallel_check(params: Mapping[str, Any], child_names: Sequence[str]) -> list[tuple[str | None, str]]:
    selected = params.get("selected", [])
    problems: list[tuple[str | None, str]] = []
    if params.get("policy") == "SuccessOnSelected":
        if not selected:
            problems.append(("policy", "policy 'SuccessOnSelected' needs a non-empty 'selected' list"))
        for child in selected:
            if child not in child_names:
                problems.append(
                    (
                        "selected",
                        f"'selected' names '{child}', which is not a direct child (children: "
                        f"{', '.join(repr(c) for c in child_names)})",
                    )
                )
    elif selected:
        problems.append(("selected", "'selected' applies only to policy 'SuccessOnSelected'"))
    if params.get("policy") == "SuccessOnOne" and params.get("synchronise") is True:
        problems.append(("synchronise", "policy 'SuccessOnOne' cannot synchronise"))
    return problems


def _comparison(params: Mapping[str, Any], key_param: str) -> ComparisonExpression:
    return ComparisonExpression(
        variable=params[key_param], value=params["value"], operator=_OPERATORS[params["operator"]]
    )


def _eternal_guard_factory(
    *,
    name: str,
    params: dict[str, Any],
    children: list[py_trees.behaviour.Behaviour],
    context: BuildContext,
    remap: dict[str, str],
) -> py_trees.behaviour.Behaviour:
    key = params["key"]
    root_key = key.split(".")[0]
    check = _comparison(params, "key")
    attributes = key.split(".")[1:]

    def condition(blackboard: py_trees.blackboard.Client) -> bool:
        # A guard on a key nobody has written yet is closed: failing safe beats running unguarded.
        try:
            value = blackboard.get(root_key)
            for attribute in attributes:
                value = getattr(value, attribute)
        except (KeyError, AttributeError):
            return False
        return bool(check.operator(value, check.value_generator()))

    return py_trees.decorators.EternalGuard(
        name=name, child=children[0], condition=condition, blackboard_keys={root_key}
    )


def _simple(fn: Callable[..., py_trees.behaviour.Behaviour]) -> NodeFactory:
    """A factory for a py_trees class built from (name, params) and its child/children."""

    def factory(
        *,
        name: str,
        params: dict[str, Any],
        children: list[py_trees.behaviour.Behaviour],
        context: BuildContext,
        remap: dict[str, str],
    ) -> py_trees.behaviour.Behaviour:
        return fn(name=name, params=params, children=children)

    return factory


#: py_trees' own docstrings are terse or playful for these; the reference says what they do.
_PY_TREES_SUMMARIES: dict[str, str] = {
    "Success": "Always SUCCESS.",
    "Failure": "Always FAILURE.",
    "Running": "Always RUNNING.",
    "Dummy": "Always RUNNING (a crash-test dummy for tests).",
    "Inverter": "SUCCESS becomes FAILURE and FAILURE becomes SUCCESS; RUNNING passes through.",
    "FailureIsSuccess": "The child's FAILURE becomes SUCCESS.",
    "FailureIsRunning": "The child's FAILURE becomes RUNNING.",
    "SuccessIsFailure": "The child's SUCCESS becomes FAILURE.",
    "SuccessIsRunning": "The child's SUCCESS becomes RUNNING.",
    "RunningIsFailure": "The child's RUNNING becomes FAILURE.",
    "RunningIsSuccess": "The child's RUNNING becomes SUCCESS.",
    "Repeat": "Re-run the child after each SUCCESS until it has succeeded num_success times; FAILURE fails.",
    "Retry": "Re-run the child after each FAILURE until it has failed num_failures times; SUCCESS succeeds.",
    "Selector": "Tick children in order until one does not fail (priority fallback); FAILURE if all fail.",
    "Sequence": "Tick children in order while they succeed; SUCCESS when all have, else the first other status.",
}


def _py_trees_specs() -> list[NodeSpec]:
    composites = py_trees.composites
    decorators = py_trees.decorators
    leaves = py_trees.behaviours
    specs = [
        behaviour_spec(composites.Sequence, params={"memory": _MEMORY}),
        behaviour_spec(composites.Selector, params={"memory": _MEMORY}),
        NodeSpec(
            type_name="Parallel",
            factory=_parallel_factory,
            summary="Tick every child on every tick; the policy decides when the parallel succeeds.",
            arity="many",
            group="composite",
            source="py_trees.composites.Parallel",
            params={
                "policy": ParamSpec(
                    "enum",
                    doc="SuccessOnAll: all children succeed; SuccessOnOne: one succeeds and none failed; "
                    "SuccessOnSelected: the children named in 'selected' succeed",
                    choices=("SuccessOnAll", "SuccessOnOne", "SuccessOnSelected"),
                    default="SuccessOnAll",
                ),
                "synchronise": ParamSpec(
                    "bool",
                    doc="stop ticking children that already succeeded until the policy is met "
                    "(not for SuccessOnOne)",
                    default=False,
                ),
                "selected": ParamSpec(
                    "list",
                    items="str",
                    doc="names of the children that must succeed (SuccessOnSelected)",
                    default=[],
                ),
            },
            cross_check=_parallel_check,
        ),
    ]
    for cls in (
        decorators.Inverter,
        decorators.PassThrough,
        decorators.Count,
        decorators.FailureIsSuccess,
        decorators.FailureIsRunning,
        decorators.SuccessIsFailure,
        decorators.SuccessIsRunning,
        decorators.RunningIsFailure,
        decorators.RunningIsSuccess,
    ):
        specs.append(behaviour_spec(cls, params={}))
    specs += [
        behaviour_spec(
            decorators.Repeat,
            params={"num_success": ParamSpec("int", doc="child successes needed; -1 repeats forever", ge=-1)},
        ),
        behaviour_spec(
            decorators.Retry,
            params={"num_failures": ParamSpec("int", doc="failures tolerated before failing", ge=1)},
        ),
        behaviour_spec(
            decorators.OneShot,
            params={
                "policy": ParamSpec(
                    "enum",
                    doc="ON_COMPLETION: latch the first SUCCESS or FAILURE; ON_SUCCESSFUL_COMPLETION: "
                    "latch only SUCCESS (failures are retried)",
                    choices=tuple(p.name for p in OneShotPolicy),
                    default="ON_SUCCESSFUL_COMPLETION",
                    convert=lambda name: OneShotPolicy[name],
                )
            },
        ),
        behaviour_spec(
            decorators.Condition,
            params={
                "status": ParamSpec(
                    "enum",
                    doc="the child status to wait for",
                    choices=_STATUS_NAMES,
                    default="SUCCESS",
                    convert=_status,
                )
            },
        ),
        behaviour_spec(
            decorators.StatusToBlackboard,
            params={
                "variable_name": ParamSpec(
                    "str", doc="key the child's status is written to", blackboard_key=True
                )
            },
        ),
        behaviour_spec(
            decorators.ForEach,
            params={
                "source_key": ParamSpec("str", doc="key of the iterable to loop over", blackboard_key=True),
                "target_key": ParamSpec("str", doc="key each item is written to", blackboard_key=True),
            },
        ),
        NodeSpec(
            type_name="EternalGuard",
            factory=_eternal_guard_factory,
            summary="Check a blackboard condition before every tick of the child; when it does not hold "
            "(or the key is absent) the child is stopped and the guard fails.",
            arity="one",
            group="decorator",
            source="py_trees.decorators.EternalGuard",
            params={
                "key": ParamSpec("str", doc="blackboard variable the condition reads", blackboard_key=True),
                **_COMPARISON_PARAMS,
            },
        ),
    ]
    for leaf in (leaves.Success, leaves.Failure, leaves.Running, leaves.Dummy):
        specs.append(behaviour_spec(leaf, params={}))
    specs += [
        behaviour_spec(
            leaves.TickCounter,
            params={
                "duration": ParamSpec("int", doc="ticks to stay RUNNING before completing", ge=0),
                "completion_status": ParamSpec(
                    "enum",
                    doc="status once the count expires",
                    choices=("SUCCESS", "FAILURE"),
                    default="SUCCESS",
                    convert=_status,
                ),
            },
        ),
        behaviour_spec(
            leaves.SuccessEveryN,
            params={"n": ParamSpec("int", doc="succeed on every n-th tick, fail otherwise", ge=1)},
        ),
        behaviour_spec(
            leaves.Periodic,
            params={
                "n": ParamSpec("int", doc="ticks spent in each of RUNNING, SUCCESS, FAILURE in turn", ge=1)
            },
        ),
        behaviour_spec(
            leaves.SetBlackboardVariable,
            params={
                "variable_name": ParamSpec("str", doc="key to write", blackboard_key=True),
                "variable_value": ParamSpec("any", doc="value to write"),
                "overwrite": ParamSpec(
                    "bool", doc="false: fail instead of replacing an existing value", default=True
                ),
            },
        ),
        NodeSpec(
            type_name="CheckBlackboardVariableValue",
            factory=_simple(
                lambda name, params, children: leaves.CheckBlackboardVariableValue(
                    name=name, check=_comparison(params, "variable")
                )
            ),
            summary="Succeed when a blackboard variable compares true with a value; fail otherwise or when "
            "the variable is absent.",
            arity="none",
            group="behaviour",
            source="py_trees.behaviours.CheckBlackboardVariableValue",
            params={
                "variable": ParamSpec("str", doc="blackboard variable to compare", blackboard_key=True),
                **_COMPARISON_PARAMS,
            },
        ),
    ]
    return [
        dataclasses.replace(spec, summary=_PY_TREES_SUMMARIES[spec.type_name])
        if spec.type_name in _PY_TREES_SUMMARIES
        else spec
        for spec in specs
    ]


# ---------------------------------------------------------------------------------------------------
# THE PRODUCT'S BEHAVIOURS: one row per behaviour in behaviours/, grouped by their part in the mission.
# To add yours: subclass behaviours.base.SemExpBehaviour (parameters as `name: type = param(...)`, keys
# as READS and WRITES), import it below and add `behaviour_spec(YourClass)`. Then regenerate the reference:
#     semexp-bt tree docs --out docs/node_reference.md
# ---------------------------------------------------------------------------------------------------


def product_behaviours() -> list[NodeSpec]:
    """The product's own node types (imported here, lazily, so the registry module stays light).

    THE table of product behaviours: one row per behaviour module in ``behaviours/``.
    """
    from behaviours.all_instructions_found import AllInstructionsFound
    from behaviours.arbitrate import Arbitrate
    from behaviours.back_up import BackUp
    from behaviours.clear_costmap import ClearCostmapAroundRobot
    from behaviours.clearance_guard import ClearanceGuard
    from behaviours.compute_path import ComputePathToSubgoal
    from behaviours.confirm_target import ConfirmTarget
    from behaviours.decide import Decide
    from behaviours.fall_guard import FallGuard
    from behaviours.follow_path import FollowPath
    from behaviours.gait import Gait
    from behaviours.lower_subgoal_potential import LowerSubgoalPotential
    from behaviours.mission_budget_guard import MissionBudgetGuard
    from behaviours.nav_failure_is import NavFailureIs
    from behaviours.next_instruction import NextInstruction
    from behaviours.perceive import Perceive
    from behaviours.rate_limiter import RateLimiter
    from behaviours.seed_master_node import SeedMasterNode
    from behaviours.sensor_health_guard import SensorHealthGuard
    from behaviours.set_subgoal_to_start import SetSubgoalToStart
    from behaviours.sim_timeout import SimTimeout
    from behaviours.spin import Spin
    from behaviours.stop_robot import StopRobot
    from behaviours.stuck_guard import StuckGuard
    from behaviours.update_costmap import UpdateCostmap
    from behaviours.update_memory import UpdateMemory
    from behaviours.wait import Wait
    from behaviours.watch_for_target import WatchForTarget
    from behaviours.watch_place_seen import WatchPlaceSeen

    return [
        behaviour_spec(RateLimiter),
        behaviour_spec(SimTimeout),
        # the paper's loop: evidence -> memory -> decision -> execution
        behaviour_spec(SeedMasterNode),
        behaviour_spec(Perceive),
        behaviour_spec(Arbitrate),
        behaviour_spec(UpdateMemory),
        behaviour_spec(Decide),
        behaviour_spec(UpdateCostmap),
        behaviour_spec(ComputePathToSubgoal),
        behaviour_spec(FollowPath),
        behaviour_spec(WatchForTarget),
        behaviour_spec(WatchPlaceSeen),
        behaviour_spec(Gait),
        behaviour_spec(ConfirmTarget),
        behaviour_spec(StopRobot),
        # guards
        behaviour_spec(MissionBudgetGuard),
        behaviour_spec(FallGuard),
        behaviour_spec(ClearanceGuard),
        behaviour_spec(StuckGuard),
        behaviour_spec(SensorHealthGuard),
        # recovery
        behaviour_spec(NavFailureIs),
        behaviour_spec(ClearCostmapAroundRobot),
        behaviour_spec(Spin),
        behaviour_spec(BackUp),
        behaviour_spec(Wait),
        behaviour_spec(LowerSubgoalPotential),
        # mission-level
        behaviour_spec(NextInstruction),
        behaviour_spec(AllInstructionsFound),
        behaviour_spec(SetSubgoalToStart),
    ]


def default_registry() -> NodeRegistry:
    """A fresh registry with the py_trees node types and the product's behaviours.

    Each call returns a new registry, so a caller (a test) may register extra types without affecting
    others. Remap targets are limited to the keys of ``blackboard.schema.SCHEMA``.
    """
    from blackboard.schema import SCHEMA

    return NodeRegistry([*_py_trees_specs(), *product_behaviours()], board_keys=SCHEMA)
