"""Bad command-line values and files, for every subcommand that takes them: one line, exit status 2.

Each row of the table is an invocation that must stop before any scene is built or episode runs, with
one line (one per problem for an invalid mission file) naming what was wrong, and no traceback.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from semexp_bt.cli import main

REPO = Path(__file__).resolve().parents[1]
MISSION = str(REPO / "trees" / "object_search.yaml")

#: (id, argv; "{tmp}" is a fresh empty folder, the working directory; "{file}" an existing file in it),
#: and the line printed (on stderr, or on stdout for `tree check`, whose report it is).
CASES: list[tuple[str, list[str], str]] = [
    ("run-negative-seed", ["run", MISSION, "--scene", "office", "--seed", "-1"],
     "semexp-bt run: error: argument --seed: expected a non-negative integer, got '-1' (see 'semexp-bt run --help')"),
    ("run-seed-not-int", ["run", MISSION, "--scene", "office", "--seed", "x"],
     "semexp-bt run: error: argument --seed: expected an integer, got 'x' (see 'semexp-bt run --help')"),
    ("run-unknown-scene", ["run", MISSION, "--scene", "ofice"],
     "semexp-bt run: error: argument --scene: unknown scene 'ofice' (did you mean 'office'?); known scenes: "),
    ("run-unknown-strategy", ["run", MISSION, "--scene", "office", "--strategy", "magic"],
     "semexp-bt run: error: argument --strategy: unknown strategy 'magic'; known strategies: ours, "),
    ("run-unknown-backend", ["run", MISSION, "--backend", "gazebo"],
     "semexp-bt run: error: argument --backend: invalid choice: 'gazebo'"),
    ("run-no-scene", ["run", MISSION], "error: --scene is required with --backend mujoco"),
    ("run-missing-mission", ["run", "nope.yaml", "--scene", "office"], "nope.yaml:1:1: mission file not found"),
    ("run-mission-is-a-folder", ["run", "{tmp}", "--scene", "office"],
     "{tmp}:1:1: mission file not a regular file (a directory)"),
    ("run-json-is-a-folder", ["run", MISSION, "--scene", "office", "--json", "{tmp}"],
     "semexp-bt run: error: argument --json: {tmp} exists and is not a regular file"),
    ("run-config-is-a-folder", ["run", MISSION, "--scene", "office", "--config", "{tmp}"],
     "error: config file {tmp}: not a regular file (a directory)"),
    ("run-config-missing", ["run", MISSION, "--scene", "office", "--config", "nope.yaml"],
     "error: config file nope.yaml: not found"),
    ("tree-check-missing", ["tree", "check", "nope.yaml"], "nope.yaml:1:1: mission file not found"),
    ("tree-check-folder", ["tree", "check", "{tmp}"], "{tmp}:1:1: mission file not a regular file (a directory)"),
    ("tree-show-missing", ["tree", "show", "nope.yaml"], "nope.yaml:1:1: mission file not found"),
    ("tree-docs-out-is-a-folder", ["tree", "docs", "--out", "{tmp}"],
     "semexp-bt tree docs: error: argument --out: {tmp} exists and is not a regular file"),
    ("tree-no-action", ["tree"], "semexp-bt tree: error: the following arguments are required: ACTION"),
    ("scene-unknown-action", ["scene", "draw"], "semexp-bt scene: error: argument {list,render}: invalid choice: 'draw'"),
    ("scene-render-unknown-scene", ["scene", "render", "nope", "--out", "{tmp}"],
     "semexp-bt scene render: error: argument scene: unknown scene 'nope'; known scenes: "),
    ("scene-render-negative-seed", ["scene", "render", "office", "--seed", "-1", "--out", "{tmp}"],
     "semexp-bt scene render: error: argument --seed: expected a non-negative integer, got '-1'"),
    ("scene-render-negative-episode-seed",
     ["scene", "render", "office", "--episode-seed", "-3", "--out", "{tmp}"],
     "semexp-bt scene render: error: argument --episode-seed: expected a non-negative integer, got '-3'"),
    ("scene-render-out-is-a-file", ["scene", "render", "office", "--out", "{file}"],
     "semexp-bt scene render: error: argument --out: {file} exists and is not a folder"),
    ("bench-core-negative-seed", ["bench", "core", "--seed", "-1"],
     "semexp-bt bench core: error: argument --seed: expected a non-negative integer, got '-1'"),
    ("bench-tree-zero-ticks", ["bench", "tree", "--ticks", "0"],
     "semexp-bt bench tree: error: argument --ticks: expected an integer >= 1, got '0'"),
    ("bench-gait-zero-seeds", ["bench", "gait", "--seeds", "0"],
     "semexp-bt bench gait: error: argument --seeds: expected an integer >= 1, got '0'"),
    ("bench-missions-unknown-scene", ["bench", "missions", "--scenes", "nope", "--out", "{tmp}", "--workers", "0"],
     "error: unknown scenes ['nope']; known: "),
    ("bench-missions-negative-seed", ["bench", "missions", "--scenes", "office", "--seeds", "-1", "--out", "{tmp}"],
     "error: seeds: cannot read '-1' in '-1'; use e.g. 0-9 or 0,3,5"),
    ("bench-missions-unknown-strategy",
     ["bench", "missions", "--scenes", "office", "--strategies", "nope", "--out", "{tmp}"],
     "error: unknown strategies ['nope']; known: "),
    ("bench-missions-missing-mission",
     ["bench", "missions", "--scenes", "office", "--mission", "nope.yaml", "--out", "{tmp}"],
     "nope.yaml:1:1: mission file not found"),
    ("bench-missions-negative-workers", ["bench", "missions", "--scenes", "office", "--workers", "-1", "--out", "{tmp}"],
     "semexp-bt bench missions: error: argument --workers: expected an integer >= 0, got '-1'"),
    ("bench-missions-nan-timeout", ["bench", "missions", "--scenes", "office", "--timeout-s", "nan", "--out", "{tmp}"],
     "semexp-bt bench missions: error: argument --timeout-s: expected a finite number of seconds > 0, got 'nan'"),
    ("bench-missions-out-is-a-file", ["bench", "missions", "--scenes", "office", "--out", "{file}"],
     "semexp-bt bench missions: error: argument --out: {file} exists and is not a folder"),
    ("bench-paper-zero-trials", ["bench", "paper", "--trials", "0", "--out", "{tmp}"],
     "semexp-bt bench paper: error: argument --trials: expected an integer >= 1, got '0'"),
    ("bench-report-no-sweep", ["bench", "report", "{tmp}"],
     "error: {tmp}/episodes.jsonl does not exist: run 'semexp-bt bench missions' first"),
    ("bench-compare-no-sweep", ["bench", "compare", "{tmp}", "{tmp}"], "error: compare: {tmp}/episodes.jsonl does not exist"),
    ("unknown-command", ["nope"], "semexp-bt: error: argument COMMAND: invalid choice: 'nope'"),
    ("no-command", [], "semexp-bt: error: the following arguments are required: COMMAND"),
]  # fmt: skip


@pytest.mark.parametrize(("argv", "expected"), [(a, e) for _, a, e in CASES], ids=[c[0] for c in CASES])
def test_bad_value_is_one_line_and_exit_status_2(
    argv: list[str],
    expected: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    folder = tmp_path / "empty"
    folder.mkdir()
    (tmp_path / "a_file.txt").write_text("not a folder\n")
    names = {"{tmp}": str(folder), "{file}": "a_file.txt"}
    argv = [names.get(arg, arg) for arg in argv]
    for placeholder, value in names.items():
        expected = expected.replace(placeholder, value)
    try:
        status = main(argv)
    except SystemExit as stop:  # the top-level parser (no or an unknown command) exits itself
        status = stop.code
    captured = capsys.readouterr()
    output = captured.out + captured.err
    print(output)
    assert status == 2
    assert "Traceback" not in output
    assert len(output.splitlines()) == 1, output
    assert output.startswith(expected)


def test_an_invalid_mission_is_one_line_per_problem(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        "tree:\n  type: Sequence\n  children:\n    - type: Sucess\n    - type: Failure\n      name: 7\n"
    )
    assert main(["run", str(bad), "--scene", "office"]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert lines == [
        f"{bad}:4:13: unknown node type 'Sucess' (did you mean 'Success'?)",
        f"{bad}:6:13: 'name' must be a non-empty string, got the scalar '7'",
        f"{bad}:2:3: missing required parameter 'memory' for node type 'Sequence'; expected bool (true: resume "
        "from the running child on the next tick; false: restart from the first child every tick (reactive))",
    ]
