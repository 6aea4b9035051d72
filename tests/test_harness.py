"""The sweep engine: keys, resumability, failures recorded as rows, process pools, the smoke protocol.

Most tests inject a fake run function (module-level, so spawned workers can import it by name) that
returns a runner-shaped record computed from the key; one test runs the real ``bench paper --smoke``.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import signal
import socket
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from semexp_bt.bench import engine, executors, protocol, store
from semexp_bt.bench.engine import SweepResult, run_sweep
from semexp_bt.bench.protocol import PaperProtocol
from semexp_bt.bench.rows import STATUS_ERROR, STATUS_OK, STATUS_TIMEOUT, flatten_record, to_episode_record
from semexp_bt.bench.store import EPISODES_FILE, load_rows
from semexp_bt.bench.sweep import EpisodeTask, HarnessError, SweepSpec, parse_seeds
from semexp_bt.core.metrics import success

#: Calls of the fake run function in this process (workers=0 runs inline).
CALLS: list[str] = []


def fake_record(task: EpisodeTask) -> dict[str, Any]:
    """A runner-shaped record, deterministic in the key: even seeds succeed 0.5 m from the goal."""
    key = task.key
    ok = key.seed % 2 == 0
    return {
        "scene": key.scene, "seed": key.seed, "strategy": key.strategy, "fidelity": key.fidelity,
        "goal": {"object_id": 3, "label": "fire extinguisher", "category": "extinguisher",
                 "position_m": [4.0, 0.0, 0.3]},
        "outcome": "success" if ok else "budget_exceeded", "success_declared": ok, "success": ok,
        "success_radius_m": task.success_radius_m,
        "final_pose": {"x_m": 3.0 if ok else 0.0, "y_m": 0.0, "yaw_rad": 0.0},
        "distance_to_goal_m": 0.5 if ok else 3.5,
        "path_length_m": 5.0, "geodesic_length_m": 4.0, "collision": False, "collisions": 0,
        "clearance_breaches": 0, "reached_category": "extinguisher" if ok else None, "goal_category": "extinguisher",
        "decisions": [
            {"stamp_s": 1.0, "robot_xy": [0, 0], "selected_node_id": 2, "oracle_node_id": 2, "reason": "ok",
             "candidates": [{"node_id": 1}, {"node_id": 2}]},
            {"stamp_s": 2.0, "robot_xy": [1, 0], "selected_node_id": 1, "oracle_node_id": 2, "reason": "ok",
             "candidates": [{"node_id": 1}, {"node_id": 2}]},
            {"stamp_s": 3.0, "robot_xy": [1, 0], "selected_node_id": None, "oracle_node_id": None, "reason": "empty",
             "candidates": []},
        ],
        "events": [{"kind": "confirm"}, {"kind": "recovery"}, {"kind": "recovery"}],
        "found_objects": [{"label": "fire extinguisher", "position_m": [4.0, 0.0, 0.3]}],
        "timings": {"decision": {"count": 2, "median_ms": 0.2, "p95_ms": 0.3, "total_s": 0.0004}},
        "tick_wall_ms": {"median": 0.1, "p99": 1.0}, "ticks": 100, "sim_time_s": 2.0, "wall_time_s": 0.01,
        **({"trajectory_xy": [[0, 0], [3, 0]], "memory_snapshot": {"nodes": [], "edges": []}}
           if task.keep_trajectory else {}),
    }  # fmt: skip


def fake_run(task: EpisodeTask) -> dict[str, Any]:
    CALLS.append(task.key.id)
    return fake_record(task)


def crashing_run(task: EpisodeTask) -> dict[str, Any]:
    if task.key.seed == 1:
        raise RuntimeError("the robot fell into a wormhole")
    return fake_record(task)


def sleepy_run(task: EpisodeTask) -> dict[str, Any]:
    if task.key.seed == 1:
        time.sleep(30.0)
    return fake_record(task)


def stuck_run(task: EpisodeTask) -> dict[str, Any]:
    """Seed 1 ignores the in-worker alarm (as native code would): only the parent can stop it."""
    if task.key.seed == 1:
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGALRM})
        time.sleep(60.0)
    return fake_record(task)


def dying_run(task: EpisodeTask) -> dict[str, Any]:
    """Seed 1 kills its worker process outright (a native crash)."""
    if task.key.seed == 1:
        os._exit(17)
    return fake_record(task)


def spec(**changes: Any) -> SweepSpec:
    fields: dict[str, Any] = {"scenes": ("alpha", "beta"), "seeds": (0, 1), "strategies": ("ours", "vlm_only"),
                              "relevance": "lexical"}  # fmt: skip
    fields.update(changes)
    return SweepSpec(**fields)


def sweep(out: Path, run_fn: Any = fake_run, **kwargs: Any) -> SweepResult:
    kwargs.setdefault("workers", 0)
    return run_sweep(kwargs.pop("spec", None) or spec(), out, run_fn=run_fn, progress=None, check_names=False,
                     **kwargs)  # fmt: skip


# ----------------------------------------------------------------------------------------------
# Keys
# ----------------------------------------------------------------------------------------------


def test_keys_are_deterministic_and_cover_the_grid() -> None:
    first, second = spec().tasks(), spec().tasks()
    assert [t.key for t in first] == [t.key for t in second]
    assert len({t.key.id for t in first}) == 2 * 2 * 2
    assert first[0].key.id.startswith("alpha/0/ours/kinematic/")
    assert all(len(t.key.config_hash) == 12 for t in first)


def test_grid_order_does_not_change_an_episodes_key() -> None:
    keys = {t.key for t in spec().tasks()}
    reordered = {t.key for t in spec(scenes=("beta", "alpha"), seeds=(1, 0)).tasks()}
    assert keys == reordered


def test_anything_that_changes_the_outcome_changes_the_hash() -> None:
    base = spec().config_hash("ours")
    assert spec(relevance="embedding").config_hash("ours") != base
    assert spec(config_overrides={"decision": {"gamma": 0.3}}).config_hash("ours") != base
    assert spec(max_sim_s=100.0).config_hash("ours") != base
    assert spec().config_hash("vlm_only") != base  # a different strategy definition
    # ... but not the execution settings
    assert spec(timeout_s=5.0, trajectories_per_cell=0).config_hash("ours") == base


def test_spec_validation_names_the_field(tmp_path: Path) -> None:
    with pytest.raises(HarnessError, match="'scenes' must not be empty"):
        spec(scenes=())
    with pytest.raises(HarnessError, match="duplicates"):
        spec(seeds=(1, 1))
    with pytest.raises(HarnessError, match="fidelity"):
        spec(fidelity="wobbly")
    with pytest.raises(HarnessError, match="timeout_s"):
        spec(timeout_s=math.nan)
    with pytest.raises(HarnessError, match="does not exist"):
        spec(mission_path=tmp_path / "missing.yaml")


def test_unknown_scene_or_strategy_is_refused_before_running(tmp_path: Path) -> None:
    with pytest.raises(HarnessError, match="unknown scenes \\['alpha', 'beta'\\]"):
        run_sweep(spec(), tmp_path, run_fn=fake_run, workers=0, progress=None)
    with pytest.raises(HarnessError, match="unknown strategies \\['magic'\\]"):
        run_sweep(spec(scenes=("office",), strategies=("magic",)), tmp_path, run_fn=fake_run, workers=0,
                  progress=None)  # fmt: skip


@pytest.mark.parametrize(
    ("text", "seeds"), [("0-3", (0, 1, 2, 3)), ("0,3,5", (0, 3, 5)), ("0-2,10", (0, 1, 2, 10)), ("4", (4,))]
)
def test_parse_seeds(text: str, seeds: tuple[int, ...]) -> None:
    assert parse_seeds(text) == seeds


@pytest.mark.parametrize("text", ["a-b", "5-2", "1,,x", "-3"])
def test_parse_seeds_rejects_bad_text(text: str) -> None:
    with pytest.raises(HarnessError):
        parse_seeds(text)


def test_paper_protocol_shares_the_ours_episodes_between_tables() -> None:
    protocol = PaperProtocol(trials_table_iii=20, trials_evidence=4, trials_decision=3, trials_ablation=2,
                             trials_reference=1)  # fmt: skip
    # ours: 10 x 20; Table I: 4 x 5 x 4; Table II: 4 x 5 x 3; Table IV: 2 x 5 x 2; references: 2 x 10 x 1
    assert protocol.episode_count() == 200 + 80 + 60 + 20 + 20


# ----------------------------------------------------------------------------------------------
# Rows
# ----------------------------------------------------------------------------------------------


def test_flatten_drops_candidate_lists_but_keeps_the_ids_gnsa_needs() -> None:
    task = spec(trajectories_per_cell=0).tasks()[0]
    row = flatten_record(fake_record(task))
    assert [d["selected_node_id"] for d in row["decisions"]] == [2, 1, None]
    assert [d["oracle_node_id"] for d in row["decisions"]] == [2, 2, None]
    assert [d["n_candidates"] for d in row["decisions"]] == [2, 2, 0]
    assert all("candidates" not in d for d in row["decisions"])
    assert row["event_counts"] == {"confirm": 1, "recovery": 2}
    assert row["refusal_causes"] == {}
    assert "events" not in row and "found_objects" not in row


def test_flatten_counts_refused_confirmations_by_cause() -> None:
    record = fake_record(spec(trajectories_per_cell=0).tasks()[0])
    record["events"] = [
        {
            "kind": "confirmation_rejected",
            "reason": "only 1 of 3 ...",
            "cause": "too_few_views",
            "stamp_s": 12.5,
            "position_m": [1.0, 2.0, 0.3],
            "robot_xy": [0.4, 2.1],
            "first_vote_m": 1.9,
        },
        {"kind": "confirmation_rejected", "reason": "only 0 of 2 ...", "cause": "too_few_views"},
        {"kind": "confirmation_rejected", "reason": "... names heard ...", "cause": "label_agreement"},
        {"kind": "confirmation_rejected", "reason": "a record from before causes"},
        {"kind": "target_sighted"},
        {
            "kind": "target_confirmed",
            "label": "bin",
            "stamp_s": 40.0,
            "position_m": [3.0, 0.1, 0.3],
            "first_vote_m": 2.2,
        },
    ]
    row = flatten_record(record)
    print(row["event_counts"], row["refusal_causes"], row["confirmations"])
    assert row["event_counts"] == {"confirmation_rejected": 4, "target_sighted": 1, "target_confirmed": 1}
    assert row["refusal_causes"] == {"too_few_views": 2, "label_agreement": 1, "unknown": 1}
    # Each refusal is listed with what it holds of where the vote and the robot were.
    assert len(row["refusals"]) == 4
    assert row["refusals"][0] == {
        "stamp_s": 12.5,
        "cause": "too_few_views",
        "reason": "only 1 of 3 ...",
        "position_m": [1.0, 2.0, 0.3],
        "robot_xy": [0.4, 2.1],
        "first_vote_m": 1.9,
    }
    assert row["refusals"][3] == {"reason": "a record from before causes"}
    # A declared confirmation is listed with how far away its first vote lay.
    assert row["confirmations"] == [{"stamp_s": 40.0, "position_m": [3.0, 0.1, 0.3], "first_vote_m": 2.2}]


def test_to_episode_record_keeps_the_distance_and_the_gnsa_steps() -> None:
    task = spec().tasks()[0]  # seed 0: success 0.5 m from the goal
    record = to_episode_record(flatten_record(fake_record(task)))
    gx, gy = record.goal_position_m
    assert math.hypot(gx - 3.0, gy) == pytest.approx(0.5)
    assert success(record)
    # the step without an oracle node is not a GNSA step
    assert [(s.selected_node_id, s.oracle_node_id) for s in record.decisions] == [(2, 2), (1, 2)]


def test_to_episode_record_counts_a_step_without_a_selection_as_a_miss() -> None:
    row = flatten_record(fake_record(spec().tasks()[0]))
    row["decisions"] = [{"selected_node_id": None, "oracle_node_id": 4}]
    assert [(s.selected_node_id, s.oracle_node_id) for s in to_episode_record(row).decisions] == [(-1, 4)]
    del row["path_length_m"]
    with pytest.raises(HarnessError, match="missing key 'path_length_m'"):
        to_episode_record(row)


# ----------------------------------------------------------------------------------------------
# Sweeps (in-process)
# ----------------------------------------------------------------------------------------------


def test_a_rerun_runs_nothing_new(tmp_path: Path) -> None:
    CALLS.clear()
    first = sweep(tmp_path)
    assert (first.ran, first.skipped, first.total) == (8, 0, 8)
    assert len(CALLS) == 8
    lines = (tmp_path / EPISODES_FILE).read_text().splitlines()
    second = sweep(tmp_path)
    assert (second.ran, second.skipped) == (0, 8)
    assert len(CALLS) == 8
    assert (tmp_path / EPISODES_FILE).read_text().splitlines() == lines


def test_a_grown_grid_runs_only_the_new_episodes(tmp_path: Path) -> None:
    CALLS.clear()
    sweep(tmp_path)
    grown = sweep(tmp_path, spec=spec(seeds=(0, 1, 2)))
    assert (grown.ran, grown.skipped) == (4, 8)
    assert sorted(CALLS[8:]) == sorted(t.key.id for t in spec(seeds=(2,)).tasks())


def test_a_crashing_episode_is_an_error_row_and_the_others_finish(tmp_path: Path) -> None:
    result = sweep(tmp_path, run_fn=crashing_run)
    rows = load_rows(tmp_path)
    assert result.errors == 4 and len(rows) == 8
    errors = [r for r in rows if r["status"] == STATUS_ERROR]
    assert {r["seed"] for r in errors} == {1}
    assert all("wormhole" in r["error"] and "Traceback" in r["error"] for r in errors)
    assert all(r["status"] == STATUS_OK for r in rows if r["seed"] == 0)
    # errors are finished keys; --retry-failed reruns them and the newest row wins
    assert sweep(tmp_path, run_fn=crashing_run).ran == 0
    retried = sweep(tmp_path, run_fn=fake_run, retry_failed=True)
    assert retried.ran == 4 and retried.errors == 0
    assert all(r["status"] == STATUS_OK for r in load_rows(tmp_path))


def test_an_episode_over_its_wall_time_is_interrupted_and_recorded_as_timeout(tmp_path: Path) -> None:
    started = time.monotonic()
    result = sweep(tmp_path, run_fn=sleepy_run, spec=spec(seeds=(0, 1), scenes=("alpha",), strategies=("ours",),
                                                          timeout_s=0.3))  # fmt: skip
    assert time.monotonic() - started < 10.0
    rows = {r["seed"]: r for r in load_rows(tmp_path)}
    assert result.timeouts == 1
    assert rows[1]["status"] == STATUS_TIMEOUT and "wall-time limit" in rows[1]["error"]
    assert rows[0]["status"] == STATUS_OK


def test_trajectories_go_to_their_own_files(tmp_path: Path) -> None:
    sweep(tmp_path, spec=spec(trajectories_per_cell=1))
    rows = load_rows(tmp_path)
    kept = [r for r in rows if "trajectory_file" in r]
    assert {r["seed"] for r in kept} == {0} and len(kept) == 4
    payload = json.loads((tmp_path / kept[0]["trajectory_file"]).read_text())
    assert payload["trajectory_xy"] == [[0, 0], [3, 0]] and "memory_snapshot" in payload
    assert all("trajectory_xy" not in r for r in rows)


def test_a_torn_last_line_is_skipped_and_rerun(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    sweep(tmp_path)
    path = tmp_path / EPISODES_FILE
    lines = path.read_text().splitlines()
    path.write_text("\n".join(lines[:-1]) + "\n" + lines[-1][: len(lines[-1]) // 2])
    assert len(load_rows(tmp_path, stream=sys.stderr)) == 7
    assert f"{EPISODES_FILE}:8: torn last line skipped" in capsys.readouterr().err
    # The resumed sweep cuts the fragment off before it appends: the new row is a line of its own.
    assert sweep(tmp_path).ran == 1
    assert "cut off a torn last line" in capsys.readouterr().err
    rewritten = path.read_text().splitlines()
    assert rewritten[:7] == lines[:7] and len(rewritten) == 8
    assert [json.loads(line)["key"] for line in rewritten] == [json.loads(line)["key"] for line in lines]


def test_a_damaged_row_before_the_last_is_an_error_naming_the_line(tmp_path: Path) -> None:
    sweep(tmp_path)
    path = tmp_path / EPISODES_FILE
    lines = path.read_text().splitlines()
    lines[2] = lines[2][:20]
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(HarnessError, match=rf"{EPISODES_FILE}:3: not a JSON line"):
        load_rows(tmp_path)
    with pytest.raises(HarnessError, match=rf"{EPISODES_FILE}:3: not a JSON line"):
        sweep(tmp_path)  # refused before anything runs, not silently rerun
    path.write_text(path.read_text().replace(lines[2], '{"no key": 1}'))
    with pytest.raises(HarnessError, match=rf"{EPISODES_FILE}:3: expected an episode row"):
        load_rows(tmp_path)


def interrupted_run(task: EpisodeTask) -> dict[str, Any]:
    """Seed 1 is where the user presses Ctrl-C."""
    if task.key.seed == 1:
        raise KeyboardInterrupt
    return fake_record(task)


def test_every_invocation_is_logged_so_a_resumed_sweep_has_a_total_wall_time(tmp_path: Path) -> None:
    with pytest.raises(KeyboardInterrupt):
        sweep(tmp_path, run_fn=interrupted_run, spec=spec(scenes=("alpha",), strategies=("ours",)))
    sweep(tmp_path)
    sweep(tmp_path)
    log = store.load_invocations(tmp_path)
    print(json.dumps(log, indent=1))
    assert [(one["ran"], one["skipped"], one["completed"]) for one in log] == [(1, 0, False), (7, 1, True),
                                                                                (0, 8, True)]  # fmt: skip
    assert all(one["wall_s"] >= 0.0 and one["workers"] == 0 for one in log)
    assert log[0]["started_unix_s"] <= log[1]["started_unix_s"] <= log[2]["started_unix_s"]


def test_a_corrupt_invocation_log_names_its_file_and_line(tmp_path: Path) -> None:
    sweep(tmp_path)
    path = tmp_path / store.INVOCATIONS_FILE
    first = path.read_text()
    path.write_text(first + '{"wall_s": "long"}\n')
    with pytest.raises(HarnessError, match=r"invocations\.jsonl:2: expected an object"):
        store.load_invocations(tmp_path)
    path.write_text("not json\n" + first)
    with pytest.raises(HarnessError, match=r"invocations\.jsonl:1: not a JSON line"):
        store.load_invocations(tmp_path)


def test_a_torn_last_invocation_line_is_skipped_and_the_next_one_starts_clean(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sweep(tmp_path)
    path = tmp_path / store.INVOCATIONS_FILE
    path.write_text(path.read_text() + '{"started_unix_s": 17')  # killed while logging the second call
    assert [one["ran"] for one in store.load_invocations(tmp_path, stream=sys.stderr)] == [8]
    assert "invocations.jsonl:2: torn last line skipped" in capsys.readouterr().err
    sweep(tmp_path)
    assert [one["ran"] for one in store.load_invocations(tmp_path)] == [8, 0]


def test_the_results_header_sums_the_invocations_and_survives_a_damaged_log(tmp_path: Path) -> None:
    from semexp_bt.cli import bench as bench_cli

    path = tmp_path / store.INVOCATIONS_FILE
    path.write_text(
        '{"wall_s": 600.0, "ran": 3, "completed": false}\n{"wall_s": 300.0, "ran": 2, "completed": true}\n'
    )
    line = bench_cli._all_invocations(tmp_path)
    print(line)
    assert line.startswith("15.0 min in 2 invocation(s) (1 stopped) that ran 5 episodes")
    path.write_text('{torn\n{"wall_s": 300.0, "ran": 2, "completed": true}\n')
    with open(os.devnull, "w") as quiet, contextlib.redirect_stderr(quiet):
        damaged = bench_cli._all_invocations(tmp_path)
    assert damaged.startswith("unknown (") and "invocations.jsonl:1" in damaged


def test_sigterm_unwinds_a_cli_sweep_and_restores_the_handler(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    from semexp_bt.cli import bench as bench_cli

    def killed(*args: Any, **kwargs: Any) -> None:
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(5.0)  # the handler raises before this returns
        raise AssertionError("SIGTERM did not interrupt the sweep")

    monkeypatch.setattr(engine, "run_sweep", killed)
    before = signal.getsignal(signal.SIGTERM)
    args = argparse.Namespace(out=tmp_path, workers=1, ray_address=None, retry_failed=False, quiet=True)
    with pytest.raises(SystemExit) as stopped:
        bench_cli._sweep(args, [])
    assert stopped.value.code == 128 + signal.SIGTERM
    assert signal.getsignal(signal.SIGTERM) is before


def test_ray_missing_is_a_clear_error(tmp_path: Path) -> None:
    if "ray" in sys.modules or _ray_installed():
        pytest.skip("Ray is installed here")
    with pytest.raises(HarnessError, match="pip install"):
        sweep(tmp_path, ray_address="auto")


def test_a_ray_address_where_no_head_answers_is_refused_not_waited_on() -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as listener:
        listener.bind(("127.0.0.1", 0))
        listener.listen(1)
        open_port = listener.getsockname()[1]
        executors.require_ray_head_answers(f"127.0.0.1:{open_port}", timeout_s=2.0)  # something answers
    with pytest.raises(HarnessError, match=f"127.0.0.1:{open_port}: no Ray head answers"):
        executors.require_ray_head_answers(f"127.0.0.1:{open_port}", timeout_s=2.0)
    with pytest.raises(HarnessError, match="expected 'auto'"):
        executors.require_ray_head_answers("my-cluster", timeout_s=2.0)
    executors.require_ray_head_answers("auto")  # left to Ray


def _ray_installed() -> bool:
    import importlib.util

    return importlib.util.find_spec("ray") is not None


# ----------------------------------------------------------------------------------------------
# Process pools (spawn)
# ----------------------------------------------------------------------------------------------


def test_process_pool_records_errors_and_timeouts_and_finishes_the_rest(tmp_path: Path) -> None:
    small = spec(scenes=("alpha",), seeds=(0, 1, 2), strategies=("ours",), timeout_s=1.0)
    result = run_sweep(small, tmp_path, run_fn=sleepy_run, workers=2, progress=None, check_names=False)
    rows = {r["seed"]: r for r in load_rows(tmp_path)}
    assert result.ran == 3 and result.timeouts == 1
    assert rows[1]["status"] == STATUS_TIMEOUT
    assert rows[0]["status"] == rows[2]["status"] == STATUS_OK


def test_a_worker_stuck_in_native_code_is_killed_by_the_parent(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(executors, "HARD_KILL_GRACE_S", 4.0)
    # 5 s, not less: on a loaded 2-core machine a quick episode in a freshly spawned worker took over 0.5 s
    # and timed out too (CI must not depend on the machine's load).
    small = spec(scenes=("alpha",), seeds=(0, 1, 2), strategies=("ours",), timeout_s=5.0)
    started = time.monotonic()
    result = run_sweep(small, tmp_path, run_fn=stuck_run, workers=2, progress=None, check_names=False)
    assert time.monotonic() - started < 40.0
    rows = {r["seed"]: r for r in load_rows(tmp_path)}
    assert result.timeouts == 1 and "killed by the harness" in rows[1]["error"]
    assert rows[0]["status"] == rows[2]["status"] == STATUS_OK


def test_a_worker_that_dies_is_an_error_row_after_retries(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(executors, "MAX_WORKER_DEATHS", 2)
    small = spec(scenes=("alpha",), seeds=(0, 1, 2), strategies=("ours",))
    result = run_sweep(small, tmp_path, run_fn=dying_run, workers=1, progress=None, check_names=False)
    rows = {r["seed"]: r for r in load_rows(tmp_path)}
    assert result.errors == 1 and "worker process died" in rows[1]["error"]
    assert rows[0]["status"] == rows[2]["status"] == STATUS_OK


def test_progress_lines_show_counts_rate_and_eta(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run_sweep(spec(), tmp_path, run_fn=fake_run, workers=0, progress=sys.stderr, check_names=False)
    err = capsys.readouterr().err
    assert "8 episodes, 0 already done, 8 to run" in err
    assert "[sweep] 8/8 done (0 failed)" in err and "episodes/h" in err and "ETA" in err


# ----------------------------------------------------------------------------------------------
# The real runner, end to end
# ----------------------------------------------------------------------------------------------


def test_bench_paper_smoke_end_to_end(tmp_path: Path) -> None:
    """``semexp-bt bench paper --smoke``: 4 real episodes (60 s of sim each), report and results."""
    from semexp_bt.cli import main

    out = tmp_path / "smoke"
    status = main(["bench", "paper", "--smoke", "--out", str(out), "--workers", "2", "--quiet"])
    rows = load_rows(out)
    assert len(rows) == 4, [r.get("error") for r in rows]
    assert status == 0, [r.get("error") for r in rows if r["status"] != STATUS_OK]
    assert {(r["scene"], r["strategy"]) for r in rows} == {
        (s, k) for s in protocol.SMOKE_SCENES for k in protocol.SMOKE_STRATEGIES
    }
    assert all(r["sim_time_s"] <= protocol.SMOKE_MAX_SIM_S + 1.0 for r in rows)
    report = (out / "report.md").read_text()
    assert "## SR (success rate)" in report and "plots/bars_sr.png" in report
    results = (out / "results.md").read_text()
    assert "## Table V" in results and "(paper 88.9)" in results
    assert "invocation(s) (0 stopped) that ran 4 episodes" in results
    assert any(p.name.startswith("trajectory_") for p in (out / "plots").iterdir())
    # resumable: the same grid again runs nothing, and the report regenerates from the rows alone
    again = run_sweep(protocol.smoke_specs(relevance="lexical"), out, workers=2, progress=None)
    assert (again.ran, again.skipped) == (0, 4)
    assert [one["ran"] for one in store.load_invocations(out)] == [4, 0]
    assert main(["bench", "report", str(out), "--no-plots"]) == 0


def test_pool_workers_run_blas_on_one_thread() -> None:
    """Two workers on two cores must not each start a BLAS thread per core: the variables that size
    OpenBLAS's pool are read when numpy loads, which a spawned worker does before its initializer."""
    threadpoolctl = pytest.importorskip("threadpoolctl")
    pool = executors.new_pool(1)
    try:
        pools = pool.submit(threadpoolctl.threadpool_info).result(timeout=120)
    finally:
        pool.shutdown(wait=True)
    print(pools)
    blas = [p for p in pools if p["user_api"] == "blas"]
    assert blas, "numpy's BLAS not found in the worker"
    assert all(p["num_threads"] == 1 for p in blas)
