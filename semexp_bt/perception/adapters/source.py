"""The models perception source: real models in worker threads behind the ``PerceptionSource`` seam.

:class:`ModelsPerception` implements ``semexp_bt.perception.interface.PerceptionSource``. ``submit``
copies the frame and hands it to one worker thread per model (the VLM and the detector run in
parallel, as in the paper) and returns a :class:`ModelsJob` at once; the tree's ``Perceive`` polls the
job every tick and never waits. The job is done when every enabled model has answered or failed;
``poll`` then returns the :class:`PerceptionResult`:

* ``scene`` is the VLM's validated evidence, or None when the VLM failed or is off;
* ``detections`` is the detector's boxes (an empty tuple when it saw nothing), or None when it
  failed or is off;
* ``errors`` holds one line per failure (a garbled reply, a time-out, an open circuit, a relevance
  batch that fell back to the lexical scorer); ``Perceive`` records each as a ``perception_error``
  event. A failure is never an exception in the tree and never evidence.

With a relevance scorer to prefetch (``LLMRelevance``, ``prefetch: true``), the VLM's worker scores
the view's labels (its proposals' labels and the detector's prompt) before the job is done, so the
tree's later relevance lookups are cache hits instead of LLM calls inside a tick.

``poll`` ignores the backend clock: the result is there when the threads are done. On a simulated robot
the simulation must then run at wall-clock pace (``semexp_bt.app.pacing``), or the models' latency
would cost no robot time.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from concurrent.futures import CancelledError, Future, ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np

from semexp_bt.core.types import Detection, Observation, SceneEvidence, Twist
from semexp_bt.perception.adapters.calls import ModelCall
from semexp_bt.perception.adapters.detection import Detector, detect_safely
from semexp_bt.perception.adapters.vlm import SceneCall, SceneVLM
from semexp_bt.perception.interface import PerceptionResult
from semexp_bt.perception.llm_relevance import LLMRelevance

#: Calls per model kept for :meth:`ModelsPerception.call_stats` (a long mission keeps its first ones).
MAX_KEPT_CALLS = 100_000


@dataclass(frozen=True)
class ModelsReport:
    """Everything one view's models did: the result the tree gets and each model's account."""

    result: PerceptionResult
    calls: tuple[ModelCall, ...]

    def as_dict(self) -> dict[str, Any]:
        scene = self.result.scene
        return {
            "scene": None
            if scene is None
            else {
                "scene_confidence": scene.scene_confidence,
                "proposals": [
                    {"kind": p.kind, "label": p.label, "point_px": list(p.point_px)} for p in scene.proposals
                ],
            },
            "detections": None
            if self.result.detections is None
            else [
                {"label": d.label, "confidence": d.confidence, "box_xyxy_px": list(d.box_xyxy_px)}
                for d in self.result.detections
            ],
            "errors": list(self.result.errors),
            "calls": [c.as_dict() for c in self.calls],
        }


def _failed_call(source: str, model: str, exc: BaseException, start: float) -> ModelCall:
    return ModelCall(
        source=source,
        model=model,
        ok=False,
        error=f"{source} {model}: unexpected {type(exc).__name__}: {exc}",
        latency_s=time.perf_counter() - start,
    )


class ModelsJob:
    """One view's pending requests (a ``PerceptionJob``)."""

    def __init__(
        self,
        *,
        scene: Future[tuple[SceneEvidence | None, tuple[ModelCall, ...]]] | None,
        detector: Future[tuple[tuple[Detection, ...] | None, ModelCall]] | None,
        stamp_s: float,
        drain_errors: Callable[[], list[str]],
    ) -> None:
        self._scene = scene
        self._detector = detector
        self._stamp_s = stamp_s
        self._drain_errors = drain_errors
        self._report: ModelsReport | None = None
        self._cancelled = False
        self._lock = threading.Lock()

    def done(self) -> bool:
        """Whether every enabled model has answered (or failed)."""
        return all(f is None or f.done() for f in (self._scene, self._detector))

    def poll(self, *, now_s: float) -> PerceptionResult | None:
        del now_s  # the threads' completion decides, not the backend clock (module docstring)
        if self._cancelled or not self.done():
            return None
        return self.report().result

    def wait(self, timeout_s: float) -> ModelsReport | None:
        """Block until done or ``timeout_s`` passed (for ``semexp-bt perceive``; never in a tick); None
        when it timed out or was cancelled."""
        deadline = time.monotonic() + timeout_s
        for future in (self._scene, self._detector):
            if future is not None:
                try:
                    future.exception(timeout=max(0.0, deadline - time.monotonic()))
                except (TimeoutError, CancelledError):
                    return None
        return None if self._cancelled else self.report()

    def report(self) -> ModelsReport:
        """The view's report (only once :meth:`done`)."""
        with self._lock:
            if self._report is None:
                self._report = self._build_report()
            return self._report

    def _build_report(self) -> ModelsReport:
        calls: list[ModelCall] = []
        scene: SceneEvidence | None = None
        detections: tuple[Detection, ...] | None = None
        scene_latency = detector_latency = 0.0
        if self._scene is not None:
            scene, scene_calls = self._scene.result()
            calls.extend(scene_calls)
            scene_latency = sum(c.latency_s for c in scene_calls if c.source == "vlm")
        if self._detector is not None:
            detections, detector_call = self._detector.result()
            calls.append(detector_call)
            detector_latency = detector_call.latency_s
        errors = [c.error for c in calls if c.error is not None]
        errors += [e for e in self._drain_errors() if e not in errors]
        result = PerceptionResult(
            scene=scene,
            detections=detections,
            observation_stamp_s=self._stamp_s,
            scene_latency_s=scene_latency,
            detector_latency_s=detector_latency,
            errors=tuple(errors),
        )
        return ModelsReport(result=result, calls=tuple(calls))

    def cancel(self) -> None:
        """Drop the view: queued requests are not sent; a request already sent finishes unseen."""
        self._cancelled = True
        for future in (self._scene, self._detector):
            if future is not None:
                future.cancel()


class ModelsPerception:
    """Real models as a ``PerceptionSource`` (see the module docstring).

    Args:
        vlm: the scene-level VLM, or None.
        detector: the open-vocabulary detector, or None.
        relevance: returns the mission's LLM relevance scorer, or None when the mission uses another; asked
            at each ``submit`` (the scorer may be built after the source). Its errors are reported here,
            and it scores each view's labels in the worker when ``prefetch`` is set.
        prefetch: score each view's labels with the relevance scorer before the job is done.

    Raises:
        ValueError: when neither a VLM nor a detector is given.
    """

    def __init__(
        self,
        *,
        vlm: SceneVLM | None,
        detector: Detector | None,
        relevance: Callable[[], LLMRelevance | None] = lambda: None,
        prefetch: bool = True,
    ) -> None:
        if vlm is None and detector is None:
            raise ValueError("the models perception source needs a VLM or a detector (configure one)")
        self.vlm = vlm
        self.detector = detector
        self.relevance = relevance
        self.prefetch = prefetch
        # One thread per model, two deep: a view abandoned by the tree (a time-out) may still hold one.
        self._vlm_pool = ThreadPoolExecutor(max_workers=2, thread_name_prefix="semexp-vlm") if vlm else None
        self._detector_pool = (
            ThreadPoolExecutor(max_workers=1, thread_name_prefix="semexp-detector") if detector else None
        )
        self._in_flight = 0
        self._lock = threading.Lock()
        self._calls: dict[str, list[ModelCall]] = {}

    def in_flight(self) -> int:
        """Model requests submitted and not yet finished."""
        with self._lock:
            return self._in_flight

    def call_stats(self) -> dict[str, dict[str, Any]]:
        """Per model (``vlm``, ``detector``, ``llm``): calls, failures and latency quantiles in seconds,
        over every view this source has finished (abandoned ones included). A mission's record carries
        them (``models.calls``): how a real model's cost is read off a run."""
        with self._lock:
            calls = {source: list(items) for source, items in self._calls.items()}
        out: dict[str, dict[str, Any]] = {}
        for source, items in calls.items():
            latency = np.array([c.latency_s for c in items])
            out[source] = {
                "calls": len(items),
                "failures": sum(not c.ok for c in items),
                "latency_s": {
                    "median": round(float(np.median(latency)), 4),
                    "p95": round(float(np.percentile(latency, 95)), 4),
                    "max": round(float(latency.max()), 4),
                },
            }
        return out

    def _track(self, future: Future[Any]) -> None:
        """Count ``future`` in :meth:`in_flight` until it finishes, fails or is cancelled; keep its calls."""
        with self._lock:
            self._in_flight += 1

        def finished(done: Future[Any]) -> None:
            calls: tuple[ModelCall, ...] = ()
            if not done.cancelled() and done.exception() is None:
                answer = done.result()[1]
                calls = answer if isinstance(answer, tuple) else (answer,)
            with self._lock:
                self._in_flight -= 1
                for call in calls:
                    kept = self._calls.setdefault(call.source, [])
                    if len(kept) < MAX_KEPT_CALLS:
                        kept.append(call)

        future.add_done_callback(finished)

    def submit(
        self, *, observation: Observation, instruction: str, target_label: str, motion: Twist, now_s: float
    ) -> ModelsJob:
        del motion, now_s  # real models see the frame; the job ignores the backend clock
        rgb = np.array(observation.rgb, copy=True)
        stamp = float(observation.stamp_s)
        relevance = self.relevance()
        scene_future = detector_future = None
        if self.vlm is not None and self._vlm_pool is not None:
            vlm = self.vlm
            scene_future = self._vlm_pool.submit(
                self._scene_work, vlm, relevance, rgb, instruction, target_label, stamp
            )
            self._track(scene_future)
        if self.detector is not None and self._detector_pool is not None:
            detector = self.detector
            detector_future = self._detector_pool.submit(self._detector_work, detector, rgb, target_label)
            self._track(detector_future)
        return ModelsJob(
            scene=scene_future,
            detector=detector_future,
            stamp_s=stamp,
            drain_errors=relevance.drain_errors if relevance is not None else list,
        )

    def _scene_work(
        self,
        vlm: SceneVLM,
        relevance: LLMRelevance | None,
        rgb: np.ndarray,
        instruction: str,
        target_label: str,
        stamp_s: float,
    ) -> tuple[SceneEvidence | None, tuple[ModelCall, ...]]:
        start = time.perf_counter()
        try:
            scene: SceneCall = vlm.perceive(
                rgb=rgb, instruction=instruction, target_label=target_label, stamp_s=stamp_s
            )
        except Exception as exc:
            return None, (_failed_call("vlm", vlm.transport.model, exc, start),)
        calls: tuple[ModelCall, ...] = (scene.call,)
        if self.prefetch and relevance is not None:
            labels = [target_label] + ([p.label for p in scene.evidence.proposals] if scene.evidence else [])
            t_prefetch = time.perf_counter()
            try:
                calls += relevance.prefetch(instruction=instruction, labels=labels)
            except Exception as exc:
                calls += (_failed_call("llm", relevance.transport.model, exc, t_prefetch),)
        return scene.evidence, calls

    def _detector_work(
        self, detector: Detector, rgb: np.ndarray, target_label: str
    ) -> tuple[tuple[Detection, ...] | None, ModelCall]:
        start = time.perf_counter()
        try:
            return detect_safely(detector, rgb, target_label)
        except Exception as exc:
            return None, _failed_call("detector", detector.name, exc, start)

    def close(self) -> None:
        """Stop the worker threads (requests already sent are not waited for)."""
        for pool in (self._vlm_pool, self._detector_pool):
            if pool is not None:
                pool.shutdown(wait=False, cancel_futures=True)
