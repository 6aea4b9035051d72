"""The base class of the product's behaviours: schema-checked blackboard access and services.

Every behaviour declares the keys it reads and writes as class attributes; the base registers them on
a blackboard client (applying the mission file's ``remap:``) so that a key outside
``blackboard.schema.SCHEMA`` is refused at build time, not discovered mid-mission.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any, ClassVar

import py_trees

from behaviours.services import MissionServices, mission_services
from behaviours.spec import BlackboardKey, BuildContext, ParamSpec
from blackboard.schema import SCHEMA, checked_write, register_keys
from semexp_bt.core.types import Twist

#: Relevance at which a label names the instructed object itself (the instructed label or a synonym), not
#: merely something like it ('shelf' for 'bucket shelf').
INSTRUCTED_OBJECT_RELEVANCE = 0.9


class SemExpBehaviour(py_trees.behaviour.Behaviour):
    """A leaf behaviour with services and schema-checked blackboard keys.

    Attributes:
        READS: keys the behaviour reads.
        WRITES: keys the behaviour writes (and may read).
        PARAMS: the parameters a mission file may set (read by ``trees/registry.py``).
    """

    READS: ClassVar[tuple[str, ...]] = ()
    WRITES: ClassVar[tuple[str, ...]] = ()
    PARAMS: ClassVar[dict[str, ParamSpec]] = {}

    BLACKBOARD_KEYS: ClassVar[dict[str, BlackboardKey]] = {}

    def __init_subclass__(cls, **kwargs: Any) -> None:
        # The registry and the generated node reference read BLACKBOARD_KEYS; derive it from READS and
        # WRITES so every key is declared once, with its documentation from the schema.
        super().__init_subclass__(**kwargs)
        keys: dict[str, BlackboardKey] = {}
        for key in dict.fromkeys((*cls.READS, *cls.WRITES)):
            access = (
                "read_write"
                if key in cls.READS and key in cls.WRITES
                else ("write" if key in cls.WRITES else "read")
            )
            keys[key] = BlackboardKey(access, doc=SCHEMA[key].doc)  # type: ignore[arg-type]
        cls.BLACKBOARD_KEYS = keys

    def __init__(self, name: str, *, context: BuildContext, remap: Mapping[str, str] | None = None) -> None:
        super().__init__(name=name)
        self.services: MissionServices = mission_services(context)
        self.board = self.attach_blackboard_client(name=name)
        register_keys(self.board, read=self.READS, write=self.WRITES, remap=remap)

    def read(self, key: str, default: Any = None) -> Any:
        """The value under ``key``, or ``default`` when nothing was written yet."""
        return self.board.get(key) if self.board.exists(key) else default

    def write(self, key: str, value: Any) -> None:
        """Write a schema-checked value."""
        checked_write(self.board, key, value)

    def names_instructed_object(self, label: str, *, threshold: float) -> bool:
        """Whether ``label``'s relevance to the current instruction reaches ``threshold`` (needs
        ``instruction`` in READS)."""
        return self.services.relevance.score(instruction=self.read("instruction"), label=label) >= threshold

    def now_s(self) -> float:
        return self.services.clock()

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
