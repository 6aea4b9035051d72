"""`semexp-bt run` turns bad input into one clear error line and exit status 2, never a traceback."""

from __future__ import annotations

from pathlib import Path

import pytest

from semexp_bt.cli import main

MISSION = Path(__file__).resolve().parents[1] / "trees" / "object_search.yaml"


def test_unknown_scene_is_named_with_the_known_ones(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", str(MISSION), "--scene", "nosuch"]) == 2
    err = capsys.readouterr().err
    assert "unknown scene 'nosuch'" in err and "office" in err and "Traceback" not in err


def test_malformed_mission_reports_file_line_and_column(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("tree:\n  type: Sequense\n  name: X\n")
    assert main(["run", str(bad), "--scene", "office"]) == 2
    assert f"{bad}:2:9: unknown node type 'Sequense' (did you mean 'Sequence'?)" in capsys.readouterr().err


def test_missing_mission_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", str(tmp_path / "none.yaml"), "--scene", "office"]) == 2
    assert capsys.readouterr().err == f"{tmp_path / 'none.yaml'}:1:1: mission file not found\n"


def test_unknown_strategy(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", str(MISSION), "--scene", "office", "--strategy", "magic"]) == 2
    assert "unknown strategy 'magic'" in capsys.readouterr().err
