"""Lint, type and layering checks, run as part of the test suite.

- ruff over the whole project;
- mypy over every package (semexp_bt, behaviours, blackboard, robots, sims);
- import-linter's contract (pyproject.toml): core modules import neither py_trees, mujoco, torch nor a
  middleware, so the maths stays testable and benchmarkable alone;
- and a direct check that importing the core in a fresh interpreter loads none of those packages.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
CORE_MODULES = (
    "semexp_bt.types",
    "semexp_bt.config",
    "semexp_bt.geometry",
    "semexp_bt.evidence",
    "semexp_bt.memory",
    "semexp_bt.decision",
    "semexp_bt.relevance",
    "semexp_bt.metrics",
    "semexp_bt.scene",
    "semexp_bt.planner",
    "semexp_bt.decision_baselines",
)
FORBIDDEN_IN_CORE = ("py_trees", "mujoco", "torch", "cyclonedds", "rclpy", "cv2", "sentence_transformers")


def _run(*cmd: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=600)


def test_ruff_is_clean() -> None:
    result = _run(str(BIN / "ruff"), "check", ".")
    assert result.returncode == 0, result.stdout + result.stderr


def test_mypy_is_clean() -> None:
    result = _run(str(BIN / "mypy"), "--no-error-summary")
    assert result.returncode == 0, result.stdout + result.stderr


def test_import_contract_holds() -> None:
    result = _run(str(BIN / "lint-imports"))
    assert result.returncode == 0, result.stdout + result.stderr


@pytest.mark.parametrize("module", CORE_MODULES)
def test_core_module_imports_no_heavy_dependency(module: str) -> None:
    code = (
        f"import sys, importlib; importlib.import_module({module!r}); "
        f"bad = [m for m in {FORBIDDEN_IN_CORE!r} if m in sys.modules]; print(','.join(bad))"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "", f"{module} pulled in {result.stdout.strip()}"
