"""The benchmark harness: grids of episodes, in parallel, resumable, one JSONL row per episode.

A sweep is a :class:`SweepSpec` (scenes x seeds x strategies, one fidelity, one relevance scorer, one
mission tree, config overrides). Each episode has an :class:`EpisodeKey` ``(scene, seed, strategy,
fidelity, config_hash)``; the config hash covers everything else that can change the outcome (the
mission tree and its subtrees, the strategy's definition, relevance scorer, overrides, r_s, clearance,
the simulated-time cap), so a key names one deterministic episode. Code changes are not in the key:
start a new output folder after changing the method (``sweep.json`` records the git revision).

Rows go to ``DIR/episodes.jsonl``, appended by the parent process only, one flushed line per finished
episode, so an interrupted sweep loses at most the episodes in flight. A rerun skips every key that
already has a row (``retry_failed`` reruns the ``error`` and ``timeout`` rows; the newest row of a key
wins when reading). Each call appends its wall time, counts and code revision to
``DIR/invocations.jsonl``, also when it is stopped, so a sweep resumed over several invocations still
has a total wall time. Rows are flat-ish: the runner's record without the per-decision candidate lists,
per-event entries and bulky snapshots; decisions keep ``selected_node_id`` and ``oracle_node_id``
(GNSA). Trajectories and memory snapshots of a few episodes per (scene, strategy) go to
``DIR/trajectories/*.json`` for the report's plots.

Execution: in-process (``workers=0``, for debugging), a ``ProcessPoolExecutor`` with the ``spawn``
start method (default; each worker sets ``MUJOCO_GL=egl`` and one torch/BLAS thread), or Ray with
``ray_address`` (imported lazily; ``pip install ray``). An exception inside an episode becomes a row
with ``status="error"`` and the traceback; an episode over its wall-time limit is interrupted inside
its worker (``SIGALRM``) and recorded as ``timeout``; a worker that does not answer even then (stuck in
native code) is killed with its pool, and the pool restarted.

Example:
    >>> spec = SweepSpec(scenes=("office",), seeds=(0, 1), strategies=("ours",), relevance="lexical")
    >>> [t.key.id.split("/")[:3] for t in spec.tasks()]
    [['office', '0', 'ours'], ['office', '1', 'ours']]
"""

from __future__ import annotations

import hashlib
import json
import math
import multiprocessing
import os
import signal
import socket
import subprocess
import sys
import threading
import time
import traceback
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, TextIO

from semexp_bt.core.metrics import DEFAULT_CLEARANCE_M, DEFAULT_SUCCESS_RADIUS_M, EpisodeRecord

#: Bumped when the row format or the meaning of a key changes (it is part of the config hash).
ROW_SCHEMA_VERSION = 1
EPISODES_FILE = "episodes.jsonl"
TRAJECTORY_DIR = "trajectories"
SWEEP_META_FILE = "sweep.json"
#: One line per call of :func:`run_sweep` on a folder: a resumed sweep's wall time is the sum of its lines.
INVOCATIONS_FILE = "invocations.jsonl"

STATUS_OK = "ok"
STATUS_ERROR = "error"
STATUS_TIMEOUT = "timeout"

#: Default wall-time limit per episode (s). A kinematic episode of the 600 s mission takes about 50 s
#: on one core of the development machine; ten times that means something is wrong.
DEFAULT_EPISODE_TIMEOUT_S = 600.0
#: Extra wall time the parent grants a worker beyond the episode's own limit before killing the pool
#: (process start and imports, the interrupted episode's clean-up).
HARD_KILL_GRACE_S = 90.0
#: A task in flight while its worker process died this many times is recorded as an error.
MAX_WORKER_DEATHS = 3
#: How often the parent wakes to check deadlines (s).
POLL_S = 1.0
#: Ray's environment switch that keeps a loopback address on loopback (see ``_import_ray_for``).
RAY_LOOPBACK_SWITCH = "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"
#: How long the harness waits for a Ray head to accept a TCP connection before refusing the address (s).
RAY_CONNECT_TIMEOUT_S = 10.0

FIDELITIES = ("kinematic", "dynamic")
RELEVANCES = ("embedding", "lexical")


class HarnessError(ValueError):
    """A sweep that cannot run as asked (bad grid, missing mission file, Ray missing, ...)."""


class EpisodeTimeout(BaseException):  # noqa: N818 - a BaseException so `except Exception` in an episode cannot swallow it
    """Raised inside a worker when the episode exceeds its wall-time limit."""


def default_mission_path() -> Path:
    """The paper's mission tree, ``trees/object_search.yaml`` (found next to the ``trees`` package)."""
    return Path(__file__).resolve().parents[2] / "trees" / "object_search.yaml"


@dataclass(frozen=True)
class EpisodeKey:
    """What names one episode of a sweep.

    Attributes:
        scene: scene name.
        seed: episode seed (layout, start pose, perception noise).
        strategy: strategy name.
        fidelity: ``kinematic`` or ``dynamic``.
        config_hash: 12 hex digits over everything else that can change the outcome.
    """

    scene: str
    seed: int
    strategy: str
    fidelity: str
    config_hash: str

    @property
    def id(self) -> str:
        """``scene/seed/strategy/fidelity/config_hash``: the row's key in ``episodes.jsonl``."""
        return f"{self.scene}/{self.seed}/{self.strategy}/{self.fidelity}/{self.config_hash}"

    @property
    def file_stem(self) -> str:
        """The id as a file name."""
        return self.id.replace("/", "__")


@dataclass(frozen=True)
class EpisodeTask:
    """One episode to run, as plain picklable data (sent to workers).

    Attributes:
        key: the episode's key.
        mission_path: the mission tree.
        relevance: ``embedding`` or ``lexical``.
        config_overrides: SemExpConfig overrides on top of the mission's and the strategy's.
        max_sim_s: cap on simulated time.
        success_radius_m: r_s.
        clearance_m: clearance threshold for OASR.
        keep_trajectory: ask the runner for ``trajectory_xy`` and ``memory_snapshot``.
        timeout_s: wall-time limit of this episode.
    """

    key: EpisodeKey
    mission_path: str
    relevance: str
    config_overrides: Mapping[str, Any]
    max_sim_s: float
    success_radius_m: float
    clearance_m: float
    keep_trajectory: bool
    timeout_s: float


#: What runs one episode: task -> the runner's record (a dict). Must be a module-level function so
#: that process pools can pickle it by name.
RunFunction = Callable[[EpisodeTask], Mapping[str, Any]]


@dataclass(frozen=True)
class SweepSpec:
    """A grid of episodes.

    Attributes:
        scenes: scene names.
        seeds: episode seeds.
        strategies: strategy names (``semexp_bt.app.strategies``).
        fidelity: ``kinematic`` or ``dynamic``.
        relevance: ``embedding`` (the method's scorer) or ``lexical`` (no torch; smoke tests).
        mission_path: the mission tree (default: the paper's ``object_search``).
        config_overrides: SemExpConfig overrides for every episode.
        max_sim_s: cap on simulated time per episode.
        success_radius_m: r_s.
        clearance_m: clearance threshold.
        timeout_s: wall-time limit per episode.
        trajectories_per_cell: keep the trajectory and memory of the first this-many seeds of each
            (scene, strategy) for the report's plots.
    """

    scenes: tuple[str, ...]
    seeds: tuple[int, ...]
    strategies: tuple[str, ...]
    fidelity: str = "kinematic"
    relevance: str = "embedding"
    mission_path: Path = field(default_factory=default_mission_path)
    config_overrides: Mapping[str, Any] = field(default_factory=dict)
    max_sim_s: float = 900.0
    success_radius_m: float = DEFAULT_SUCCESS_RADIUS_M
    clearance_m: float = DEFAULT_CLEARANCE_M
    timeout_s: float = DEFAULT_EPISODE_TIMEOUT_S
    trajectories_per_cell: int = 1

    def __post_init__(self) -> None:
        for name in ("scenes", "seeds", "strategies"):
            values = tuple(getattr(self, name))
            if not values:
                raise HarnessError(f"sweep: '{name}' must not be empty")
            if len(set(values)) != len(values):
                raise HarnessError(f"sweep: '{name}' has duplicates: {list(values)}")
            object.__setattr__(self, name, values)
        if not all(isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in self.seeds):
            raise HarnessError(f"sweep: seeds must be integers >= 0, got {list(self.seeds)}")
        if self.fidelity not in FIDELITIES:
            raise HarnessError(f"sweep: fidelity must be one of {list(FIDELITIES)}, got {self.fidelity!r}")
        if self.relevance not in RELEVANCES:
            raise HarnessError(f"sweep: relevance must be one of {list(RELEVANCES)}, got {self.relevance!r}")
        for name in ("max_sim_s", "success_radius_m", "clearance_m", "timeout_s"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise HarnessError(f"sweep: {name} must be a finite number > 0, got {value!r}")
        object.__setattr__(self, "mission_path", Path(self.mission_path))
        if not self.mission_path.is_file():
            raise HarnessError(f"sweep: mission file {self.mission_path} does not exist")

    def config_hash(self, strategy: str) -> str:
        """12 hex digits over the mission files, the strategy's definition and the sweep's settings."""
        payload = {
            "schema": ROW_SCHEMA_VERSION,
            "mission": _mission_digest(self.mission_path),
            "strategy": _strategy_fingerprint(strategy),
            "relevance": self.relevance,
            "config_overrides": self.config_overrides,
            "max_sim_s": float(self.max_sim_s),
            "success_radius_m": float(self.success_radius_m),
            "clearance_m": float(self.clearance_m),
        }
        canonical = json.dumps(payload, sort_keys=True, separators=(",", ":"), default=str)
        return hashlib.sha256(canonical.encode()).hexdigest()[:12]

    def tasks(self) -> list[EpisodeTask]:
        """Every episode of the grid, ordered by seed, then scene, then strategy.

        Seed-major order makes a partial sweep balanced: after a quarter of the time every (scene,
        strategy) cell has about a quarter of its trials.
        """
        hashes = {s: self.config_hash(s) for s in self.strategies}
        keep_seeds = set(sorted(self.seeds)[: self.trajectories_per_cell])
        return [
            EpisodeTask(
                key=EpisodeKey(
                    scene=scene,
                    seed=seed,
                    strategy=strategy,
                    fidelity=self.fidelity,
                    config_hash=hashes[strategy],
                ),  # fmt: skip
                mission_path=str(self.mission_path),
                relevance=self.relevance,
                config_overrides=dict(self.config_overrides),
                max_sim_s=float(self.max_sim_s),
                success_radius_m=float(self.success_radius_m),
                clearance_m=float(self.clearance_m),
                keep_trajectory=seed in keep_seeds,
                timeout_s=float(self.timeout_s),
            )
            for seed in self.seeds
            for scene in self.scenes
            for strategy in self.strategies
        ]


def _mission_digest(mission_path: Path) -> str:
    """sha256 over the mission file and every YAML under its folder's ``subtrees``."""
    digest = hashlib.sha256(mission_path.read_bytes())
    subtrees = mission_path.parent / "subtrees"
    if subtrees.is_dir():
        for path in sorted(subtrees.rglob("*.yaml")):
            digest.update(path.relative_to(subtrees).as_posix().encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()


def _strategy_fingerprint(name: str) -> Any:
    """The strategy's definition (so redefining a strategy changes its key); the name if unknown."""
    from semexp_bt.app.strategies import STRATEGIES

    strategy = STRATEGIES.get(name)
    return name if strategy is None else asdict(strategy)


def validate_names(spec: SweepSpec) -> None:
    """Check the spec's scene and strategy names against the catalogues.

    Raises:
        HarnessError: naming the unknown scenes or strategies and listing the known ones.
    """
    from semexp_bt.app.strategies import STRATEGIES
    from sims.catalogue import list_scenes

    known_scenes = list_scenes()
    bad_scenes = [s for s in spec.scenes if s not in known_scenes]
    if bad_scenes:
        raise HarnessError(f"unknown scenes {bad_scenes}; known: {known_scenes}")
    bad_strategies = [s for s in spec.strategies if s not in STRATEGIES]
    if bad_strategies:
        raise HarnessError(f"unknown strategies {bad_strategies}; known: {sorted(STRATEGIES)}")


def parse_seeds(text: str) -> tuple[int, ...]:
    """``"0-9"``, ``"0,3,5"`` or ``"0-4,10"`` -> seeds.

    Raises:
        HarnessError: on malformed text or a negative or reversed range.
    """
    seeds: list[int] = []
    for part in (p.strip() for p in text.split(",")):
        try:
            if "-" in part:
                lo_text, hi_text = part.split("-", 1)
                lo, hi = int(lo_text), int(hi_text)
                if lo > hi:
                    raise HarnessError(f"seed range {part!r} is reversed")
                seeds.extend(range(lo, hi + 1))
            else:
                seeds.append(int(part))
        except ValueError:
            raise HarnessError(f"seeds: cannot read {part!r} in {text!r}; use e.g. 0-9 or 0,3,5") from None
    if any(s < 0 for s in seeds):
        raise HarnessError(f"seeds must be >= 0, got {text!r}")
    return tuple(dict.fromkeys(seeds))


# --------------------------------------------------------------------------------------------------
# Rows
# --------------------------------------------------------------------------------------------------

#: Record keys dropped from rows (bulky; the trajectory file keeps what plots need).
_DROPPED_KEYS = ("trajectory_xy", "memory_snapshot", "events", "decisions", "found_objects")


def flatten_record(record: Mapping[str, Any]) -> dict[str, Any]:
    """The runner's record as a JSONL row: decisions reduced, events counted, bulky parts dropped."""
    row = {k: v for k, v in record.items() if k not in _DROPPED_KEYS}
    row["decisions"] = [
        {
            "stamp_s": d.get("stamp_s"),
            "selected_node_id": d.get("selected_node_id"),
            "oracle_node_id": d.get("oracle_node_id"),
            "n_candidates": len(d.get("candidates", ())),
            "reason": d.get("reason"),
        }
        for d in record.get("decisions", ())
    ]
    counts: dict[str, int] = {}
    for event in record.get("events", ()):
        kind = str(event.get("kind", "?"))
        counts[kind] = counts.get(kind, 0) + 1
    row["event_counts"] = counts
    row["found_labels"] = [f.get("label") for f in record.get("found_objects", ())]
    return row


def to_episode_record(row: Mapping[str, Any]) -> EpisodeRecord:
    """The runner's record (or a row of it) as a :class:`~semexp_bt.core.metrics.EpisodeRecord`.

    The metrics follow the paper's definitions on the final base position: ``goal_position_m`` is put
    at the record's ``distance_to_goal_m`` (distance from the final position to the goal object's
    footprint) along the line to the goal's centre, so ``||P - G||`` is exactly that distance.
    Decision steps without an oracle node (no reachable candidate) are not GNSA steps; a step with
    candidates but no selected node counts as a miss (``selected_node_id = -1``).

    Raises:
        HarnessError: naming the missing key.
    """
    try:
        final = row["final_pose"]
        final_xy = (float(final["x_m"]), float(final["y_m"]))
        centre = row["goal"]["position_m"]
        distance = float(row["distance_to_goal_m"])
        dx, dy = float(centre[0]) - final_xy[0], float(centre[1]) - final_xy[1]
        norm = math.hypot(dx, dy)
        goal_xy = (
            final_xy
            if norm < 1e-12
            else (final_xy[0] + dx / norm * distance, final_xy[1] + dy / norm * distance)
        )
        steps = [
            {"selected_node_id": -1 if d["selected_node_id"] is None else int(d["selected_node_id"]),
             "oracle_node_id": int(d["oracle_node_id"])}
            for d in row.get("decisions", ())
            if d.get("oracle_node_id") is not None
        ]  # fmt: skip
        return EpisodeRecord(
            scene=str(row["scene"]),
            seed=int(row["seed"]),
            strategy=str(row["strategy"]),
            success_declared=bool(row["success_declared"]),
            final_position_m=final_xy,
            goal_position_m=goal_xy,
            goal_category=str(row["goal_category"]),
            reached_category=row.get("reached_category"),
            path_length_m=float(row["path_length_m"]),
            geodesic_length_m=float(row["geodesic_length_m"]),
            collision=bool(row["collision"]),
            decisions=steps,  # type: ignore[arg-type]
        )
    except KeyError as exc:
        where = f"{row.get('scene')}/{row.get('seed')}/{row.get('strategy')}"
        raise HarnessError(f"episode row {where}: missing key {exc.args[0]!r}") from None


def load_rows(out_dir: Path, *, stream: TextIO | None = None) -> list[dict[str, Any]]:
    """Rows of ``out_dir/episodes.jsonl``, the newest per key, in file order of that newest row.

    A torn last line (the sweep was killed mid-write) is skipped with a warning on ``stream``.
    """
    path = Path(out_dir) / EPISODES_FILE
    if not path.is_file():
        return []
    latest: dict[str, dict[str, Any]] = {}
    lines = path.read_text().splitlines()
    for number, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        try:
            row = json.loads(line)
        except json.JSONDecodeError:
            print(f"warning: {path}:{number}: unreadable row skipped", file=stream or sys.stderr)
            continue
        latest.pop(row["key"], None)  # re-insert so order follows the newest row
        latest[row["key"]] = row
    return list(latest.values())


def _failure_row(task: EpisodeTask, status: str, message: str, wall_s: float) -> dict[str, Any]:
    return {"status": status, "error": message, "harness_wall_s": round(wall_s, 3),
            "scene": task.key.scene, "seed": task.key.seed, "strategy": task.key.strategy,
            "fidelity": task.key.fidelity}  # fmt: skip


def _with_key(row: dict[str, Any], task: EpisodeTask) -> dict[str, Any]:
    return {"key": task.key.id, "config_hash": task.key.config_hash, "relevance": task.relevance, **row}


# --------------------------------------------------------------------------------------------------
# Running one episode (inside a worker)
# --------------------------------------------------------------------------------------------------


#: Thread-pool sizes of native libraries, read once when each library loads.
ONE_THREAD_ENV = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}


def _limit_native_threads() -> None:
    """One thread per native library in this process and those it spawns, unless the user chose."""
    for var, value in ONE_THREAD_ENV.items():
        os.environ.setdefault(var, value)


def prepare_worker() -> None:
    """Per-process settings: headless MuJoCo and one BLAS/torch thread (the cores belong to the pool).

    The BLAS variables only take effect in a process that has not loaded numpy yet: a spawned pool worker
    imports numpy before it runs this initializer, so :func:`_new_pool` sets them before spawning.
    """
    os.environ.setdefault("MUJOCO_GL", "egl")
    _limit_native_threads()
    # Model-loading progress bars would interleave with the sweep's own progress lines.
    for var, value in (
        ("TQDM_DISABLE", "1"),
        ("HF_HUB_DISABLE_PROGRESS_BARS", "1"),
        ("TRANSFORMERS_VERBOSITY", "error"),
    ):
        os.environ.setdefault(var, value)
    if "torch" in sys.modules:
        sys.modules["torch"].set_num_threads(1)


def run_real_episode(task: EpisodeTask) -> dict[str, Any]:
    """Run one episode with :func:`semexp_bt.app.episode.run_episode` (the default run function)."""
    if task.relevance == "embedding":
        import torch

        torch.set_num_threads(1)
    from semexp_bt.app.episode import EpisodeOptions, run_episode

    return run_episode(
        EpisodeOptions(
            mission_path=Path(task.mission_path),
            scene=task.key.scene,
            seed=task.key.seed,
            fidelity=task.key.fidelity,
            strategy=task.key.strategy,
            relevance=task.relevance,
            config_overrides=dict(task.config_overrides) or None,
            success_radius_m=task.success_radius_m,
            clearance_m=task.clearance_m,
            max_sim_s=task.max_sim_s,
            keep_trajectory=task.keep_trajectory,
        )
    )


@contextmanager
def _wall_time_limit(seconds: float) -> Iterator[None]:
    """Raise :class:`EpisodeTimeout` in this thread after ``seconds`` (main thread on POSIX only)."""
    usable = hasattr(signal, "setitimer") and threading.current_thread() is threading.main_thread()
    if not usable:
        yield
        return

    def _expire(signum: int, frame: Any) -> None:
        raise EpisodeTimeout(f"episode exceeded its wall-time limit of {seconds:.0f} s")

    previous = signal.signal(signal.SIGALRM, _expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)


def execute_task(task: EpisodeTask, run_fn: RunFunction) -> dict[str, Any]:
    """Run one episode and return its row (never raises for a failing episode)."""
    prepare_worker()
    start = time.perf_counter()
    try:
        with _wall_time_limit(task.timeout_s):
            record = run_fn(task)
        row = {"status": STATUS_OK, **flatten_record(record)}
        for bulky in ("trajectory_xy", "memory_snapshot"):
            if bulky in record:
                row.setdefault("_extras", {})[bulky] = record[bulky]
        if record.get("goal") is not None and "_extras" in row:
            row["_extras"]["goal"] = record["goal"]
    except EpisodeTimeout as exc:
        row = _failure_row(task, STATUS_TIMEOUT, str(exc), time.perf_counter() - start)
    except Exception:
        row = _failure_row(task, STATUS_ERROR, traceback.format_exc(), time.perf_counter() - start)
    row["harness_wall_s"] = round(time.perf_counter() - start, 3)
    return _with_key(row, task)


# --------------------------------------------------------------------------------------------------
# The sweep (parent process)
# --------------------------------------------------------------------------------------------------


@dataclass
class SweepResult:
    """What a sweep did.

    Attributes:
        out_dir: the output folder.
        total: episodes in the grid.
        skipped: episodes that already had a row.
        ran: episodes run now.
        errors: of those, rows with status ``error``.
        timeouts: of those, rows with status ``timeout``.
        wall_s: wall time of this call.
    """

    out_dir: Path
    total: int
    skipped: int
    ran: int = 0
    errors: int = 0
    timeouts: int = 0
    wall_s: float = 0.0


class Progress:
    """Progress lines on a stream: done/total, failures, episodes per hour, ETA."""

    def __init__(self, *, total: int, already_done: int, stream: TextIO | None) -> None:
        self.total = total
        self.done = already_done
        self.ran = 0
        self.failed = 0
        self.start = time.monotonic()
        self.stream = stream

    def update(self, row: Mapping[str, Any]) -> None:
        self.done += 1
        self.ran += 1
        self.failed += row.get("status") != STATUS_OK
        if self.stream is None:
            return
        elapsed = max(time.monotonic() - self.start, 1e-9)
        rate_h = self.ran / elapsed * 3600.0
        remaining = self.total - self.done
        eta = remaining / (self.ran / elapsed) if self.ran else math.inf
        outcome = row.get("outcome") if row.get("status") == STATUS_OK else row.get("status")
        print(
            f"[sweep] {self.done}/{self.total} done ({self.failed} failed) | {rate_h:.0f} episodes/h"
            f" | ETA {_format_duration(eta)} | {row.get('scene')}/{row.get('seed')}/{row.get('strategy')}:"
            f" {outcome} in {row.get('harness_wall_s', 0):.1f} s",
            file=self.stream,
            flush=True,
        )


def _format_duration(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "?"
    seconds = int(round(seconds))
    hours, rest = divmod(seconds, 3600)
    return f"{hours}h{rest // 60:02d}m" if hours else f"{rest // 60}m{rest % 60:02d}s"


class _RowWriter:
    """Appends rows to ``episodes.jsonl`` (parent only) and trajectories to their own files."""

    def __init__(self, out_dir: Path) -> None:
        self.out_dir = out_dir
        self.path = out_dir / EPISODES_FILE
        self.file = self.path.open("a", encoding="utf-8")

    def write(self, row: dict[str, Any]) -> dict[str, Any]:
        extras = row.pop("_extras", None)
        if extras:
            folder = self.out_dir / TRAJECTORY_DIR
            folder.mkdir(exist_ok=True)
            name = row["key"].replace("/", "__") + ".json"
            payload = {"key": row["key"], "scene": row.get("scene"), "seed": row.get("seed"),
                       "strategy": row.get("strategy"), "outcome": row.get("outcome"),
                       "success": row.get("success"), "start_pose": row.get("start_pose"),
                       "final_pose": row.get("final_pose"), **extras}  # fmt: skip
            (folder / name).write_text(json.dumps(payload, separators=(",", ":")))
            row["trajectory_file"] = f"{TRAJECTORY_DIR}/{name}"
        self.file.write(json.dumps(row, separators=(",", ":"), default=_json_default) + "\n")
        self.file.flush()
        os.fsync(self.file.fileno())
        return row

    def close(self) -> None:
        self.file.close()


def _json_default(value: Any) -> Any:
    if hasattr(value, "tolist"):
        return value.tolist()
    if hasattr(value, "item"):
        return value.item()
    return str(value)


def run_sweep(
    spec: SweepSpec | Sequence[SweepSpec],
    out_dir: Path,
    *,
    workers: int = 1,
    run_fn: RunFunction = run_real_episode,
    ray_address: str | None = None,
    retry_failed: bool = False,
    progress: TextIO | None = sys.stderr,
    check_names: bool = True,
) -> SweepResult:
    """Run every episode of ``spec`` that ``out_dir`` does not hold yet.

    Args:
        spec: the grid, or several grids run as one (episodes with the same key run once).
        out_dir: output folder (created); rows go to ``episodes.jsonl``.
        workers: parallel worker processes (0: run in this process, for debugging).
        run_fn: runs one episode; a module-level function (picklable by name).
        ray_address: run on a Ray cluster (``auto`` or ``ray://host:10001``) instead of local processes.
        retry_failed: rerun keys whose row is ``error`` or ``timeout``.
        progress: where progress lines go (None: silent).
        check_names: validate scene and strategy names against the catalogues first.

    Returns:
        A :class:`SweepResult`.

    Raises:
        HarnessError: on unknown names, a negative worker count, or Ray missing.
    """
    if workers < 0:
        raise HarnessError(f"workers must be >= 0, got {workers}")
    specs = [spec] if isinstance(spec, SweepSpec) else list(spec)
    if not specs:
        raise HarnessError("run_sweep: no sweep given")
    if check_names:
        for one in specs:
            validate_names(one)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    started = time.monotonic()
    unique: dict[str, EpisodeTask] = {}
    for one in specs:
        for task in one.tasks():
            previous = unique.get(task.key.id)
            if previous is None or (task.keep_trajectory and not previous.keep_trajectory):
                unique[task.key.id] = task
    tasks = list(unique.values())
    existing = {row["key"]: row for row in load_rows(out_dir, stream=progress)}
    todo = [
        t for t in tasks
        if t.key.id not in existing or (retry_failed and existing[t.key.id].get("status") != STATUS_OK)
    ]  # fmt: skip
    result = SweepResult(out_dir=out_dir, total=len(tasks), skipped=len(tasks) - len(todo))
    revision = _git_revision()
    _write_meta(out_dir, specs, workers=workers, ray_address=ray_address, revision=revision)
    if progress is not None:
        print(f"[sweep] {len(tasks)} episodes, {result.skipped} already done, {len(todo)} to run"
              f" on {'ray ' + ray_address if ray_address else f'{workers} worker(s)'} -> {out_dir}",
              file=progress, flush=True)  # fmt: skip
    meter = Progress(total=len(tasks), already_done=result.skipped, stream=progress)
    writer = _RowWriter(out_dir)

    def accept(row: dict[str, Any]) -> None:
        writer.write(row)
        meter.update(row)
        result.ran += 1
        result.errors += row["status"] == STATUS_ERROR
        result.timeouts += row["status"] == STATUS_TIMEOUT

    started_unix_s = time.time()
    completed = False
    try:
        if not todo:
            pass
        elif ray_address is not None:
            _run_ray(todo, run_fn=run_fn, address=ray_address, workers=workers, accept=accept)
        elif workers == 0:
            for task in todo:
                accept(execute_task(task, run_fn))
        else:
            _run_pool(todo, run_fn=run_fn, workers=workers, accept=accept)
        completed = True
    finally:
        writer.close()
        result.wall_s = time.monotonic() - started
        # Also on Ctrl-C or SIGTERM (the CLI turns it into an exception): a stopped invocation's wall
        # time still counts towards the sweep's.
        _log_invocation(out_dir, result, started_unix_s=started_unix_s, workers=workers,
                        ray_address=ray_address, completed=completed, revision=revision)  # fmt: skip
    return result


def _log_invocation(out_dir: Path, result: SweepResult, *, started_unix_s: float, workers: int,
                    ray_address: str | None, completed: bool, revision: str | None) -> None:  # fmt: skip
    record = {
        "started_unix_s": round(started_unix_s, 1),
        "wall_s": round(result.wall_s, 1),
        "ran": result.ran,
        "skipped": result.skipped,
        "total": result.total,
        "errors": result.errors,
        "timeouts": result.timeouts,
        "workers": workers,
        "ray_address": ray_address,
        "completed": completed,
        "git_revision": revision,
    }
    with (out_dir / INVOCATIONS_FILE).open("a", encoding="utf-8") as log:
        log.write(json.dumps(record, separators=(",", ":")) + "\n")


def load_invocations(out_dir: Path) -> list[dict[str, Any]]:
    """The lines of ``DIR/invocations.jsonl`` (empty when the folder has none).

    Raises:
        HarnessError: naming the file and line of a line that is not a JSON object with a ``wall_s``.
    """
    path = Path(out_dir) / INVOCATIONS_FILE
    if not path.is_file():
        return []
    records = []
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        if not line.strip():
            continue
        try:
            record = json.loads(line)
        except json.JSONDecodeError as exc:
            raise HarnessError(f"{path}:{number}: not JSON ({exc.msg})") from exc
        if not isinstance(record, dict) or not isinstance(record.get("wall_s"), (int, float)):
            raise HarnessError(f"{path}:{number}: expected an object with a numeric 'wall_s'")
        records.append(record)
    return records


def _write_meta(
    out_dir: Path, specs: Sequence[SweepSpec], *, workers: int, ray_address: str | None, revision: str | None
) -> None:
    """``sweep.json``: the last specs run here, the machine and the code revision (not part of keys)."""
    meta = {
        "specs": [
            {k: (str(v) if isinstance(v, Path) else v) for k, v in asdict(one).items()} for one in specs
        ],
        "workers": workers,
        "ray_address": ray_address,
        "cpu_count": os.cpu_count(),
        "python": sys.version.split()[0],
        "git_revision": revision,
        "written_unix_s": round(time.time(), 1),
    }
    (out_dir / SWEEP_META_FILE).write_text(json.dumps(meta, indent=1, default=str) + "\n")


def _git_revision() -> str | None:
    try:
        out = subprocess.run(["git", "describe", "--always", "--dirty"], cwd=Path(__file__).resolve().parents[2],
                             capture_output=True, text=True, timeout=10)  # fmt: skip
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() or None


def _new_pool(workers: int) -> ProcessPoolExecutor:
    # A worker's OpenBLAS would otherwise start one thread per core, and with one worker per core the
    # workers' BLAS threads compete for the same cores. Spawned children inherit this environment.
    _limit_native_threads()
    # spawn, not fork: MuJoCo's GL contexts and torch's thread pools do not survive a fork.
    return ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
                               initializer=prepare_worker)  # fmt: skip


def _kill_pool(pool: ProcessPoolExecutor) -> None:
    """Kill a pool whose worker hangs. ProcessPoolExecutor has no public kill; its process table is a
    CPython detail, so this degrades to a plain shutdown where the table is absent."""
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        if process.is_alive():
            process.kill()
    pool.shutdown(wait=False, cancel_futures=True)


def _run_pool(todo: list[EpisodeTask], *, run_fn: RunFunction, workers: int,
              accept: Callable[[dict[str, Any]], None]) -> None:  # fmt: skip
    """Local processes, at most ``workers`` episodes in flight (so a submit time is a start time)."""
    queue = list(reversed(todo))  # pop() from the end keeps the grid order
    deaths: dict[str, int] = {}
    pool = _new_pool(workers)
    in_flight: dict[Future[dict[str, Any]], tuple[EpisodeTask, float]] = {}
    try:
        while queue or in_flight:
            while queue and len(in_flight) < workers:
                task = queue.pop()
                in_flight[pool.submit(execute_task, task, run_fn)] = (task, time.monotonic())
            done, _ = wait(list(in_flight), timeout=POLL_S, return_when=FIRST_COMPLETED)
            broken = False
            for future in done:
                task, _ = in_flight.pop(future)
                try:
                    accept(future.result())
                except BrokenProcessPool:
                    broken = True
                    deaths[task.key.id] = deaths.get(task.key.id, 0) + 1
                    if deaths[task.key.id] >= MAX_WORKER_DEATHS:
                        accept(_with_key(_failure_row(task, STATUS_ERROR, "worker process died (native crash?) "
                                                      f"{deaths[task.key.id]} times", 0.0), task))  # fmt: skip
                    else:
                        queue.append(task)
            now = time.monotonic()
            overdue = [f for f, (t, t0) in in_flight.items() if now - t0 > t.timeout_s + HARD_KILL_GRACE_S]
            if overdue or broken:
                for future in overdue:
                    task, t0 = in_flight.pop(future)
                    accept(_with_key(_failure_row(task, STATUS_TIMEOUT, "killed by the harness: no answer "
                                                  f"{now - t0:.0f} s after start", now - t0), task))  # fmt: skip
                # Restart the pool; the other episodes in flight start again from scratch.
                queue.extend(t for t, _ in in_flight.values())
                in_flight.clear()
                _kill_pool(pool)
                pool = _new_pool(workers)
    finally:
        if in_flight:
            _kill_pool(pool)
        else:
            pool.shutdown(wait=True)


def _run_ray(todo: list[EpisodeTask], *, run_fn: RunFunction, address: str, workers: int,
             accept: Callable[[dict[str, Any]], None]) -> None:  # fmt: skip
    """Ray tasks, one CPU each; ``workers`` caps the episodes in flight (0: the cluster's CPUs)."""
    require_ray_head_answers(address)  # seconds cheaper than importing Ray, and it cannot hang
    ray = _import_ray_for(address)
    ray.init(address=address, ignore_reinit_error=True, log_to_driver=False)
    limit = workers or max(1, int(ray.cluster_resources().get("CPU", 1)))
    remote = ray.remote(num_cpus=1, max_retries=0)(execute_task)
    queue = list(reversed(todo))
    in_flight: dict[Any, tuple[EpisodeTask, float]] = {}
    while queue or in_flight:
        while queue and len(in_flight) < limit:
            task = queue.pop()
            in_flight[remote.remote(task, run_fn)] = (task, time.monotonic())
        ready, _ = ray.wait(list(in_flight), num_returns=1, timeout=POLL_S)
        for ref in ready:
            task, t0 = in_flight.pop(ref)
            try:
                accept(ray.get(ref))
            except Exception:  # a dead Ray worker or node: the episode is an error, the sweep goes on
                accept(_with_key(_failure_row(task, STATUS_ERROR, traceback.format_exc(),
                                              time.monotonic() - t0), task))  # fmt: skip
        now = time.monotonic()
        for ref, (task, t0) in list(in_flight.items()):
            if now - t0 > task.timeout_s + HARD_KILL_GRACE_S:
                ray.cancel(ref, force=True)
                in_flight.pop(ref)
                accept(_with_key(_failure_row(task, STATUS_TIMEOUT, f"cancelled by the harness after {now - t0:.0f} s",
                                              now - t0), task))  # fmt: skip


def require_ray_head_answers(address: str, *, timeout_s: float = RAY_CONNECT_TIMEOUT_S) -> None:
    """Refuse a ``host:port`` address where nothing accepts a TCP connection.

    ``ray.init`` retries an unreachable head without end (seen with Ray 2.60), so a mistyped address
    would hang the sweep. ``auto`` and ``ray://`` (Ray Client) addresses are left to Ray.

    Raises:
        HarnessError: naming the address, when the connection is refused or times out.
    """
    if address == "auto" or address.startswith("ray://"):
        return
    host, port = _host_and_port(address)
    if not host or not port.isdigit():
        raise HarnessError(f"--ray-address {address!r}: expected 'auto', 'ray://host:port' or 'host:port'")
    try:
        with socket.create_connection((host, int(port)), timeout=timeout_s):
            pass
    except OSError as exc:
        raise HarnessError(
            f"--ray-address {address}: no Ray head answers there ({exc.strerror or exc}); start one with "
            "'ray start --head' or give the address it printed"
        ) from None


def _host_and_port(address: str) -> tuple[str, str]:
    """``[ray://]host:port`` -> (host without IPv6 brackets, port text)."""
    host, _, port = address.removeprefix("ray://").rpartition(":")
    return host.strip("[]"), port


def _is_loopback(address: str) -> bool:
    return _host_and_port(address)[0] in ("127.0.0.1", "localhost", "::1")


def _import_ray_for(address: str) -> Any:
    """Import Ray so that it can reach ``address``.

    Ray swaps a loopback address for the machine's routable one before it connects, and then waits for a
    head that a loopback-only cluster (docs/harness.md) does not serve there. Its switch for keeping
    loopback, ``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0``, is read once, when Ray is first imported.
    """
    loopback = _is_loopback(address)
    if loopback and "ray" not in sys.modules:
        os.environ.setdefault(RAY_LOOPBACK_SWITCH, "0")
    try:
        import ray  # type: ignore[import-not-found]
    except ImportError:
        raise HarnessError(
            "--ray-address needs Ray, which is not installed: pip install -e '.[cluster]'"
        ) from None
    constants = getattr(getattr(ray, "_private", None), "ray_constants", None)
    if loopback and getattr(constants, "ENABLE_RAY_CLUSTER", False):
        raise HarnessError(
            f"--ray-address {address} is on loopback, but Ray was imported before {RAY_LOOPBACK_SWITCH}=0 was "
            "set: set it in the environment, or give the address that 'ray start' printed"
        )
    return ray


def summarize_rows(rows: Sequence[Mapping[str, Any]]) -> dict[str, int]:
    """Counts of rows by status."""
    counts: dict[str, int] = {}
    for row in rows:
        counts[str(row.get("status"))] = counts.get(str(row.get("status")), 0) + 1
    return counts


# --------------------------------------------------------------------------------------------------
# The paper's protocol (Sec. IV): which grids regenerate Tables I-V
# --------------------------------------------------------------------------------------------------

#: The paper's five simulation scenes (Tables I and II) and the analogues of its five real scenes.
SIM_SCENES = ("garden_sim", "sidewalk", "road", "warehouse_a", "warehouse_b")
REAL_SCENES = ("office", "showroom", "laboratory", "living_room", "garden_real")
TABLE_I_STRATEGIES = ("vlm_only", "detector_only", "yolo_world", "naive_fusion", "ours")
TABLE_II_STRATEGIES = ("bayesian", "llm_relevance", "vlfm", "hovsg", "ours")
TABLE_III_REFERENCES = ("nearest_frontier", "oracle")
TABLE_IV_STRATEGIES = ("ablation_baseline", "ablation_arbitration", "ours")
#: The smoke protocol: two small scenes, one seed, two strategies.
SMOKE_SCENES = ("office", "laboratory")
SMOKE_STRATEGIES = ("ours", "nearest_frontier")


@dataclass(frozen=True)
class PaperProtocol:
    """Trial counts of the paper protocol (``semexp-bt bench paper``).

    Table III keeps the paper's 20 trials per scene. The paper does not give trial counts for Tables I,
    II and IV; ours are chosen so that the whole protocol in kinematic fidelity fits 2 hours on 2 cores
    (``docs/harness.md`` shows the arithmetic). Seeds are ``0..n-1`` everywhere, so the ``ours``
    episodes of Tables I, II and IV are a subset of Table III's and run once.

    Attributes:
        trials_table_iii: trials per scene for ``ours`` over the ten scenes.
        trials_evidence: trials per sim scene for each Table I baseline.
        trials_decision: trials per sim scene for each Table II baseline.
        trials_ablation: trials per sim scene for each Table IV ablation.
        trials_reference: trials per scene (ten scenes) for nearest frontier and the oracle.
    """

    trials_table_iii: int = 20
    trials_evidence: int = 2
    trials_decision: int = 2
    trials_ablation: int = 2
    trials_reference: int = 1

    def specs(self, **common: Any) -> list[SweepSpec]:
        """The protocol's grids; ``common`` goes to every :class:`SweepSpec` (fidelity, relevance, ...)."""

        def grid(scenes: tuple[str, ...], strategies: tuple[str, ...], trials: int) -> SweepSpec:
            return SweepSpec(scenes=scenes, seeds=tuple(range(trials)), strategies=strategies, **common)

        everywhere = SIM_SCENES + REAL_SCENES
        specs = [grid(everywhere, ("ours",), self.trials_table_iii)]
        for strategies, trials, scenes in (
            (TABLE_I_STRATEGIES[:-1], self.trials_evidence, SIM_SCENES),
            (TABLE_II_STRATEGIES[:-1], self.trials_decision, SIM_SCENES),
            (TABLE_IV_STRATEGIES[:-1], self.trials_ablation, SIM_SCENES),
            (TABLE_III_REFERENCES, self.trials_reference, everywhere),
        ):
            if trials > 0:
                specs.append(grid(scenes, strategies, trials))
        return specs

    def episode_count(self) -> int:
        """Distinct episodes of the protocol."""
        keys = {(t.key.scene, t.key.seed, t.key.strategy) for s in self.specs() for t in s.tasks()}
        return len(keys)


#: Simulated-time cap of the smoke protocol (s): it checks the pipeline end to end, not the results.
SMOKE_MAX_SIM_S = 60.0


def smoke_specs(**common: Any) -> list[SweepSpec]:
    """The smoke grid of ``semexp-bt bench paper --smoke`` (simulated time capped at :data:`SMOKE_MAX_SIM_S`)."""
    common.setdefault("max_sim_s", SMOKE_MAX_SIM_S)
    return [SweepSpec(scenes=SMOKE_SCENES, seeds=(0,), strategies=SMOKE_STRATEGIES, **common)]
