"""The models perception source never blocks and never raises: submit returns at once, poll says
"not yet" while the models think, the VLM and the detector run side by side, a cancelled view stays
silent, and an unexpected failure in a worker is an error line, not an exception."""

from __future__ import annotations

import threading
import time
from typing import Any

import numpy as np
import pytest

pytest.importorskip("openai")
pytest.importorskip("jsonschema")

from semexp_bt.core.types import Detection
from semexp_bt.perception.adapters.chat import ChatReply, ChatRequest
from semexp_bt.perception.adapters.detection import DetectorOutput
from semexp_bt.perception.adapters.source import ModelsPerception
from semexp_bt.perception.adapters.vlm import SceneVLM
from sims.scripted_chat_server import ScriptedChatServer, ScriptedReply
from tests.models_support import INSTRUCTION, TARGET, observation, scene_json, scene_vlm, still, vlm_config


class GatedTransport:
    """A chat transport that answers only once the test opens its gate."""

    model = "gated-vlm"

    def __init__(self) -> None:
        self.gate = threading.Event()
        self.started = threading.Event()

    def complete(self, request: ChatRequest) -> ChatReply:
        self.started.set()
        assert self.gate.wait(10.0)
        return ChatReply(text=scene_json(), finish_reason="stop", latency_s=0.0, attempts=1)


class RaisingTransport:
    model = "raising-vlm"

    def complete(self, request: ChatRequest) -> ChatReply:
        raise TypeError("a bug in a transport")


class WaitingDetector:
    """Answers only once the VLM's request has started: a sequential source would never finish."""

    name = "waiting detector"

    def __init__(self, vlm_started: threading.Event) -> None:
        self.vlm_started = vlm_started

    def detect(self, rgb: np.ndarray, prompt: str) -> DetectorOutput:
        assert self.vlm_started.wait(10.0), "the VLM never started while the detector ran"
        return DetectorOutput(detections=(Detection((1.0, 1.0, 20.0, 20.0), prompt, 0.9),), timings_ms={})


def submit(source: ModelsPerception) -> Any:
    return source.submit(
        observation=observation(), instruction=INSTRUCTION, target_label=TARGET, motion=still(), now_s=3.0
    )


def test_submit_returns_at_once_and_poll_waits_for_the_models() -> None:
    transport = GatedTransport()
    source = ModelsPerception(vlm=SceneVLM(vlm_config("http://unused/v1"), transport), detector=None)
    job = submit(source)
    assert transport.started.wait(5.0)
    assert job.poll(now_s=100.0) is None and source.in_flight() == 1  # however late the backend clock says
    transport.gate.set()
    report = job.wait(5.0)
    assert report is not None and report.result.scene is not None
    assert job.poll(now_s=3.0) is report.result and source.in_flight() == 0
    assert report.result.observation_stamp_s == 1.5
    source.close()


def test_the_vlm_and_the_detector_run_in_parallel() -> None:
    transport = GatedTransport()
    transport.gate.set()
    source = ModelsPerception(
        vlm=SceneVLM(vlm_config("http://unused/v1"), transport), detector=WaitingDetector(transport.started)
    )
    report = submit(source).wait(10.0)
    source.close()
    assert report is not None and report.result.errors == ()
    assert report.result.scene is not None and report.result.detections is not None
    assert [c.source for c in report.calls] == ["vlm", "detector"]


def test_a_cancelled_view_stays_silent() -> None:
    with ScriptedChatServer([ScriptedReply(content=scene_json(), delay_s=0.3)]) as server:
        source = ModelsPerception(vlm=scene_vlm(server.url), detector=None)
        job = submit(source)
        job.cancel()
        deadline = time.monotonic() + 5.0
        while source.in_flight() and time.monotonic() < deadline:
            time.sleep(0.01)
        assert source.in_flight() == 0 and job.done()  # the request already sent has finished...
        assert job.poll(now_s=10.0) is None  # ...but the tree never sees it
        assert job.wait(1.0) is None
        source.close()


def test_an_unexpected_failure_in_a_worker_is_an_error_line() -> None:
    source = ModelsPerception(vlm=SceneVLM(vlm_config("http://unused/v1"), RaisingTransport()), detector=None)
    report = submit(source).wait(5.0)
    source.close()
    assert report is not None and report.result.scene is None
    (error,) = report.result.errors
    assert error == "vlm raising-vlm: unexpected TypeError: a bug in a transport"


def test_a_source_needs_a_model() -> None:
    with pytest.raises(ValueError, match="needs a VLM or a detector"):
        ModelsPerception(vlm=None, detector=None)
