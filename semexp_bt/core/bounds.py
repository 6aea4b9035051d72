"""Numeric bounds, written once: the interval a configuration value or a node parameter must lie in.

Three kinds of declaration carry bounds: the method's configuration (``semexp_bt.core.config``), the
navigation stack's configurations (``semexp_bt.nav.costmap.CostmapConfig``, ``GlobalPlannerConfig``) and
a behaviour's parameters (``behaviours.spec.ParamSpec``). All three state them as an :class:`Interval` and check a value with it,
so a bound means the same everywhere and is tested once. The comparison names (``gt``, ``ge``, ``lt``,
``le``) are those of annotated-types' ``Interval`` (the convention of pydantic and msgspec); this module
re-states them rather than importing the library because the core imports the standard library and
numpy only.

Example:
    >>> unit = Interval.between(0.0, 1.0, high_open=True)
    >>> unit.notation(), unit.broken_bound(1.0)
    ('[0.0, 1.0)', ('<', 1.0))

This is a core module: standard library only.
"""

from __future__ import annotations

import dataclasses
import operator
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

#: The key of a dataclass field's metadata that holds its :class:`Interval` (see :func:`field_range`).
RANGE_METADATA_KEY = "range"


@dataclass(frozen=True)
class Interval:
    """Bounds on a number: each end exclusive (``gt``, ``lt``), inclusive (``ge``, ``le``) or absent.

    At most one lower bound (``gt`` or ``ge``) and one upper bound (``lt`` or ``le``).

    Attributes:
        gt: the value must be greater than this.
        ge: the value must be at least this.
        lt: the value must be less than this.
        le: the value must be at most this.
    """

    gt: float | None = None
    ge: float | None = None
    lt: float | None = None
    le: float | None = None

    def __post_init__(self) -> None:
        if self.gt is not None and self.ge is not None:
            raise ValueError(f"an Interval takes one lower bound, got gt={self.gt!r} and ge={self.ge!r}")
        if self.lt is not None and self.le is not None:
            raise ValueError(f"an Interval takes one upper bound, got lt={self.lt!r} and le={self.le!r}")

    @classmethod
    def between(cls, low: float, high: float, *, low_open: bool = False, high_open: bool = False) -> Interval:
        """The interval from ``low`` to ``high``, each end closed unless said open."""
        return cls(
            gt=low if low_open else None,
            ge=None if low_open else low,
            lt=high if high_open else None,
            le=None if high_open else high,
        )

    @property
    def low(self) -> float | None:
        """The lower bound, exclusive or inclusive; None when there is none."""
        return self.gt if self.gt is not None else self.ge

    @property
    def high(self) -> float | None:
        """The upper bound, exclusive or inclusive; None when there is none."""
        return self.lt if self.lt is not None else self.le

    def broken_bound(self, value: float) -> tuple[str, float] | None:
        """The first bound ``value`` breaks, as ``(comparison, bound)`` such as ``(">=", 1)``.

        The bounds are tried in the order ``gt``, ``ge``, ``lt``, ``le``; None when ``value`` keeps all.
        """
        for symbol, bound, holds in _COMPARISONS:
            limit = getattr(self, bound)
            if limit is not None and not holds(value, limit):
                return symbol, limit
        return None

    def contains(self, value: float) -> bool:
        """Whether ``value`` keeps every bound."""
        return self.broken_bound(value) is None

    def notation(self) -> str:
        """Interval notation with the bounds as written, e.g. ``(0.0, 1.0]``; a missing end is infinite."""
        low, high = self.low, self.high
        left = f"({low}" if self.gt is not None else "(-inf" if low is None else f"[{low}"
        right = f"{high})" if self.lt is not None else "inf)" if high is None else f"{high}]"
        return f"{left}, {right}"


_COMPARISONS: tuple[tuple[str, str, Callable[[Any, Any], bool]], ...] = (
    (">", "gt", operator.gt),
    (">=", "ge", operator.ge),
    ("<", "lt", operator.lt),
    ("<=", "le", operator.le),
)


def field_range(
    low: float, high: float, *, low_open: bool = False, high_open: bool = False
) -> dict[str, Any]:
    """Dataclass field metadata saying the field's value must lie between ``low`` and ``high``.

    Example:
        >>> from dataclasses import dataclass, field
        >>> @dataclass(frozen=True)
        ... class Gate:
        ...     rho: float = field(default=0.3, metadata=field_range(0.0, 1.0, low_open=True))
        >>> field_interval(dataclasses.fields(Gate)[0]).notation()
        '(0.0, 1.0]'
    """
    return {RANGE_METADATA_KEY: Interval.between(low, high, low_open=low_open, high_open=high_open)}


def field_interval(spec: dataclasses.Field[Any]) -> Interval | None:
    """The :class:`Interval` a dataclass field declares with :func:`field_range`, or None."""
    interval = spec.metadata.get(RANGE_METADATA_KEY)
    return interval if isinstance(interval, Interval) else None
