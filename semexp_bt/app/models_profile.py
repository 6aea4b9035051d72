"""Reading a models profile (YAML) into ``semexp_bt.perception.model_config.ModelsProfile``.

A profile names the real models perception runs (``semexp-bt run ... --perception models --models
PROFILE``, ``semexp-bt perceive ... --models PROFILE``); ``docs/perception.md`` shows a whole one.
Every key is checked: an unknown key, a missing one, a wrong type or an out-of-range value is a
:class:`ConfigError` naming the file and the dotted key (``detector.box_treshold``). The profile holds
the *names* of the environment variables with API keys, never a key.

``--vlm-url URL --vlm-model NAME`` (and ``--llm-url``, ``--llm-model``) point at a server without
writing a profile, or override a profile's endpoint; the key then comes from ``OPENAI_API_KEY`` when
that is set.

Example:
    >>> profile = profile_from_mapping(
    ...     {"vlm": {"base_url": "http://127.0.0.1:8000/v1", "model": "Qwen/Qwen2.5-VL-7B-Instruct"}},
    ...     where="profile.yaml",
    ... )
    >>> profile.vlm.timeout_s, profile.detector
    (30.0, None)
"""

from __future__ import annotations

import argparse
import dataclasses
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any, get_type_hints

from semexp_bt.core.config import ConfigError, config_from_dict
from semexp_bt.files.yaml_source import YamlSourceError, load_yaml_file
from semexp_bt.perception.model_config import (
    DEVICE,
    ENV_NAME,
    CircuitBreakerConfig,
    DetectorConfig,
    LLMConfig,
    ModelsProfile,
    SimulationConfig,
    VLMConfig,
)

#: The environment variable the command-line endpoints read their key from (when it is set).
FLAG_KEY_ENV = "OPENAI_API_KEY"
#: Profile sections and their dataclasses.
SECTIONS: dict[str, type] = {
    "vlm": VLMConfig,
    "llm": LLMConfig,
    "detector": DetectorConfig,
    "circuit_breaker": CircuitBreakerConfig,
    "simulation": SimulationConfig,
}


def read_models_profile(path: Path) -> ModelsProfile:
    """The profile in a YAML file, read by the product's one safe YAML reader (``semexp_bt.files.yaml_source``: not a
    regular file, too big, not UTF-8, tabs, deep nesting, alias bombs, duplicate keys and non-plain tags
    are refused).

    Raises:
        ConfigError: one line naming the file (and the line and column, or the dotted key).
    """
    try:
        document = load_yaml_file(path)
    except YamlSourceError as exc:
        raise ConfigError(f"models profile {exc}") from None
    return profile_from_mapping(document, where=str(path))


def _section(cls: type, data: Any, *, where: str, name: str) -> Any:
    if not isinstance(data, dict):
        raise ConfigError(f"{where}: '{name}' must be a mapping, got {type(data).__name__}")
    fields = dataclasses.fields(cls)
    for f in fields:
        if (
            f.default is dataclasses.MISSING
            and f.default_factory is dataclasses.MISSING
            and f.name not in data
        ):
            raise ConfigError(f"{where}: missing key '{name}.{f.name}'")
    hints = get_type_hints(cls)
    for key, value in data.items():
        if hints.get(key) is str and not isinstance(value, str):
            raise ConfigError(f"{where}: key '{name}.{key}' must be a string, got {value!r}")
    section = config_from_dict(data, cls=cls, where=where, prefix=name)
    _check_strings(section, where=where, name=name)
    return section


def _check_strings(section: Any, *, where: str, name: str) -> None:
    base_url = getattr(section, "base_url", None)
    if base_url is not None and not base_url.startswith(("http://", "https://")):
        raise ConfigError(
            f"{where}: key '{name}.base_url' must start with http:// or https://, got {base_url!r}"
        )
    for key in ("model", "weights"):
        value = getattr(section, key, None)
        if value is not None and not value.strip():
            raise ConfigError(f"{where}: key '{name}.{key}' must not be empty")
    key_env = getattr(section, "api_key_env", "")
    if key_env and not ENV_NAME.match(key_env):
        raise ConfigError(
            f"{where}: key '{name}.api_key_env' must be the NAME of an environment variable (not a key), "
            f"like OPENAI_API_KEY"
        )
    device = getattr(section, "device", None)
    if device is not None and not DEVICE.match(device):
        raise ConfigError(f"{where}: key '{name}.device' must be cpu, cuda, cuda:N or mps, got {device!r}")


def profile_from_mapping(data: Any, *, where: str) -> ModelsProfile:
    """A profile from parsed YAML (``None`` is an empty profile).

    Raises:
        ConfigError: naming ``where`` and the dotted key.
    """
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"{where}: a models profile must be a mapping, got {type(data).__name__}")
    unknown = sorted(set(map(str, data)) - set(SECTIONS))
    if unknown:
        raise ConfigError(f"{where}: unknown key '{unknown[0]}'; expected one of {sorted(SECTIONS)}")
    sections = {name: _section(SECTIONS[name], value, where=where, name=name) for name, value in data.items()}
    return ModelsProfile(**sections, source=where)


def with_endpoint_flags(
    profile: ModelsProfile | None,
    *,
    vlm_url: str | None = None,
    vlm_model: str | None = None,
    llm_url: str | None = None,
    llm_model: str | None = None,
    environ: Mapping[str, str] | None = None,
) -> ModelsProfile | None:
    """``profile`` with the command line's endpoints laid over it (a new section where it had none).

    A section made from flags takes its key from ``OPENAI_API_KEY`` when that is set, and sends none
    otherwise; a flag only replaces the URL or model of a profile's section.

    Raises:
        ConfigError: a URL without a model (or the reverse) for a section the profile lacks, or a URL that
            is not http(s).
    """
    env = os.environ if environ is None else environ
    flags = {"vlm": (vlm_url, vlm_model), "llm": (llm_url, llm_model)}
    if all(url is None and model is None for url, model in flags.values()):
        return profile
    base = profile if profile is not None else ModelsProfile(source="<command line>")
    changes: dict[str, Any] = {}
    for name, (url, model) in flags.items():
        if url is None and model is None:
            continue
        current = getattr(base, name)
        if current is None:
            if url is None or model is None:
                raise ConfigError(
                    f"{base.source}: no '{name}' section, so --{name}-url and --{name}-model are both needed"
                )
            values = {
                "base_url": url,
                "model": model,
                "api_key_env": FLAG_KEY_ENV if env.get(FLAG_KEY_ENV) else "",
            }
            changes[name] = _section(SECTIONS[name], values, where="<command line>", name=name)
        else:
            replaced = dataclasses.replace(
                current, **({"base_url": url} if url else {}), **({"model": model} if model else {})
            )
            _check_strings(replaced, where="<command line>", name=name)
            changes[name] = replaced
    return dataclasses.replace(base, **changes)


def add_models_arguments(parser: argparse.ArgumentParser) -> None:
    """``--models PROFILE`` and the endpoint flags (shared by ``run`` and ``perceive``)."""
    parser.add_argument("--models", type=Path, default=None, help="models profile (YAML; docs/perception.md)")
    parser.add_argument(
        "--vlm-url", default=None, help="OpenAI-compatible VLM endpoint, e.g. http://127.0.0.1:8000/v1"
    )
    parser.add_argument("--vlm-model", default=None, help="the VLM's model name on that server")
    parser.add_argument("--llm-url", default=None, help="OpenAI-compatible endpoint of the relevance LLM")
    parser.add_argument("--llm-model", default=None, help="the relevance LLM's model name on that server")


def models_profile_from_args(args: argparse.Namespace) -> ModelsProfile | None:
    """The profile the command line asks for (``--models`` with the endpoint flags over it), or None.

    Raises:
        ConfigError: naming the file or the flag.
    """
    profile = read_models_profile(args.models) if args.models is not None else None
    return with_endpoint_flags(
        profile,
        vlm_url=args.vlm_url,
        vlm_model=args.vlm_model,
        llm_url=args.llm_url,
        llm_model=args.llm_model,
    )
