"""One typed configuration for every hyperparameter of the paper (Sec. III-C to III-E).

The paper names its hyperparameters but does not publish their values; the defaults below are ours,
chosen for the simulated scenes and documented in ``docs/config.md``. :func:`config_from_dict` builds
a config from nested overrides; an unknown key, a wrong type or an out-of-range value raises
:class:`ConfigError` naming the source, the key path and what was expected. Which overrides apply, and in
which order, is the application's business (``semexp_bt.app.configuration``).

This is a core module: standard library only.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal, get_args, get_origin, get_type_hints

from semexp_bt.core.bounds import Interval, field_interval, field_range


class ConfigError(ValueError):
    """A configuration value is unknown, of the wrong type, or out of range."""


@dataclass(frozen=True)
class ArbitrationConfig:
    """Evidence arbitration, Eq. 1-4."""

    tau: float = field(default=0.25, metadata=field_range(0.0, 1.0, high_open=True))
    """Calibration threshold of Eq. 1: confidences at or below tau calibrate to 0."""
    beta_o: float = field(default=1.0, metadata=field_range(0.0, 10.0))
    """Exponent of the calibrated object confidence in Eq. 2 and Eq. 4."""
    beta_s: float = field(default=1.0, metadata=field_range(0.0, 10.0))
    """Exponent of the calibrated scene confidence in Eq. 2 and Eq. 4."""
    lambda_iou: float = field(default=0.5, metadata=field_range(0.0, 10.0))
    """Exponent lambda of the spatial-consistency term (IoU + epsilon) in Eq. 2."""
    mu: float = field(default=1.0, metadata=field_range(0.0, 10.0))
    """Exponent mu of the depth-feasibility term (kappa + epsilon) in Eq. 2."""
    epsilon: float = field(default=1e-3, metadata=field_range(0.0, 0.1, low_open=True))
    """Numerical-stability constant of Eq. 2."""
    scene_region_half_size_px: float = field(default=40.0, metadata=field_range(1.0, 1000.0))
    """Half side of the square scene region built around a VLM point that comes without a box."""
    direction_prior: float = field(default=0.25, metadata=field_range(0.0, 1.0))
    """P(t) of an unexplored-direction candidate in Eq. 2 (object candidates have P = 1): a direction
    is where to look, not the target, and should win only when no object evidence is worth more."""
    cross_source_consistency: bool = True
    """When both sources answered for a view, an object candidate one of them did not corroborate is
    scored as spatially inconsistent (IoU = unsupported_iou) instead of dropping the term; see
    docs/arbitration.md. False gives the literal per-candidate omission."""
    unsupported_iou: float = field(default=0.05, metadata=field_range(0.0, 1.0))
    """The IoU an uncorroborated object candidate gets in the consistency term."""
    depth_min_m: float = field(default=0.3, metadata=field_range(0.0, 100.0))
    """Nearest valid depth for kappa (D435i minimum range)."""
    depth_max_m: float = field(default=10.0, metadata=field_range(0.1, 100.0))
    """Farthest valid depth for kappa (D435i useful range)."""
    depth_patch_px: int = field(default=5, metadata=field_range(1, 101))
    """Side of the pixel patch around the target pixel whose median depth is the target depth."""
    occluder_margin_m: float = field(default=0.3, metadata=field_range(0.0, 10.0))
    """kappa penalises a target when depth along the ray is closer than the target by this margin."""


@dataclass(frozen=True)
class MemoryConfig:
    """Controlled-growth topological memory, Eq. 5-7 and maintenance."""

    delta_d: float = field(default=0.75, metadata=field_range(0.01, 100.0))
    """Insertion distance gate (m): a candidate closer than this to its nearest node merges into it."""
    cf_gate: float = field(default=0.3, metadata=field_range(0.0, 1.0))
    """Insertion confidence gate: C_f must exceed it for a new node."""
    rho: float = field(default=0.3, metadata=field_range(0.0, 1.0, low_open=True))
    """EMA smoothing factor of Eq. 6, in (0, 1]."""
    delta_r: float = field(default=2.5, metadata=field_range(0.0, 100.0, low_open=True))
    """Edge radius (m): a new node connects to every node within delta_r ..."""
    k_nearest: int = field(default=3, metadata=field_range(1, 64))
    """... or, if none lies within delta_r, to its k nearest nodes."""
    xi: float = field(default=0.3, metadata=field_range(0.0, 1.0, low_open=True))
    """Exploration-potential decay rate of Eq. 7, in (0, 1]."""
    observe_radius_m: float = field(default=1.5, metadata=field_range(0.0, 100.0))
    """Nodes within this distance of the robot count as 'surroundings observed' and decay."""
    prune_potential: float = field(default=0.05, metadata=field_range(0.0, 1.0))
    """Pruning removes nodes whose potential is below this ..."""
    prune_confidence: float = field(default=0.2, metadata=field_range(0.0, 1.0))
    """... and whose fused confidence is below this (both must hold)."""
    merge_radius_m: float = field(default=1.0, metadata=field_range(0.0, 100.0))
    """Maintenance merges adjacent nodes with the same label closer than this."""
    maintenance_every: int = field(default=10, metadata=field_range(1, 1_000_000))
    """Run pruning/merging every this many updates."""
    max_nodes: int = field(default=5000, metadata=field_range(2, 10_000_000))
    """Hard cap: beyond it the lowest-value non-master node is evicted (a safety net; the gates bound
    the count for a bounded area long before it)."""


@dataclass(frozen=True)
class DecisionConfig:
    """Utility-driven subgoal decision, Eq. 8-10."""

    tau_p: float = field(default=0.2, metadata=field_range(0.0, 1.0))
    """Candidate filter of Eq. 8: nodes with potential below tau_p are not candidates."""
    alpha: float = field(default=1.0, metadata=field_range(0.0, 10.0))
    """Exponent of semantic relevance S_LLM in Eq. 9."""
    beta: float = field(default=0.5, metadata=field_range(0.0, 10.0))
    """Exponent of the node's fused confidence in Eq. 9."""
    eta: float = field(default=1.0, metadata=field_range(0.0, 10.0))
    """Exponent of exploration potential in Eq. 9."""
    gamma: float = field(default=0.15, metadata=field_range(0.0, 10.0))
    """Travel-cost rate (1/m) in Eq. 9."""
    travel_cost: Literal["graph", "euclidean", "costmap"] = "graph"
    """Travel cost d(P_robot, P_v): shortest path on the memory graph, straight-line distance, or the
    shortest way on the costmap (``GlobalPlanner.travel_distances``; the graph's where there is no costmap)."""
    relevance_floor: float = field(default=0.1, metadata=field_range(0.0, 1.0))
    """S is floored at this value in Eq. 9, so nodes whose label is unrelated to the instruction (an
    unexplored direction) keep exploration value; 0 gives the paper's literal product."""
    tie_tolerance: float = field(default=1e-9, metadata=field_range(0.0, 1.0))
    """Utilities within this relative tolerance are a tie, broken by the lower node id (reported)."""


@dataclass(frozen=True)
class SemExpConfig:
    """All hyperparameters of the method, grouped by paper section."""

    arbitration: ArbitrationConfig = field(default_factory=ArbitrationConfig)
    memory: MemoryConfig = field(default_factory=MemoryConfig)
    decision: DecisionConfig = field(default_factory=DecisionConfig)


def check_value(value: Any, ftype: Any, interval: Interval | None) -> tuple[Any, str | None]:
    """Check one value against a field's type and bounds.

    Args:
        value: the value to check.
        ftype: the field's type: a ``Literal``, ``bool``, ``int`` or ``float``; other types are not checked.
        interval: the field's bounds (:func:`semexp_bt.core.bounds.field_interval`), or None.

    Returns:
        ``(value, None)`` when valid (an int given for a float widened to float), else ``(value, problem)``
        with ``problem`` saying what was expected and what was given, e.g. ``must lie in [0.0, 1.0], got 2``.
    """
    if get_origin(ftype) is Literal:
        allowed = get_args(ftype)
        return value, (None if value in allowed else f"must be one of {list(allowed)}, got {value!r}")
    if ftype is bool:
        return value, (None if isinstance(value, bool) else f"must be a boolean, got {value!r}")
    if ftype is int:
        if isinstance(value, bool) or not isinstance(value, int):
            return value, f"must be an integer, got {value!r}"
    elif ftype is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return value, f"must be a number, got {value!r}"
        value = float(value)
        if not math.isfinite(value):
            return value, f"must be finite, got {value!r}"
    if interval is not None and not interval.contains(value):
        return value, f"must lie in {interval.notation()}, got {value!r}"
    return value, None


def field_problem(instance: Any) -> str | None:
    """The first field of a dataclass instance whose value breaks its type or bounds, as
    ``"name problem"`` (see :func:`check_value`); None when every field is valid.

    For a dataclass that validates itself in ``__post_init__`` (as ``PlannerConfig`` does), so that one
    built in code obeys the same rules as one read from YAML by :func:`config_from_dict`.
    """
    hints = get_type_hints(type(instance))
    for spec in dataclasses.fields(instance):
        _, problem = check_value(getattr(instance, spec.name), hints[spec.name], field_interval(spec))
        if problem is not None:
            return f"{spec.name} {problem}"
    return None


def config_from_dict(
    data: Any, *, cls: type = SemExpConfig, where: str = "<config>", prefix: str = ""
) -> Any:
    """Build a config dataclass from nested mappings, validating every key.

    Args:
        data: a mapping (possibly nested) of overrides; missing keys keep their defaults.
        cls: the dataclass to build.
        where: the source to name in errors (a file path).
        prefix: the dotted key path of ``data`` within the whole config.

    Raises:
        ConfigError: on an unknown key, a wrong type or an out-of-range value.
    """
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"{where}: '{prefix or '<root>'}' must be a mapping, got {type(data).__name__}")
    hints = get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    kwargs: dict[str, Any] = {}
    for key, value in data.items():
        path = f"{prefix}.{key}" if prefix else str(key)
        if key not in fields:
            raise ConfigError(f"{where}: unknown key '{path}'; expected one of {sorted(fields)}")
        ftype = hints[key]
        if dataclasses.is_dataclass(ftype):
            kwargs[key] = config_from_dict(value, cls=ftype, where=where, prefix=path)  # type: ignore[arg-type]
        else:
            kwargs[key], problem = check_value(value, ftype, field_interval(fields[key]))
            if problem is not None:
                raise ConfigError(f"{where}: key '{path}' {problem}")
    return cls(**kwargs)


def deep_merge(base: Mapping[str, Any], extra: Mapping[str, Any] | None) -> dict[str, Any]:
    """``base`` with ``extra`` laid over it: nested mappings merge key by key, anything else replaces.

    Neither argument is modified.

    Example:
        >>> deep_merge({"memory": {"xi": 0.3, "rho": 0.3}}, {"memory": {"xi": 0.5}})
        {'memory': {'xi': 0.5, 'rho': 0.3}}
    """
    out = dict(base)
    for key, value in (extra or {}).items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = deep_merge(out[key], value)
        else:
            out[key] = value
    return out
