"""The model benchmarks' commands keep working (tiny runs; the figures come from the full ones)."""

from __future__ import annotations

import pytest

pytest.importorskip("openai")
pytest.importorskip("jsonschema")

from semexp_bt.bench.models import NO_MODEL, format_report, measure_overhead, measure_ticks


def test_the_overhead_run_times_every_stage_and_says_no_model_ran() -> None:
    overhead = measure_overhead(requests=3)
    assert [row["frame"] for row in overhead["rows"]] == [
        "320x240 png", "320x240 jpeg", "640x480 png", "640x480 jpeg", "16 labels"
    ]  # fmt: skip
    for row in overhead["rows"]:
        assert all(row[stage]["median"] >= 0.0 for stage in ("encode", "request", "parse"))
    report = format_report({"machine": "test", "overhead": overhead})
    print(report)
    assert report.startswith(NO_MODEL) and "| vlm | 320x240 png |" in report


@pytest.mark.slow
def test_the_ticks_run_sees_ticks_with_a_request_in_flight() -> None:
    ticks = measure_ticks(delay_s=1.0, max_sim_s=12.0)
    print(format_report({"machine": "test", "ticks": ticks}))
    assert ticks["in_flight"]["ticks"] > 0 and ticks["not_in_flight"]["ticks"] > 0
    assert ticks["perception_timeouts"] == 0
