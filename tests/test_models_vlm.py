"""The scene-level VLM adapter against a real chat-completions server on 127.0.0.1.

Each scripted reply is checked twice: what the adapter yields (evidence, or None and an error) and what
the record shows when the tree's ``Perceive`` runs on the models perception source (its
``perception_error`` events and the scene evidence it wrote), and that the request carried the frame as
an image content part and the model's name.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import py_trees
import pytest

pytest.importorskip("openai")
pytest.importorskip("jsonschema")

from semexp_bt.core.types import SceneProposal
from semexp_bt.perception.adapters.source import ModelsPerception
from semexp_bt.perception.prompts import SCENE_PROPOSALS, load_prompt
from sims.scripted_chat_server import ScriptedChatServer, ScriptedReply, decode_image
from tests.models_support import (
    HEIGHT,
    INSTRUCTION,
    TARGET,
    WIDTH,
    frame,
    perceive_once,
    scene_json,
    scene_vlm,
)


@pytest.fixture()
def server() -> Iterator[ScriptedChatServer]:
    with ScriptedChatServer([ScriptedReply(content=scene_json())]) as running:
        yield running


def ask(server: ScriptedChatServer, reply: ScriptedReply, **overrides: object):  # type: ignore[no-untyped-def]
    server.set_script([reply])
    vlm = scene_vlm(server.url, **overrides)  # type: ignore[arg-type]
    return vlm.perceive(rgb=frame(), instruction=INSTRUCTION, target_label=TARGET, stamp_s=1.5)


def test_a_well_formed_reply_becomes_scene_evidence_and_the_request_carries_image_and_model(
    server: ScriptedChatServer,
) -> None:
    scene = ask(server, ScriptedReply(content=scene_json()))
    print(scene)
    assert scene.call.ok and scene.call.error is None
    assert scene.evidence is not None
    assert scene.evidence.proposals == (
        SceneProposal(point_px=(150.0, 120.0), label=TARGET, kind="object"),
        SceneProposal(point_px=(300.0, 200.0), label="open corridor", kind="direction"),
    )
    assert scene.evidence.scene_confidence == 0.8 and scene.evidence.stamp_s == 1.5
    assert set(scene.call.timings_ms) == {"encode", "request", "parse"}

    (request,) = server.requests
    body = request.body
    assert request.path == "/v1/chat/completions"
    assert body["model"] == "Qwen/Qwen2.5-VL-7B-Instruct" and body["temperature"] == 0.0
    sent = request.image_data_url()
    assert sent is not None and sent.startswith("data:image/png;base64,")
    np.testing.assert_array_equal(decode_image(sent), frame())  # PNG: the very frame, lossless
    assert f"{WIDTH} pixels wide and {HEIGHT} pixels high" in request.text()
    assert json.dumps(INSTRUCTION) in request.text() and json.dumps(TARGET) in request.text()
    prompt = load_prompt(SCENE_PROPOSALS)
    assert body["response_format"] == {
        "type": "json_schema",
        "json_schema": {"name": prompt.name, "schema": prompt.schema, "strict": True},
    }
    assert "authorization" in request.headers and "no-key" in request.headers["authorization"]


def test_json_mode_and_no_mode_change_only_the_response_format(server: ScriptedChatServer) -> None:
    assert ask(server, ScriptedReply(content=scene_json()), response_format="json_object").evidence
    assert server.requests[-1].body["response_format"] == {"type": "json_object"}
    assert ask(server, ScriptedReply(content=scene_json()), response_format="none").evidence
    assert "response_format" not in server.requests[-1].body


def test_jpeg_frames_are_sent_as_jpeg(server: ScriptedChatServer) -> None:
    ask(server, ScriptedReply(content=scene_json()), image_format="jpeg", jpeg_quality=80)
    sent = server.requests[-1].image_data_url()
    assert sent is not None and sent.startswith("data:image/jpeg;base64,")
    assert decode_image(sent).shape == (HEIGHT, WIDTH, 3)


def test_json_in_a_code_fence_is_read(server: ScriptedChatServer) -> None:
    scene = ask(server, ScriptedReply(content="```json\n" + scene_json() + "\n```"))
    assert scene.call.ok and scene.evidence is not None and len(scene.evidence.proposals) == 2


def test_normalized_points_are_converted_to_pixels(server: ScriptedChatServer) -> None:
    reply = scene_json([{"kind": "object", "label": TARGET, "point": [500, 1000]}])
    scene = ask(server, ScriptedReply(content=reply), point_format="normalized_1000")
    assert scene.evidence is not None
    assert scene.evidence.proposals[0].point_px == pytest.approx((0.5 * (WIDTH - 1), HEIGHT - 1))


def test_proposals_beyond_max_proposals_are_dropped(server: ScriptedChatServer) -> None:
    many = [{"kind": "direction", "label": f"door {i}", "point": [i, i]} for i in range(5)]
    scene = ask(server, ScriptedReply(content=scene_json(many)), max_proposals=3)
    assert scene.evidence is not None
    assert [p.label for p in scene.evidence.proposals] == ["door 0", "door 1", "door 2"]


BAD_REPLIES = {
    "prose around JSON": (
        ScriptedReply(content="Sure! Here it is: " + scene_json() + " Hope it helps."),
        "not JSON",
    ),
    "truncated JSON": (ScriptedReply(content=scene_json()[:40]), "not JSON"),
    "cut at max_tokens": (ScriptedReply(content=scene_json()[:40], finish_reason="length"), "truncated"),
    "empty reply": (ScriptedReply(content="   "), "empty reply"),
    "wrong schema: no scene_confidence": (
        ScriptedReply(content=json.dumps({"proposals": []})),
        "'scene_confidence' is a required property",
    ),
    "wrong schema: a three-number point": (
        ScriptedReply(content=scene_json([{"kind": "object", "label": TARGET, "point": [1, 2, 3]}])),
        "proposals[0].point",
    ),
    "wrong schema: an unknown kind": (
        ScriptedReply(content=scene_json([{"kind": "thing", "label": TARGET, "point": [1, 2]}])),
        "proposals[0].kind",
    ),
    "out of range: a point off the image": (
        ScriptedReply(content=scene_json([{"kind": "object", "label": TARGET, "point": [WIDTH, 10]}])),
        "lies outside the 320x240 image",
    ),
    "out of range: a negative point": (
        ScriptedReply(content=scene_json([{"kind": "object", "label": TARGET, "point": [-1, 10]}])),
        "lies outside",
    ),
    "out of range: C_s above 1": (ScriptedReply(content=scene_json(confidence=1.5)), "scene_confidence"),
    "out of range: NaN": (ScriptedReply(content=scene_json(confidence=0.5).replace("0.5", "NaN")), "NaN"),
    "an empty label": (
        ScriptedReply(content=scene_json([{"kind": "object", "label": "   ", "point": [1, 2]}])),
        "proposals[0].label is empty",
    ),
}


#: Failures of the request itself: (reply, what the error says, endpoint settings).
FAILED_REQUESTS: dict[str, tuple[ScriptedReply, str, dict[str, object]]] = {
    "slow past the timeout": (
        ScriptedReply(content=scene_json(), delay_s=1.5),
        "no reply within the 0.3 s timeout (2 attempts)",
        {"timeout_s": 0.3, "max_retries": 1},
    ),
    "429": (ScriptedReply(status=429, headers={"retry-after-ms": "1"}), "HTTP 429", {"max_retries": 1}),
    "500": (ScriptedReply(status=500, content="internal error"), "HTTP 500: ", {"max_retries": 1}),
}
CASES = {
    **{name: (reply, reason, {}) for name, (reply, reason) in BAD_REPLIES.items()},
    **FAILED_REQUESTS,
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_bad_reply_or_failed_request_yields_no_evidence_and_one_recorded_model_error(
    server: ScriptedChatServer, case: str, tmp_path: Path
) -> None:
    reply, reason, settings = CASES[case]
    scene = ask(server, reply, **settings)
    print(case, "->", scene.call.error)
    assert scene.evidence is None and not scene.call.ok
    assert scene.call.error is not None and reason in scene.call.error
    assert scene.call.error.startswith("vlm Qwen/Qwen2.5-VL-7B-Instruct")
    if case in BAD_REPLIES:
        assert scene.call.reply == reply.content  # what the model returned is kept for the user
    else:
        assert scene.call.reply is None and len(server.requests) == 2  # one retry, then given up

    # The record: the tree's Perceive gets no scene evidence and logs the error; nothing raises.
    source = ModelsPerception(vlm=scene_vlm(server.url, **settings), detector=None)
    result = perceive_once(tmp_path, source)
    source.close()
    errors = [e for e in result.services.events if e["kind"] == "perception_error"]
    print(result.services.events)
    assert len(errors) == 1 and reason in errors[0]["message"]
    assert py_trees.blackboard.Blackboard.get("/scene_evidence") is None
    assert result.outcome == "success"  # Perceive itself succeeded: the view simply has no evidence
    assert result.services.robot.now_s() < 20.0  # answered, not timed out
    assert server.requests[-1].body["model"] == "Qwen/Qwen2.5-VL-7B-Instruct"
    assert server.requests[-1].image_data_url() is not None  # the frame went with the request


def test_the_record_of_a_good_reply_has_the_evidence_and_no_error(
    server: ScriptedChatServer, tmp_path: Path
) -> None:
    server.set_script([ScriptedReply(content=scene_json())])
    source = ModelsPerception(vlm=scene_vlm(server.url), detector=None)
    result = perceive_once(tmp_path, source)
    source.close()
    print(result.services.events)
    assert not [e for e in result.services.events if e["kind"] == "perception_error"]
    written = py_trees.blackboard.Blackboard.get("/scene_evidence")
    assert written is not None and [p.label for p in written.proposals] == [TARGET, "open corridor"]
    assert py_trees.blackboard.Blackboard.get("/detections") is None  # no detector configured
    assert server.requests[-1].image_data_url() is not None
