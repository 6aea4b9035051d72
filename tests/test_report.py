"""Reports: tables from hand-made rows match hand-computed numbers; plots and the paper's tables are written."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from semexp_bt.bench.markdown import (
    cell_text,
    metric_table,
    outcome_table,
    refusal_cause_table,
    success_path_table,
    success_time_table,
)
from semexp_bt.bench.paper_results import write_paper_results
from semexp_bt.bench.report import write_report
from semexp_bt.bench.rows import STATUS_ERROR, STATUS_OK
from semexp_bt.bench.stats import (
    ALL_SCENES,
    cell_summaries,
    intervals_disjoint,
    latency_table,
    matched_rows,
    outcomes_and_safety,
    refusal_causes,
    success_paths,
    success_times,
    summarize_rows,
)
from semexp_bt.bench.store import EPISODES_FILE
from semexp_bt.core.metrics import wilson_interval


def row(scene: str, strategy: str, seed: int, *, declared: bool, distance_m: float, path_m: float,
        geodesic_m: float, collision: bool = False, reached: str | None = "extinguisher",
        steps: tuple[tuple[int | None, int | None], ...] = (), status: str = STATUS_OK,
        timings: dict[str, Any] | None = None, sim_s: float = 10.0, ticks: int = 500) -> dict[str, Any]:  # fmt: skip
    """A flattened episode row; the robot ends ``distance_m`` from the goal's footprint, on the x axis."""
    return {
        "key": f"{scene}/{seed}/{strategy}/kinematic/abc", "status": status, "scene": scene, "seed": seed,
        "strategy": strategy, "fidelity": "kinematic", "relevance": "lexical",
        "goal": {"position_m": [10.0, 0.0, 0.0], "category": "extinguisher"},
        "final_pose": {"x_m": 10.0 - distance_m, "y_m": 0.0, "yaw_rad": 0.0}, "distance_to_goal_m": distance_m,
        "success_declared": declared, "success_radius_m": 1.0, "path_length_m": path_m, "geodesic_length_m": geodesic_m,
        "collision": collision, "reached_category": reached, "goal_category": "extinguisher",
        "decisions": [{"selected_node_id": s, "oracle_node_id": o} for s, o in steps],
        "timings": timings or {}, "tick_wall_ms": {"median": 0.1, "p99": 2.0}, "ticks": ticks, "sim_time_s": sim_s,
        "harness_wall_s": 1.0,
    }  # fmt: skip


def office_ours() -> list[dict[str, Any]]:
    """Four hand-worked episodes: SR 3/4, SPL (0.8 + 1 + 0.5 + 0) / 4, OASR 3/4, SA 2/4, GNSA 4/6."""
    return [
        row("office", "ours", 0, declared=True, distance_m=0.5, path_m=5.0, geodesic_m=4.0, steps=((2, 2), (1, 2))),
        row("office", "ours", 1, declared=True, distance_m=0.2, path_m=4.0, geodesic_m=4.0, collision=True,
            steps=((3, 3),)),
        row("office", "ours", 2, declared=True, distance_m=0.9, path_m=6.0, geodesic_m=3.0, reached="chair",
            steps=((1, 1), (2, 2))),
        row("office", "ours", 3, declared=False, distance_m=3.0, path_m=10.0, geodesic_m=5.0, reached=None,
            steps=((5, 6),)),
    ]  # fmt: skip


def test_cell_summary_matches_the_hand_computed_metrics() -> None:
    summary = summarize_rows(office_ours())
    assert summary is not None
    assert summary["n_episodes"] == 4
    assert summary["sr"] == pytest.approx(0.75)
    assert summary["spl"] == pytest.approx((0.8 + 1.0 + 0.5 + 0.0) / 4)
    assert summary["oasr"] == pytest.approx(0.75)
    assert summary["sa"] == pytest.approx(0.5)
    assert summary["gnsa"] == pytest.approx(4 / 6)
    assert summary["decision_steps"] == 6
    # Wilson 95% for 3/4, worked by hand: centre 0.6275, half-width 0.3269
    assert summary["sr_ci95"] == pytest.approx([0.3006, 0.9544], abs=1e-4)
    assert summary["sa_ci95"] == pytest.approx([0.1500, 0.8500], abs=1e-4)
    lo, hi = summary["spl_ci95"]
    assert 0.0 <= lo <= summary["spl"] <= hi <= 1.0


def test_failed_rows_are_left_out_of_the_metrics() -> None:
    rows = office_ours() + [row("office", "ours", 9, declared=True, distance_m=0.1, path_m=1, geodesic_m=1,
                                status=STATUS_ERROR)]  # fmt: skip
    summary = summarize_rows(rows)
    assert summary is not None and summary["n_episodes"] == 4 and summary["sr"] == pytest.approx(0.75)
    assert summarize_rows([rows[-1]]) is None


def test_mixed_success_radii_are_refused() -> None:
    rows = office_ours()
    rows[0]["success_radius_m"] = 1.5
    with pytest.raises(ValueError, match="success radii"):
        summarize_rows(rows)


def test_metric_table_cells_are_value_and_interval_in_percent() -> None:
    summaries = cell_summaries(office_ours())
    table = metric_table(summaries, "sr", scenes=["office"], strategies=["ours"])
    lines = table.splitlines()
    assert lines[0] == "| strategy | office | all | n |"
    assert lines[2] == "| Ours | 75.0 [30, 95] | 75.0 [30, 95] | 4 |"
    assert cell_text(summaries[("office", "ours")], "sa") == "50.0 [15, 85]"
    assert cell_text(None, "sr") == "-"


def test_metric_table_shows_the_papers_number_beside_ours() -> None:
    summaries = cell_summaries(office_ours())
    table = metric_table(summaries, "sr", scenes=["office"], strategies=["ours"], paper={"ours": (55.0,)})
    assert "75.0 [30, 95] (paper 55.0)" in table


def test_pooled_column_pools_the_scenes() -> None:
    rows = office_ours() + [
        row("road", "ours", 0, declared=False, distance_m=5.0, path_m=3.0, geodesic_m=9.0)
    ]
    summaries = cell_summaries(rows)
    assert summaries[(ALL_SCENES, "ours")]["n_episodes"] == 5
    assert summaries[(ALL_SCENES, "ours")]["sr"] == pytest.approx(3 / 5)
    assert summaries[("road", "ours")]["sr"] == 0.0


def test_matched_rows_keep_only_pairs_every_strategy_finished() -> None:
    rows = office_ours() + [
        row("office", "vlm_only", 1, declared=False, distance_m=4.0, path_m=1.0, geodesic_m=1.0),
        row("office", "vlm_only", 2, declared=False, distance_m=4.0, path_m=1.0, geodesic_m=1.0),
        row("office", "vlm_only", 3, declared=False, distance_m=4.0, path_m=1.0, geodesic_m=1.0, status=STATUS_ERROR),
    ]  # fmt: skip
    matched = matched_rows(rows, strategies=["ours", "vlm_only"], scenes=["office"])
    assert sorted((r["strategy"], r["seed"]) for r in matched) == [
        ("ours", 1), ("ours", 2), ("vlm_only", 1), ("vlm_only", 2)
    ]  # fmt: skip


def test_latency_table_rates_on_the_sim_clock_and_medians_of_episodes() -> None:
    rows = [
        row("office", "ours", 0, declared=False, distance_m=3, path_m=1, geodesic_m=1, sim_s=10.0, ticks=500,
            timings={"decision": {"count": 2, "median_ms": 0.2, "p95_ms": 0.3, "total_s": 0.0}}),
        row("office", "ours", 1, declared=False, distance_m=3, path_m=1, geodesic_m=1, sim_s=30.0, ticks=1500,
            timings={"decision": {"count": 4, "median_ms": 0.4, "p95_ms": 0.5, "total_s": 0.0}}),
    ]  # fmt: skip
    table = {r["stage"]: r for r in latency_table(rows)}
    assert table["decision"]["rate_hz"] == pytest.approx(6 / 40)
    assert table["decision"]["median_ms"] == pytest.approx(0.3)
    assert table["decision"]["p95_ms"] == pytest.approx(0.4)
    assert table["decision"]["calls_per_episode"] == pytest.approx(3.0)
    assert table["tick"]["rate_hz"] == pytest.approx(50.0)


def test_outcomes_count_falls_and_episodes_that_touched_or_breached() -> None:
    rows = office_ours()
    outcomes = ("success", "success", "fallen", "budget_exceeded")
    for r, outcome, contacts, breaches, least in zip(
        rows, outcomes, (0, 2, 1, 0), (0, 3, 0, 1), (0.4, -0.01, None, 0.08), strict=True
    ):
        r.update(outcome=outcome, collisions=contacts, clearance_breaches=breaches, min_clearance_m=least)
    rows.append(
        row("office", "ours", 9, declared=False, distance_m=5, path_m=1, geodesic_m=1, status=STATUS_ERROR)
    )
    cells = outcomes_and_safety(rows)
    print(cells)
    assert cells == {
        "ours": {
            "episodes": 4,  # the errored episode is not one that ended
            "outcomes": {"success": 2, "fallen": 1, "budget_exceeded": 1},
            "with_contact": 2,
            "with_breach": 2,
            "least_clearance_m": 0.08,  # median of the three recorded
        }
    }
    table = outcome_table(cells, strategies=["ours"])
    print(table)
    assert "| 4 | success 2, budget_exceeded 1, fallen 1 | 2 | 2 | 0.080 |" in table


def test_success_paths_compare_the_successes_with_and_without_a_refused_confirmation() -> None:
    rows = office_ours()  # seeds 0-2 succeed (path / L*: 1.25, 1.0, 2.0); seed 3 does not (2.0)
    rows[0]["event_counts"] = {"confirmation_rejected": 2}
    rows[3]["event_counts"] = {"confirmation_rejected": 5}  # a failure: not counted
    rows.append(row("lab", "vlm_only", 0, declared=True, distance_m=0.1, path_m=9.0, geodesic_m=3.0))
    cells = success_paths(rows)
    print(cells)
    assert cells["ours"] == {
        "successes": 3,
        "ratio": (1.25, 1.125, 1.625),
        "rejected": 1,
        "ratio_rejected": 1.25,
        "ratio_clean": 1.5,
    }
    assert cells["vlm_only"]["ratio_rejected"] is None and cells["vlm_only"]["ratio_clean"] == 3.0
    table = success_path_table(cells, strategies=["ours", "vlm_only"])
    print(table)
    assert table.splitlines()[2] == "| Ours | 3 | 1.25 (1.12-1.62) | 1 | 1.25 | 1.50 |"
    assert table.splitlines()[3].endswith("| 1 | 3.00 (3.00-3.00) | 0 | - | 3.00 |")


def test_refusal_causes_count_events_episodes_and_the_successes_among_them() -> None:
    rows = office_ours()  # seeds 0-2 succeed, seed 3 does not
    rows[0]["refusal_causes"] = {"too_few_views": 2}
    rows[1]["refusal_causes"] = {"too_few_views": 1, "label_agreement": 3}
    rows[3]["refusal_causes"] = {"label_agreement": 40}
    cells = refusal_causes(rows)
    print(cells)
    assert cells == {
        "ours": {
            "too_few_views": {"refusals": 3, "episodes": 2, "successes": 2},
            "label_agreement": {"refusals": 43, "episodes": 2, "successes": 1},
        }
    }
    table = refusal_cause_table(cells, strategies=["ours", "vlm_only"])
    print(table)
    assert table.splitlines()[2:] == [
        "| Ours | label_agreement | 43 | 2 | 1 |",
        "| Ours | too_few_views | 3 | 2 | 2 |",
    ]
    assert "no refusal recorded" in refusal_cause_table({}, strategies=["ours"])


def test_success_times_are_the_median_simulated_time_of_the_successes_only() -> None:
    rows = office_ours()  # seeds 0-2 succeed, seed 3 does not
    for r, sim_s in zip(rows, (30.0, 10.0, 20.0, 5.0), strict=True):
        r["sim_time_s"] = sim_s
    rows.append(row("lab", "ours", 0, declared=True, distance_m=0.1, path_m=2, geodesic_m=2, sim_s=70.0))
    rows.append(
        row("lab", "ours", 1, declared=True, distance_m=2.0, path_m=2, geodesic_m=2, sim_s=1.0)
    )  # too far
    times = success_times(rows)
    print(times)
    assert times[("office", "ours")] == {"median_s": 20.0, "n": 3}
    assert times[(ALL_SCENES, "ours")] == {"median_s": 25.0, "n": 4}
    assert times[("lab", "ours")] == {"median_s": 70.0, "n": 1}
    table = success_time_table(times, scenes=["office", "lab", "garden"], strategies=["ours"])
    print(table)
    assert table.splitlines()[-1] == "| Ours | 20.0 (3) | 70.0 (1) | - | 25.0 (4) |"


def test_intervals_disjoint_only_when_strictly_above() -> None:
    assert intervals_disjoint([0.7, 1.0], [0.0, 0.3])
    assert not intervals_disjoint([0.2, 0.8], [0.0, 0.3])
    assert not intervals_disjoint([0.0, 0.3], [0.7, 1.0])
    assert not intervals_disjoint(None, [0.0, 0.1])


def test_write_report_writes_tables_plots_and_failures(tmp_path: Path) -> None:
    rows = office_ours() + [row("office", "vlm_only", 0, declared=False, distance_m=3, path_m=1, geodesic_m=1,
                                status=STATUS_ERROR)]  # fmt: skip
    rows[-1]["error"] = "Traceback ...\nRuntimeError: the robot fell"
    (tmp_path / EPISODES_FILE).write_text("".join(json.dumps(r) + "\n" for r in rows))
    path = write_report(tmp_path)
    text = path.read_text()
    assert "| Ours | 75.0 [30, 95] | 75.0 [30, 95] | 4 |" in text  # SR
    assert "| Ours | 66.7 " in text  # GNSA 4/6
    assert "`office/0/vlm_only/kinematic/abc`: error: RuntimeError: the robot fell" in text
    for name in ("bars_sr.png", "bars_spl.png", "spl_distribution.png"):
        assert (tmp_path / "plots" / name).stat().st_size > 1000
        assert f"plots/{name}" in text
    # Seed 3 declared nothing; seeds 0-2 declared within r_s: no false success yet.
    assert "## Success declared away from the goal\n\n0 of 4 episodes." in text
    assert "| Ours | 10.0 (3) | 10.0 (3) |" in text  # the successes' median mission time
    rows[3]["success_declared"] = True  # now seed 3 declares success 3 m from the goal
    for r, wall_s in zip(rows, (1.0, 2.0, 3.0, 4.0), strict=False):
        r["wall_time_s"] = wall_s
        r["harness_wall_s"] = wall_s + 0.5  # process start and model loading on top of the episode
    text = write_report(tmp_path, rows=rows, plots=False).read_text()
    assert "1 of 4 episodes.\n- `office/3/ours/kinematic/abc`" in text
    assert "Wall time per simulated second: 0.250 s" in text  # 10 s of wall over 40 s simulated
    # Four kinematic episodes in 12 s of harness wall time: 1200 per hour on one core.
    assert "| kinematic | 4 | 1200 | 0.250 |" in text


def test_write_report_without_rows_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="bench missions"):
        write_report(tmp_path)


def test_paper_results_claim_a_gain_only_where_intervals_do_not_overlap(tmp_path: Path) -> None:
    rows = []
    for seed in range(10):
        for scene in ("garden_sim", "road"):
            rows.append(row(scene, "ours", seed, declared=True, distance_m=0.3, path_m=5, geodesic_m=4))
            rows.append(
                row(scene, "ablation_baseline", seed, declared=False, distance_m=5, path_m=9, geodesic_m=4)
            )
            rows.append(row(scene, "ablation_arbitration", seed, declared=seed % 5 != 0, distance_m=0.3,
                            path_m=5, geodesic_m=4))  # fmt: skip
    path = write_paper_results(rows, tmp_path / "results.md", header={"machine": "test box"},
                               figures_dir=tmp_path / "figures")  # fmt: skip
    text = path.read_text()
    assert "- **machine**: test box" in text
    table_iv = text.split("## Table IV")[1].split("## Table V")[0]
    assert "Matched episodes: 20 (scene, seed) pairs." in table_iv
    assert "| Ours | yes | yes | 20 | 100.0 [84, 100] | 80.0 " in table_iv
    assert "ours 100.0 vs ablation_baseline 0.0: ours is higher (95% intervals do not overlap)." in table_iv
    assert "ours 100.0 vs ablation_arbitration 80.0: intervals overlap: no difference claimed." in table_iv
    lo, _ = wilson_interval(20, 20)
    assert f"[{100 * lo:.0f}, 100]" in table_iv
    assert "| garden_sim | green bin | 10 | 100.0 [72, 100] | 100.0 [72, 100] | 80.0 " in text
    assert "## How this differs from the paper" in text
    assert (tmp_path / "figures" / "table_iii_sr.png").is_file()
