"""The base class of the product's behaviours: declared parameters, schema-checked blackboard access, services.

A behaviour declares, as class attributes, the keys it reads and writes (``READS``, ``WRITES``) and each
parameter a mission file may set (``name: type = param(...)``, see :mod:`behaviours.spec`). From those
declarations alone the base class

- collects ``PARAMS`` and ``BLACKBOARD_KEYS``, which the tree registry and the generated node reference
  read (``trees/registry.py``, ``docs/node_reference.md``);
- checks the parameters a node is built with, fills in the defaults and sets them as the instance's
  typed attributes, so a behaviour's ``__init__`` creates only its own state (or does not exist);
- registers the keys on a blackboard client (applying the mission file's ``remap:``), so that a key
  outside ``blackboard.schema.SCHEMA`` is refused at build time, not discovered mid-mission.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any, ClassVar

import py_trees

from behaviours.services import MissionServices, mission_services
from behaviours.spec import BlackboardKey, BuildContext, ParamSpec
from blackboard.schema import SCHEMA, checked_write, key_access, register_keys
from semexp_bt.core.relevance import NAMES_OBJECT_RELEVANCE
from semexp_bt.core.types import Observation, Twist
from semexp_bt.perception.interface import PerceptionJob

#: Names a parameter cannot take: py_trees' instance state, the base class's, and the constructor's own
#: keywords.
_TAKEN_NAMES = frozenset(vars(py_trees.behaviours.Success(name="probe"))) | {
    "services",
    "board",
    "context",
    "remap",
}

#: The Python type a parameter kind is annotated with (``list`` and ``any`` are not checked).
_ANNOTATION_OF_KIND = {"int": "int", "float": "float", "bool": "bool", "str": "str", "enum": "str"}


class SemExpBehaviour(py_trees.behaviour.Behaviour):
    """A leaf behaviour with declared parameters, services and schema-checked blackboard keys.

    Attributes:
        READS: keys the behaviour reads.
        WRITES: keys the behaviour writes (and may read).
        PARAMS: the parameters a mission file may set, collected from the class's :func:`~behaviours.spec.param`
            attributes (read by ``trees/registry.py``).
        BLACKBOARD_KEYS: every declared key with its access and the schema's description of it.
        services: what the behaviour may call (robot, perception, relevance, planner, config, records).
        board: the behaviour's blackboard client.
    """

    READS: ClassVar[tuple[str, ...]] = ()
    WRITES: ClassVar[tuple[str, ...]] = ()
    PARAMS: ClassVar[dict[str, ParamSpec]] = {}
    BLACKBOARD_KEYS: ClassVar[dict[str, BlackboardKey]] = {}

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "PARAMS" in vars(cls) or "BLACKBOARD_KEYS" in vars(cls):
            raise TypeError(
                f"{cls.__qualname__}: declare parameters as `name: type = param(...)` and keys as READS and "
                "WRITES; PARAMS and BLACKBOARD_KEYS are derived from them"
            )
        own = {name: value for name, value in vars(cls).items() if isinstance(value, ParamSpec)}
        annotations = vars(cls).get("__annotations__", {})
        for name, spec in own.items():
            _check_declaration(cls, name, spec, annotations.get(name))
            # The instance holds the value; reading the attribute before __init__ set it is an error.
            delattr(cls, name)
        cls.PARAMS = {**cls.PARAMS, **own}
        cls.BLACKBOARD_KEYS = {
            key: BlackboardKey(access, doc=SCHEMA[key].doc)
            for key, access in key_access(reads=cls.READS, writes=cls.WRITES).items()
        }

    def __init__(
        self, name: str, *, context: BuildContext, remap: Mapping[str, str] | None = None, **params: Any
    ) -> None:
        """Build the behaviour.

        Args:
            name: the node's name.
            context: the build context; its services must hold the mission's
                :class:`~behaviours.services.MissionServices`.
            remap: logical key -> board key, from the mission file's ``remap:``.
            **params: values for the declared parameters; those left out take their defaults.

        Raises:
            TypeError: for an undeclared parameter or a missing required one.
            ValueError: for a value its :class:`~behaviours.spec.ParamSpec` refuses.
        """
        super().__init__(name=name)
        for key, value in self.checked_params(name, params).items():
            setattr(self, key, value)
        self.services: MissionServices = mission_services(context)
        self.board = self.attach_blackboard_client(name=name)
        register_keys(self.board, read=self.READS, write=self.WRITES, remap=remap)
        #: Each declared key's place on the board (after the remapping), for :meth:`read`.
        self._board_keys = {key: self.board.remappings["/" + key] for key in self.BLACKBOARD_KEYS}

    @classmethod
    def checked_params(cls, name: str, given: Mapping[str, Any]) -> dict[str, Any]:
        """Every declared parameter's value: the given one checked against its spec, else the default.

        Raises:
            TypeError: for an undeclared parameter or a missing required one.
            ValueError: for a value its spec refuses.
        """
        where = f"{cls.__name__} '{name}'"
        unknown = [key for key in given if key not in cls.PARAMS]
        if unknown:
            raise TypeError(
                f"{where}: unknown parameter(s) {unknown}; expected: {', '.join(cls.PARAMS) or 'none'}"
            )
        values: dict[str, Any] = {}
        for key, spec in cls.PARAMS.items():
            if key not in given and spec.required:
                raise TypeError(f"{where}: missing required parameter '{key}' ({spec.describe()})")
            value, problem = spec.check(given[key] if key in given else spec.default)
            if problem is not None:
                raise ValueError(f"{where}: parameter '{key}': {problem}")
            values[key] = value
        return values

    def read(self, key: str, default: Any = None) -> Any:
        """The value under ``key``, or ``default`` when nothing was written yet.

        A declared key is read from the board's storage directly: py_trees' ``exists`` then ``get`` walk
        its access checks twice and, while a recorder or the view listens, push two READ items to the
        activity stream, which nothing here reads (the tick record keeps writes). That was 3.6 us a read
        (6.9 with the stream on) against 0.05, at about 175 reads a simulated second on the README's
        mission (session 34, docs/viewer.md). The keys were checked against the schema and registered at
        build time; an undeclared key still goes through py_trees and gets its access error.
        """
        board_key = self._board_keys.get(key)
        if board_key is None:
            return self.board.get(key) if self.board.exists(key) else default
        return py_trees.blackboard.Blackboard.storage.get(board_key, default)

    def write(self, key: str, value: Any) -> None:
        """Write a schema-checked value."""
        checked_write(self.board, key, value)

    def names_instructed_object(self, label: str, *, threshold: float = NAMES_OBJECT_RELEVANCE) -> bool:
        """Whether ``label``'s relevance to the current instruction reaches ``threshold`` (needs
        ``instruction`` in READS); the default is the core's one threshold at which a label names the
        instructed object itself."""
        return self.services.relevance.score(instruction=self.read("instruction"), label=label) >= threshold

    def memory_label(self, label: str) -> str:
        """The label under which evidence labelled ``label`` enters the memory (needs ``instruction`` and
        ``target_label`` in READS): ``target_label`` when ``label`` names the instructed object, else
        ``label`` itself.

        Why: the memory's rules (label switch, the position step that will not crowd another label,
        maintenance merging) compare labels as strings. A prompted detector labels its boxes with the
        instruction's words and the VLM names the same object in its own, so without this one object
        got one node or two depending on the instruction's wording (docs/memory.md, "One label for the
        instructed object").

        Example:
            instruction "find the legged robot", target_label "legged robot": the VLM's
            "quadruped robot" and the detector's "legged robot" both enter as "legged robot"; the VLM's
            "office chair" enters as "office chair".
        """
        target = self.read("target_label")
        if not target or label == target or not self.names_instructed_object(label):
            return label
        return str(target)

    def now_s(self) -> float:
        return self.services.clock()

    def submit_view(self, observation: Observation) -> PerceptionJob:
        """Ask perception about ``observation`` for the current instruction, with the base's twist of
        now (a moving camera sees worse); needs ``instruction`` and ``target_label`` in READS."""
        return self.services.perception.submit(
            observation=observation,
            instruction=self.read("instruction"),
            target_label=self.read("target_label"),
            motion=self.services.robot.base_twist(),
            now_s=self.now_s(),
        )

    def command(self, twist: Twist) -> None:
        """Publish a base velocity command for the gait (needs ``cmd_twist`` and ``cmd_stamp_s`` in WRITES)."""
        self.write("cmd_twist", twist)
        self.write("cmd_stamp_s", float(self.now_s()))

    def timed(self, stage: str) -> _StageTimer:
        """``with self.timed("decision"): ...`` records wall time under that stage."""
        return _StageTimer(self.services, stage)


class _StageTimer:
    def __init__(self, services: MissionServices, stage: str) -> None:
        self.services = services
        self.stage = stage
        self.start = 0.0

    def __enter__(self) -> _StageTimer:
        self.start = time.perf_counter()
        return self

    def __exit__(self, *exc: object) -> None:
        self.services.timings.add(self.stage, time.perf_counter() - self.start)


def _check_declaration(cls: type, name: str, spec: ParamSpec, annotation: Any) -> None:
    """A parameter attribute is annotated with its kind's type and shadows nothing of the base classes."""
    where = f"{cls.__qualname__}.{name}"
    if annotation is None:
        raise TypeError(f"{where}: annotate the parameter with its type (`{name}: float = param(...)`)")
    expected = _ANNOTATION_OF_KIND.get(spec.kind)
    written = annotation if isinstance(annotation, str) else getattr(annotation, "__name__", repr(annotation))
    if expected is not None and written != expected:
        raise TypeError(f"{where}: a {spec.kind!r} parameter is annotated `{expected}`, not `{written}`")
    if spec.convert is not None:
        raise TypeError(
            f"{where}: a behaviour parameter takes no convert (the loader's raw value is checked)"
        )
    if name in _TAKEN_NAMES or any(hasattr(base, name) for base in cls.__mro__[1:]):
        raise TypeError(f"{where}: the name is taken by a base class")
