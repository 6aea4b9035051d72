"""Shared by the view's tests: a saved view read back (the world through Rerun's own reader, the tick record),
and a headless Chromium that may reach this machine only (the browser tests, in process and over ROS 2)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import pytest

CHROMIUM = "/usr/bin/chromium"
#: Flags for a quiet, offline, throw-away browser (no sandbox: CI runs as root).
CHROMIUM_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]
ARTIFACTS = Path(__file__).resolve().parents[1] / "runs" / "test-artifacts"
#: The Rerun web viewer is 67 MB of WebAssembly compiled on a software rasteriser: allow it a while.
RERUN_START_S = 90.0


def require_chromium() -> None:
    """Fail with the command that installs it when Debian's Chromium is missing."""
    if shutil.which("chromium") is None:
        pytest.fail("Chromium is missing: run `make viewer-test` (it installs Debian's chromium)")


def page_statuses(page: Any) -> dict[str, str]:
    return page.eval_on_selector_all(
        ".node", "els => Object.fromEntries(els.map(e => [e.dataset.name, e.dataset.status]))"
    )


#: What the view's pages say of their own state (``window.semexpView``), for a wait that timed out.
_VIEW_STATE = """() => {
  const v = window.semexpView;
  return v ? {done: v.done, ticks: v.ticks, shownTick: v.shownTick, rerun: v.rerun} : null;
}"""


def wait_for(page: Any, expression: str, timeout_s: float) -> Any:
    """Wait until ``expression`` is truthy in the page; its value. (A function, not a string to evaluate:
    the page's content security policy forbids eval, and Playwright calls a function without it.)

    A wait that times out fails naming the expression and what the page said of its state then (Playwright's
    own error names neither, which left a rare failure of the replay test unexplained; docs/viewer.md)."""
    from playwright.sync_api import TimeoutError as PlaywrightTimeoutError

    function = f"() => ({expression})"
    try:
        page.wait_for_function(function, timeout=timeout_s * 1000.0)
    except PlaywrightTimeoutError:
        try:
            state: Any = page.evaluate(_VIEW_STATE)
        except Exception as error:  # the page itself may be gone: say so rather than mask the timeout
            state = f"unreadable ({error})"
        pytest.fail(f"waited {timeout_s:g} s for `{expression}`; the page's view state then: {state}")
    return page.evaluate(function)


def timed_rows(world_path: Path) -> dict[str, list[int]]:
    """The ticks at which each entity was logged, by entity path (Rerun's reader)."""
    import rerun.chunk as rrc

    ticks: dict[str, list[int]] = {}
    for chunk in rrc.RrdReader(str(world_path)).store().stream():
        if chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        ticks.setdefault(chunk.entity_path.lstrip("/"), []).extend(batch.column("tick").to_pylist())
    return {entity: sorted(values) for entity, values in ticks.items()}


def written_at(tick_lines: list[str], key: str) -> list[int]:
    """The ticks at which the tick record says ``key`` was written."""
    out = []
    for line in tick_lines:
        record = json.loads(line)
        if any(w["key"] == key for w in record["writes"]):
            out.append(record["tick"])
    return out
