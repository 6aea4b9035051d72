"""The heap settings keep the controller's numpy temporaries off fresh pages (semexp_bt/app/process_heap.py).

Each case runs in a fresh interpreter: the C heap's thresholds depend on a process's whole history.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from semexp_bt.app.process_heap import keep_freed_memory

# The arithmetic of Costmap.distance_at over 15,000 points (its temporaries are 120-240 KB each), 300 calls;
# prints the minor page faults those calls cost.
PROBE = """
import json, resource, sys
import numpy as np
if sys.argv[1] == "tuned":
    from semexp_bt.app.process_heap import keep_freed_memory
    assert keep_freed_memory()
rng = np.random.default_rng(0)
flat = rng.random(300 * 300)
xy = rng.random((15000, 2)) * 250.0
def lookup():
    p = xy + 0.5
    cx = np.clip(p[..., 0], 0.0, 298.0)
    cy = np.clip(p[..., 1], 0.0, 298.0)
    c0, r0 = cx.astype(np.int64), cy.astype(np.int64)
    fx, fy = cx - c0, cy - r0
    i = r0 * 300 + c0
    top = flat[i] * (1.0 - fx) + flat[i + 1] * fx
    bottom = flat[i + 300] * (1.0 - fx) + flat[i + 301] * fx
    return top * (1.0 - fy) + bottom * fy
lookup()
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(300):
    lookup()
print(json.dumps(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before))
"""


def _page_faults(mode: str) -> int:
    out = subprocess.run([sys.executable, "-c", PROBE, mode], capture_output=True, text=True, check=True)
    return int(json.loads(out.stdout))


@pytest.mark.skipif(not keep_freed_memory(), reason="this C library has no mallopt (not glibc)")
def test_tuned_heap_serves_temporaries_without_page_faults() -> None:
    default, tuned = _page_faults("default"), _page_faults("tuned")
    print(f"minor page faults over 300 look-ups: default heap {default}, tuned heap {tuned}")
    # Fixed thresholds: the temporaries reuse the heap, so 300 calls fault a few pages at most.
    assert tuned < 300
    assert tuned * 10 < max(default, 3000)


def test_keep_freed_memory_is_set_once() -> None:
    assert keep_freed_memory() is keep_freed_memory()
