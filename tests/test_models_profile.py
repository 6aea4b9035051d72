"""Models profiles: every key checked against the file that wrote it, the endpoint flags, the shipped
example profile, and the command line's errors."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from semexp_bt.app.models_profile import profile_from_mapping, read_models_profile, with_endpoint_flags
from semexp_bt.cli import main
from semexp_bt.core.config import ConfigError
from semexp_bt.perception.model_config import DetectorConfig, LLMConfig, VLMConfig

ROOT = Path(__file__).resolve().parents[1]
PROFILES = ROOT / "profiles"
MISSION = ROOT / "trees" / "object_search.yaml"
VLM = {"base_url": "http://127.0.0.1:8000/v1", "model": "Qwen/Qwen2.5-VL-7B-Instruct"}


def test_a_full_profile_is_read_into_typed_sections(tmp_path: Path) -> None:
    path = tmp_path / "profile.yaml"
    path.write_text(
        "vlm: {base_url: 'http://gpu:8000/v1', model: qwen, timeout_s: 12, response_format: json_object}\n"
        "llm: {base_url: 'https://api.openai.com/v1', model: gpt-4o, api_key_env: OPENAI_API_KEY, batch_size: 8}\n"
        "detector: {kind: owlv2, weights: /models/owlv2, device: 'cuda:1', box_threshold: 0.2}\n"
        "circuit_breaker: {failures_to_open: 5}\n"
        "simulation: {real_time_factor: 0}\n"
    )
    profile = read_models_profile(path)
    print(profile)
    assert profile.vlm == VLMConfig(
        base_url="http://gpu:8000/v1", model="qwen", timeout_s=12.0, response_format="json_object"
    )
    assert (
        isinstance(profile.llm, LLMConfig)
        and profile.llm.batch_size == 8
        and profile.llm.api_key_env == "OPENAI_API_KEY"
    )
    assert profile.detector == DetectorConfig(
        kind="owlv2", weights="/models/owlv2", device="cuda:1", box_threshold=0.2
    )
    assert profile.circuit_breaker.failures_to_open == 5 and profile.simulation.real_time_factor == 0.0
    assert profile.source == str(path) and profile.enabled_sources() == ("vlm", "llm", "detector")


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"vlms": {}}, "unknown key 'vlms'"),
        ({"vlm": {"model": "q"}}, "missing key 'vlm.base_url'"),
        ({"vlm": {**VLM, "timeout": 3}}, "unknown key 'vlm.timeout'"),
        ({"vlm": {**VLM, "timeout_s": 0}}, "key 'vlm.timeout_s' must lie in (0.0, 600.0]"),
        ({"vlm": {**VLM, "max_retries": 1.5}}, "key 'vlm.max_retries' must be an integer"),
        ({"vlm": {**VLM, "response_format": "xml"}}, "key 'vlm.response_format' must be one of"),
        ({"vlm": {**VLM, "base_url": "127.0.0.1:8000"}}, "'vlm.base_url' must start with http"),
        ({"vlm": {**VLM, "model": 7}}, "key 'vlm.model' must be a string"),
        ({"vlm": {**VLM, "model": " "}}, "key 'vlm.model' must not be empty"),
        ({"vlm": {**VLM, "api_key_env": "sk-abc123"}}, "must be the NAME of an environment variable"),
        ({"detector": {"kind": "grounding_dino"}}, "missing key 'detector.weights'"),
        ({"detector": {"kind": "dino", "weights": "w"}}, "key 'detector.kind' must be one of"),
        (
            {"detector": {"kind": "owlv2", "weights": "w", "device": "gpu"}},
            "'detector.device' must be cpu, cuda",
        ),
        (
            {"detector": {"kind": "owlv2", "weights": "w", "box_threshold": 2}},
            "'detector.box_threshold' must lie in",
        ),
        ({"circuit_breaker": {"failures_to_open": 0}}, "'circuit_breaker.failures_to_open' must lie in"),
        ({"simulation": {"real_time_factor": -1}}, "'simulation.real_time_factor' must lie in [0.0, 1000.0]"),
        ({"llm": [1, 2]}, "'llm' must be a mapping"),
        ([1, 2], "a models profile must be a mapping"),
    ],
)
def test_a_bad_profile_names_the_file_and_the_key(data: object, message: str) -> None:
    with pytest.raises(ConfigError) as error:
        profile_from_mapping(data, where="my/profile.yaml")
    print(error.value)
    assert str(error.value).startswith("my/profile.yaml: ") and message in str(error.value)


def test_unreadable_and_invalid_files_are_named(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"models profile .*none\.yaml: not found"):
        read_models_profile(tmp_path / "none.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("vlm: [unclosed\n")
    with pytest.raises(ConfigError, match=r"models profile .*bad\.yaml:\d+:\d+: "):
        read_models_profile(bad)
    empty = tmp_path / "empty.yaml"
    empty.write_text("")
    assert read_models_profile(empty).enabled_sources() == ()


def test_endpoint_flags_make_or_override_sections() -> None:
    made = with_endpoint_flags(None, vlm_url="http://127.0.0.1:9/v1", vlm_model="qwen", environ={})
    assert made is not None and made.vlm is not None and made.llm is None
    assert (made.vlm.base_url, made.vlm.model, made.vlm.api_key_env) == ("http://127.0.0.1:9/v1", "qwen", "")
    keyed = with_endpoint_flags(
        None, llm_url="https://x/v1", llm_model="gpt-4o", environ={"OPENAI_API_KEY": "k"}
    )
    assert keyed is not None and keyed.llm is not None and keyed.llm.api_key_env == "OPENAI_API_KEY"
    base = profile_from_mapping({"vlm": {**VLM, "timeout_s": 9}}, where="p.yaml")
    over = with_endpoint_flags(base, vlm_model="other", environ={})
    assert over is not None and over.vlm is not None
    assert (over.vlm.model, over.vlm.base_url, over.vlm.timeout_s) == ("other", VLM["base_url"], 9.0)
    assert with_endpoint_flags(base) is base
    with pytest.raises(ConfigError, match="--llm-url and --llm-model are both needed"):
        with_endpoint_flags(base, llm_url="http://127.0.0.1:9/v1")
    with pytest.raises(ConfigError, match="must start with http"):
        with_endpoint_flags(None, vlm_url="localhost:9", vlm_model="q")


def test_the_shipped_example_profiles_parse() -> None:
    paper = read_models_profile(PROFILES / "qwen_vllm_grounding_dino.yaml")
    assert paper.enabled_sources() == ("vlm", "llm", "detector")
    assert paper.detector is not None and paper.detector.kind == "grounding_dino"
    cloud = read_models_profile(PROFILES / "openai_gpt4o.yaml")
    assert cloud.vlm is not None and cloud.vlm.api_key_env == "OPENAI_API_KEY" and cloud.detector is None


def test_run_needs_a_profile_for_models_perception_and_llm_relevance(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["run", str(MISSION), "--scene", "road", "--perception", "models"]) == 2
    err = capsys.readouterr().err
    assert "the models perception source needs a models profile" in err and "Traceback" not in err
    assert main(["run", str(MISSION), "--scene", "road", "--relevance", "llm"]) == 2
    assert "the llm relevance scorer needs a models profile" in capsys.readouterr().err


def test_run_reports_a_bad_profile_with_its_file_and_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    profile = tmp_path / "p.yaml"
    profile.write_text("detector: {kind: owlv2, weights: w, box_treshold: 0.3}\n")
    assert (
        main(["run", str(MISSION), "--scene", "road", "--perception", "models", "--models", str(profile)])
        == 2
    )
    assert f"{profile}: unknown key 'detector.box_treshold'" in capsys.readouterr().err


def test_the_default_path_imports_no_model_library() -> None:
    """`semexp-bt run` with the emulator pays nothing for the adapters: no openai, transformers or jsonschema."""
    code = (
        "import sys\n"
        "import semexp_bt.cli.run, semexp_bt.cli.perceive, semexp_bt.app.episode, semexp_bt.app.components\n"
        "from semexp_bt.app.components import build_relevance\n"
        "build_relevance('lexical')\n"
        "heavy = [m for m in ('openai', 'transformers', 'jsonschema', 'httpx2', 'ultralytics') if m in sys.modules]\n"
        "print(heavy)\n"
        "assert not heavy, heavy\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert done.returncode == 0, done.stderr
