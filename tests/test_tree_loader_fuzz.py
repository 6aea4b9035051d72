"""Property-based fuzzing of the mission loader (hypothesis): whatever the file holds, the loader either
reads it or raises MissionLoadError whose every line is ``file:line:column: message``, in bounded time.

Three sources of input: random bytes (and YAML-ish text), random YAML documents (nested mappings, lists
and scalars with anchors, aliases and tags, many shaped like tree nodes), and random mutations of the
shipped trees (in a copy, so that their includes resolve). 120 examples each (360 in all, about 15 s on
the 2-core VM); a longer hunt: ``SEMEXP_FUZZ_EXAMPLES=1500 pytest tests/test_tree_loader_fuzz.py``.
The examples are derandomised: the same ones every run, so a failure reproduces.
"""

from __future__ import annotations

import json
import os
import random
import re
import shutil
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from trees.declarations import FILE_KEYS, INCLUDE_KEYS, NODE_KEYS
from trees.loader import MissionLoadError, parse_mission
from trees.registry import default_registry

REPO = Path(__file__).resolve().parents[1]
SHIPPED = REPO / "trees"
#: Per example, in CPU time of this process (other load on a shared machine does not count): reading one
#: file and its includes takes milliseconds (a shipped mission about 15 ms), the bound is generous.
EXAMPLE_TIME_BOUND_S = 2.0
LOCATED = re.compile(r"^[^\n]+:(?P<line>\d+):(?P<column>\d+): [^\n]+$")
FUZZ_SETTINGS = settings(
    max_examples=int(os.environ.get("SEMEXP_FUZZ_EXAMPLES", 120)),
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
)

TYPES = sorted(spec.type_name for spec in default_registry())
PARAMS = ["memory", "duration_s", "num_failures", "rate_hz", "variable_name", "variable_value", "policy"]
WORDS = [*FILE_KEYS, *NODE_KEYS, *INCLUDE_KEYS, *TYPES, *PARAMS, "instruction", "budget_s", "config"]
INCLUDES = [
    "subtrees/explore_step.yaml",
    "subtrees/recovery.yaml",
    "subtrees/nope.yaml",
    "subtrees",
    "../trees/object_search.yaml",
    "/dev/null",
    "x.yml",
    "self.yaml",
    "mission.yaml",
]
TAGS = [
    "!!str",
    "!!int",
    "!!map",
    "!!seq",
    "!!python/object/apply:os.system",
    "!!python/name:os.getcwd",
    "!include",
    "!",
    "!!binary",
    "!!set",
    "!!timestamp",
    "!local",
]
ODD_SCALARS = [
    "${x}",
    "$${y}",
    "${max_steps}",
    "a ${label} b",
    "2024-13-45",
    "2024-01-01",
    "0x1F",
    "1:30",
    ".nan",
    ".inf",
    "-.inf",
    "~",
    "=",
    "<<",
    "1e999",
    "9" * 5000,
    "null",
    "yes",
    "'",
    '"',
    "{",
    "]",
]


@pytest.fixture(scope="module")
def workspace() -> Iterator[Path]:
    """A folder with a copy of the shipped trees (so that includes resolve) to write examples into."""
    folder = Path(tempfile.mkdtemp(prefix="semexp_fuzz_"))
    shutil.copytree(SHIPPED / "subtrees", folder / "subtrees")
    yield folder
    shutil.rmtree(folder)


def check_file(path: Path) -> None:
    """The property: reads, or raises MissionLoadError, each line located; within the time bound."""
    started = time.process_time()
    try:
        document = parse_mission(path)
    except MissionLoadError as exc:
        assert exc.errors
        for error in exc.errors:
            text = str(error)
            match = LOCATED.match(text)
            assert match, f"not one located line: {text!r}"
            assert error.line >= 1 and error.column >= 1
            assert error.file, text
    else:
        assert document.declaration.type_name in TYPES
    elapsed = time.process_time() - started
    assert elapsed < EXAMPLE_TIME_BOUND_S, f"{path.name} took {elapsed:.2f} s of CPU"


# --------------------------------------------------------------------------------------------------
# Random bytes
# --------------------------------------------------------------------------------------------------

YAMLISH = st.lists(st.sampled_from(list("{}[]:,-&*!|>'\"#%@`?$ \n\t\r\x00é") + WORDS), max_size=80).map(
    "".join
)


@FUZZ_SETTINGS
@given(data=st.one_of(st.binary(max_size=2000), YAMLISH.map(lambda text: text.encode("utf-8"))))
def test_random_bytes(workspace: Path, data: bytes) -> None:
    path = workspace / "mission.yaml"
    path.write_bytes(data)
    check_file(path)


# --------------------------------------------------------------------------------------------------
# Random YAML documents
# --------------------------------------------------------------------------------------------------

SCALARS = st.one_of(
    st.sampled_from(WORDS),
    st.sampled_from(ODD_SCALARS),
    st.integers(-3, 10**6),
    st.floats(allow_nan=True, allow_infinity=True),
    st.booleans(),
    st.none(),
    st.text(alphabet=st.characters(blacklist_categories=("Cs", "Cc")), max_size=8),
    st.text(max_size=3),
)
VALUES = st.recursive(
    SCALARS,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4),
        st.dictionaries(st.one_of(st.sampled_from(WORDS), st.text(max_size=4)), inner, max_size=4),
    ),
    max_leaves=25,
)
NODES = st.recursive(
    st.fixed_dictionaries(
        {"type": st.sampled_from(TYPES)},
        optional={
            "name": st.one_of(st.text(max_size=6), st.sampled_from(ODD_SCALARS)),
            "params": st.dictionaries(st.sampled_from(PARAMS), SCALARS, max_size=3),
        },
    )
    | st.fixed_dictionaries(
        {"include": st.sampled_from(INCLUDES)},
        optional={"args": st.dictionaries(st.sampled_from(["execute_timeout_s", "label", "x"]), SCALARS)},
    ),
    lambda inner: st.fixed_dictionaries(
        {"type": st.sampled_from(TYPES), "children": st.lists(inner, max_size=3)},
        optional={"params": st.dictionaries(st.sampled_from(PARAMS), SCALARS, max_size=2)},
    ),
    max_leaves=12,
)
DOCUMENTS = st.one_of(
    VALUES,
    st.fixed_dictionaries(
        {"tree": NODES},
        optional={
            "mission": st.dictionaries(st.sampled_from(["name", "budget_s", "config", "robot"]), VALUES),
            "parameters": st.dictionaries(st.sampled_from(["x", "label"]), VALUES, max_size=2),
        },
    ),
)


class Emitter:
    """Writes a value as YAML text, block or flow style at random, with random anchors, aliases and tags."""

    def __init__(self, rng: random.Random) -> None:
        self.rng = rng
        self.anchors: list[str] = []

    def _decorate(self) -> str:
        parts = []
        if self.rng.random() < 0.03:
            parts.append(self.rng.choice(TAGS))
        if self.rng.random() < 0.08:
            name = f"a{len(self.anchors)}"
            self.anchors.append(name)
            parts.append(f"&{name}")
        return " ".join(parts) + (" " if parts else "")

    def scalar(self, value: Any) -> str:
        if self.anchors and self.rng.random() < 0.1:
            return f"*{self.rng.choice(self.anchors)}"
        if isinstance(value, str) and self.rng.random() < 0.3:
            return self._decorate() + value  # plain, possibly not valid YAML
        return self._decorate() + json.dumps(value, allow_nan=True)

    def flow(self, value: Any) -> str:
        if isinstance(value, dict):
            return (
                self._decorate()
                + "{"
                + ", ".join(f"{self.scalar(k)}: {self.flow(v)}" for k, v in value.items())
                + "}"
            )
        if isinstance(value, list):
            return self._decorate() + "[" + ", ".join(self.flow(v) for v in value) + "]"
        return self.scalar(value)

    def block(self, value: Any, indent: int) -> str:
        pad = " " * indent
        if isinstance(value, dict) and value and self.rng.random() < 0.8:
            lines = []
            for key, inner in value.items():
                head = f"{pad}{self.scalar(key) if self.rng.random() < 0.2 else key}:"
                if isinstance(inner, dict | list) and inner and self.rng.random() < 0.8:
                    lines.append(f"{head}\n{self.block(inner, indent + 2)}")
                else:
                    lines.append(f"{head} {self.flow(inner)}")
            return "\n".join(lines)
        if isinstance(value, list) and value and self.rng.random() < 0.8:
            return "\n".join(f"{pad}- {self.flow(inner)}" for inner in value)
        return pad + self.flow(value)


@FUZZ_SETTINGS
@given(document=DOCUMENTS, rng=st.randoms(use_true_random=False))
def test_random_documents(workspace: Path, document: Any, rng: random.Random) -> None:
    text = Emitter(rng).block(document, 0) + "\n"
    path = workspace / "mission.yaml"
    path.write_text(text, encoding="utf-8")
    print(text)
    check_file(path)


# --------------------------------------------------------------------------------------------------
# Mutations of the shipped trees
# --------------------------------------------------------------------------------------------------

SHIPPED_FILES = sorted([*SHIPPED.glob("*.yaml"), *SHIPPED.glob("subtrees/*.yaml")])
MISSIONS = sorted(SHIPPED.glob("*.yaml"))
REPLACEMENTS = [
    b"-1",
    b"0",
    b"1e999",
    b".nan",
    b"true",
    b"[]",
    b"{}",
    b"&a",
    b"*a",
    b"!!python/none",
    b"${x}",
    b"\t",
    b"\xff",
    b"\x00",
    b"---",
    b": ",
    b"- ",
    b"include",
    b"children",
    b"'",
    b"\n  ",
]


def mutate(data: bytes, rng: random.Random, count: int) -> bytes:
    """``count`` random edits: delete, duplicate or swap lines, reindent, insert, replace or truncate."""
    for _ in range(count):
        lines = data.split(b"\n")
        i, j = rng.randrange(len(lines)), rng.randrange(len(lines))
        operation = rng.randrange(7)
        if operation == 0:
            del lines[i]
        elif operation == 1:
            lines.insert(i, lines[i])
        elif operation == 2:
            lines[i], lines[j] = lines[j], lines[i]
        elif operation == 3:
            lines[i] = b" " * rng.randrange(1, 5) + lines[i] if rng.random() < 0.5 else lines[i].lstrip(b" ")
        if operation <= 3:
            data = b"\n".join(lines)
            continue
        at = rng.randrange(len(data) + 1)
        if operation == 4:
            data = data[:at] + rng.choice(REPLACEMENTS) + data[at:]
        elif operation == 5:
            data = data[:at] + rng.choice(REPLACEMENTS) + data[at + rng.randrange(1, 8) :]
        else:
            data = data[:at]
    return data


@FUZZ_SETTINGS
@given(
    target=st.sampled_from(SHIPPED_FILES),
    mission=st.sampled_from(MISSIONS),
    count=st.integers(1, 4),
    rng=st.randoms(use_true_random=False),
)
def test_mutated_shipped_trees(
    workspace: Path, target: Path, mission: Path, count: int, rng: random.Random
) -> None:
    copy = workspace / target.relative_to(SHIPPED)
    for path in MISSIONS:
        shutil.copy(path, workspace / path.name)
    copy.write_bytes(mutate(target.read_bytes(), rng, count))
    try:
        check_file(workspace / mission.name)
    finally:
        shutil.copy(target, copy)  # the next example starts from the shipped file again


def test_unmutated_shipped_trees_load(workspace: Path) -> None:
    """The property's positive side: the copies the mutations start from are valid."""
    for mission in MISSIONS:
        shutil.copy(mission, workspace / mission.name)
        copy = parse_mission(workspace / mission.name).declaration
        original = parse_mission(mission).declaration
        assert [(d.type_name, d.name, d.params) for d in copy.walk()] == [
            (d.type_name, d.name, d.params) for d in original.walk()
        ]
