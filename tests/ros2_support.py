"""Shared by the ROS 2 tests: loopback-only DDS for every ROS process they start, and process helpers.

Every ROS participant a test creates, in this process or a child, uses the Fast DDS profile that allows
only 127.0.0.1 (``scripts/fastdds_loopback.xml``), ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and a
domain id of its own (random, drawn once per test). ``make test`` also runs these tests inside a network
namespace that has only ``lo`` (``scripts/ros2_isolated.sh``).
"""

from __future__ import annotations

import os
import random
import re
import signal
import subprocess
import sys
import time
from collections.abc import Mapping, Sequence
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LOOPBACK_PROFILE = ROOT / "scripts" / "fastdds_loopback.xml"
MISSION = ROOT / "trees" / "object_search.yaml"
#: How long :func:`stop` leaves a process to print its stacks.
STACK_DUMP_S = 1.0

#: The domain ids drawn in this process, so that no two tests share one.
_USED_DOMAINS: set[int] = set()


def fresh_domain_id() -> int:
    """A random ROS domain id (1-101) no earlier test of this process used."""
    while True:
        domain = random.SystemRandom().randint(1, 101)
        if domain not in _USED_DOMAINS:
            _USED_DOMAINS.add(domain)
            return domain


def isolated_env(domain_id: int, **extra: str) -> dict[str, str]:
    """The environment of a ROS process a test starts: loopback only, on ``domain_id``."""
    env = dict(os.environ)
    env.update(
        FASTRTPS_DEFAULT_PROFILES_FILE=str(LOOPBACK_PROFILE),
        FASTDDS_DEFAULT_PROFILES_FILE=str(LOOPBACK_PROFILE),
        ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
        ROS_DOMAIN_ID=str(domain_id),
        RMW_IMPLEMENTATION="rmw_fastrtps_cpp",
        MUJOCO_GL="egl",
        PYTHONUNBUFFERED="1",
    )
    env.update(extra)
    return env


def isolate_this_process(domain_id: int) -> None:
    """Apply :func:`isolated_env` to this process (before its first ROS context on that domain).

    Fast DDS reads the profile file when the first participant of the process is created; the domain id
    is read per context, so a test may move to a fresh one.
    """
    os.environ.update({k: v for k, v in isolated_env(domain_id).items() if k not in ("PYTHONUNBUFFERED",)})


def mission_with_budget(folder: Path, budget_s: float) -> Path:
    """``trees/object_search.yaml`` with ``budget_s`` cut to ``budget_s``, written into ``folder`` (created)
    beside a link to the shipped subtrees (its includes are relative to it). The end-to-end tests and
    ``scripts/bench_ros2.py --budget-s`` run both backends on the same copy."""
    text, count = re.subn(
        r"^(\s*budget_s:\s*)\S+$", rf"\g<1>{budget_s:g}", MISSION.read_text(), count=1, flags=re.M
    )
    assert count == 1, f"{MISSION} has no budget_s line"
    folder.mkdir(parents=True)
    (folder / "subtrees").symlink_to(MISSION.parent / "subtrees", target_is_directory=True)
    path = folder / MISSION.name
    path.write_text(text)
    return path


def run_bridge_and_executive(
    bridge_argv: Sequence[str],
    executive_argv: Sequence[str],
    *,
    quiet: bool = False,
    timeout_s: float = 900.0,
) -> None:
    """Start the bridge command, run the executive command to its end, then let the bridge end (it stops
    with the mission), terminating it if it does not: the two-process run the ROS 2 scripts time
    (``scripts/bench_ros2.py``, ``scripts/profile_ros2_lockstep.py``). Both run in ``ROOT``; standard
    output is dropped, and with ``quiet`` their standard error too."""
    errors = subprocess.DEVNULL if quiet else None
    bridge = subprocess.Popen(list(bridge_argv), cwd=ROOT, stdout=subprocess.DEVNULL, stderr=errors)
    try:
        subprocess.run(
            list(executive_argv),
            cwd=ROOT,
            check=False,
            stdout=subprocess.DEVNULL,
            stderr=errors,
            timeout=timeout_s,
        )
        bridge.wait(timeout=60)
    finally:
        if bridge.poll() is None:
            bridge.terminate()
            bridge.wait(timeout=30)


def semexp(args: Sequence[str], *, env: Mapping[str, str], log: Path) -> subprocess.Popen[bytes]:
    """Start ``semexp-bt ARGS`` with this interpreter (the ROS 2 environment), output to ``log``."""
    handle = open(log, "wb")
    return subprocess.Popen(
        [sys.executable, "-m", "semexp_bt", *args],
        cwd=ROOT,
        env=dict(env),
        stdout=handle,
        stderr=subprocess.STDOUT,
    )


def stop(process: subprocess.Popen[bytes], *, timeout_s: float = 20.0, dump_stacks: bool = False) -> int:
    """SIGTERM, then SIGKILL after ``timeout_s``; the exit status.

    ``dump_stacks``: first SIGUSR1, on which a running semexp-bt ROS 2 command prints every thread's stack
    to its log (semexp_bt/cli/process_end.py): where a process that outlived its test was. Only for a
    process past its start (before, SIGUSR1 would end it).
    """
    if process.poll() is None:
        if dump_stacks:
            process.send_signal(signal.SIGUSR1)
            time.sleep(STACK_DUMP_S)
        process.terminate()
        try:
            return process.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            process.kill()
    return process.wait(timeout=timeout_s)


def wait_for_bridge(log: Path, process: subprocess.Popen[bytes], *, timeout_s: float = 180.0) -> None:
    """Wait until the bridge says it is serving (its scene, oracle and renderer are built)."""
    ready = wait_for(
        lambda: "sim-bridge: " in log.read_text() or process.poll() is not None, timeout_s=timeout_s
    )
    if not ready or process.poll() is not None:
        raise AssertionError(f"the bridge did not come up:\n{log.read_text()[-3000:]}")


class CommandSpy:
    """``tests/ros2_spy.py`` started as a process of its own on ``env``'s domain; reads its log back.

    ``commands`` are ``(steady time, vx, wz)`` of each ``/cmd_vel`` message, ``speeds`` ``(steady time,
    |v| + |w|)`` of each ``/odom`` one, both as received so far.
    """

    def __init__(self, env: Mapping[str, str], log: Path, *, timeout_s: float = 60.0) -> None:
        self.log = log
        log.write_text("")
        self.process = subprocess.Popen(
            [sys.executable, "-m", "tests.ros2_spy", str(log)],
            cwd=ROOT,
            env=dict(env),
            stderr=open(log.with_suffix(".err"), "wb"),
        )
        if not wait_for(
            lambda: self._lines()[:1] == ["ready"] or self.process.poll() is not None, timeout_s=timeout_s
        ):
            raise AssertionError(f"the command spy did not come up: {log.with_suffix('.err').read_text()}")
        if self.process.poll() is not None:
            raise AssertionError(f"the command spy ended: {log.with_suffix('.err').read_text()}")

    def _lines(self) -> list[str]:
        text = self.log.read_text()
        return text.split("\n")[: text.count("\n")]  # complete lines only: the spy may be mid-line

    @property
    def commands(self) -> list[tuple[float, float, float]]:
        rows = [line.split() for line in self._lines() if line.startswith("cmd ")]
        return [(float(t), float(vx), float(wz)) for _, t, vx, wz in rows]

    @property
    def speeds(self) -> list[tuple[float, float]]:
        rows = [line.split() for line in self._lines() if line.startswith("odom ")]
        return [(float(t), float(speed)) for _, t, speed in rows]

    def moving_command_seen(self) -> bool:
        return any(abs(vx) + abs(wz) > 1e-3 for _, vx, wz in self.commands)

    def close(self) -> None:
        stop(self.process, timeout_s=10.0)


def wait_for(predicate: object, *, timeout_s: float, period_s: float = 0.05) -> bool:
    """Poll ``predicate()`` until it is true or ``timeout_s`` passes."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():  # type: ignore[operator]
            return True
        time.sleep(period_s)
    return bool(predicate())  # type: ignore[operator]
