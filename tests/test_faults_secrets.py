"""Nothing let in: keys in the environment never reach a record, a log or an error message.

A mission runs with fake keys in its environment, faults that make the models fail (so error messages
are written) and a camera loss that ends it; every output (stdout, stderr, the episode record, the
per-tick record, the replay of it, and an error exit) is searched for the keys.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
#: Fake keys, under the names model clients read.
FAKE_KEYS = {
    "OPENAI_API_KEY": "sk-test-FAKEKEY-0123456789abcdef",
    "HF_TOKEN": "hf_FAKETOKEN9876543210",
    "SEMEXP_VLM_API_KEY": "fake-vlm-key-55aa55aa",
}


def semexp(*args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, **FAKE_KEYS}
    return subprocess.run(
        [sys.executable, "-m", "semexp_bt", *args],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )


def test_keys_in_the_environment_reach_no_output(tmp_path: Path) -> None:
    faults = tmp_path / "faults.yaml"
    faults.write_text(
        "faults:\n"
        "  - {class: perception_error, start_s: 0, duration_s: 6}\n"
        "  - {class: perception_garbage, start_s: 6, duration_s: 6}\n"
        "  - {class: camera_drop, start_s: 12}\n"
    )
    record, ticks = tmp_path / "episode.json", tmp_path / "ticks.jsonl"
    run = semexp("run", "trees/object_search.yaml", "--scene", "office", "--seed", "0", "--relevance", "lexical",
                 "--faults", str(faults), "--json", str(record), "--record", str(ticks))  # fmt: skip
    assert run.returncode == 1, run.stderr
    episode = record.read_text()
    assert '"perception_error"' in episode and "sensor_lost: camera" in episode  # errors were written
    replayed = semexp("replay", str(ticks), "--all")
    refused = semexp("run", "trees/object_search.yaml", "--scene", "no_such_scene", "--faults", str(faults))
    assert refused.returncode == 2
    outputs = {
        "run stdout": run.stdout,
        "run stderr": run.stderr,
        "episode record": episode,
        "tick record": ticks.read_text(),
        "replay": replayed.stdout + replayed.stderr,
        "error exit": refused.stdout + refused.stderr,
    }
    for name, text in outputs.items():
        for key, value in FAKE_KEYS.items():
            assert value not in text, f"{key}'s value leaked into the {name}"
