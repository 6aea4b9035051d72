"""Command-line values, checked where argparse reads them: a bad one is one line and exit status 2.

Each function here is an argparse ``type=``: it returns the value, or raises
``argparse.ArgumentTypeError`` with what was expected, and :class:`OneLineArgumentParser` prints that as
``semexp-bt run: error: argument --seed: expected a non-negative integer, got '-1'`` (one line, no usage
block) and exits with status 2.

Example:
    >>> parser = OneLineArgumentParser(prog="demo")
    >>> _ = parser.add_argument("--seed", type=seed, default=0)
    >>> parser.parse_args(["--seed", "3"]).seed
    3
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import NoReturn


class OneLineArgumentParser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose usage errors are one line on stderr (exit status 2), not a usage block.

    Sub-commands made with ``add_subparsers()`` are of the same class, so they inherit it.
    """

    def error(self, message: str) -> NoReturn:
        """Print ``PROG: error: MESSAGE (see PROG --help)`` and exit with status 2."""
        one_line = " ".join(message.split())
        self.exit(2, f"{self.prog}: error: {one_line} (see '{self.prog} --help')\n")


def _integer(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None


def seed(text: str) -> int:
    """A seed: a non-negative integer (the scene layout, the start pose and the noise all take one)."""
    value = _integer(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {text!r}")
    return value


def positive_int(text: str) -> int:
    """A count that must be at least 1 (ticks, trials, seeds)."""
    value = _integer(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {text!r}")
    return value


def non_negative_int(text: str) -> int:
    """A count that may be 0 (e.g. trajectories kept)."""
    value = _integer(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {text!r}")
    return value


def positive_seconds(text: str) -> float:
    """A duration in seconds: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got {text!r}") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"expected a finite number of seconds > 0, got {text!r}")
    return value


def output_folder(text: str) -> Path:
    """A folder to write into: created if missing; refused when something that is not a folder is there."""
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} exists and is not a folder")
    return path


def output_file(text: str) -> Path:
    """A file to write: refused when a folder (or anything but a regular file) is already there."""
    path = Path(text)
    if path.exists() and not path.is_file():
        raise argparse.ArgumentTypeError(f"{text} exists and is not a regular file")
    return path


def scene_name(text: str) -> str:
    """A scene of the catalogue (``semexp-bt scene list``)."""
    from sims.catalogue import list_scenes
    from trees.registry import did_you_mean

    known = list_scenes()
    if text not in known:
        close = did_you_mean(text, known)
        hint = f" (did you mean '{close}'?)" if close else ""
        raise argparse.ArgumentTypeError(f"unknown scene {text!r}{hint}; known scenes: {', '.join(known)}")
    return text


def strategy_name(text: str) -> str:
    """A strategy of ``semexp_bt/app/strategies.yaml``."""
    from semexp_bt.app.strategies import STRATEGIES
    from trees.registry import did_you_mean

    if text not in STRATEGIES:
        close = did_you_mean(text, STRATEGIES)
        hint = f" (did you mean '{close}'?)" if close else ""
        raise argparse.ArgumentTypeError(
            f"unknown strategy {text!r}{hint}; known strategies: {', '.join(STRATEGIES)}"
        )
    return text


def print_error(message: str) -> None:
    """One line ``error: MESSAGE`` on stderr (the form every subcommand uses after parsing)."""
    print(f"error: {' '.join(str(message).split())}", file=sys.stderr)
