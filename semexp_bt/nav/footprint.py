"""The robot's planar footprint: an oriented rectangle in ``base_link``, as Nav2 describes a robot.

Nav2's costmap takes a footprint polygon and derives two radii from it (``nav2_costmap_2d``'s
``calculateMinAndMaxDistances``): the *inscribed* radius, the largest circle around the base origin
that stays inside the footprint, and the *circumscribed* radius, the smallest circle around the origin
that holds it. A base centre closer than the inscribed radius to an obstacle is in collision whatever
its heading; one farther than the circumscribed radius is free whatever its heading; in between, only a
check of the oriented footprint can tell. The inflation layer and the controller's footprint check use
exactly these quantities (``semexp_bt.nav.costmap``, ``semexp_bt.nav.controller``).

The Go1's footprint is not centred on ``base_link`` (the trunk centre, about which it turns): its legs
reach 0.38 m behind the trunk centre and the head 0.29 m ahead. The numbers come from the Go1 model
(``robots.go1.go1_footprint``); this module holds only the geometry, so that navigation stays free of the
robot description's files.

Example:
    >>> fp = Footprint(x_min_m=-0.378, x_max_m=0.29, half_width_m=0.15)
    >>> round(fp.inscribed_radius_m, 3), round(fp.circumscribed_radius_m, 3)
    (0.15, 0.407)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from semexp_bt.core.types import FloatArray, InvalidInputError, require_finite

#: Spacing of :attr:`Footprint.clearance_points` along the outline and the centre line (one costmap cell).
CLEARANCE_SPACING_M = 0.05


@dataclass(frozen=True)
class Footprint:
    """An axis-aligned rectangle in ``base_link`` (x forward, y left), turning about the origin.

    Attributes:
        x_min_m: the rear edge (negative: behind the base origin).
        x_max_m: the front edge.
        half_width_m: half the width (the rectangle spans ``[-half_width_m, half_width_m]`` in y).
    """

    x_min_m: float
    x_max_m: float
    half_width_m: float

    def __post_init__(self) -> None:
        require_finite("Footprint", (self.x_min_m, self.x_max_m, self.half_width_m))
        if not (self.x_min_m <= 0.0 <= self.x_max_m and self.x_max_m > self.x_min_m):
            raise InvalidInputError(
                f"Footprint must hold the base origin: x_min_m={self.x_min_m} <= 0 <= x_max_m={self.x_max_m}"
            )
        if self.half_width_m <= 0.0:
            raise InvalidInputError(f"Footprint.half_width_m must be > 0, got {self.half_width_m}")

    # ------------------------------------------------------------------ Nav2's two radii
    @property
    def length_m(self) -> float:
        return self.x_max_m - self.x_min_m

    @property
    def centre_x_m(self) -> float:
        """Where the rectangle's centre lies on the x axis of ``base_link``."""
        return 0.5 * (self.x_min_m + self.x_max_m)

    @property
    def inscribed_radius_m(self) -> float:
        """Distance from the origin to the nearest edge: any heading collides closer than this."""
        return min(self.half_width_m, -self.x_min_m, self.x_max_m)

    @property
    def circumscribed_radius_m(self) -> float:
        """Distance from the origin to the farthest corner: the circle a turn in place sweeps."""
        return math.hypot(max(-self.x_min_m, self.x_max_m), self.half_width_m)

    def corners(self) -> FloatArray:
        """``(4, 2)`` corners, counter-clockwise from the rear right."""
        w = self.half_width_m
        return np.array([[self.x_min_m, -w], [self.x_max_m, -w], [self.x_max_m, w], [self.x_min_m, w]])

    def padded(self, padding_m: float) -> Footprint:
        """The rectangle grown by ``padding_m`` on every side (Nav2's ``footprint_padding``)."""
        require_finite("padding_m", padding_m)
        if padding_m < 0.0:
            raise InvalidInputError(f"padding_m must be >= 0, got {padding_m}")
        return Footprint(self.x_min_m - padding_m, self.x_max_m + padding_m, self.half_width_m + padding_m)

    # ------------------------------------------------------------------ collision model
    @cached_property
    def covering_discs(self) -> tuple[FloatArray, float]:
        """Equal discs whose union holds the rectangle: ``(centres (n, 2), radius)``.

        A state's clearance is then ``min_i (distance field at centre_i) - radius``, a handful of look-ups
        instead of a polygon scan. Two rows of discs (at ``y = +-half_width / 2``), about square cells
        per disc, so that the union overshoots the rectangle by at most a quarter of the width along the
        sides and the ends (2.5 and 3.4 cm for the Go1): a single row would overshoot the ends by up to
        the half width, and a turn near a wall is decided by the ends.
        """
        a = 0.5 * self.half_width_m
        count = max(1, math.ceil(self.length_m / (2.0 * a)))
        step = self.length_m / count
        radius = math.hypot(a, 0.5 * step)
        xs = self.x_min_m + step * (np.arange(count) + 0.5)
        centres = np.concatenate([np.stack([xs, np.full(count, y)], axis=1) for y in (-a, a)])
        return centres, float(radius)

    @cached_property
    def clearance_points(self) -> FloatArray:
        """``(P, 2)`` points whose distances to the nearest obstacle give the rectangle's own clearance: the
        outline every :data:`CLEARANCE_SPACING_M` (an obstacle outside the rectangle is nearest to its
        outline; between two points the error is under 3 mm at the controller's 0.13 m) and the centre line,
        so that an obstacle inside the rectangle is never farther than a quarter width from a point.

        Unlike :attr:`covering_discs` it does not overshoot the rectangle (the discs add 2.5 cm at the sides,
        which made a 0.60 m passage the narrowest one the 0.30 m wide Go1 could drive).
        """
        spacing = CLEARANCE_SPACING_M
        count = max(1, math.ceil(self.length_m / spacing))
        centre_line = np.stack(
            [self.x_min_m + self.length_m * (np.arange(1, count) / count), np.zeros(count - 1)], axis=1
        )
        return np.concatenate([self.outline(spacing), centre_line])

    def contains(self, points_base: FloatArray) -> np.ndarray:
        """Which of the ``(N, 2)`` base-frame points lie inside the rectangle (edges included)."""
        p = np.asarray(points_base, dtype=float)
        return (
            (p[..., 0] >= self.x_min_m)
            & (p[..., 0] <= self.x_max_m)
            & (np.abs(p[..., 1]) <= self.half_width_m)
        )

    def outline(self, spacing_m: float) -> FloatArray:
        """``(N, 2)`` points along the edges, at most ``spacing_m`` apart (corners included)."""
        corners = self.corners()
        points = []
        for a, b in zip(corners, np.roll(corners, -1, axis=0), strict=True):
            n = max(1, math.ceil(float(np.hypot(*(b - a))) / spacing_m))
            t = np.arange(n)[:, None] / n
            points.append(a + t * (b - a))
        return np.concatenate(points)


def transform_points(
    points_base: FloatArray, x_m: FloatArray, y_m: FloatArray, yaw_rad: FloatArray
) -> FloatArray:
    """Base-frame points ``(P, 2)`` at every pose ``(...)``: world points ``(..., P, 2)``."""
    c, s = np.cos(yaw_rad)[..., None], np.sin(yaw_rad)[..., None]
    px, py = points_base[:, 0], points_base[:, 1]
    return np.stack([x_m[..., None] + c * px - s * py, y_m[..., None] + s * px + c * py], axis=-1)
