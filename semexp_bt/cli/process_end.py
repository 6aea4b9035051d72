"""The end of a ROS 2 command, bounded in time: ``sim-bridge`` and ``run --backend ros2``.

Fast DDS can hold a participant's teardown (node destruction, context shutdown, the interpreter's exit)
for seconds once a peer is gone, and rarely for good: a CI run saw a bridge that had written its result
stay alive for 80 s, deaf to SIGTERM, because the command's own signal handler (which asks the mission
loop to stop) was still installed while the teardown hung. Both commands write their result files before
the teardown, so nothing is lost by ending the process hard once its work is done. The standard library's
``faulthandler`` does both halves: it prints every thread's stack (where the teardown hung) and exits.

Example::

    dump_stacks_on_request()         # at start: `kill -USR1 PID` prints every thread's stack to stderr
    result = bridge.run()            # the result file is written here
    bound_the_teardown()             # SIGINT/SIGTERM now end the process at once
    bridge.close()                   # ... and the process is gone within TEARDOWN_DEADLINE_S
"""

from __future__ import annotations

import faulthandler
import signal

#: How long a command may take from the end of its work to the end of its process. A clean teardown
#: takes about 1-3 s (the executor's 1 s shutdown, the spinner's 2 s join).
TEARDOWN_DEADLINE_S = 10.0


def dump_stacks_on_request() -> None:
    """SIGUSR1 prints every thread's Python stack to stderr (the process goes on)."""
    faulthandler.register(signal.SIGUSR1, all_threads=True)


def bound_the_teardown(deadline_s: float = TEARDOWN_DEADLINE_S) -> None:
    """From now on SIGINT and SIGTERM end the process at once (their default action), and if the process
    is still alive ``deadline_s`` from now, every thread's stack goes to stderr and it exits with status 1.

    Call it once the command's result is written, before closing ROS.
    """
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    faulthandler.dump_traceback_later(deadline_s, exit=True)


__all__ = ["TEARDOWN_DEADLINE_S", "bound_the_teardown", "dump_stacks_on_request"]
