"""The method's configuration, resolved once, before anything that uses it is built.

Four layers, each laid over the one before (:func:`semexp_bt.core.config.deep_merge`):

1. the defaults (``semexp_bt.core.config``, documented in ``docs/config.md``);
2. the strategy's overrides (``semexp_bt/app/strategies.yaml``);
3. the mission file's ``config:`` section;
4. the command line (``semexp-bt run --config FILE``, or a sweep's overrides).

Each layer is validated on its own first, so that an unknown key or an out-of-range value is reported
against the layer that wrote it (the mission file, the config file), not against the merged result.

Example:
    >>> config = resolve_config(mission_overrides={"memory": {"xi": 0.5}}, mission_source="m.yaml")
    >>> config.memory.xi, config.memory.delta_d
    (0.5, 0.75)
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from semexp_bt.core.config import ConfigError, SemExpConfig, config_from_dict, deep_merge
from semexp_bt.files.yaml_source import YamlSourceError, load_yaml_file


def resolve_config(
    *,
    strategy_overrides: Mapping[str, Any] | None = None,
    mission_overrides: Mapping[str, Any] | None = None,
    command_line_overrides: Mapping[str, Any] | None = None,
    strategy_source: str = "<strategy>",
    mission_source: str = "<mission>",
    command_line_source: str = "<command line>",
) -> SemExpConfig:
    """The effective configuration: defaults < strategy < mission file < command line.

    Args:
        strategy_overrides: the strategy's nested overrides.
        mission_overrides: the mission file's ``config:`` section.
        command_line_overrides: overrides given on the command line (or by a sweep).
        strategy_source: how errors name the strategy layer.
        mission_source: how errors name the mission layer (its file).
        command_line_source: how errors name the command-line layer (a config file's path).

    Raises:
        ConfigError: naming the layer's source and the key when a layer is invalid.
    """
    merged: dict[str, Any] = {}
    for overrides, source in (
        (strategy_overrides, strategy_source),
        (mission_overrides, mission_source),
        (command_line_overrides, command_line_source),
    ):
        if not overrides:
            continue
        config_from_dict(dict(overrides), where=source)
        merged = deep_merge(merged, overrides)
    return config_from_dict(merged, where="<resolved configuration>")


def read_config_file(path: Path) -> dict[str, Any]:
    """The overrides in a YAML config file (top level: any of ``arbitration``, ``memory``, ``decision``).

    The file is read by the product's one safe YAML reader (``semexp_bt.files.yaml_source``): not a regular file,
    too big, not UTF-8, tabs, deep nesting, alias bombs, duplicate keys and non-plain tags are refused.

    Raises:
        ConfigError: one line naming the file (and the line and column where there is one) when it
            cannot be read, is not plain YAML, or is not a mapping of valid keys.
    """
    try:
        loaded = load_yaml_file(path)
    except YamlSourceError as exc:
        raise ConfigError(f"config file {exc}") from None
    if loaded is None:
        return {}
    if not isinstance(loaded, dict):
        raise ConfigError(f"{path}: top level must be a mapping, got {type(loaded).__name__}")
    config_from_dict(loaded, where=str(path))
    return loaded
