"""Lint, type and layering checks, run as part of the test suite.

- ruff over the whole project;
- mypy over every package (pyproject.toml's ``[tool.mypy] files``);
- import-linter's contracts (pyproject.toml, the one place they are written): the layers of the house
  (docs/architecture.md) and the libraries the core and navigation may not import;
- and a direct check that importing every core and navigation module in a fresh interpreter loads none of
  the libraries their contracts forbid (a lazy import inside a function is allowed; one at import time not).
"""

from __future__ import annotations

import pkgutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

import semexp_bt.core
import semexp_bt.nav

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
CONTRACTS = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]["contracts"]
FORBIDDEN = {
    source: tuple(contract["forbidden_modules"])
    for contract in CONTRACTS
    if contract["type"] == "forbidden"
    for source in contract["source_modules"]
}
MODULES = [
    (module.name, FORBIDDEN[package.__name__])
    for package in (semexp_bt.core, semexp_bt.nav)
    for module in pkgutil.walk_packages(package.__path__, prefix=package.__name__ + ".")
]


def _run(*cmd: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=600)


def test_ruff_is_clean() -> None:
    result = _run(str(BIN / "ruff"), "check", ".")
    assert result.returncode == 0, result.stdout + result.stderr


def test_ruff_format_is_clean() -> None:
    result = _run(str(BIN / "ruff"), "format", "--check", ".")
    assert result.returncode == 0, result.stdout + result.stderr


def test_mypy_is_clean() -> None:
    result = _run(str(BIN / "mypy"), "--no-error-summary")
    assert result.returncode == 0, result.stdout + result.stderr


def test_import_contracts_hold() -> None:
    result = _run(str(BIN / "lint-imports"))
    assert result.returncode == 0, result.stdout + result.stderr


@pytest.mark.parametrize(("module", "forbidden"), MODULES, ids=[m for m, _ in MODULES])
def test_core_and_nav_modules_load_no_forbidden_library(module: str, forbidden: tuple[str, ...]) -> None:
    code = (
        f"import sys, importlib; importlib.import_module({module!r}); "
        f"bad = [m for m in {forbidden!r} if m in sys.modules]; print(','.join(bad))"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "", f"{module} pulled in {result.stdout.strip()}"
