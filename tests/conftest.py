"""Test-suite settings shared by every test file, and the fixtures more than one file uses.

Hypothesis runs derandomised (a fixed seed per test) so that the default suite is reproducible in CI:
the same clone gives the same examples every run. Set HYPOTHESIS_PROFILE=explore to search afresh.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import settings

from tests.viewer_support import CHROMIUM, CHROMIUM_FLAGS, require_chromium

settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
settings.register_profile("explore", deadline=None, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))
os.environ.setdefault("MUJOCO_GL", "egl")


@pytest.fixture
def browser_context(tmp_path: Path) -> Iterator[tuple[Any, list[str]]]:
    """A fresh Chromium profile whose requests to anything but loopback are refused and listed."""
    from playwright.sync_api import sync_playwright

    require_chromium()

    outside: list[str] = []

    def guard(route: Any) -> None:
        url = route.request.url
        if url.startswith(("http://127.0.0.1", "http://localhost", "data:", "blob:")):
            route.continue_()
        else:
            outside.append(url)
            route.abort()

    with sync_playwright() as playwright:
        context = playwright.chromium.launch_persistent_context(
            user_data_dir=str(tmp_path / "profile"),
            executable_path=CHROMIUM,
            args=CHROMIUM_FLAGS,
            headless=True,
            viewport={"width": 1600, "height": 1000},
        )
        context.route("**/*", guard)
        try:
            yield context, outside
        finally:
            context.close()
