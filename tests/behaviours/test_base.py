"""SemExpBehaviour: parameters, blackboard keys and services come from one declaration per behaviour.

Also the blackboard schema against the behaviours' declared keys: the schema lists key, type and doc;
who writes a key comes only from the behaviours' ``WRITES`` (and the runner's initial board).
"""

from __future__ import annotations

import ast
import importlib
import inspect
import pkgutil

import py_trees
import pytest

import behaviours
from behaviours.base import SemExpBehaviour
from behaviours.spec import BlackboardKey, BuildContext, param
from behaviours.spin import Spin
from behaviours.stop_robot import StopRobot
from blackboard.schema import SCHEMA, SchemaError, key_access
from semexp_bt.app.executive import RUNNER_KEYS
from tests.behaviours.rig import Rig
from trees.registry import behaviour_spec, default_registry, key_uses, product_behaviours


def product_behaviour_classes() -> list[type[SemExpBehaviour]]:
    """Every SemExpBehaviour defined in a module of behaviours/."""
    found = []
    for module_info in pkgutil.iter_modules(behaviours.__path__):
        module = importlib.import_module(f"behaviours.{module_info.name}")
        found += [
            cls
            for cls in vars(module).values()
            if inspect.isclass(cls)
            and issubclass(cls, SemExpBehaviour)
            and cls is not SemExpBehaviour
            and cls.__module__ == module.__name__
        ]
    return found


# --------------------------------------------------------------------------------------------------
# Parameters: declared once, as typed class attributes
# --------------------------------------------------------------------------------------------------


def test_parameters_left_out_take_their_declared_defaults(rig: Rig) -> None:
    turn = rig.build(Spin)
    rig.show(turn)
    for name, spec in Spin.PARAMS.items():
        assert getattr(turn, name) == spec.default
    assert list(Spin.PARAMS) == ["angle_deg", "yaw_rate_radps", "lookahead_s", "timeout_s"]


def test_given_parameters_are_checked_and_normalised(rig: Rig) -> None:
    turn = rig.build(Spin, angle_deg=90, timeout_s=3.0)
    assert turn.angle_deg == 90.0 and isinstance(turn.angle_deg, float)  # an int widened, as the loader does
    assert turn.timeout_s == 3.0
    with pytest.raises(ValueError, match=r"Spin 'Turn': parameter 'yaw_rate_radps'.*out of range"):
        rig.build(Spin, name="Turn", yaw_rate_radps=3.0)
    with pytest.raises(ValueError, match="parameter 'outcome'"):
        rig.build(StopRobot, outcome="exploded")
    with pytest.raises(TypeError, match=r"unknown parameter\(s\) \['angle'\]; expected: angle_deg"):
        rig.build(Spin, angle=90.0)


def test_a_parameter_is_an_instance_attribute_only() -> None:
    """The declaration leaves no class attribute behind: reading one before __init__ is an error, not a
    ParamSpec passed off as a value."""
    assert "angle_deg" not in vars(Spin)
    assert not hasattr(Spin, "angle_deg")


def test_every_product_parameter_has_a_default_that_its_spec_accepts() -> None:
    checked = 0
    for cls in product_behaviour_classes():
        for name, spec in cls.PARAMS.items():
            assert not spec.required, f"{cls.__name__}.{name} has no default"
            assert spec.check(spec.default)[1] is None
            checked += 1
    assert checked == 87


def test_read_takes_a_declared_key_from_its_remapped_entry_and_refuses_an_undeclared_one(rig: Rig) -> None:
    class ReadsTheDecision(SemExpBehaviour):
        READS = ("decision", "instruction")

        def update(self) -> py_trees.common.Status:
            return py_trees.common.Status.SUCCESS

    reader = ReadsTheDecision(name="Reader", context=rig.context, remap={"instruction": "target_label"})
    assert not rig.board.exists("decision")
    assert reader.read("decision") is None and reader.read("decision", default="none") == "none"
    rig.set("instruction", "find the chair")
    rig.set("target_label", "chair")
    assert reader.read("instruction") == "chair"  # remapped: its entry is target_label
    # The rig listens to the activity stream as a recorder does: no READ items for the record to skip.
    stream = py_trees.blackboard.Blackboard.activity_stream
    assert stream is not None
    assert [item.key for item in stream.data if item.client_name == "Reader"] == []
    with pytest.raises(AttributeError, match="does not have read/write access to '/memory'"):
        reader.read("memory")


def test_a_required_parameter_must_be_given(rig: Rig) -> None:
    class Needs(SemExpBehaviour):
        gain: float = param("float", doc="a gain", gt=0.0)

        def update(self) -> py_trees.common.Status:
            return py_trees.common.Status.SUCCESS

    with pytest.raises(TypeError, match="missing required parameter 'gain'"):
        rig.build(Needs)
    assert rig.build(Needs, gain=2).gain == 2.0
    assert behaviour_spec(Needs).params["gain"].required


@pytest.mark.parametrize(
    ("body", "problem"),
    [
        ("speed = param('float', doc='x', default=1.0)", "annotate the parameter"),
        ("speed: int = param('float', doc='x', default=1.0)", "annotated `float`, not `int`"),
        ("name_: str = param('str', doc='x', default='a', convert=str.upper)", "takes no convert"),
        ("gain: float = param('float', doc='x', default=1.0)", None),
        ("status: str = param('str', doc='x', default='a')", "taken by a base class"),
        ("read: str = param('str', doc='x', default='a')", "taken by a base class"),
        ("remap: str = param('str', doc='x', default='a')", "taken by a base class"),
        ("PARAMS = {}", "derived from them"),
    ],
)
def test_a_malformed_declaration_fails_when_the_class_is_defined(body: str, problem: str | None) -> None:
    source = f"class Bad(SemExpBehaviour):\n    {body}\n"
    if problem is None:
        exec(source, {"SemExpBehaviour": SemExpBehaviour, "param": param})
        return
    with pytest.raises(TypeError, match=problem):
        exec(source, {"SemExpBehaviour": SemExpBehaviour, "param": param})


def test_the_registry_builds_a_behaviour_from_its_declaration(rig: Rig) -> None:
    spec = behaviour_spec(Spin)
    assert dict(spec.params) == Spin.PARAMS and spec.blackboard_keys == Spin.BLACKBOARD_KEYS
    built = spec.factory(name="Turn", params={"angle_deg": -30.0}, children=[], context=rig.context, remap={})
    assert isinstance(built, Spin) and built.angle_deg == -30.0 and built.timeout_s == 15.0


# --------------------------------------------------------------------------------------------------
# Blackboard keys: one access rule, one schema, writers from the declarations
# --------------------------------------------------------------------------------------------------


def test_key_access_is_read_write_for_a_key_in_both_lists() -> None:
    assert key_access(reads=("subgoal", "memory"), writes=("memory", "plan")) == {
        "subgoal": "read",
        "memory": "read_write",
        "plan": "write",
    }
    with pytest.raises(SchemaError, match="'nowhere' is not in blackboard.schema.SCHEMA"):
        key_access(reads=("nowhere",), writes=())


def test_a_behaviours_keys_are_its_reads_and_writes_documented_from_the_schema() -> None:
    assert Spin.BLACKBOARD_KEYS == {
        "local_map": BlackboardKey("read", doc=SCHEMA["local_map"].doc),
        "cmd_twist": BlackboardKey("write", doc=SCHEMA["cmd_twist"].doc),
        "cmd_stamp_s": BlackboardKey("write", doc=SCHEMA["cmd_stamp_s"].doc),
    }
    for spec in product_behaviours():
        if spec.arity == "none":  # a leaf acts on the board; the decorators (RateLimiter, SimTimeout) do not
            assert spec.blackboard_keys, f"{spec.type_name} declares no blackboard key"


def test_every_declared_key_is_in_the_schema_and_every_schema_key_has_a_writer() -> None:
    declared = {key for cls in product_behaviour_classes() for key in (*cls.READS, *cls.WRITES)}
    assert declared <= set(SCHEMA)
    uses = key_uses(default_registry(), other_writers={"runner": RUNNER_KEYS})
    nobody_writes = [key for key in SCHEMA if not (key in uses and uses[key].writers)]
    assert nobody_writes == []
    assert set(uses) <= set(SCHEMA)
    # Spot checks of the derived table against the code (the hand-written one had these wrong).
    assert uses["arbitration"].writers == ("Arbitrate",)
    assert "StuckGuard" not in uses["mission_outcome"].writers
    assert uses["memory"].writers[0] == "runner"


def _board_calls(cls: type[SemExpBehaviour]) -> tuple[set[str], set[str]]:
    """The keys a behaviour's own code passes to ``self.read`` and ``self.write`` (``self.command`` writes
    both command keys; ``names_instructed_object`` reads the instruction)."""
    reads: set[str] = set()
    writes: set[str] = set()
    for node in ast.walk(ast.parse(inspect.getsource(cls))):
        if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)):
            continue
        target, method = node.func.value, node.func.attr
        if not (isinstance(target, ast.Name) and target.id == "self"):
            continue
        key = node.args[0].value if node.args and isinstance(node.args[0], ast.Constant) else None
        if method == "read" and isinstance(key, str):
            reads.add(key)
        elif method == "write" and isinstance(key, str):
            writes.add(key)
        elif method == "command":
            writes |= {"cmd_twist", "cmd_stamp_s"}
        elif method == "names_instructed_object":
            reads.add("instruction")
    return reads, writes


@pytest.mark.parametrize("cls", product_behaviour_classes(), ids=lambda cls: cls.__name__)
def test_a_behaviour_declares_every_key_its_code_reads_or_writes(cls: type[SemExpBehaviour]) -> None:
    """The node reference's key table is only as true as READS and WRITES: every key the code reads is
    in READS and every key it writes is in WRITES (a key it only changes in place, such as the memory,
    is declared by hand)."""
    reads, writes = _board_calls(cls)
    assert reads <= set(cls.READS), f"reads {sorted(reads - set(cls.READS))} without declaring them"
    assert writes <= set(cls.WRITES), f"writes {sorted(writes - set(cls.WRITES))} without declaring them"


@pytest.mark.parametrize("cls", product_behaviour_classes(), ids=lambda cls: cls.__name__)
def test_a_behaviours_docstring_states_its_semantics_keys_and_an_example(cls: type[SemExpBehaviour]) -> None:
    doc = inspect.getmodule(cls).__doc__ or ""
    missing = [key for key in (*cls.READS, *cls.WRITES) if f"``{key}``" not in doc]
    assert missing == [], f"{cls.__name__}'s module docstring does not mention {missing}"
    assert "Semantics" in doc and any(status in doc for status in ("SUCCESS", "FAILURE", "RUNNING"))
    assert "Example" in doc and f"- type: {cls.__name__}" in doc, f"{cls.__name__} has no YAML example"


def test_building_without_mission_services_is_a_clear_error() -> None:
    with pytest.raises(RuntimeError, match=r"BuildContext.services\['mission'\] is missing"):
        Spin(name="Turn", context=BuildContext(clock=lambda: 0.0))
