"""Named strategies: the paper's method and its baselines as configurations of the same tree.

A strategy changes which perception sources run, hyperparameter overrides of the method, and named
switches a behaviour reads (``services.strategy``); it never forks the tree. The evidence strategies
follow the paper's Table I, the decision strategies its Table II, the ablation its Table IV. They are
data, in ``strategies.yaml`` next to this module; this module reads and checks it once.

Example:
    >>> resolve_strategy("detector_only").switches["evidence"]
    'detector_only'
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import yaml

#: The strategies' data.
STRATEGIES_FILE = Path(__file__).with_name("strategies.yaml")


@dataclass(frozen=True)
class Strategy:
    """One strategy.

    Attributes:
        name: its key.
        description: one line for reports.
        enable_vlm: run the scene-level source.
        enable_detector: run the object-level source.
        detector_profile: which emulated detector (``detector`` = GroundingDINO-like,
            ``detector_yolo_world``).
        config_overrides: SemExpConfig overrides (nested mapping); the ``config:`` of its entry.
        switches: named switches for behaviours (``evidence``, ``decision``, ``perception``).
    """

    name: str
    description: str
    enable_vlm: bool = True
    enable_detector: bool = True
    detector_profile: str = "detector"
    config_overrides: dict[str, Any] = field(default_factory=dict)
    switches: dict[str, str] = field(default_factory=dict)


#: Keys a strategy's entry may hold, and the Strategy field each fills.
_ENTRY_FIELDS = {"description": "description", "enable_vlm": "enable_vlm",
                 "enable_detector": "enable_detector", "detector_profile": "detector_profile",
                 "config": "config_overrides", "switches": "switches"}  # fmt: skip


def _strategy(name: str, entry: Any, where: Path) -> Strategy:
    if not isinstance(entry, dict):
        raise ValueError(f"{where}: strategy '{name}' must be a mapping, got {type(entry).__name__}")
    unknown = sorted(set(entry) - set(_ENTRY_FIELDS))
    if unknown:
        raise ValueError(
            f"{where}: strategy '{name}' has unknown keys {unknown}; expected {sorted(_ENTRY_FIELDS)}"
        )
    values = {_ENTRY_FIELDS[key]: value for key, value in entry.items()}
    types = {f.name: f.type for f in fields(Strategy)}
    for key, value in values.items():
        expected = {"bool": bool, "str": str}.get(str(types[key]), dict)
        if not isinstance(value, expected):
            raise ValueError(
                f"{where}: strategy '{name}': '{key}' must be {expected.__name__}, got {value!r}"
            )
    return Strategy(name=name, **values)


@functools.cache
def load_strategies(path: Path = STRATEGIES_FILE) -> dict[str, Strategy]:
    """Every strategy in ``path``, by name, in file order.

    Raises:
        ValueError: naming the file and the strategy when an entry is malformed.
    """
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    entries = data.get("strategies") if isinstance(data, dict) else None
    if not isinstance(entries, dict) or not entries:
        raise ValueError(f"{path}: expected a non-empty 'strategies:' mapping")
    return {name: _strategy(name, entry, path) for name, entry in entries.items()}


#: Every strategy by name.
STRATEGIES: dict[str, Strategy] = load_strategies()


def resolve_strategy(name: str) -> Strategy:
    """The strategy called ``name``; a clear error listing the known ones otherwise."""
    try:
        return STRATEGIES[name]
    except KeyError:
        raise ValueError(f"unknown strategy {name!r}; expected one of {sorted(STRATEGIES)}") from None
