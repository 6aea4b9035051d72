"""What the mission loader refuses (docs/trees.md), file by file: one located line each, exit status 2.

The corpus in tests/data/trees/bad/ holds one file per refusal with its exact expected errors; refusals
that need a special file (a FIFO, a file past the size cap, caps on include chains, tree depth and error
count) are built here in a temporary folder.
"""

from __future__ import annotations

import os
import re
import sys
import time
from pathlib import Path

import pytest

from semexp_bt.cli import main as cli_main
from semexp_bt.files.yaml_source import MAX_FILE_BYTES
from tests.test_tree_loader import expected_errors
from trees.declarations import MAX_INCLUDE_DEPTH, MAX_REPORTED_ERRORS, MAX_TREE_DEPTH
from trees.loader import MissionLoadError, parse_mission, validate_mission

BAD = Path(__file__).resolve().parent / "data" / "trees" / "bad"
LOCATED = re.compile(r"^[^\n]+:\d+:\d+: [^\n]+$")
BAD_FILES = sorted(BAD.glob("*.yaml"))


def test_the_corpus_covers_every_refusal() -> None:
    assert len(BAD_FILES) >= 20
    assert all(expected_errors(p) for p in BAD_FILES), "every corpus file states its expected errors"


@pytest.mark.parametrize("path", BAD_FILES, ids=lambda p: p.stem)
def test_refused_file_reports_its_exact_errors(path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(BAD)  # error paths are then relative to the corpus folder, as written there
    errors = validate_mission(path.name)
    for error in errors:
        print(error)
    assert errors == expected_errors(path)
    assert all(LOCATED.match(str(error)) for error in errors)


@pytest.mark.parametrize("path", BAD_FILES, ids=lambda p: p.stem)
def test_tree_check_prints_one_line_per_problem_and_exits_2(
    path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(BAD)
    assert cli_main(["tree", "check", path.name]) == 2
    assert capsys.readouterr().out.splitlines() == [str(e) for e in expected_errors(path)]
    assert cli_main(["tree", "show", path.name]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.splitlines() == [str(e) for e in expected_errors(path)]


def test_a_symlink_that_stays_inside_is_followed(tmp_path: Path) -> None:
    mission = tmp_path / "m.yaml"
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "leaf.yaml").write_text("tree: {type: Success, name: Leaf}\n")
    (tmp_path / "sub" / "link.yaml").symlink_to("leaf.yaml")
    mission.write_text("tree:\n  include: sub/link.yaml\n")
    assert parse_mission(mission).declaration.name == "Leaf"


# --------------------------------------------------------------------------------------------------
# Refusals that need a file made on the spot
# --------------------------------------------------------------------------------------------------


@pytest.mark.skipif(sys.platform == "win32", reason="FIFOs are POSIX")
def test_a_fifo_is_refused_at_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    os.mkfifo("pipe.yaml")  # reading it would block until a writer came
    Path("m.yaml").write_text("tree:\n  include: pipe.yaml\n")
    started = time.monotonic()
    assert [str(e) for e in validate_mission("m.yaml")] == [
        "m.yaml:2:12: subtree file not a regular file (a FIFO): 'pipe.yaml' (looked for pipe.yaml)"
    ]
    assert [str(e) for e in validate_mission("pipe.yaml")] == [
        "pipe.yaml:1:1: mission file not a regular file (a FIFO)"
    ]
    assert time.monotonic() - started < 5.0


def test_a_file_past_the_size_cap(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    Path("big.yaml").write_text("tree: {type: Success}\n" + "#" * MAX_FILE_BYTES + "\n")
    assert [str(e) for e in validate_mission("big.yaml")] == [
        f"big.yaml:1:1: mission file larger than {MAX_FILE_BYTES} bytes (the reader's cap)"
    ]


def test_an_include_chain_past_its_cap(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    last = MAX_INCLUDE_DEPTH + 1
    for index in range(last):
        Path(f"c{index:02d}.yaml").write_text(f"tree:\n  include: c{index + 1:02d}.yaml\n")
    Path(f"c{last:02d}.yaml").write_text("tree: {type: Success}\n")
    assert [str(e) for e in validate_mission(f"c{1:02d}.yaml")] == []  # 16 includes deep: fine
    assert [str(e) for e in validate_mission("c00.yaml")] == [
        f"c{MAX_INCLUDE_DEPTH:02d}.yaml:2:12: includes nested deeper than {MAX_INCLUDE_DEPTH} files (the loader's cap)"
    ]


def test_a_tree_past_its_depth_cap(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Each file nests 20 Inverters (40 YAML levels, inside the reader's cap); includes stack them."""
    monkeypatch.chdir(tmp_path)
    per_file = 20
    files = MAX_TREE_DEPTH // per_file + 1  # 4 files: 80 levels
    for index in range(files):
        leaf = f"{{include: d{index + 1}.yaml}}" if index + 1 < files else "{type: Success}"
        text = leaf
        for level in reversed(range(per_file)):
            text = f"{{type: Inverter, name: I{index}_{level}, children: [{text}]}}"
        Path(f"d{index}.yaml").write_text(f"tree: {text}\n")
    errors = validate_mission("d0.yaml")
    # Depth 65 is the fifth Inverter of d3.yaml (d0 holds depths 1-20, d1 21-40, d2 41-60).
    column = Path("d3.yaml").read_text().index("{type: Inverter, name: I3_4,") + 1
    assert [str(e) for e in errors] == [
        f"d3.yaml:1:{column}: tree nested deeper than {MAX_TREE_DEPTH} nodes (the loader's cap)"
    ]


def test_checking_stops_after_the_error_cap(tmp_path: Path) -> None:
    path = tmp_path / "many.yaml"
    children = "".join(f"    - type: Nope{i}\n" for i in range(MAX_REPORTED_ERRORS + 50))
    path.write_text(f"tree:\n  type: Sequence\n  children:\n{children}")
    errors = validate_mission(path)
    assert len(errors) == MAX_REPORTED_ERRORS + 1
    assert errors[-1].message == f"stopped after {MAX_REPORTED_ERRORS} errors"
    with pytest.raises(MissionLoadError) as caught:
        parse_mission(path)
    assert len(caught.value.errors) == MAX_REPORTED_ERRORS + 1


def test_messages_that_echo_a_value_stay_one_line(tmp_path: Path) -> None:
    path = tmp_path / "echo.yaml"
    path.write_text('tree:\n  type: "Seq\\nuence"\n  "na\\rme": x\n')
    errors = [str(e) for e in validate_mission(path)]
    print("\n".join(errors))
    assert len(errors) == 2
    assert all(LOCATED.match(e) for e in errors)
    assert "unknown node type 'Seq\\nuence'" in errors[1]
