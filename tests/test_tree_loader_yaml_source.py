"""The safe YAML reader (semexp_bt/files/yaml_source.py): each refusal, its one-line message, and what it lets in."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

from semexp_bt.app.configuration import read_config_file
from semexp_bt.core.config import ConfigError
from semexp_bt.files.yaml_source import (
    MAX_ALIASES,
    MAX_EXPANDED_NODES,
    MAX_FILE_BYTES,
    MAX_NESTING_DEPTH,
    YamlLimits,
    YamlSourceError,
    compose_yaml_file,
    load_yaml_file,
)

needs_posix = pytest.mark.skipif(sys.platform == "win32", reason="FIFOs and /dev/null are POSIX")


def refusal(path: Path, roots: list[Path] | None = None) -> str:
    """The one-line message the reader refuses ``path`` with (named as given, relative to its folder)."""
    with pytest.raises(YamlSourceError) as caught:
        load_yaml_file(path, display=path.name, roots=roots)
    message = str(caught.value)
    print(message)
    assert "\n" not in message
    return message


def write(tmp_path: Path, text: str | bytes, name: str = "f.yaml") -> Path:
    path = tmp_path / name
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text, encoding="utf-8")
    return path


def test_plain_yaml_loads_with_safe_types(tmp_path: Path) -> None:
    path = write(tmp_path, "a: 1\nb: [x, 2.5, true, null]\nc: &c {d: e}\nf: *c\n")
    assert load_yaml_file(path) == {"a": 1, "b": ["x", 2.5, True, None], "c": {"d": "e"}, "f": {"d": "e"}}
    assert load_yaml_file(write(tmp_path, "# only a comment\n", "empty.yaml")) is None


def test_marks_name_the_displayed_file(tmp_path: Path) -> None:
    root = compose_yaml_file(write(tmp_path, "a:\n  b: 1\n"), display="missions/f.yaml")
    assert root is not None
    assert root.start_mark.name == "missions/f.yaml"


# --------------------------------------------------------------------------------------------------
# The file itself
# --------------------------------------------------------------------------------------------------


def test_missing_file(tmp_path: Path) -> None:
    assert refusal(tmp_path / "nope.yaml") == "nope.yaml: not found"


def test_directory(tmp_path: Path) -> None:
    (tmp_path / "folder.yaml").mkdir()
    assert refusal(tmp_path / "folder.yaml") == "folder.yaml: not a regular file (a directory)"


@needs_posix
def test_fifo_is_refused_without_blocking(tmp_path: Path) -> None:
    fifo = tmp_path / "pipe.yaml"
    os.mkfifo(fifo)
    assert refusal(fifo) == "pipe.yaml: not a regular file (a FIFO)"  # opening it would block forever


@needs_posix
def test_character_device(tmp_path: Path) -> None:
    link = tmp_path / "null.yaml"
    link.symlink_to("/dev/null")
    assert refusal(link) == "null.yaml: not a regular file (a character device)"


def test_symlink_loop(tmp_path: Path) -> None:
    (tmp_path / "a.yaml").symlink_to("b.yaml")
    (tmp_path / "b.yaml").symlink_to("a.yaml")
    assert refusal(tmp_path / "a.yaml") == "a.yaml: symlink loop (too many levels of symbolic links)"


def test_dangling_symlink(tmp_path: Path) -> None:
    (tmp_path / "gone.yaml").symlink_to("missing.yaml")
    assert refusal(tmp_path / "gone.yaml") == "gone.yaml: is a symlink to a missing file"


def test_roots_confine_the_resolved_path(tmp_path: Path) -> None:
    inside, outside = tmp_path / "inside", tmp_path / "outside"
    inside.mkdir()
    outside.mkdir()
    write(outside, "a: 1\n", "secret.yaml")
    write(inside, "a: 2\n", "own.yaml")
    (inside / "link.yaml").symlink_to(outside / "secret.yaml")
    (inside / "link_in.yaml").symlink_to("own.yaml")
    real_inside = os.path.realpath(inside)
    real_secret = os.path.realpath(outside / "secret.yaml")
    expected = f"resolves to {real_secret}, outside the allowed folders ({real_inside})"
    assert refusal(inside / "link.yaml", roots=[inside]) == f"link.yaml: {expected}"
    assert refusal(inside / ".." / "outside" / "secret.yaml", roots=[inside]) == f"secret.yaml: {expected}"
    assert load_yaml_file(inside / "link_in.yaml", roots=[inside]) == {"a": 2}  # a link that stays inside
    assert load_yaml_file(inside / "link.yaml") == {"a": 1}  # a file the user names may link anywhere


def test_size_cap(tmp_path: Path) -> None:
    at_cap = write(tmp_path, "a: " + "x" * (MAX_FILE_BYTES - 4) + "\n", "at_cap.yaml")
    assert at_cap.stat().st_size == MAX_FILE_BYTES
    assert load_yaml_file(at_cap) == {"a": "x" * (MAX_FILE_BYTES - 4)}
    over = write(tmp_path, "a: " + "x" * (MAX_FILE_BYTES - 3) + "\n", "over.yaml")
    assert refusal(over) == f"over.yaml: larger than {MAX_FILE_BYTES} bytes (the reader's cap)"


# --------------------------------------------------------------------------------------------------
# The text
# --------------------------------------------------------------------------------------------------


def test_not_utf8_is_located(tmp_path: Path) -> None:
    path = write(tmp_path, "tree:\n  type: ok\xc3\xa9 \xff\xfe\n".encode("latin-1"))
    assert refusal(path) == "f.yaml:2:13: not UTF-8 text: byte 0xff (invalid start byte)"


def test_utf8_byte_order_mark_is_accepted(tmp_path: Path) -> None:
    assert load_yaml_file(write(tmp_path, "\ufeffa: é\n")) == {"a": "é"}


def test_control_character(tmp_path: Path) -> None:
    assert refusal(write(tmp_path, "a: 1\nb: x\x00y\n")) == (
        "f.yaml:2:5: control character U+0000 is not allowed in YAML"
    )


def test_tab_in_indentation(tmp_path: Path) -> None:
    assert refusal(write(tmp_path, "tree:\n  type: x\n \tname: y\n")) == (
        "f.yaml:3:2: tab in indentation; YAML indents with spaces"
    )


def test_syntax_error_is_one_located_line(tmp_path: Path) -> None:
    message = refusal(write(tmp_path, "a: [1, 2\nb: 3\n"))
    assert message.startswith("f.yaml:2:2: YAML syntax error: ")


def test_one_document_only(tmp_path: Path) -> None:
    message = refusal(write(tmp_path, "a: 1\n---\nb: 2\n"))
    assert message == (
        "f.yaml:2:1: YAML syntax error: but found another document "
        "(expected a single document in the stream at line 1)"
    )


# --------------------------------------------------------------------------------------------------
# The structure
# --------------------------------------------------------------------------------------------------


def test_nesting_cap_flow_and_block(tmp_path: Path) -> None:
    ok = "[" * MAX_NESTING_DEPTH + "]" * MAX_NESTING_DEPTH
    assert load_yaml_file(write(tmp_path, ok, "ok.yaml")) is not None
    flow = "[" * 60_000  # far deeper than Python's recursion limit: refused at level 65, unparsed beyond
    assert refusal(write(tmp_path, flow)) == (
        f"f.yaml:1:{MAX_NESTING_DEPTH + 1}: nested deeper than {MAX_NESTING_DEPTH} levels (the reader's cap)"
    )
    block = (
        "".join("  " * level + f"k{level}:\n" for level in range(MAX_NESTING_DEPTH + 1)) + "  " * 70 + "v\n"
    )
    assert refusal(write(tmp_path, block, "block.yaml")) == (
        f"block.yaml:{MAX_NESTING_DEPTH + 1}:{2 * MAX_NESTING_DEPTH + 1}: nested deeper than "
        f"{MAX_NESTING_DEPTH} levels (the reader's cap)"
    )


def test_billion_laughs(tmp_path: Path) -> None:
    lines = ["l0: &l0 [x, x, x, x, x, x, x, x, x, x]"]
    lines += [f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * 10)}]" for i in range(1, 9)]
    message = refusal(write(tmp_path, "\n".join(lines) + "\n"))
    # l3 expands to 11,111 nodes; the eighth alias in l4 takes the file past the cap of 100,000.
    assert (
        message
        == f"f.yaml:5:45: more than {MAX_EXPANDED_NODES} nodes with aliases expanded (the reader's cap)"
    )


def test_alias_count_cap(tmp_path: Path) -> None:
    text = "a: &a x\nb: [" + ", ".join(["*a"] * (MAX_ALIASES + 1)) + "]\n"
    message = refusal(write(tmp_path, text))
    assert message == f"f.yaml:2:{5 + 4 * MAX_ALIASES}: more than {MAX_ALIASES} aliases (the reader's cap)"


def test_recursive_alias(tmp_path: Path) -> None:
    assert refusal(write(tmp_path, "a: &a\n  b: *a\n")) == (
        "f.yaml:2:6: alias '*a' refers to a collection that contains it (recursive)"
    )


@pytest.mark.parametrize(
    ("text", "tag"),
    [
        ("a: !!python/object/apply:os.system [ls]\n", "!!python/object/apply:os.system"),
        ("a: !!python/name:os.system\n", "!!python/name:os.system"),
        ("a: !custom {b: 1}\n", "!custom"),
        ("a: !!binary aGVsbG8=\n", "!!binary"),
        ("a: !!set {x}\n", "!!set"),
        ("%TAG !p! tag:yaml.org,2002:python/\n---\na: !p!tuple [1]\n", "!!python/tuple"),
    ],
)
def test_only_plain_tags(tmp_path: Path, text: str, tag: str) -> None:
    line = text.count("\n") if text.startswith("%") else 1
    assert refusal(write(tmp_path, text)) == (
        f"f.yaml:{line}:4: tag '{tag}' is not allowed: only plain values are read "
        "(strings, numbers, booleans, null, lists, mappings)"
    )


def test_explicit_plain_tags_are_fine(tmp_path: Path) -> None:
    assert load_yaml_file(write(tmp_path, "a: !!str 1\nb: !!int '2'\nc: ! x\n")) == {
        "a": "1",
        "b": 2,
        "c": "x",
    }


def test_duplicate_key_first_in_the_file(tmp_path: Path) -> None:
    text = "a: 1\nb:\n  c: 2\n  c: 3\na: 4\n"
    assert refusal(write(tmp_path, text)) == "f.yaml:4:3: duplicate key 'c' (first given at line 3)"


def test_invalid_scalar_value_is_located(tmp_path: Path) -> None:
    assert refusal(write(tmp_path, "a: 1\nb: [x, 2024-13-45]\n")) == (
        "f.yaml:2:8: invalid value: month must be in 1..12"
    )
    assert (
        refusal(write(tmp_path, "? [a]\n: 1\n", "key.yaml"))
        == "key.yaml:1:3: invalid value: found unhashable key"
    )
    assert refusal(write(tmp_path, "a: " + "9" * 5000 + "\n", "long.yaml")) == (
        f"long.yaml:1:4: invalid value: integer longer than {sys.get_int_max_str_digits()} digits"
    )


def test_limits_are_parameters(tmp_path: Path) -> None:
    path = write(tmp_path, "a: [[1]]\n")
    with pytest.raises(YamlSourceError, match="nested deeper than 2 levels"):
        load_yaml_file(path, limits=YamlLimits(max_depth=2))


# --------------------------------------------------------------------------------------------------
# The config file reader uses it
# --------------------------------------------------------------------------------------------------


def test_config_file_refusals_are_config_errors(tmp_path: Path) -> None:
    (tmp_path / "dir.yaml").mkdir()
    with pytest.raises(ConfigError, match=r"^config file .*dir\.yaml: not a regular file \(a directory\)$"):
        read_config_file(tmp_path / "dir.yaml")
    tagged = write(tmp_path, "memory: !!python/object/apply:os.system [ls]\n")
    with pytest.raises(
        ConfigError, match=r"f\.yaml:1:9: tag '!!python/object/apply:os\.system' is not allowed"
    ):
        read_config_file(tagged)
    assert read_config_file(write(tmp_path, "memory: {xi: 0.5}\n", "good.yaml")) == {"memory": {"xi": 0.5}}
