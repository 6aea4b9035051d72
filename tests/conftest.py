"""Test-suite settings shared by every test file.

Hypothesis runs derandomised (a fixed seed per test) so that the default suite is reproducible in CI:
the same clone gives the same examples every run. Set HYPOTHESIS_PROFILE=explore to search afresh.
"""

from __future__ import annotations

import os

from hypothesis import settings

settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
settings.register_profile("explore", deadline=None, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))
os.environ.setdefault("MUJOCO_GL", "egl")
