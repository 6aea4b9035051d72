"""Mission-tree format: registry, validating loader, `semexp-bt tree` (the sim-clock decorators' own tests are
in tests/behaviours/)."""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any, ClassVar

import py_trees
import pytest
from hypothesis import given
from hypothesis import strategies as st
from py_trees.common import Access, Status

from behaviours.rate_limiter import RateLimiter
from behaviours.sim_timeout import SimTimeout
from behaviours.spec import BlackboardKey, BuildContext, ParamSpec
from semexp_bt.cli import main as cli_main
from semexp_bt.cli.tree import node_reference
from trees.loader import MissionLoadError, TreeError, analyse_mission, load_mission, validate_mission
from trees.registry import NodeRegistry, behaviour_spec, default_registry

REPO = Path(__file__).resolve().parents[1]
DATA = Path(__file__).resolve().parent / "data"
MALFORMED = DATA / "malformed_trees"
VALID = DATA / "trees"
EXPECT = re.compile(
    r"# expect: (?:(?P<file>[\w./-]+\.ya?ml):)?(?P<line>\d+):(?P<column>\d+): (?P<message>.*)"
)


class FakeClock:
    """A robot clock the test moves by hand."""

    def __init__(self, start_s: float = 0.0) -> None:
        self.now_s = start_s

    def __call__(self) -> float:
        return self.now_s


class BoardCopy(py_trees.behaviour.Behaviour):
    """Copy the value under ``source`` to ``destination`` (registers its keys, takes no remap argument)."""

    BLACKBOARD_KEYS: ClassVar[dict[str, BlackboardKey]] = {
        "source": BlackboardKey("read", doc="value to copy"),
        "destination": BlackboardKey("write", doc="where the copy goes"),
    }

    def __init__(self, name: str) -> None:
        super().__init__(name=name)
        self.board = self.attach_blackboard_client(name=name)
        self.board.register_key(key="source", access=Access.READ)
        self.board.register_key(key="destination", access=Access.WRITE)

    def update(self) -> Status:
        self.board.destination = self.board.source
        return Status.SUCCESS


class RemapAware(py_trees.behaviour.Behaviour):
    """Takes its remap as a constructor argument (as behaviours.base.SemExpBehaviour does)."""

    BLACKBOARD_KEYS: ClassVar[dict[str, BlackboardKey]] = {"memory": BlackboardKey("read", doc="a memory")}
    PARAMS: ClassVar[dict[str, ParamSpec]] = {"gain": ParamSpec("float", doc="a gain", default=1.0, ge=0.0)}

    def __init__(self, name: str, *, gain: float, context: BuildContext, remap: dict[str, str]) -> None:
        super().__init__(name=name)
        self.gain = gain
        self.context = context
        self.remap = remap

    def update(self) -> Status:
        return Status.SUCCESS


def test_registry() -> NodeRegistry:
    """The default registry plus two test-only node types that use the blackboard."""
    registry = default_registry()
    registry.register(behaviour_spec(BoardCopy))
    registry.register(behaviour_spec(RemapAware))
    return registry


test_registry.__test__ = False  # type: ignore[attr-defined]  # a helper, not a test


@pytest.fixture(autouse=True)
def clean_blackboard() -> Iterator[None]:
    py_trees.blackboard.Blackboard.storage.clear()
    py_trees.blackboard.Blackboard.metadata.clear()
    py_trees.blackboard.Blackboard.clients.clear()
    yield
    py_trees.blackboard.Blackboard.storage.clear()
    py_trees.blackboard.Blackboard.metadata.clear()
    py_trees.blackboard.Blackboard.clients.clear()


def tick_until_done(
    root: py_trees.behaviour.Behaviour, clock: FakeClock, *, dt_s: float, max_ticks: int
) -> int:
    """Tick in lockstep with the fake clock; the number of ticks until the root stops RUNNING."""
    tree = py_trees.trees.BehaviourTree(root)
    for tick in range(1, max_ticks + 1):
        tree.tick()
        if root.status != Status.RUNNING:
            return tick
        clock.now_s += dt_s
    raise AssertionError(f"tree still RUNNING after {max_ticks} ticks")


# --------------------------------------------------------------------------------------------------
# The malformed corpus: one file per error kind, the expected errors in its leading comments
# --------------------------------------------------------------------------------------------------


def expected_errors(path: Path) -> list[TreeError]:
    """The ``# expect:`` lines at the top of a corpus file (read as bytes: some files are not UTF-8);
    ``{REPO}`` in them stands for the repository's absolute path."""
    expected = []
    for raw in path.read_bytes().splitlines():
        line = raw.decode("utf-8", errors="replace")
        if not line.startswith("# expect:"):
            break
        match = EXPECT.fullmatch(line.replace("{REPO}", str(REPO)))
        assert match, f"{path.name}: malformed expectation line {line!r}"
        expected.append(
            TreeError(match["file"] or path.name, int(match["line"]), int(match["column"]), match["message"])
        )
    return expected


MALFORMED_FILES = sorted(MALFORMED.glob("*.yaml"))


def test_malformed_corpus_is_substantial() -> None:
    assert len(MALFORMED_FILES) >= 30
    assert all(expected_errors(p) for p in MALFORMED_FILES), "every corpus file states its expected errors"


@pytest.mark.parametrize("path", MALFORMED_FILES, ids=lambda p: p.stem)
def test_malformed_tree_reportsexpected_errors(path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(MALFORMED)  # error paths are then relative to the corpus folder, as written there
    errors = validate_mission(path.name, test_registry())
    for error in errors:
        print(error)
    assert errors == expected_errors(path)


def test_tree_error_str_is_file_line_column_message() -> None:
    error = TreeError("missions/x.yaml", 12, 7, "unknown node type 'Sequense' (did you mean 'Sequence'?)")
    assert str(error) == "missions/x.yaml:12:7: unknown node type 'Sequense' (did you mean 'Sequence'?)"


def test_load_mission_raises_every_error_and_builds_nothing(tmp_path: Path) -> None:
    built: list[str] = []

    def counting_factory(**kwargs: Any) -> py_trees.behaviour.Behaviour:
        built.append(kwargs["name"])
        return py_trees.behaviours.Success(name=kwargs["name"])

    registry = test_registry()
    spec = behaviour_spec(py_trees.behaviours.Success, type_name="Counted", params={})
    registry.register(dataclasses.replace(spec, factory=counting_factory))
    path = tmp_path / "m.yaml"
    path.write_text(
        "tree:\n  type: Sequence\n  params: {memory: true}\n  children:\n"
        "    - type: Counted\n    - type: Counted\n      name: Again\n    - type: Nope\n"
        "    - type: Retry\n      params: {num_failures: 0}\n      children: [{type: Counted, name: C3}]\n"
    )
    with pytest.raises(MissionLoadError) as caught:
        load_mission(path, registry=registry, context=BuildContext(clock=FakeClock()))
    assert [(e.line, e.column) for e in caught.value.errors] == [(8, 13), (10, 30)]
    assert "unknown node type 'Nope'" in str(caught.value)
    assert built == []


# --------------------------------------------------------------------------------------------------
# Valid trees build and tick
# --------------------------------------------------------------------------------------------------


def test_basic_mission_builds_and_ticks_on_the_robot_clock() -> None:
    clock = FakeClock()
    mission = load_mission(VALID / "basic.yaml", context=BuildContext(clock=clock))
    print(py_trees.display.unicode_tree(mission.root))
    assert mission.settings.name == "basic"
    assert mission.settings.instruction == "find the fire extinguisher"
    assert mission.settings.budget_s == 60.0
    assert [c.name for c in mission.root.children] == ["SetLabel", "Choose", "Both", "LabelIsSet"]
    limiter = next(n for n in mission.root.iterate() if isinstance(n, RateLimiter))
    # Worked by hand: ticks every 20 ms; the 10 Hz limiter lets the TickCounter(duration=2) tick at
    # t = 0, 0.1, 0.2 s; it completes on its third tick, at t = 0.2 s = tick 11, and so does the mission.
    ticks = tick_until_done(mission.root, clock, dt_s=0.02, max_ticks=100)
    print(py_trees.display.unicode_tree(mission.root, show_status=True))
    assert ticks == 11
    assert mission.root.status == Status.SUCCESS
    assert limiter.child_ticks == 3
    assert py_trees.blackboard.Blackboard.get("/target_label") == "fire extinguisher"


def test_subtree_arguments_and_defaults_substitute_with_their_types() -> None:
    clock = FakeClock()
    mission = load_mission(VALID / "with_include.yaml", context=BuildContext(clock=clock))
    print(py_trees.display.unicode_tree(mission.root))
    first, second = mission.root.children
    assert (first.name, second.name) == ("CountDefault", "CountThree")
    counters = [n for n in mission.root.iterate() if isinstance(n, py_trees.behaviours.TickCounter)]
    assert [(c.name, c.duration) for c in counters] == [("Tick one", 1), ("Tick three", 3)]
    assert all(type(c.duration) is int for c in counters)  # "${ticks}" kept the declared int type
    # Default subtree: RUNNING once then SUCCESS (tick 2), where the second starts: 3 RUNNING + SUCCESS.
    assert tick_until_done(mission.root, clock, dt_s=0.02, max_ticks=20) == 5


def test_interpolation_and_escape(tmp_path: Path) -> None:
    (tmp_path / "sub.yaml").write_text(
        "parameters:\n  label: {type: str, default: chair}\n  n: {type: int, default: 2}\n"
        "tree:\n  type: SetBlackboardVariable\n  name: 'Set $${literal} ${label} x${n}'\n"
        "  params: {variable_name: target_label, variable_value: '${n}'}\n"
    )
    (tmp_path / "main.yaml").write_text("tree:\n  include: sub.yaml\n  args: {n: 7}\n")
    _, root, errors = analyse_mission(tmp_path / "main.yaml")
    assert errors == []
    assert root is not None
    assert root.name == "Set ${literal} chair x7"
    assert root.params["variable_value"] == 7


def test_remap_redirects_a_behaviours_blackboard_keys(tmp_path: Path) -> None:
    path = tmp_path / "remap.yaml"
    path.write_text(
        "tree:\n  type: BoardCopy\n  name: Copy\n  remap: {source: instruction, destination: /target_label}\n"
    )
    mission = load_mission(path, registry=test_registry(), context=BuildContext(clock=FakeClock()))
    py_trees.blackboard.Blackboard.set("/instruction", "find the chair")
    tick_until_done(mission.root, FakeClock(), dt_s=0.02, max_ticks=1)
    assert mission.root.status == Status.SUCCESS
    assert py_trees.blackboard.Blackboard.get("/target_label") == "find the chair"
    assert "/destination" not in py_trees.blackboard.Blackboard.storage
    assert "/source" not in py_trees.blackboard.Blackboard.metadata


def test_remap_is_passed_to_a_constructor_that_takes_it(tmp_path: Path) -> None:
    path = tmp_path / "aware.yaml"
    path.write_text("tree:\n  type: RemapAware\n  params: {gain: 2}\n  remap: {memory: /memory}\n")
    clock = FakeClock(5.0)
    mission = load_mission(path, registry=test_registry(), context=BuildContext(clock=clock))
    assert isinstance(mission.root, RemapAware)
    assert mission.root.remap == {"memory": "/memory"}
    assert mission.root.gain == 2.0 and isinstance(mission.root.gain, float)
    assert mission.root.context.clock() == 5.0


def test_a_subtree_file_checks_on_its_own() -> None:
    assert validate_mission(VALID / "subtrees" / "required_param.yaml") == []
    assert validate_mission(VALID / "subtrees" / "counting.yaml") == []


# --------------------------------------------------------------------------------------------------
# Registry and parameter specs
# --------------------------------------------------------------------------------------------------


def test_registry_rejects_duplicates_and_suggests_names() -> None:
    registry = default_registry()
    with pytest.raises(ValueError, match="already registered"):
        registry.register(behaviour_spec(SimTimeout))
    assert registry.suggest("Sequense") == "Sequence"
    assert registry.suggest("sequence") == "Sequence"
    assert registry.suggest("Zzzzzz") is None
    assert "Timeout" not in registry  # py_trees' Timeout reads the wall clock; SimTimeout replaces it


def test_behaviour_spec_catches_a_param_the_constructor_does_not_take() -> None:
    class Broken(py_trees.behaviour.Behaviour):
        PARAMS: ClassVar[dict[str, ParamSpec]] = {"speed": ParamSpec("float", doc="m/s", default=1.0)}

        def __init__(self, name: str) -> None:
            super().__init__(name=name)

    with pytest.raises(ValueError, match="speed"):
        behaviour_spec(Broken)


def test_param_spec_rejects_an_invalid_default() -> None:
    with pytest.raises(ValueError, match="out of range"):
        ParamSpec("int", doc="x", default=0, ge=1)


@given(st.floats(allow_nan=True, allow_infinity=True), st.floats(-10, 10), st.floats(0, 10))
def test_float_param_accepts_exactly_finite_values_in_range(value: float, low: float, width: float) -> None:
    spec = ParamSpec("float", doc="x", gt=low, le=low + width)
    normalised, problem = spec.check(value)
    inside = math.isfinite(value) and low < value <= low + width
    assert (problem is None) == inside
    if inside:
        assert normalised == value


@given(st.one_of(st.integers(), st.booleans(), st.text(max_size=5), st.none()))
def test_int_param_refuses_bools_and_non_ints(value: Any) -> None:
    _, problem = ParamSpec("int", doc="x").check(value)
    assert (problem is None) == (isinstance(value, int) and not isinstance(value, bool))


def test_node_reference_is_up_to_date() -> None:
    committed = (REPO / "docs" / "node_reference.md").read_text(encoding="utf-8")
    assert committed == node_reference(default_registry()), (
        "docs/node_reference.md is stale: run `semexp-bt tree docs --out docs/node_reference.md`"
    )


# --------------------------------------------------------------------------------------------------
# The product's shipped trees (written by the lead) must pass `tree check`
# --------------------------------------------------------------------------------------------------

SHIPPED = sorted([*REPO.glob("trees/*.yaml"), *REPO.glob("trees/subtrees/*.yaml")])


@pytest.mark.parametrize(
    "path",
    SHIPPED or [pytest.param(None, marks=pytest.mark.skip(reason="no shipped trees in trees/ yet"))],
    ids=lambda p: p.relative_to(REPO).as_posix() if p else "none",
)
def test_shipped_tree_passes_check(path: Path) -> None:
    errors = validate_mission(path)
    assert errors == [], "\n".join(str(e) for e in errors)


# --------------------------------------------------------------------------------------------------
# CLI
# --------------------------------------------------------------------------------------------------


def test_cli_check_prints_ok_or_every_error(capsys: pytest.CaptureFixture[str]) -> None:
    good = VALID / "basic.yaml"
    bad = MALFORMED / "many_errors.yaml"
    assert cli_main(["tree", "check", str(good)]) == 0
    assert capsys.readouterr().out == f"{good}: ok\n"
    assert cli_main(["tree", "check", str(good), str(bad)]) == 2
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == f"{good}: ok"
    assert len(lines) == 1 + len(expected_errors(bad))
    assert lines[2].startswith(f"{bad}:12:13: unknown node type 'Succes'")


def test_cli_show_prints_types_and_params(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli_main(["tree", "show", str(VALID / "with_include.yaml")]) == 0
    out = capsys.readouterr().out
    print(out)
    assert "{-} Root (Sequence, memory=true)" in out
    assert "        --> Tick three (TickCounter, duration=3, completion_status=SUCCESS)" in out


def test_cli_docs_writes_the_reference(tmp_path: Path) -> None:
    out = tmp_path / "ref.md"
    assert cli_main(["tree", "docs", "--out", str(out)]) == 0
    text = out.read_text()
    assert "### SimTimeout" in text and "| `duration_s` | float > 0 | **required** |" in text


def test_blackboard_conditions_compare_board_values(tmp_path: Path) -> None:
    path = tmp_path / "guard.yaml"
    path.write_text(
        "tree:\n  type: Sequence\n  params: {memory: false}\n  children:\n"
        "    - type: CheckBlackboardVariableValue\n      name: Far\n"
        "      params: {variable: budget, operator: gt, value: 2}\n"
        "    - type: EternalGuard\n      name: Guard\n      params: {key: mission_outcome, value: running}\n"
        "      children: [{type: Running, name: Work}]\n"
    )
    mission = load_mission(path, context=BuildContext(clock=FakeClock()))
    board = py_trees.blackboard.Blackboard
    mission.root.tick_once()
    assert mission.root.status == Status.FAILURE  # 'budget' absent: the check fails
    board.set("/budget", 3)
    mission.root.tick_once()
    assert mission.root.status == Status.FAILURE  # the guard's key is absent: closed
    board.set("/mission_outcome", "running")
    mission.root.tick_once()
    assert mission.root.status == Status.RUNNING
    board.set("/mission_outcome", "fallen")
    mission.root.tick_once()
    print(py_trees.display.unicode_tree(mission.root, show_status=True))
    assert mission.root.status == Status.FAILURE
    board.set("/budget", 1)
    board.set("/mission_outcome", "running")
    mission.root.tick_once()
    assert mission.root.status == Status.FAILURE  # 1 > 2 is false
