"""The C heap's settings for a mission process: keep freed memory instead of handing it back at once.

Why: the navigation stack's hot loops (the controller's footprint checks, ``Costmap.distance_at`` over
some 15,000 sampled points a call) allocate and free numpy temporaries of 100-250 KB many times a
second. glibc's ``malloc`` serves blocks above its mmap threshold (128 KB at start, raised dynamically)
with fresh ``mmap`` pages and gives the top of the heap back to the kernel whenever more than the trim
threshold is free there, so whether such a loop page-faults on every temporary depends on where
long-lived objects happen to sit on the heap. In the ROS 2 executive's process it did: the same
controller calls cost about 1,000 us a ``Costmap.distance_at`` where the in-process run paid a third of
that (docs/ros2.md, "The C heap"; ``tests/test_process_heap.py`` counts the page faults).

:func:`keep_freed_memory` fixes the two thresholds (``mallopt``), which also turns glibc's dynamic
adjustment off: blocks up to :data:`MMAP_THRESHOLD_BYTES` come from the heap, and the heap's top is
trimmed only past :data:`TRIM_THRESHOLD_BYTES` free. The cost is resident memory the process has freed
but not returned, at most about the trim threshold. On a C library without ``mallopt`` (musl, macOS) it
does nothing.

Example:
    >>> keep_freed_memory() in (True, False)
    True
"""

from __future__ import annotations

import ctypes
import functools
from typing import Any

#: glibc's ``mallopt`` parameter numbers (malloc.h).
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
#: Blocks up to this size come from the heap (glibc's own upper bound for its dynamic threshold, 64-bit).
MMAP_THRESHOLD_BYTES = 32 * 1024 * 1024
#: Free memory at the heap's top is returned to the kernel only beyond this.
TRIM_THRESHOLD_BYTES = 128 * 1024 * 1024


@functools.cache
def _loaded_symbols() -> ctypes.CDLL | None:
    """The process's own symbols, the C library's among them (``dlopen(NULL)``: no library search, which
    ``ctypes.util.find_library`` does with a subprocess at every call)."""
    try:
        return ctypes.CDLL(None)
    except OSError:
        return None


def _c_function(name: str) -> Any:
    """The C library's function ``name``, or None where this C library has no such function."""
    symbols = _loaded_symbols()
    return None if symbols is None else getattr(symbols, name, None)


@functools.cache
def keep_freed_memory() -> bool:
    """Set the heap's mmap and trim thresholds for this process (once); whether the C library took them."""
    mallopt = _c_function("mallopt")
    if mallopt is None:
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    return bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)) and bool(
        mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES)
    )


def release_free_heap() -> bool:
    """Hand the C allocator's free pages back to the OS (glibc ``malloc_trim``; False where there is none).

    A mission frees its scene, its maps and its MuJoCo model when it ends, but glibc keeps the freed
    pages of its arenas for reuse (the more so with :func:`keep_freed_memory`), so a large scene's peak
    stays resident after it. A process that runs missions back to back calls this between them; what is
    resident after it is what is still in use.
    """
    trim = _c_function("malloc_trim")
    if trim is None:
        return False
    trim(0)
    return True


__all__ = ["MMAP_THRESHOLD_BYTES", "TRIM_THRESHOLD_BYTES", "keep_freed_memory", "release_free_heap"]
