"""What the model adapters cost and save, measured against the scripted chat server (no real model).

``python -m semexp_bt.bench.models [overhead] [cache] [ticks] [--json OUT]`` runs three measurements:

- ``overhead``: the adapters' own cost per request, on frames of 320x240 (the simulated head camera)
  and 640x480, PNG and JPEG: ``encode`` (prompt and image into a request), ``request`` (the client's
  round trip to a server on 127.0.0.1 that answers at once with a fixed valid reply, so it is the
  client and HTTP on loopback, not a model) and ``parse`` (JSON, schema and range checks into
  evidence); the same for one relevance batch of 16 labels. Median and p95 over ``--requests``.
- ``cache``: the relevance cache's hit rate over a sweep: missions (perception emulator, ``--relevance
  llm`` against the scripted server, one fresh on-disk cache for the whole sweep) on each scene and
  seed in turn; per mission, the lookups that reached the LLM scorer, how many it had to ask, and the
  hit rate ``1 - asked / lookups``.
- ``ticks``: the tree's tick time while a 3 s request is in flight: one MuJoCo mission with
  ``--perception models``, the scripted VLM answering each view after ``--delay-s`` seconds, the
  simulation held to real time; tick wall time and thread CPU time of ticks with a request in flight
  against ticks without one.

It says plainly in its output that no real model ran. Figures: docs/perception.md.
"""

from __future__ import annotations

import argparse
import json
import platform
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from semexp_bt.app.runner import MissionRun
from semexp_bt.perception.adapters.chat import CircuitBreaker, OpenAIChatClient
from semexp_bt.perception.adapters.vlm import SceneVLM
from semexp_bt.perception.llm_relevance import LLMRelevance
from semexp_bt.perception.model_config import CircuitBreakerConfig, LLMConfig, ModelsProfile, VLMConfig
from sims.scripted_chat_server import ScriptedChatServer, ScriptedReply, scripted_models, scripted_scene_reply

MISSION = Path(__file__).resolve().parents[2] / "trees" / "object_search.yaml"
NO_MODEL = "no real model ran: every reply came from sims.scripted_chat_server on 127.0.0.1"
#: A fixed valid scene reply (four proposals) for the overhead runs.
SCENE_REPLY = json.dumps(
    {
        "proposals": [
            {"kind": "object", "label": "fire extinguisher", "point": [100, 80]},
            {"kind": "object", "label": "red trash can", "point": [200, 120]},
            {"kind": "direction", "label": "open corridor", "point": [160, 200]},
            {"kind": "direction", "label": "doorway", "point": [300, 150]},
        ],
        "scene_confidence": 0.8,
    }
)
LABELS_16 = [f"object {i}" for i in range(16)]
MEASUREMENTS = ("overhead", "cache", "ticks")


def _quantiles(values: Sequence[float]) -> dict[str, float]:
    arr = np.asarray(values, dtype=float)
    return {
        "median": round(float(np.median(arr)), 3),
        "p95": round(float(np.percentile(arr, 95)), 3),
        "p99": round(float(np.percentile(arr, 99)), 3),
        "max": round(float(arr.max()), 3),
    }


def _client(config: VLMConfig | LLMConfig, role: str) -> OpenAIChatClient:
    return OpenAIChatClient(
        config=config, breaker=CircuitBreaker(CircuitBreakerConfig(), name=role), role=role, environ={}
    )


def measure_overhead(*, requests: int = 200) -> dict[str, Any]:
    """Per-stage milliseconds of the VLM and relevance adapters (see the module docstring)."""
    rows: list[dict[str, Any]] = []
    rng = np.random.default_rng(0)
    with ScriptedChatServer([ScriptedReply(content=SCENE_REPLY)]) as server:
        for width, height in ((320, 240), (640, 480)):
            # A smooth frame with noise compresses like a camera picture, not like white noise.
            yy, xx = np.mgrid[0:height, 0:width]
            base = np.stack([xx * 255 // width, yy * 255 // height, (xx + yy) * 127 // (width + height)], -1)
            rgb = np.clip(base + rng.integers(-8, 9, base.shape), 0, 255).astype(np.uint8)
            for image_format in ("png", "jpeg"):
                config = VLMConfig(base_url=server.url, model="scripted", image_format=image_format)
                vlm = SceneVLM(config, _client(config, "vlm"))
                stages: dict[str, list[float]] = {"encode": [], "request": [], "parse": []}
                for _ in range(requests):
                    call = vlm.perceive(
                        rgb=rgb,
                        instruction="find the fire extinguisher",
                        target_label="fire extinguisher",
                        stamp_s=0.0,
                    ).call
                    assert call.ok, call.error
                    for stage in stages:
                        stages[stage].append(call.timings_ms[stage])
                image_kb = (
                    len(vlm.request(rgb=rgb, instruction="x", target_label="x").image_data_url or "") / 1024
                )
                rows.append(
                    {"adapter": "vlm", "frame": f"{width}x{height} {image_format}", "request_kb": round(image_kb, 1),
                     **{stage: _quantiles(v) for stage, v in stages.items()}}
                )  # fmt: skip
        scores = json.dumps({"scores": [{"id": i + 1, "relevance": 0.5} for i in range(16)]})
        server.set_script([ScriptedReply(content=scores)])
        llm_config = LLMConfig(base_url=server.url, model="scripted", cache_path="")
        stages = {"encode": [], "request": [], "parse": []}
        for i in range(requests):
            llm = LLMRelevance(llm_config, _client(llm_config, "llm"))  # a fresh scorer: every batch is asked
            llm.scores(instruction=f"find the thing number {i}", labels=LABELS_16)
            call = llm.calls[-1]
            assert call.ok, call.error
            for stage in stages:
                stages[stage].append(call.timings_ms[stage])
        rows.append(
            {
                "adapter": "llm",
                "frame": "16 labels",
                "request_kb": None,
                **{s: _quantiles(v) for s, v in stages.items()},
            }
        )
    return {"requests": requests, "rows": rows}


def measure_cache(
    *, scenes: Sequence[str] = ("office", "road"), seeds: Sequence[int] = (0, 1, 2), max_sim_s: float = 120.0
) -> dict[str, Any]:
    """The relevance cache's hit rate over a sweep of emulator missions with the LLM scorer."""
    from semexp_bt.app.episode import EpisodeOptions, run_episode

    rows: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as cache_dir, ScriptedChatServer(scripted_models) as server:
        config = LLMConfig(
            base_url=server.url, model="scripted", cache_path=str(Path(cache_dir) / "relevance.sqlite3")
        )
        for scene in scenes:
            for seed in seeds:
                record = run_episode(
                    EpisodeOptions(mission_path=MISSION, scene=scene, seed=seed, relevance="llm",
                                   models=ModelsProfile(llm=config, source="bench"), max_sim_s=max_sim_s)
                )  # fmt: skip
                stats = record["models"]["relevance"]
                rows.append({"scene": scene, "seed": seed, "outcome": record["outcome"], **stats})
    total_lookups = sum(r["lookups"] for r in rows)
    total_asked = sum(r["asked"] for r in rows)
    return {
        "max_sim_s": max_sim_s,
        "rows": rows,
        "sweep_hit_rate": round(1 - total_asked / total_lookups, 3) if total_lookups else 0.0,
    }


class TickClock:
    """Times every ``tree.tick()`` (wall and thread CPU) and notes whether a model request was in flight
    when it began. It wraps the tree's ``tick`` in ``start``: a measuring hook, it changes nothing."""

    wants_activity_stream = False

    def __init__(self) -> None:
        self.samples: list[tuple[float, float, bool]] = []

    def start(self, run: MissionRun) -> None:
        tick = run.tree.tick
        perception = run.services.perception
        in_flight = getattr(perception, "in_flight", lambda: 0)

        def timed() -> Any:
            busy = in_flight() > 0
            wall, cpu = time.perf_counter(), time.thread_time()
            try:
                return tick()
            finally:
                self.samples.append((time.perf_counter() - wall, time.thread_time() - cpu, busy))

        run.tree.tick = timed  # type: ignore[method-assign,assignment]

    def after_tick(self, run: MissionRun) -> None:
        del run

    def finish(self, run: MissionRun, outcome: str) -> None:
        del run, outcome


def measure_ticks(
    *, delay_s: float = 3.0, scene_name: str = "office", seed: int = 0, max_sim_s: float = 40.0
) -> dict[str, Any]:
    """Tick wall and CPU time with and without a ``delay_s`` VLM request in flight (MuJoCo, real time)."""
    from semexp_bt.app.components import (
        DEFAULT_PLANNER,
        ComponentRequest,
        build_perception,
        build_planner,
        build_relevance,
        build_robot,
    )
    from semexp_bt.app.configuration import resolve_config
    from semexp_bt.app.pacing import WallClockPacer
    from semexp_bt.app.runner import MissionComponents, run_mission
    from semexp_bt.app.strategies import resolve_strategy
    from semexp_bt.perception.adapters.stack import ModelStack
    from sims.catalogue import build_scene
    from sims.episodes import sample_episode
    from trees.loader import parse_mission

    def slow(body: dict[str, Any]) -> ScriptedReply:
        return ScriptedReply(content=scripted_scene_reply(body).content, delay_s=delay_s)

    clock = TickClock()
    scene = build_scene(scene_name, seed=seed)
    episode = sample_episode(scene, seed=seed)
    with ScriptedChatServer(slow) as server:
        profile = ModelsProfile(vlm=VLMConfig(base_url=server.url, model="scripted", timeout_s=delay_s + 5.0))
        stack = ModelStack(profile)
        request = ComponentRequest(
            seed=seed, strategy=resolve_strategy("ours"), scene=scene, start_pose=episode.start, models=stack
        )
        robot = build_robot("mujoco", request)
        try:
            result = run_mission(
                mission=parse_mission(MISSION),
                components=MissionComponents(
                    robot=robot,
                    perception=build_perception("models", request),
                    relevance=build_relevance("lexical"),
                    planner=build_planner(DEFAULT_PLANNER),
                ),
                config=resolve_config(),
                instructions=[scene.instruction],
                seed=seed,
                start_pose=episode.start,
                max_time_s=max_sim_s,
                observers=[clock, WallClockPacer()],
            )
        finally:
            robot.close()
            stack.close()
        views = len([r for r in server.requests if r.image_data_url() is not None])

    def summary(samples: list[tuple[float, float, bool]]) -> dict[str, Any]:
        return {
            "ticks": len(samples),
            "wall_ms": _quantiles([s[0] * 1e3 for s in samples]) if samples else None,
            "cpu_ms": _quantiles([s[1] * 1e3 for s in samples]) if samples else None,
        }

    return {
        "delay_s": delay_s,
        "scene": scene_name,
        "seed": seed,
        "views": views,
        "sim_time_s": round(result.sim_time_s, 2),
        "in_flight": summary([s for s in clock.samples if s[2]]),
        "not_in_flight": summary([s for s in clock.samples if not s[2]]),
        "perception_timeouts": len([e for e in result.services.events if e["kind"] == "perception_timeout"]),
    }


def format_report(result: dict[str, Any]) -> str:
    """The measurements as the terminal shows them (and docs/perception.md quotes)."""
    lines = [NO_MODEL, f"machine: {result['machine']}"]
    if "overhead" in result:
        lines.append(
            f"adapter overhead per request, ms (median / p95 over {result['overhead']['requests']} requests):"
        )
        lines.append("| adapter | input | request size | encode | request (loopback) | parse |")
        lines.append("| --- | --- | --- | --- | --- | --- |")
        for row in result["overhead"]["rows"]:
            size = "" if row["request_kb"] is None else f"{row['request_kb']} KiB"
            cells = [f"{row[s]['median']} / {row[s]['p95']}" for s in ("encode", "request", "parse")]
            lines.append(f"| {row['adapter']} | {row['frame']} | {size} | " + " | ".join(cells) + " |")
    if "cache" in result:
        cache = result["cache"]
        lines.append(
            f"relevance cache over a sweep (missions of at most {cache['max_sim_s']:g} s, in this order):"
        )
        lines.append("| scene | seed | lookups | disk hits | asked | requests | hit rate |")
        lines.append("| --- | --- | --- | --- | --- | --- | --- |")
        for r in cache["rows"]:
            lines.append(
                f"| {r['scene']} | {r['seed']} | {r['lookups']} | {r['disk_hits']} | {r['asked']} | {r['requests']} "
                f"| {r['hit_rate']:.0%} |"
            )
        lines.append(f"whole sweep: {cache['sweep_hit_rate']:.0%} of lookups answered without asking")
    if "ticks" in result:
        t = result["ticks"]
        lines.append(
            f"tick time with a {t['delay_s']:g} s VLM request in flight ({t['scene']} seed {t['seed']}, {t['views']} views "
            f"in {t['sim_time_s']} s at real time, {t['perception_timeouts']} perception time-outs):"
        )
        lines.append("| ticks | count | wall median / p99 / max, ms | CPU median / p99 / max, ms |")
        lines.append("| --- | --- | --- | --- |")
        for name in ("in_flight", "not_in_flight"):
            s = t[name]
            if not s["ticks"]:
                continue
            wall, cpu = s["wall_ms"], s["cpu_ms"]
            lines.append(
                f"| {name.replace('_', ' ')} | {s['ticks']} | {wall['median']} / {wall['p99']} / {wall['max']} "
                f"| {cpu['median']} / {cpu['p99']} / {cpu['max']} |"
            )
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("what", nargs="*", help="any of overhead, cache, ticks (default: all three)")
    parser.add_argument("--requests", type=int, default=200, help="requests per overhead row")
    parser.add_argument("--delay-s", type=float, default=3.0, help="the VLM's latency in the ticks run")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args(argv)
    import torch

    torch.set_num_threads(1)
    what = args.what or list(MEASUREMENTS)
    unknown = sorted(set(what) - set(MEASUREMENTS))
    if unknown:
        parser.error(f"unknown measurement {unknown[0]!r}; choose from {', '.join(MEASUREMENTS)}")
    result: dict[str, Any] = {
        "note": NO_MODEL,
        "machine": f"{platform.machine()} {platform.system()}, Python {platform.python_version()}",
    }
    if "overhead" in what:
        result["overhead"] = measure_overhead(requests=args.requests)
    if "cache" in what:
        result["cache"] = measure_cache()
    if "ticks" in what:
        result["ticks"] = measure_ticks(delay_s=args.delay_s)
    print(format_report(result))
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
