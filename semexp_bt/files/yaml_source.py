"""The one safe reader for every YAML file a user hands the product (missions, subtrees, config files).

A file is refused, with one line naming it (and the line and column where there is one), in time and
memory bounded by the size cap, when it is:

- not a regular file (a directory, a FIFO, a device, a socket), missing, or a symlink that loops, dangles
  or (for files that must stay inside ``roots``) resolves outside the allowed folders;
- larger than :data:`MAX_FILE_BYTES`, not UTF-8, or holding a control character YAML does not allow;
- indented with tabs (any tab in a line's leading whitespace);
- nested deeper than :data:`MAX_NESTING_DEPTH` collections, holding more than :data:`MAX_ALIASES` aliases
  or more than :data:`MAX_EXPANDED_NODES` nodes once aliases are expanded ("billion laughs"), or holding a
  recursive alias (``&a [*a]``);
- tagged with anything but the plain tags (:data:`PLAIN_TAGS`: strings, numbers, booleans, null, lists,
  mappings), so that no tag can construct a Python object; values are built by PyYAML's
  ``SafeConstructor`` only;
- holding the same key twice in one mapping (PyYAML would silently keep the last).

Depth, aliases and node counts are checked on PyYAML's event stream as the composer consumes it (a
counter, no recursion), so the composer's own recursion never goes deeper than the depth cap, far below
Python's recursion limit.

Symlink policy: a file the user names (``roots=None``) may be a symlink anywhere; it is followed to its
final target, which must exist and be a regular file. A file that must stay inside ``roots`` (an include)
is accepted only when its fully resolved path (every symlink followed) lies inside one of them, so
neither ``../`` nor a symlink can lead out.

Example:
    >>> from semexp_bt.files.yaml_source import load_yaml_file, YamlSourceError
    >>> try:
    ...     load_yaml_file("/dev/null")
    ... except YamlSourceError as exc:
    ...     print(exc)
    /dev/null: not a regular file (a character device)
"""

from __future__ import annotations

import errno
import os
import re
import stat
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

__all__ = [
    "DEFAULT_LIMITS",
    "MAX_ALIASES",
    "MAX_EXPANDED_NODES",
    "MAX_FILE_BYTES",
    "MAX_NESTING_DEPTH",
    "PLAIN_TAGS",
    "YamlLimits",
    "YamlSourceError",
    "compose_yaml_file",
    "load_yaml_file",
    "node_value",
    "read_yaml_text",
    "shorten",
]

#: Largest file read, in bytes. The shipped mission trees are 0.7-2.1 kB; PyYAML's pure-Python parser
#: reads about 100 kB a second on the 2-core reference VM, so a file at the cap parses in under a second.
MAX_FILE_BYTES = 64 * 1024
#: Deepest nesting of collections (mappings and lists). A tree level costs two (a node mapping and its
#: ``children`` list); the shipped trees reach 15. Far below Python's recursion limit (1000).
MAX_NESTING_DEPTH = 64
#: Most aliases (``*name``) in one file.
MAX_ALIASES = 256
#: Most nodes in one file once every alias is expanded (an alias counts as the whole node it names).
MAX_EXPANDED_NODES = 100_000

_CORE = "tag:yaml.org,2002:"
#: The only tags a file may carry, explicitly or by implicit resolution of a collection or a scalar.
PLAIN_TAGS: frozenset[str] = frozenset(
    {"!", *(_CORE + name for name in ("str", "int", "float", "bool", "null", "seq", "map"))}
)
#: File-type names for the refusal message of a file that is not regular.
_FILE_KINDS = (
    (stat.S_ISDIR, "a directory"),
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)
_LEADING_WHITESPACE = re.compile(r"[ \t]*")
_MESSAGE_VALUE_CHARS = 60


@dataclass(frozen=True)
class YamlLimits:
    """Caps on one file; the defaults are the named constants above."""

    max_bytes: int = MAX_FILE_BYTES
    max_depth: int = MAX_NESTING_DEPTH
    max_aliases: int = MAX_ALIASES
    max_nodes: int = MAX_EXPANDED_NODES


DEFAULT_LIMITS = YamlLimits()


class YamlSourceError(ValueError):
    """A file refused by the reader: one line, ``file:line:column: message`` or ``file: message``.

    Attributes:
        file: the file as the caller displays it.
        line: 1-based line, or ``None`` for a problem with the file itself (missing, not regular, too big).
        column: 1-based column, or ``None`` with ``line``.
        message: what is wrong, one line.
        excerpt: for a syntax error, the offending line and the one before it (to hint at a fix).
    """

    def __init__(
        self, file: str, message: str, line: int | None = None, column: int | None = None, excerpt: str = ""
    ) -> None:
        self.file = file
        self.line = line
        self.column = column
        self.message = " ".join(message.split())  # one line, whatever the library said
        self.excerpt = excerpt
        where = f"{file}:{line}:{column}" if line is not None else file
        super().__init__(f"{where}: {self.message}")

    @property
    def is_whole_file(self) -> bool:
        """True when the file could not be opened or read at all (no position inside it)."""
        return self.line is None


def shorten(value: object) -> str:
    """``repr(value)`` cut to a length that fits an error line."""
    text = repr(value)
    return text if len(text) <= _MESSAGE_VALUE_CHARS else text[: _MESSAGE_VALUE_CHARS - 3] + "..."


# ---------------------------------------------------------------------------------------------------
# Bytes to text
# ---------------------------------------------------------------------------------------------------


def _resolve(path: Path, display: str, roots: Sequence[Path] | None) -> Path:
    try:
        real = Path(os.path.realpath(path, strict=True))
    except FileNotFoundError:
        reason = "is a symlink to a missing file" if path.is_symlink() else "not found"
        raise YamlSourceError(display, reason) from None
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise YamlSourceError(display, "symlink loop (too many levels of symbolic links)") from None
        raise YamlSourceError(display, f"unreadable ({exc.strerror})") from None
    except RuntimeError:  # pathlib's loop report on some Python versions
        raise YamlSourceError(display, "symlink loop (too many levels of symbolic links)") from None
    if roots is not None:
        allowed = [Path(os.path.realpath(root)) for root in roots]
        if not any(real.is_relative_to(root) for root in allowed):
            folders = ", ".join(str(root) for root in allowed)
            raise YamlSourceError(display, f"resolves to {real}, outside the allowed folders ({folders})")
    return real


def _refuse_if_not_regular(mode: int, display: str) -> None:
    if stat.S_ISREG(mode):
        return
    kind = next((name for test, name in _FILE_KINDS if test(mode)), "not a plain file")
    raise YamlSourceError(display, f"not a regular file ({kind})")


def _read_bytes(real: Path, display: str, limits: YamlLimits) -> bytes:
    too_big = f"larger than {limits.max_bytes} bytes (the reader's cap)"
    try:
        before = os.stat(real)
        _refuse_if_not_regular(before.st_mode, display)  # before open(): opening a FIFO would block
        if before.st_size > limits.max_bytes:
            raise YamlSourceError(display, too_big)
        # O_NONBLOCK: should the file have been swapped for a FIFO since the stat, open() still returns.
        flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0)
        descriptor = os.open(real, flags)
        with os.fdopen(descriptor, "rb") as stream:
            _refuse_if_not_regular(os.fstat(stream.fileno()).st_mode, display)
            data = stream.read(limits.max_bytes + 1)  # the file may have grown since the stat
    except OSError as exc:
        raise YamlSourceError(display, f"unreadable ({exc.strerror})") from None
    if len(data) > limits.max_bytes:
        raise YamlSourceError(display, too_big)
    return data


def _decode(data: bytes, display: str) -> str:
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        line_start = data.rfind(b"\n", 0, exc.start) + 1
        column = len(data[line_start : exc.start].decode("utf-8", errors="replace")) + 1
        raise YamlSourceError(
            display, f"not UTF-8 text: byte 0x{data[exc.start]:02x} ({exc.reason})", line, column
        ) from None
    text = text.removeprefix("\ufeff")
    bad = yaml.reader.Reader.NON_PRINTABLE.search(text)  # PyYAML's own rule, checked here to locate it
    if bad is not None:
        line, column = _position(text, bad.start())
        raise YamlSourceError(
            display, f"control character U+{ord(bad.group()):04X} is not allowed in YAML", line, column
        )
    for number, content in enumerate(text.splitlines(), start=1):
        indent = _LEADING_WHITESPACE.match(content)
        if indent is not None and "\t" in indent.group():
            raise YamlSourceError(
                display,
                "tab in indentation; YAML indents with spaces",
                number,
                indent.group().index("\t") + 1,
            )
    return text


def _position(text: str, index: int) -> tuple[int, int]:
    line = text.count("\n", 0, index) + 1
    return line, index - (text.rfind("\n", 0, index) + 1) + 1


def read_yaml_text(
    path: str | Path,
    *,
    display: str | None = None,
    roots: Sequence[Path] | None = None,
    limits: YamlLimits = DEFAULT_LIMITS,
) -> str:
    """The text of a YAML file, after the file-level checks (type, symlinks, size, UTF-8, tabs).

    Args:
        path: the file.
        display: how messages name the file (default: ``path`` as given).
        roots: when given, the file's resolved path must lie inside one of these folders.
        limits: the caps.

    Raises:
        YamlSourceError: one line naming the file.
    """
    path = Path(path)
    display = str(path) if display is None else display
    return _decode(_read_bytes(_resolve(path, display, roots), display, limits), display)


# ---------------------------------------------------------------------------------------------------
# Text to nodes
# ---------------------------------------------------------------------------------------------------


def _mark_position(mark: Any) -> tuple[int, int]:
    """1-based ``(line, column)`` of a PyYAML mark (pure-Python or libyaml's), ``(1, 1)`` without one."""
    return (mark.line + 1, mark.column + 1) if mark is not None else (1, 1)


def _tag_for_humans(tag: str) -> str:
    return "!!" + tag.removeprefix(_CORE) if tag.startswith(_CORE) else tag


class _BoundedLoader(yaml.SafeLoader):
    """PyYAML's safe loader, with every event the composer consumes checked against the caps."""

    def __init__(self, text: str, display: str, limits: YamlLimits) -> None:
        super().__init__(text)
        self.name = display  # marks carry the file, so that nodes from included files name theirs
        self.limits = limits
        self.aliases = 0
        self.nodes = 0
        self.open_collections: list[tuple[str | None, int]] = []  # (anchor, node count before it)
        self.anchor_sizes: dict[str, int] = {}

    def refuse(self, event: yaml.Event, message: str) -> YamlSourceError:
        line, column = _mark_position(event.start_mark)
        return YamlSourceError(self.name, message, line, column)

    def get_event(self) -> yaml.Event:
        event = super().get_event()
        if isinstance(event, yaml.AliasEvent):
            self.aliases += 1
            if self.aliases > self.limits.max_aliases:
                raise self.refuse(event, f"more than {self.limits.max_aliases} aliases (the reader's cap)")
            if any(anchor == event.anchor for anchor, _ in self.open_collections):
                raise self.refuse(
                    event, f"alias '*{event.anchor}' refers to a collection that contains it (recursive)"
                )
            self.nodes += self.anchor_sizes.get(event.anchor or "", 0)  # undefined: the composer says so
        elif isinstance(event, yaml.NodeEvent):
            tag = getattr(event, "tag", None)
            if tag is not None and tag not in PLAIN_TAGS:
                raise self.refuse(
                    event,
                    f"tag '{_tag_for_humans(tag)}' is not allowed: only plain values are read "
                    "(strings, numbers, booleans, null, lists, mappings)",
                )
            self.nodes += 1
            if isinstance(event, yaml.ScalarEvent):
                if event.anchor is not None:
                    self.anchor_sizes[event.anchor] = 1
            else:
                self.open_collections.append((event.anchor, self.nodes - 1))
                if len(self.open_collections) > self.limits.max_depth:
                    raise self.refuse(
                        event, f"nested deeper than {self.limits.max_depth} levels (the reader's cap)"
                    )
        elif isinstance(event, yaml.CollectionEndEvent) and self.open_collections:
            anchor, before = self.open_collections.pop()
            if anchor is not None:
                self.anchor_sizes[anchor] = self.nodes - before
        if self.nodes > self.limits.max_nodes:
            raise self.refuse(
                event,
                f"more than {self.limits.max_nodes} nodes with aliases expanded (the reader's cap)",
            )
        return event


def _syntax_error(exc: yaml.YAMLError, display: str, text: str) -> YamlSourceError:
    if not isinstance(exc, yaml.MarkedYAMLError):
        return YamlSourceError(display, f"YAML syntax error: {exc}", 1, 1)
    mark = exc.problem_mark or exc.context_mark
    context = (
        f" ({exc.context} at line {exc.context_mark.line + 1})" if exc.context and exc.context_mark else ""
    )
    line, column = _mark_position(mark)
    excerpt = "\n".join(text.splitlines()[max(0, line - 2) : line])
    problem = exc.problem or "invalid YAML"
    return YamlSourceError(display, f"YAML syntax error: {problem}{context}", line, column, excerpt)


def _refuse_duplicate_keys(root: yaml.Node, display: str) -> None:
    # Walks the node graph once (aliases share nodes), without recursion; reports the first in the file.
    duplicates: list[tuple[yaml.Node, yaml.Node]] = []
    stack = [root]
    seen: set[int] = set()
    while stack:
        node = stack.pop()
        if id(node) in seen:
            continue
        seen.add(id(node))
        if isinstance(node, yaml.MappingNode):
            first: dict[str, yaml.Node] = {}
            for key_node, value_node in node.value:
                if isinstance(key_node, yaml.ScalarNode):
                    if key_node.value in first:
                        duplicates.append((key_node, first[key_node.value]))
                    else:
                        first[key_node.value] = key_node
                else:
                    stack.append(key_node)
                stack.append(value_node)
        elif isinstance(node, yaml.SequenceNode):
            stack.extend(node.value)
    if duplicates:
        key_node, earlier = min(duplicates, key=lambda pair: pair[0].start_mark.index)
        line, column = _mark_position(key_node.start_mark)
        raise YamlSourceError(
            display,
            f"duplicate key {shorten(key_node.value)} (first given at line {earlier.start_mark.line + 1})",
            line,
            column,
        )


def compose_yaml_file(
    path: str | Path,
    *,
    display: str | None = None,
    roots: Sequence[Path] | None = None,
    limits: YamlLimits = DEFAULT_LIMITS,
) -> yaml.Node | None:
    """The composed root node of a single-document YAML file (marks name ``display``); ``None`` if empty.

    Args:
        path: the file.
        display: how messages (and the nodes' marks) name the file (default: ``path`` as given).
        roots: when given, the file's resolved path must lie inside one of these folders.
        limits: the caps.

    Raises:
        YamlSourceError: one line naming the file, the line and the column.
    """
    path = Path(path)
    display = str(path) if display is None else display
    text = read_yaml_text(path, display=display, roots=roots, limits=limits)
    loader = _BoundedLoader(text, display, limits)
    try:
        root = loader.get_single_node()
    except yaml.YAMLError as exc:
        raise _syntax_error(exc, display, text) from None
    finally:
        loader.dispose()
    if root is not None:
        _refuse_duplicate_keys(root, display)
    return root


def node_value(node: yaml.Node) -> Any:
    """The Python value of a node from :func:`compose_yaml_file` (plain values only).

    Raises:
        YamlSourceError: located at the node, when a scalar is not a valid value of its resolved type
            (e.g. the date ``2024-13-45``, an integer of more than 4300 digits).
    """
    try:
        return yaml.constructor.SafeConstructor().construct_object(node, deep=True)
    except _CONSTRUCTION_ERRORS as exc:
        failure: Exception = exc
    mark = failure.problem_mark if isinstance(failure, yaml.MarkedYAMLError) else None
    if mark is None:  # a scalar's own constructor failed (e.g. int() or date()): find which scalar
        at, failure = _first_invalid_scalar(node) or (node, failure)
        mark = at.start_mark
    reason = getattr(failure, "problem", None) or str(failure)
    if "int_max_str_digits" in reason:  # Python's own guard against quadratic int() of huge numbers
        reason = f"integer longer than {sys.get_int_max_str_digits()} digits"
    line, column = _mark_position(mark)
    raise YamlSourceError(mark.name, f"invalid value: {reason}", line, column)


_CONSTRUCTION_ERRORS = (yaml.YAMLError, ValueError, TypeError, OverflowError)


def _first_invalid_scalar(root: yaml.Node) -> tuple[yaml.Node, Exception] | None:
    """The first scalar in the file (by position) that SafeConstructor refuses, to locate the error."""
    scalars: dict[int, yaml.ScalarNode] = {}
    stack = [root]
    while stack:
        node = stack.pop()
        if isinstance(node, yaml.ScalarNode):
            scalars[id(node)] = node
        elif isinstance(node, yaml.SequenceNode):
            stack.extend(node.value)
        elif isinstance(node, yaml.MappingNode):
            stack.extend(part for pair in node.value for part in pair)
    for scalar in sorted(scalars.values(), key=lambda n: n.start_mark.index):
        try:
            yaml.constructor.SafeConstructor().construct_object(scalar, deep=True)
        except _CONSTRUCTION_ERRORS as exc:
            return scalar, exc
    return None


def load_yaml_file(
    path: str | Path,
    *,
    display: str | None = None,
    roots: Sequence[Path] | None = None,
    limits: YamlLimits = DEFAULT_LIMITS,
) -> Any:
    """The plain Python value of a YAML file (``None`` when it is empty), after every check above.

    Raises:
        YamlSourceError: one line naming the file (and the line and column where there is one).
    """
    root = compose_yaml_file(path, display=display, roots=roots, limits=limits)
    return None if root is None else node_value(root)
