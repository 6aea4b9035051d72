"""What the browser view costs a mission: wall time per simulated second with the view off and on.

Runs the README's mission (road, seed 0, lexical relevance; ``--sim-s`` caps the robot time) in fresh
processes, alternating the configurations ``repeats`` times so that the machine's load falls on all of
them alike, and prints for each the fastest run's wall and CPU seconds per simulated second (the run
least disturbed by whatever else the machine does) and the extra share over ``off``, and the median over
the repeats of each run's share over the ``off`` run of the same repeat (paired: on a machine whose load
changes from minute to minute, the fastest ``off`` and the fastest ``view`` may have met different loads).
The same paired share is also given for the mission loop alone (the episode record's ``mission_wall_s``:
the ticks, with the view's start and end), beside the paired difference in seconds of what lies outside
it (set-up and scoring, where the view's Rerun import and sinks are made): a fixed cost that a short
mission divides by few simulated seconds:

- ``off``: no recorder, no view (what ``semexp-bt run`` costs);
- ``record``: ``--record`` (the JSONL tick record alone, for reference);
- ``view``: ``--view-record DIR`` (tree records, world frames logged to world.rrd by the worker);
- ``live_only``: ``--view`` alone (the page and Rerun's gRPC stream served, nothing saved): what a user
  runs to watch a mission;
- ``live``: ``--view`` and ``--view-record`` with the page and Rerun's gRPC stream served;
- ``stalled``: as ``live``, with four clients that ask the page for ticks and never read the answer,
  and a Rerun viewer that pulls the gRPC stream and then freezes: ``rerun URL --save FILE`` (Rerun's own
  client, headless), stopped with SIGSTOP once it has written its first bytes, and resumed and ended after
  the mission.

Usage:
    MUJOCO_GL=egl .venv/bin/python scripts/measure_viewer_cost.py --repeats 3 --sim-s 120
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ("off", "record", "view", "live_only", "live", "stalled")
#: The configurations that view the mission (the others run it plainly or only record its ticks).
VIEW_CONFIGS = ("view", "live_only", "live", "stalled")


def _children_cpu_s() -> float:
    """User and system CPU seconds of this process's ended and waited-for children."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def one_run(config: str, sim_s: float, workdir: Path) -> dict[str, float]:
    """Run the mission once in this process; the figures as a dict (called in a child process)."""
    world_process = None
    if config in VIEW_CONFIGS:
        # As ``semexp-bt run`` does: the view's world process is spawned before the mission stack is
        # imported, so that Rerun's import in it overlaps those imports.
        from semexp_bt.app.viewer.world_process import WorldProcess

        world_process = WorldProcess.spawn()
    import torch

    torch.set_num_threads(1)
    from semexp_bt.app.episode import EpisodeOptions, run_episode
    from semexp_bt.app.viewer.observer import ViewObserver, ViewOptions

    stalls: list[socket.socket] = []
    frozen_viewers: list[subprocess.Popen[bytes]] = []

    def stall(url: str) -> None:
        # Clients that ask and never read: pages that froze.
        host, port = url.split("//")[1].split("/")[0].split(":")
        for _ in range(4):
            client = socket.create_connection((host, int(port)))
            client.sendall(b"GET /api/ticks?after=0 HTTP/1.1\r\nHost: x\r\n\r\n")
            stalls.append(client)
        # A Rerun viewer that stopped pulling the stream: Rerun's client, frozen once it has data.
        with urllib.request.urlopen(url + "api/session") as answer:
            grpc_url = json.loads(answer.read())["world"]["url"]
        saved = workdir / "frozen_viewer.rrd"
        viewer = subprocess.Popen(
            [str(Path(sys.executable).with_name("rerun")), grpc_url, "--save", str(saved),
             "--bind", "127.0.0.1", "--port", "auto"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )  # fmt: skip
        frozen_viewers.append(viewer)

        def freeze() -> None:
            deadline = time.monotonic() + 30.0
            while time.monotonic() < deadline and not (saved.is_file() and saved.stat().st_size > 0):
                time.sleep(0.05)
            viewer.send_signal(signal.SIGSTOP)

        threading.Thread(target=freeze, daemon=True).start()

    frozen: dict[str, float] = {}

    def hold(view: ViewObserver, outcome: str) -> None:
        # A live view's drops (one without --view-record writes no manifest).
        frozen["frames_dropped"], frozen["frames_queued"] = (
            float(view.frames_dropped),
            float(view.frames_queued),
        )
        for client in stalls:
            client.close()
        for viewer in frozen_viewers:
            # The viewer must have stayed stopped (state T) to the end, holding what it had pulled.
            state = Path(f"/proc/{viewer.pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
            frozen["frozen_viewer_stopped"] = float(state == "T")
            frozen["frozen_viewer_bytes"] = float((workdir / "frozen_viewer.rrd").stat().st_size)
            viewer.send_signal(signal.SIGCONT)
            viewer.terminate()
            viewer.wait(timeout=10.0)

    view = None
    if config in VIEW_CONFIGS:
        view = ViewOptions(
            live=config != "view",
            record_dir=None if config == "live_only" else workdir / "view",
            announce=stall if config == "stalled" else None,
            after_mission=hold,
            world_process=world_process,
        )
    options = EpisodeOptions(
        mission_path=ROOT / "trees" / "object_search.yaml",
        scene="road",
        seed=0,
        relevance="lexical",
        max_sim_s=sim_s,
        record_path=workdir / "ticks.jsonl" if config == "record" else None,
        view=view,
    )
    cpu0, wall0, children0 = time.process_time(), time.perf_counter(), _children_cpu_s()
    record = run_episode(options)
    # The view's world process is a child, ended and waited for by the end of the episode: its CPU counts.
    wall = time.perf_counter() - wall0
    cpu = time.process_time() - cpu0 + _children_cpu_s() - children0
    sim = float(record["sim_time_s"])
    out = {"wall_per_sim_s": wall / sim, "cpu_per_sim_s": cpu / sim, "sim_s": sim, "ticks": record["ticks"],
           "loop_wall_per_sim_s": record["mission_wall_s"] / sim, "outside_loop_s": wall - record["mission_wall_s"],
           "tick_p50_ms": record["tick_wall_ms"]["median"], "tick_p99_ms": record["tick_wall_ms"]["p99"]}  # fmt: skip
    out.update(frozen)
    manifest = workdir / "view" / "manifest.json"
    if "frames_dropped" not in out and manifest.is_file():  # a saved view alone: its manifest counts them
        frames = json.loads(manifest.read_text())["frames"]
        out["frames_dropped"], out["frames_queued"] = frames["dropped"], frames["queued"]
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--sim-s", type=float, default=120.0, help="robot time per mission (s)")
    parser.add_argument("--configs", default=",".join(CONFIGS))
    parser.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        with tempfile.TemporaryDirectory() as tmp:
            print(json.dumps(one_run(args.child, args.sim_s, Path(tmp))))
        return 0
    configs = args.configs.split(",")
    results: dict[str, list[dict[str, float]]] = {c: [] for c in configs}
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    for repeat in range(args.repeats):
        for config in configs:
            answer = subprocess.run(
                [sys.executable, __file__, "--child", config, "--sim-s", str(args.sim_s)],
                capture_output=True, text=True, env=env, cwd=ROOT, check=True,
            )  # fmt: skip
            results[config].append(json.loads(answer.stdout.strip().splitlines()[-1]))
            print(f"repeat {repeat} {config}: {results[config][-1]}", file=sys.stderr)
    base = min(r["wall_per_sim_s"] for r in results[configs[0]])
    base_cpu = min(r["cpu_per_sim_s"] for r in results[configs[0]])
    print(
        f"| config | wall s per sim s | extra wall vs {configs[0]} | paired extra wall | CPU s per sim s | extra CPU"
        " | paired extra CPU | paired extra wall, mission loop | set-up and end, paired extra s | tick p99 ms"
        " | frames dropped |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for config in configs:
        rows = results[config]
        wall = min(r["wall_per_sim_s"] for r in rows)
        cpu = min(r["cpu_per_sim_s"] for r in rows)
        paired = {
            key: statistics.median(
                r[key] / o[key] - 1 for r, o in zip(rows, results[configs[0]], strict=True)
            )
            for key in ("wall_per_sim_s", "cpu_per_sim_s", "loop_wall_per_sim_s")
        }
        # What the run costs outside the mission loop (set-up, scoring; the view's import and sinks),
        # against the same repeat's first configuration, in seconds.
        fixed = statistics.median(
            r["outside_loop_s"] - o["outside_loop_s"] for r, o in zip(rows, results[configs[0]], strict=True)
        )
        p99 = statistics.median(r["tick_p99_ms"] for r in rows)
        dropped = "-" if "frames_dropped" not in rows[0] else f"{max(r['frames_dropped'] for r in rows):.0f}"
        print(
            f"| {config} | {wall:.4f} | {100 * (wall / base - 1):+.1f} % | {100 * paired['wall_per_sim_s']:+.1f} %"
            f" | {cpu:.4f} | {100 * (cpu / base_cpu - 1):+.1f} % | {100 * paired['cpu_per_sim_s']:+.1f} %"
            f" | {100 * paired['loop_wall_per_sim_s']:+.1f} % | {fixed:+.2f} | {p99:.2f} | {dropped} |"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
