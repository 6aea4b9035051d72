"""Checks of what callers and snapshots hand the memory: each returns the value in the memory's own type
or raises :class:`~semexp_bt.core.types.InvalidInputError` naming the field, so nothing non-finite or out
of range ever enters the graph.

This is a core module: standard library and numpy only.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from semexp_bt.core.memory.spatial_index import Vec3
from semexp_bt.core.types import InvalidInputError, require_finite

_REAL_TYPES = (int, float, np.integer, np.floating)


def as_position(name: str, value: Any) -> Vec3:
    """Three finite numbers ``(x, y, z)`` in metres, as a tuple of floats."""
    if (
        isinstance(value, (tuple, list))
        and len(value) == 3
        and all(isinstance(v, _REAL_TYPES) for v in value)
    ):
        x, y, z = float(value[0]), float(value[1]), float(value[2])  # the hot path: no numpy round trip
        if math.isfinite(x) and math.isfinite(y) and math.isfinite(z):
            return (x, y, z)
        raise InvalidInputError(f"{name} must be finite, got {value!r}")
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{name} must be three numbers (x, y, z) in metres, got {value!r}") from exc
    if arr.shape != (3,):
        raise InvalidInputError(f"{name} must have shape (3,) (x, y, z in metres), got shape {arr.shape}")
    require_finite(name, arr)
    return (float(arr[0]), float(arr[1]), float(arr[2]))


def as_number(name: str, value: Any) -> float:
    """A finite real number (not a bool), as a float."""
    if isinstance(value, bool) or not isinstance(value, _REAL_TYPES):
        raise InvalidInputError(f"{name} must be a number, got {value!r}")
    number = float(value)
    if not math.isfinite(number):
        raise InvalidInputError(f"{name} must be finite, got {value!r}")
    return number


def as_unit(name: str, value: Any) -> float:
    """A finite number in [0, 1] (a confidence, a potential, a factor), as a float."""
    number = as_number(name, value)
    if not 0.0 <= number <= 1.0:
        raise InvalidInputError(f"{name} must lie in [0, 1], got {value!r}")
    return number


def as_label(name: str, value: Any) -> str:
    """A non-empty label, stripped."""
    if not isinstance(value, str) or not value.strip():
        raise InvalidInputError(f"{name} must be a non-empty string, got {value!r}")
    return value.strip()


def as_count(name: str, value: Any) -> int:
    """A non-negative integer (a node id, a count)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
        raise InvalidInputError(f"{name} must be a non-negative integer, got {value!r}")
    return int(value)
