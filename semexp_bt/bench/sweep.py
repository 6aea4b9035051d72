"""What a sweep is: a grid of episodes (:class:`SweepSpec`), each named by an :class:`EpisodeKey`.

A sweep is scenes x seeds x strategies with one fidelity, one relevance scorer, one mission tree and
optional config overrides. Each episode has a key ``scene/seed/strategy/fidelity/config_hash``; the
12-digit config hash covers everything else that can change the outcome (the mission tree and its
subtrees, the strategy's definition, the relevance scorer, the overrides, r_s, the clearance threshold,
the simulated-time cap and the row schema), so a key names one deterministic episode. Code changes are
not in the key: start a new output folder after changing the method (``sweep.json`` records the git
revision). The execution settings (workers, wall-time limit, which trajectories are kept) are not in it
either.

Example:
    >>> spec = SweepSpec(scenes=("office",), seeds=(0, 1), strategies=("ours",), relevance="lexical")
    >>> [t.key.id.split("/")[:3] for t in spec.tasks()]
    [['office', '0', 'ours'], ['office', '1', 'ours']]
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from robots.interface import FIDELITIES
from semexp_bt.app.components import RELEVANCE_SCORERS
from semexp_bt.core.metrics import DEFAULT_CLEARANCE_M, DEFAULT_SUCCESS_RADIUS_M

#: Bumped when the row format or the meaning of a key changes (it is part of the config hash).
ROW_SCHEMA_VERSION = 1
RELEVANCES = tuple(RELEVANCE_SCORERS)
#: Default wall-time limit per episode (s). A kinematic episode of the 600 s mission takes about 50 s
#: on one core of the development machine; ten times that means something is wrong.
DEFAULT_EPISODE_TIMEOUT_S = 600.0


class HarnessError(ValueError):
    """A sweep that cannot run as asked (bad grid, missing mission file, Ray missing, ...)."""


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
        instruction: the instruction, when the sweep overrides the mission's and the scene's.
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
    instruction: str | None = None


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
        instruction: every episode's instruction (the phrasing benchmark); None keeps the mission's and
            the scene's. It is part of the config hash only when set, so other sweeps keep their keys.
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
    instruction: str | None = None

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
        if self.instruction is not None:
            payload["instruction"] = self.instruction
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
                instruction=self.instruction,
            )
            for seed in self.seeds
            for scene in self.scenes
            for strategy in self.strategies
        ]


def unique_tasks(specs: list[SweepSpec]) -> list[EpisodeTask]:
    """The tasks of several grids, each key once (in first-seen order); a task that keeps its
    trajectory wins over one with the same key that does not."""
    unique: dict[str, EpisodeTask] = {}
    for one in specs:
        for task in one.tasks():
            previous = unique.get(task.key.id)
            if previous is None or (task.keep_trajectory and not previous.keep_trajectory):
                unique[task.key.id] = task
    return list(unique.values())


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
        except HarnessError:
            raise
        except ValueError:
            raise HarnessError(f"seeds: cannot read {part!r} in {text!r}; use e.g. 0-9 or 0,3,5") from None
    if any(s < 0 for s in seeds):
        raise HarnessError(f"seeds must be >= 0, got {text!r}")
    return tuple(dict.fromkeys(seeds))
