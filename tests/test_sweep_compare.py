"""``semexp-bt bench compare``: two sweeps matched by key, results compared, wall time before and after."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from semexp_bt.bench.compare import compare_sweeps
from semexp_bt.cli import main


def row(key: str, *, wall_s: float, outcome: str = "success", **extra: Any) -> dict[str, Any]:
    return {
        "key": key,
        "status": "ok",
        "outcome": outcome,
        "final_pose": {"x_m": 1.0, "y_m": 2.0, "yaw_rad": 0.5},
        "sim_time_s": 100.0,
        "harness_wall_s": wall_s,
        "wall_time_s": wall_s - 1.0,
        "timings": {"planner": {"count": 10, "median_ms": wall_s}},
        "mission": "/somewhere/trees/object_search.yaml",
        **extra,
    }


def write_sweep(folder: Path, rows: list[dict[str, Any]]) -> Path:
    folder.mkdir(parents=True)
    (folder / "episodes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    return folder


def test_rows_equal_but_for_wall_clock_fields_are_identical_and_the_wall_ratio_is_summed() -> None:
    before = [row("office/0", wall_s=30.0), row("road/0", wall_s=70.0), row("lab/0", wall_s=5.0)]
    after = [
        row("office/0", wall_s=20.0, mission="/elsewhere/trees/object_search.yaml"),
        row("road/0", wall_s=55.0),
        row("garden/0", wall_s=9.0),
    ]
    comparison = compare_sweeps(before, after)
    print(comparison.to_dict())
    assert comparison.matched == 2 and comparison.identical == 2 and comparison.differing == {}
    assert comparison.only_before == 1 and comparison.only_after == 1
    assert comparison.wall_before_s == pytest.approx(100.0)
    assert comparison.wall_after_s == pytest.approx(75.0)
    assert comparison.to_dict()["wall_ratio"] == pytest.approx(0.75)


def test_a_changed_result_is_reported_with_its_fields_and_failed_rows_are_not_matched() -> None:
    before = [row("office/0", wall_s=30.0), row("road/0", wall_s=70.0)]
    after = [
        row("office/0", wall_s=20.0, outcome="budget_exceeded", final_pose={"x_m": 0.0}),
        {"key": "road/0", "status": "error", "error": "boom", "harness_wall_s": 1.0},
    ]
    comparison = compare_sweeps(before, after)
    assert comparison.matched == 2
    # The episode that crashed after the change is a difference, not something to leave out.
    assert comparison.differing == {"office/0": ["final_pose", "outcome"], "road/0": ["status"]}
    assert comparison.identical == 0
    assert comparison.only_before == 0
    assert comparison.wall_before_s == pytest.approx(30.0)  # only episodes finished in both


def test_nan_fields_compare_equal_and_each_sweep_has_its_own_simulated_time() -> None:
    before = [row("office/0", wall_s=30.0, min_clearance_m=float("nan"))]
    after = [row("office/0", wall_s=15.0, min_clearance_m=float("nan"), sim_time_s=50.0)]
    comparison = compare_sweeps(before, after)
    assert comparison.differing == {"office/0": ["sim_time_s"]}
    assert comparison.sim_before_s == pytest.approx(100.0) and comparison.sim_after_s == pytest.approx(50.0)


def test_cli_exit_status_says_identical_differing_or_nothing_to_compare(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    first = write_sweep(tmp_path / "a", [row("office/0", wall_s=30.0)])
    same = write_sweep(tmp_path / "b", [row("office/0", wall_s=24.0)])
    changed = write_sweep(tmp_path / "c", [row("office/0", wall_s=24.0, collisions=3)])
    unrelated = write_sweep(tmp_path / "d", [row("road/9", wall_s=24.0)])

    assert main(["bench", "compare", str(first), str(same), "--json", str(tmp_path / "cmp.json")]) == 0
    out = capsys.readouterr().out
    print(out)
    assert "identical apart from wall-clock fields: 1 of 1" in out and "(-20 %)" in out
    assert json.loads((tmp_path / "cmp.json").read_text())["wall_ratio"] == pytest.approx(0.8)

    assert main(["bench", "compare", str(first), str(changed)]) == 1
    assert "differs: office/0: collisions" in capsys.readouterr().out

    assert main(["bench", "compare", str(first), str(unrelated)]) == 2
    assert "share no finished episode" in capsys.readouterr().err

    assert main(["bench", "compare", str(first), str(tmp_path / "missing")]) == 2
    assert "missing/episodes.jsonl does not exist" in capsys.readouterr().err
