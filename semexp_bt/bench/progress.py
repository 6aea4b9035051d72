"""A sweep's progress on a stream: one line per finished episode, with counts, rate and ETA.

Example line:
``[sweep] 12/40 done (1 failed) | 142 episodes/h | ETA 12m14s | road/3/ours: success in 31.2 s``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from typing import Any, TextIO

from semexp_bt.bench.rows import STATUS_OK


class Progress:
    """Progress lines on a stream: done/total, failures, episodes per hour, ETA.

    Args:
        total: episodes in the grid.
        already_done: episodes that had a row before this invocation.
        stream: where the lines go (None: count, print nothing).
    """

    def __init__(self, *, total: int, already_done: int, stream: TextIO | None) -> None:
        self.total = total
        self.done = already_done
        self.ran = 0
        self.failed = 0
        self.start = time.monotonic()
        self.stream = stream

    def update(self, row: Mapping[str, Any]) -> None:
        """Count one finished episode and print its line."""
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
            f" | ETA {format_duration(eta)} | {row.get('scene')}/{row.get('seed')}/{row.get('strategy')}:"
            f" {outcome} in {row.get('harness_wall_s', 0):.1f} s",
            file=self.stream,
            flush=True,
        )


def format_duration(seconds: float) -> str:
    """``734`` -> ``12m14s``; ``4000`` -> ``1h06m``; infinity -> ``?``."""
    if not math.isfinite(seconds):
        return "?"
    seconds = int(round(seconds))
    hours, rest = divmod(seconds, 3600)
    return f"{hours}h{rest // 60:02d}m" if hours else f"{rest // 60}m{rest % 60:02d}s"
