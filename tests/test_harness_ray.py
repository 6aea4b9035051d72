"""The sweep engine on a real Ray cluster (``--ray-address``), one machine, loopback only.

Ray is optional (``pip install -e '.[cluster]'``), so these tests carry the ``ray`` marker and run with
``make ray``. The fixture starts a one-node Ray head bound to 127.0.0.1 (see docs/harness.md for the two
environment variables that keep every Ray socket on loopback) and stops it afterwards.
"""

from __future__ import annotations

import contextlib
import importlib.util
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from semexp_bt.bench.compare import WALL_CLOCK_FIELDS as COMPARED_WALL_CLOCK_FIELDS
from semexp_bt.bench.engine import run_sweep
from semexp_bt.bench.rows import STATUS_ERROR, STATUS_OK
from semexp_bt.bench.store import load_rows

pytestmark = [
    pytest.mark.ray,
    pytest.mark.skipif(importlib.util.find_spec("ray") is None, reason="Ray is not installed (make ray)"),
    pytest.mark.skipif(not Path("/proc").is_dir(), reason="the fixture stops the head by pid via /proc"),
]

REPO = Path(__file__).resolve().parents[1]
#: Keeps every socket of the head on loopback: Ray otherwise replaces 127.0.0.1 by the machine's routable
#: address. The driver side (the harness) sets the same switch itself for a loopback address.
LOOPBACK_ENV = {"RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0", "RAY_USAGE_STATS_ENABLED": "0"}
#: Row fields that measure the machine, not the episode (a Ray row also names its worker's process).
WALL_CLOCK_FIELDS = COMPARED_WALL_CLOCK_FIELDS | {"worker_pid"}


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _ray_cli() -> str:
    cli = Path(sys.executable).with_name("ray")
    if not cli.exists():
        pytest.skip("the ray command is not next to this Python")
    return str(cli)


@pytest.fixture(scope="module")
def ray_address(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """A one-node Ray cluster on 127.0.0.1 with two CPUs; its workers can import this test module."""
    port = _free_port()
    temp_dir = tmp_path_factory.mktemp("ray")
    env = {**os.environ, **LOOPBACK_ENV,
           "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}  # fmt: skip
    start = [_ray_cli(), "start", "--head", "--node-ip-address=127.0.0.1", f"--port={port}", "--num-cpus=2",
             "--include-dashboard=false", "--disable-usage-stats", f"--temp-dir={temp_dir}"]  # fmt: skip
    subprocess.run(start, env=env, check=True, capture_output=True, timeout=180, cwd=REPO)
    try:
        yield f"127.0.0.1:{port}"
    finally:
        if "ray" in sys.modules:
            sys.modules["ray"].shutdown()
        _stop_processes_under(temp_dir)
        shutil.rmtree(temp_dir, ignore_errors=True)


def _stop_processes_under(temp_dir: Path) -> None:
    """Stop, by pid, every process whose command line names ``temp_dir`` (this head and its workers).

    ``ray stop`` would stop every Ray process on the machine, a user's own cluster included.
    """
    mine = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit() or int(entry.name) == os.getpid():
            continue
        try:
            command = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        if str(temp_dir) in command:
            mine.append(int(entry.name))
    for signal_number in (signal.SIGTERM, signal.SIGKILL):
        for pid in mine:
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal_number)
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline and any(Path(f"/proc/{pid}").exists() for pid in mine):
            time.sleep(0.2)


def _comparable(rows: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    return {row["key"]: {k: v for k, v in row.items() if k not in WALL_CLOCK_FIELDS} for row in rows}


def test_a_ray_sweep_gives_the_rows_of_a_local_sweep_and_survives_a_crash(
    ray_address: str, tmp_path: Path
) -> None:
    from tests.test_harness import crashing_run, spec

    grid = spec()
    on_ray = run_sweep(grid, tmp_path / "ray", run_fn=crashing_run, ray_address=ray_address, workers=2,
                       progress=None, check_names=False)  # fmt: skip
    local = run_sweep(
        grid, tmp_path / "local", run_fn=crashing_run, workers=0, progress=None, check_names=False
    )
    ray_rows, local_rows = load_rows(tmp_path / "ray"), load_rows(tmp_path / "local")
    print(json.dumps(sorted((r["key"], r["status"]) for r in ray_rows), indent=1))
    assert on_ray.ran == local.ran == 8 and on_ray.errors == local.errors == 4
    assert {r["status"] for r in ray_rows if r["seed"] == 1} == {STATUS_ERROR}
    assert "wormhole" in next(r["error"] for r in ray_rows if r["seed"] == 1)
    assert {r["status"] for r in ray_rows if r["seed"] == 0} == {STATUS_OK}
    ray_view, local_view = _comparable(ray_rows), _comparable(local_rows)
    for view in (ray_view, local_view):  # the tracebacks differ in their frames, not in their meaning
        for row in view.values():
            row.pop("error", None)
    assert ray_view == local_view
    rerun = run_sweep(grid, tmp_path / "ray", run_fn=crashing_run, ray_address=ray_address, workers=2,
                      progress=None, check_names=False)  # fmt: skip
    assert rerun.ran == 0


def test_bench_missions_on_ray_runs_a_real_episode_like_a_local_worker(
    ray_address: str, tmp_path: Path
) -> None:
    """The CLI with --ray-address: a 40 s simulated road episode, the same row as a local worker's."""
    common = ["--scenes", "road", "--seeds", "1", "--strategies", "ours", "--relevance", "lexical",
              "--max-sim-s", "40", "--quiet"]  # fmt: skip
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    env.pop("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", None)  # the harness must keep the loopback address itself
    cli = [sys.executable, "-m", "semexp_bt", "bench", "missions"]
    for out, engine in (
        (tmp_path / "ray", ["--ray-address", ray_address]),
        (tmp_path / "local", ["--workers", "1"]),
    ):
        done = subprocess.run([*cli, *common, "--out", str(out), *engine], env=env, cwd=REPO, capture_output=True,
                              text=True, timeout=600)  # fmt: skip
        assert done.returncode == 0, done.stderr[-2000:]
    ray_rows, local_rows = load_rows(tmp_path / "ray"), load_rows(tmp_path / "local")
    print(
        json.dumps(
            {k: ray_rows[0].get(k) for k in ("key", "status", "outcome", "path_length_m", "sim_time_s")}
        )
    )
    assert len(ray_rows) == len(local_rows) == 1 and ray_rows[0]["status"] == STATUS_OK
    assert 0.0 < ray_rows[0]["sim_time_s"] <= 40.5
    assert _comparable(ray_rows) == _comparable(local_rows)
    assert (tmp_path / "ray" / "report.md").is_file()
