"""A ROS 2 command's end is bounded (semexp_bt/cli/process_end.py): a teardown that hangs (here a
non-daemon thread that never ends, as a Fast DDS participant's can) still ends the process, with every
thread's stack on stderr, and SIGTERM during the teardown is no longer swallowed by the command's own
stop handler."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
import time

from tests.ros2_support import ROOT

#: A command that swallows SIGTERM while it works (as sim-bridge's handler does), then hangs on exit.
HANGING_COMMAND = textwrap.dedent(
    """
    import signal, sys, threading
    from semexp_bt.cli.process_end import bound_the_teardown, dump_stacks_on_request

    dump_stacks_on_request()
    signal.signal(signal.SIGTERM, lambda signum, frame: None)
    bound_the_teardown(float(sys.argv[1]))
    threading.Thread(target=threading.Event().wait).start()
    print("working done", flush=True)
    """
)


def _start(deadline_s: float) -> subprocess.Popen[str]:
    process = subprocess.Popen(
        [sys.executable, "-c", HANGING_COMMAND, str(deadline_s)],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert process.stdout is not None and process.stdout.readline() == "working done\n"
    return process


def test_a_hung_teardown_ends_at_the_deadline_with_every_threads_stack() -> None:
    started = time.monotonic()
    process = _start(deadline_s=1.0)
    _, stderr = process.communicate(timeout=30)
    print(stderr)
    assert process.returncode == 1
    # The main thread's stack: stuck joining the thread that never ends.
    assert "Timeout (0:00:01)!" in stderr and "in _shutdown" in stderr
    assert time.monotonic() - started < 20


def test_sigterm_during_the_teardown_ends_the_process_at_once() -> None:
    process = _start(deadline_s=60.0)
    process.send_signal(signal.SIGUSR1)  # the stacks, and the process goes on
    time.sleep(0.5)
    assert process.poll() is None
    process.terminate()
    _, stderr = process.communicate(timeout=10)
    assert process.returncode == -signal.SIGTERM
    assert "Thread 0x" in stderr, stderr  # SIGUSR1's dump
