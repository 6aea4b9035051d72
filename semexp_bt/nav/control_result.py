"""One controller cycle's result: what a path-following controller commands, and why.

Its own module, apart from the controllers (``controller.py``), because it travels: the tick record
summarises it, and the view's frames carry it to a world process that unpickles it. Importing it costs
numpy and the core types, not the costmap and scipy that the controllers need.

Example:
    >>> ControlResult(Twist.zero(), "blocked").clearance_m
    inf
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from semexp_bt.core.types import FloatArray, Twist

ControlStatus = Literal["tracking", "rotating", "blocked", "arrived"]
"""``tracking`` the path; ``rotating`` in place toward it; ``blocked``: no admissible motion (zero
twist); ``arrived`` at the path's end (zero twist)."""


@dataclass
class ControlResult:
    """One controller cycle.

    Attributes:
        twist: the command.
        status: see :data:`ControlStatus`.
        clearance_m: the least footprint clearance along the commanded trajectory (inf when far from all).
        trajectory: ``(T, 3)`` the commanded trajectory's states (x, y, yaw), for display.
        scores: the chosen trajectory's critic terms.
        candidates: how many trajectories were sampled, and how many were admissible.
    """

    twist: Twist
    status: ControlStatus
    clearance_m: float = math.inf
    trajectory: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))
    scores: dict[str, float] = field(default_factory=dict)
    candidates: tuple[int, int] = (0, 0)
