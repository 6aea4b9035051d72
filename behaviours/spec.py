"""How a behaviour declares itself to the mission-tree loader: parameters, blackboard keys, build context.

A behaviour class states what a mission file may set on it as class attributes, and the tree registry
(``trees/registry.py``) reads them; the generated node reference (``docs/node_reference.md``) is built
from the same declarations, so a parameter is written once, next to the code that uses it. A product
behaviour (``behaviours.base.SemExpBehaviour``) declares each parameter as a typed class attribute with
:func:`param`, as a dataclass declares a field, and its blackboard keys as ``READS`` and ``WRITES``::

    class PanoramicInit(SemExpBehaviour):
        WRITES = ("memory",)

        views: int = param("int", doc="views to perceive in one turn", default=8, ge=1, le=64)

The base class collects the declarations into ``PARAMS`` (name -> :class:`ParamSpec`) and
``BLACKBOARD_KEYS`` (name -> :class:`BlackboardKey`), checks the values a node is built with against
them, and sets ``self.views`` to the checked value (the default when the mission file leaves it out).
Other node types (py_trees' own, ``RateLimiter``, ``SimTimeout``) state ``PARAMS`` directly or get a
spec in the registry.

This module lives in ``behaviours/`` rather than ``trees/`` because the layering is trees -> behaviours:
a behaviour must be able to declare itself without importing the loader.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

from semexp_bt.core.bounds import Interval
from semexp_bt.core.config import SemExpConfig

if TYPE_CHECKING:
    from blackboard.schema import KeyAccess
    from robots.interface import Robot

ParamKind = Literal["int", "float", "bool", "str", "list", "enum", "any"]
PARAM_KINDS: tuple[str, ...] = ("int", "float", "bool", "str", "list", "enum", "any")

#: A blackboard key as mission files may write it: ``name``, ``/ns/name`` or ``name.attribute``
#: (py_trees' nested-attribute access). Deliberately narrow so a typo such as a space is caught early.
BLACKBOARD_KEY_PATTERN = re.compile(r"/?[A-Za-z_]\w*(?:[/.][A-Za-z_]\w*)*")


class _Required:
    """Sentinel type: the parameter has no default and must be set in the mission file."""

    _instance: _Required | None = None

    def __new__(cls) -> _Required:
        if cls._instance is None:
            cls._instance = super().__new__(cls)
        return cls._instance

    def __repr__(self) -> str:
        return "REQUIRED"


REQUIRED: Any = _Required()

_SCALAR_TYPES = (str, int, float, bool)


def _type_name(value: Any) -> str:
    if value is None:
        return "null"
    return {bool: "bool", int: "int", float: "float", str: "str", list: "list", dict: "mapping"}.get(
        type(value), type(value).__name__
    )


@dataclass(frozen=True)
class ParamSpec:
    """One parameter a mission file may set on a node.

    Attributes:
        kind: ``int``, ``float`` (an int is accepted and widened), ``bool``, ``str``, ``list``,
            ``enum`` (a string among ``choices``) or ``any`` (a scalar or a list of scalars).
        doc: one sentence for the node reference, with the unit.
        default: the value when the mission file leaves it out; :data:`REQUIRED` when it must be set.
        gt, ge, lt, le: numeric bounds (exclusive/inclusive) for ``int`` and ``float``.
        choices: the allowed strings of an ``enum``.
        items: the kind of every element of a ``list`` (``None``: any scalar).
        blackboard_key: the value names a blackboard key (checked against
            :data:`BLACKBOARD_KEY_PATTERN`, and flagged in the reference).
        convert: maps the validated YAML value to the constructor argument (e.g. ``"SUCCESS"`` to
            ``py_trees.common.Status.SUCCESS``); applied at build time only.
    """

    kind: ParamKind
    doc: str
    default: Any = REQUIRED
    gt: float | None = None
    ge: float | None = None
    lt: float | None = None
    le: float | None = None
    choices: tuple[str, ...] = ()
    items: ParamKind | None = None
    blackboard_key: bool = False
    convert: Callable[[Any], Any] | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        if self.kind not in PARAM_KINDS:
            raise ValueError(f"ParamSpec kind must be one of {list(PARAM_KINDS)}, got {self.kind!r}")
        if self.kind == "enum" and not self.choices:
            raise ValueError("an enum ParamSpec needs choices")
        if self.items is not None and (self.kind != "list" or self.items in ("list", "enum")):
            raise ValueError("ParamSpec items applies to a list of scalars only")
        if self.blackboard_key and self.kind != "str":
            raise ValueError("a blackboard-key ParamSpec must have kind 'str'")
        if not self.required:
            _, problem = self.check(self.default)
            if problem is not None:
                raise ValueError(f"ParamSpec default {self.default!r} is invalid: {problem}")

    @property
    def required(self) -> bool:
        """Whether the mission file must set this parameter."""
        return self.default is REQUIRED

    def describe(self) -> str:
        """The expected value in words, e.g. ``float > 0`` or ``enum {a, b}``."""
        if self.kind == "enum":
            return "one of " + ", ".join(repr(c) for c in self.choices)
        text: str = self.kind
        if self.kind == "list" and self.items is not None:
            text = f"list of {self.items}"
        if self.blackboard_key:
            text = "blackboard key"
        bounds = [
            f"{op} {_number(bound)}"
            for op, bound in ((">", self.gt), (">=", self.ge), ("<", self.lt), ("<=", self.le))
            if bound is not None
        ]
        return f"{text} {' and '.join(bounds)}" if bounds else text

    def check(self, value: Any) -> tuple[Any, str | None]:
        """Validate a value parsed from YAML.

        Returns:
            ``(normalised_value, None)`` when valid (ints widened to float for ``float``), else
            ``(value, problem)`` where ``problem`` says what was expected and what was given.
        """
        expected = f"expected {self.describe()}"
        if self.kind == "int":
            if isinstance(value, bool) or not isinstance(value, int):
                return value, f"{expected}, got {_type_name(value)} {value!r}"
        elif self.kind == "float":
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                return value, f"{expected}, got {_type_name(value)} {value!r}"
            value = float(value)
            if not math.isfinite(value):
                return value, f"{expected}, got non-finite {value!r}"
        elif self.kind == "bool":
            if not isinstance(value, bool):
                return value, f"{expected} (true or false), got {_type_name(value)} {value!r}"
        elif self.kind == "str":
            if not isinstance(value, str):
                return value, f"{expected}, got {_type_name(value)} {value!r}"
            if self.blackboard_key and not BLACKBOARD_KEY_PATTERN.fullmatch(value):
                return value, f"{expected} like 'name', '/ns/name' or 'name.attr', got {value!r}"
        elif self.kind == "enum":
            if not isinstance(value, str) or value not in self.choices:
                return value, f"{expected}, got {value!r}"
        elif self.kind == "list":
            if not isinstance(value, list):
                return value, f"{expected}, got {_type_name(value)} {value!r}"
            item_spec = ParamSpec(self.items or "any", doc="")
            normalised = []
            for index, item in enumerate(value):
                if isinstance(item, list):
                    return value, f"{expected}, item {index} is a nested list"
                item_value, problem = item_spec.check(item)
                if problem is not None:
                    return value, f"item {index}: {problem}"
                normalised.append(item_value)
            value = normalised
        elif self.kind == "any":
            if isinstance(value, list):
                return ParamSpec("list", doc="").check(value)
            if value is not None and not isinstance(value, _SCALAR_TYPES):
                return value, f"expected a scalar or a list of scalars, got {_type_name(value)}"
            if isinstance(value, float) and not math.isfinite(value):
                return value, f"expected a finite number, got {value!r}"
        if self.kind in ("int", "float"):
            problem = self._range_problem(value)
            if problem is not None:
                return value, problem
        return value, None

    def _range_problem(self, value: float) -> str | None:
        broken = Interval(gt=self.gt, ge=self.ge, lt=self.lt, le=self.le).broken_bound(value)
        if broken is None:
            return None
        return f"value {value!r} out of range: must be {broken[0]} {_number(broken[1])}"


def param(kind: ParamKind, doc: str, **options: Any) -> Any:
    """Declare a behaviour parameter as a typed class attribute (see the module docstring).

    ``options`` are the other fields of :class:`ParamSpec` (``default``, bounds, ``choices``, ...).
    Returns the :class:`ParamSpec`, typed ``Any`` so that the attribute keeps its annotated type, as
    ``dataclasses.field`` does: the class collects it into ``PARAMS`` and each instance holds the value.
    """
    return ParamSpec(kind, doc, **options)


def _number(value: float) -> str:
    return str(int(value)) if float(value).is_integer() else repr(value)


@dataclass(frozen=True)
class BlackboardKey:
    """A blackboard key a behaviour registers under a logical name, which a mission file may remap.

    The behaviour registers the key in ``__init__`` under its logical name (e.g. ``memory``); a node's
    ``remap: {memory: topo_memory}`` makes that client read and write ``/topo_memory`` instead.

    Attributes:
        access: ``read``, ``write`` or ``read_write``.
        doc: what the value is, with its type.
    """

    access: KeyAccess
    doc: str


@dataclass
class BuildContext:
    """What node factories need at build time. Other subsystems add fields here (with defaults).

    Attributes:
        clock: the robot backend's clock in seconds (``Robot.now_s``); behaviours never read the wall.
        robot: the robot backend, when the tree drives one (``None`` for checks and unit tests).
        config: the effective hyperparameters (the caller's config with the mission's overrides).
        services: named shared services (perception adapters, relevance scorer, recorder, ...).
    """

    clock: Callable[[], float]
    robot: Robot | None = None
    config: SemExpConfig = field(default_factory=SemExpConfig)
    services: dict[str, Any] = field(default_factory=dict)
