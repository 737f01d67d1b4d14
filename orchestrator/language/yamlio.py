"""YAML loading that remembers where every key and value came from, and that no file can break.

The file is read as a stream of parser events (libyaml's when available) and assembled here,
without recursion, under the caps of `InputLimits`: a file too large, nested too deep, with too
many values once aliases are expanded, a recursive alias, an unknown tag (`!!python/...`) or a
value its tag cannot read (`!!int abc`) is answered with a located message, never a traceback,
a hang or a memory blow-up.
"""

from __future__ import annotations

import re
import stat
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from ..exceptions import ConfigError
from .diagnostics import Diagnostic, clip, format_path
from .limits import InputLimits, current_limits
from .yaml_errors import explain_yaml_error
from .yaml_memo import parsed_once

__all__ = ["SourceMap", "YamlDocument", "load_yaml", "parse_yaml"]

Path_ = tuple[str | int, ...]

# Plain scalars that YAML 1.1 turns into booleans. As mapping keys they are almost always a
# mistake: `on: {found: APPROACH}` is read as `True: {...}`.
_YAML11_BOOLS = {"on", "off", "yes", "no", "y", "n", "true", "false"}

_LOADER: Any = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
"""libyaml's parser when PyYAML was built with it (about 10x faster), else the pure one."""

_STD = "tag:yaml.org,2002:"
_SCALAR_TAGS = {_STD + t for t in ("str", "int", "float", "bool", "null", "timestamp")}
_MERGE = _STD + "merge"
_STR = _STD + "str"
_VALID_TAGS = ("!!str", "!!int", "!!float", "!!bool", "!!null", "!!timestamp", "!!map", "!!seq")

# What YAML allows in a file (PyYAML's reader refuses the rest, without a usable position).
_NOT_PRINTABLE = re.compile(
    "[^\x09\x0a\x0d\x20-\x7e\x85\xa0-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]"
)


@dataclass
class SourceMap:
    """Positions (1-based line and column) of the keys and values of one YAML document."""

    file: str
    marks: dict[Path_, tuple[int, int]] = field(default_factory=dict)

    def locate(self, path: Path_) -> tuple[int, int]:
        """Position of `path`, or of its longest known prefix."""
        path = tuple(path)
        while path:
            if path in self.marks:
                return self.marks[path]
            path = path[:-1]
        return self.marks.get((), (1, 1))

    def diag(self, path: Path_, message: str, valid: tuple[str, ...] = ()) -> Diagnostic:
        """A diagnostic at `path` in this file."""
        line, col = self.locate(path)
        return Diagnostic(self.file, line, col, format_path(path), message, tuple(valid))


@dataclass
class YamlDocument:
    """A parsed YAML file: its data, where each key is, and problems found while reading."""

    data: Any
    source: SourceMap
    problems: list[Diagnostic] = field(default_factory=list)


class _Fatal(Exception):
    """A limit was hit: stop reading at once."""

    def __init__(self, diag: Diagnostic) -> None:
        self.diag = diag


_NO_KEY = object()
_MERGE_KEY = object()
_BAD_KEY = object()


class _Frame:
    """A mapping or list being assembled."""

    __slots__ = ("anchor", "height", "is_map", "key", "merges", "path", "pos", "start", "value")

    def __init__(self, is_map: bool, path: Path_, pos: tuple[int, int], start: int) -> None:
        self.is_map = is_map
        self.value: Any = {} if is_map else []
        self.path = path
        self.pos = pos
        self.start = start  # node count when it opened
        self.height = 0  # nesting below it
        self.key: Any = _NO_KEY
        self.merges: list[dict] = []
        self.anchor: str | None = None


class _Anchor:
    __slots__ = ("height", "open", "size", "value")

    def __init__(self, value: Any, size: int, height: int, open_: bool) -> None:
        self.value, self.size, self.height, self.open = value, size, height, open_


class _Assembler:
    """Turns parser events into Python values, counting and locating everything."""

    def __init__(self, source: SourceMap, limits: InputLimits) -> None:
        self.source = source
        self.limits = limits
        self.resolver = yaml.SafeLoader("")
        self.special = set(self.resolver.yaml_implicit_resolvers)
        """First characters some implicit resolver (int, float, bool, null, ...) looks at."""
        self.stack: list[_Frame] = []
        self.anchors: dict[str, _Anchor] = {}
        self.count = 0
        self.documents = 0
        self.root: Any = None
        self.problems: list[Diagnostic] = []
        self.errors: list[Diagnostic] = []

    def at(self, mark: Any) -> tuple[int, int]:
        return (mark.line + 1, mark.column + 1)

    def fatal(self, pos: tuple[int, int], message: str) -> _Fatal:
        return _Fatal(Diagnostic(self.source.file, *pos, self._here(), message))

    def _here(self) -> str:
        return format_path(self.stack[-1].path) if self.stack else "<yaml>"

    def count_nodes(self, n: int, pos: tuple[int, int]) -> None:
        self.count += n
        if self.count > self.limits.max_nodes:
            raise self.fatal(
                pos,
                f"more than {self.limits.max_nodes} values once aliases are expanded "
                f"(limit max_nodes; see docs/machine-language.md#limits to widen it)",
            )

    def child_path(self) -> Path_ | None:
        """Path of the next value of the open collection (None: it is a mapping key)."""
        if not self.stack:
            return ()
        top = self.stack[-1]
        if not top.is_map:
            return (*top.path, len(top.value))
        if top.key is _NO_KEY:
            return None
        if top.key is _MERGE_KEY or top.key is _BAD_KEY:
            return top.path
        return (*top.path, top.key)

    def feed(self, event: Any) -> None:
        kind = type(event)
        if kind is yaml.ScalarEvent:  # most events: the fast path first
            self.scalar(event)
        elif isinstance(event, yaml.DocumentStartEvent):
            self.documents += 1
            if self.documents > 1:
                raise self.fatal(
                    self.at(event.start_mark),
                    "a second YAML document (`---`): a file holds one machine or scenario",
                )
        elif isinstance(event, yaml.ScalarEvent):
            self.scalar(event)
        elif isinstance(event, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
            self.open(event)
        elif isinstance(event, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
            self.close()
        elif isinstance(event, yaml.AliasEvent):
            self.alias(event)

    def scalar(self, event: Any) -> None:
        mark = event.start_mark
        pos = (mark.line + 1, mark.column + 1)
        self.count += 1
        if self.count > self.limits.max_nodes:
            self.count_nodes(0, pos)
        tag = event.tag
        text = event.value
        if (
            tag is None
            and event.anchor is None
            and text
            and (text[0] not in self.special or not event.implicit[0])
            and self.stack
        ):
            # a plain word no implicit resolver claims, or a quoted string (state names, keys,
            # most values): a str. The common cases are assembled inline; this loop runs for
            # every value of a 512 KiB file well within the 2 s every answer must take.
            top = self.stack[-1]
            key = top.key
            if not top.is_map:
                self.source.marks.setdefault((*top.path, len(top.value)), pos)
                top.value.append(text)
                return
            if key is _NO_KEY and text not in top.value:
                top.key = text
                self.source.marks[(*top.path, text)] = pos
                return
            if key is not _NO_KEY and key is not _MERGE_KEY and key is not _BAD_KEY:
                self.source.marks.setdefault((*top.path, key), pos)
                top.value[key] = text
                top.key = _NO_KEY
                return
        if tag is None or tag == "!":
            implicit = event.implicit if tag is None else (False, False)
            tag = self.resolver.resolve(yaml.ScalarNode, event.value, implicit)
        path = self.child_path()
        if path is not None:
            self.source.marks.setdefault(path, pos)
        value: Any = event.value
        if tag == _MERGE and path is None:
            pass  # `<<` as a key: handled in complete()
        elif tag not in _SCALAR_TAGS:
            self.errors.append(self._bad_tag(event.tag or tag, pos, path))
        else:
            node = yaml.ScalarNode(tag, event.value, event.start_mark, event.end_mark, event.style)
            try:
                value = self.resolver.yaml_constructors[tag](self.resolver, node)
            except (ValueError, KeyError, TypeError, OverflowError, yaml.YAMLError):
                self.errors.append(self._bad_scalar(tag, event.value, pos, path))
        if event.anchor is not None:
            self.anchors[event.anchor] = _Anchor(value, 1, 0, False)
        self.complete(value, pos, 0, event, tag)

    def _bad_tag(self, tag: str, pos: tuple[int, int], path: Path_ | None) -> Diagnostic:
        shown = "!!" + tag[len(_STD) :] if tag.startswith(_STD) else tag
        return Diagnostic(
            self.source.file,
            *pos,
            format_path(path) if path is not None else self._here(),
            f"unknown YAML tag {clip(shown)}: tags are not interpreted here; remove it",
            _VALID_TAGS,
        )

    def _bad_scalar(
        self, tag: str, raw: str, pos: tuple[int, int], path: Path_ | None
    ) -> Diagnostic:
        kind = tag[len(_STD) :]
        if kind == "int" and sum(c.isdigit() for c in raw) > 4000:
            why = f"an integer of {sum(c.isdigit() for c in raw)} digits is too long"
        else:
            why = f"{clip(raw)!r} is not a valid !!{kind}"
        return Diagnostic(
            self.source.file,
            *pos,
            format_path(path) if path is not None else self._here(),
            why,
        )

    def open(self, event: Any) -> None:
        is_map = type(event) is yaml.MappingStartEvent
        mark = event.start_mark
        pos = (mark.line + 1, mark.column + 1)
        self.count += 1
        if self.count > self.limits.max_nodes:
            self.count_nodes(0, pos)
        stack = self.stack
        top = stack[-1] if stack else None
        if top is None:
            path: Path_ | None = ()
        elif not top.is_map:
            path = (*top.path, len(top.value))
        else:
            path = self.child_path()
        if event.tag is not None and event.tag not in ("!", _STD + ("map" if is_map else "seq")):
            self.errors.append(self._bad_tag(event.tag, pos, path))
        if path is None:  # a mapping or list used as a key
            self.errors.append(
                Diagnostic(
                    self.source.file,
                    *pos,
                    self._here(),
                    "a key must be a plain value, not a mapping or a list",
                )
            )
            path = (*stack[-1].path, "<key>")
        self.source.marks.setdefault(path, pos)
        frame = _Frame(is_map, path, pos, self.count)
        if event.anchor is not None:
            frame.anchor = event.anchor
            self.anchors[event.anchor] = _Anchor(frame.value, 0, 0, True)
        stack.append(frame)
        if len(stack) > self.limits.max_depth:
            raise self.fatal(
                pos,
                f"nested deeper than {self.limits.max_depth} levels (limit max_depth; see "
                "docs/machine-language.md#limits)",
            )

    def close(self) -> None:
        frame = self.stack.pop()
        if frame.merges:
            for merged in frame.merges:
                for key, value in merged.items():
                    if key not in frame.value:
                        frame.value[key] = value
        height = frame.height + 1
        if frame.anchor is not None:
            self.anchors[frame.anchor] = _Anchor(
                frame.value, self.count - frame.start + 1, height, False
            )
        if self.stack:  # the common case inline: a value of a mapping or an item of a list
            top = self.stack[-1]
            key = top.key
            if not top.is_map or (
                key is not _NO_KEY and key is not _MERGE_KEY and key is not _BAD_KEY
            ):
                top.height = max(top.height, height)
                if top.is_map:
                    top.value[key] = frame.value
                    top.key = _NO_KEY
                else:
                    top.value.append(frame.value)
                return
        self.complete(frame.value, frame.pos, height, None, None)

    def alias(self, event: Any) -> None:
        pos = self.at(event.start_mark)
        anchor = self.anchors.get(event.anchor)
        if anchor is None:
            raise self.fatal(pos, f"alias *{clip(event.anchor)} names no anchor defined before it")
        if anchor.open:
            raise self.fatal(
                pos,
                f"alias *{clip(event.anchor)} refers to the collection that contains it "
                "(a recursive alias)",
            )
        self.count_nodes(anchor.size, pos)
        if len(self.stack) + anchor.height > self.limits.max_depth:
            raise self.fatal(
                pos,
                f"alias *{clip(event.anchor)} nests deeper than {self.limits.max_depth} levels "
                "(limit max_depth)",
            )
        path = self.child_path()
        if path is not None:
            self.source.marks.setdefault(path, pos)
        elif isinstance(anchor.value, (dict, list)):
            self.errors.append(
                Diagnostic(
                    self.source.file,
                    *pos,
                    self._here(),
                    "a key must be a plain value, not a mapping or a list",
                )
            )
        self.complete(anchor.value, pos, anchor.height, None, None)

    def complete(
        self, value: Any, pos: tuple[int, int], height: int, event: Any, tag: str | None
    ) -> None:
        if not self.stack:
            self.root = value
            return
        top = self.stack[-1]
        top.height = max(top.height, height)
        if not top.is_map:
            top.value.append(value)
            return
        if top.key is _NO_KEY:
            top.key = self.key(top, value, pos, event, tag)
            return
        key, top.key = top.key, _NO_KEY
        if key is _MERGE_KEY:
            items = value if isinstance(value, list) else [value]
            if not all(isinstance(m, dict) for m in items):
                self.errors.append(
                    Diagnostic(
                        self.source.file,
                        *pos,
                        format_path(top.path),
                        "`<<` merges a mapping or a list of mappings",
                    )
                )
                return
            top.merges.extend(items)
        elif key is not _BAD_KEY:
            top.value[key] = value

    def key(self, top: _Frame, value: Any, pos: tuple[int, int], event: Any, tag: str | None):
        if tag == _MERGE:
            return _MERGE_KEY
        if isinstance(value, (dict, list)):
            return _BAD_KEY  # reported where it opened, or by alias()
        if isinstance(value, bool) and event is not None:
            raw = event.value
            if raw.lower() in _YAML11_BOOLS and raw.lower() not in ("true", "false"):
                hint = " — use `transitions:` for outcome -> state" if raw == "on" else ""
                self.source.marks[(*top.path, str(raw))] = pos
                self.problems.append(
                    self.source.diag(
                        (*top.path, str(raw)),
                        f"key `{raw}` is read by YAML 1.1 as the boolean {value}, not as"
                        f" the name {raw!r}{hint}; quote it if you mean the word",
                    )
                )
            value = str(raw)
        if not isinstance(value, (str, int)):
            value = str(value)
        kpath = (*top.path, value)
        self.source.marks[kpath] = pos
        if value in top.value:
            self.problems.append(
                Diagnostic(
                    self.source.file,
                    *pos,
                    format_path(kpath),
                    "duplicate key; the later one would silently win — remove one",
                )
            )
        return value


def _position(text: str, index: int) -> tuple[int, int]:
    """1-based line and column of character `index` of `text`."""
    line_start = text.rfind("\n", 0, index) + 1
    return text.count("\n", 0, index) + 1, index - line_start + 1


_BRACKET = re.compile(r"[\[\]{}]")


def _flow_depth_candidate(text: str, max_depth: int) -> int | None:
    """Where `text` may open its `max_depth + 1`-th nested flow collection: the offset just past
    the first `[` or `{` at which the brackets counted so far (quotes and comments ignored) run
    deeper than `max_depth`, or None when they never do.

    A YAML scanner reads ahead on a line (up to 1024 characters, to tell whether a key follows)
    before the first collection's event reaches `_Assembler`: a long run of `[[[[…` meets the
    parser's own nesting cap, if its build has one, before the assembler counts 65 levels.
    The count here can only overestimate (a bracket inside a quoted or plain string counts
    too); `_refuse_deep_prefix` confirms it.
    """
    if text.count("[") + text.count("{") <= max_depth:
        return None
    depth = 0
    for m in _BRACKET.finditer(text):
        if m.group() in "[{":
            depth += 1
            if depth > max_depth:
                return m.end()
        elif depth:
            depth -= 1
    return None


def _refuse_deep_prefix(prefix: str, source: SourceMap, limits: InputLimits) -> None:
    """Raise the max_depth message if `prefix` (the text up to `_flow_depth_candidate`) really
    nests deeper than `limits.max_depth`: its events reach the assembler before the parser reads
    further. Anything else the prefix does (it ends mid-document) is left to the full parse."""
    assembler = _Assembler(SourceMap(source.file), limits)
    loader = _LOADER(prefix)
    try:
        while True:
            event = loader.get_event()
            if event is None or type(event) is yaml.StreamEndEvent:
                return
            assembler.feed(event)
    except _Fatal as exc:
        raise ConfigError([exc.diag]) from None
    except yaml.YAMLError:
        return
    finally:
        loader.dispose()


def parse_yaml(text: str, file: str, limits: InputLimits | None = None) -> YamlDocument:
    """Parse YAML `text`; every problem raises ConfigError naming `file:line:col`."""
    limits = limits or current_limits()
    source = SourceMap(file)
    text = text.removeprefix("\ufeff")
    bad = _NOT_PRINTABLE.search(text)
    if bad is not None:
        ch = bad.group()
        what = "a NUL character" if ch == "\x00" else f"the control character U+{ord(ch):04X}"
        raise ConfigError(
            [
                Diagnostic(
                    file,
                    *_position(text, bad.start()),
                    "<yaml>",
                    f"{what} is not allowed in YAML; remove it (use an escape such as \\t "
                    "inside a double-quoted string)",
                )
            ]
        )
    deep = _flow_depth_candidate(text, limits.max_depth)
    if deep is not None:
        _refuse_deep_prefix(text[:deep], source, limits)
    assembler = _Assembler(source, limits)
    loader = _LOADER(text)
    feed = assembler.feed
    try:
        while True:
            event = loader.get_event()
            if event is None or type(event) is yaml.StreamEndEvent:
                break
            feed(event)
    except _Fatal as exc:
        raise ConfigError([exc.diag]) from None
    except yaml.MarkedYAMLError as exc:
        line, col, message = explain_yaml_error(exc, text)
        raise ConfigError([Diagnostic(file, line, col, "<yaml>", message)]) from None
    except yaml.YAMLError as exc:  # pragma: no cover - the reader's errors are caught above
        raise ConfigError([Diagnostic(file, 1, 1, "<yaml>", f"YAML error: {exc}")]) from None
    finally:
        loader.dispose()
    if assembler.errors:
        found = sorted(assembler.problems + assembler.errors, key=lambda d: (d.line, d.col))
        raise ConfigError(found)
    return YamlDocument(assembler.root, source, assembler.problems)


def load_yaml(path: Path, limits: InputLimits | None = None) -> YamlDocument:
    """Read and parse a YAML file: a regular file, at most `limits.max_file_bytes`, UTF-8."""
    limits = limits or current_limits()
    name = str(path)
    try:
        st = path.stat()
        if stat.S_ISDIR(st.st_mode):
            raise ConfigError([Diagnostic(name, 0, 0, "<file>", "is a directory, not a file")])
        if not stat.S_ISREG(st.st_mode):
            raise ConfigError(
                [Diagnostic(name, 0, 0, "<file>", "not a regular file (a device, a pipe?)")]
            )
        if st.st_size > limits.max_file_bytes:
            raise ConfigError([_too_large(name, st.st_size, limits)])
        with path.open("rb") as f:
            raw = f.read(limits.max_file_bytes + 1)
    except FileNotFoundError:
        raise ConfigError([Diagnostic(name, 0, 0, "<file>", "file not found")]) from None
    except OSError as exc:
        why = exc.strerror or type(exc).__name__
        raise ConfigError([Diagnostic(name, 0, 0, "<file>", f"cannot read: {why}")]) from None
    if len(raw) > limits.max_file_bytes:
        raise ConfigError([_too_large(name, len(raw), limits)])
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        start = raw.rfind(b"\n", 0, exc.start) + 1
        col = len(raw[start : exc.start].decode("utf-8", errors="replace")) + 1
        line = raw.count(b"\n", 0, exc.start) + 1
        raise ConfigError(
            [
                Diagnostic(
                    name,
                    line,
                    col,
                    "<file>",
                    f"not UTF-8: byte 0x{raw[exc.start]:02x} cannot be decoded; save the file "
                    "as UTF-8",
                )
            ]
        ) from None
    return parsed_once(text, name, limits, parse_yaml)  # a text already read: a copy


def _too_large(name: str, size: int, limits: InputLimits) -> Diagnostic:
    return Diagnostic(
        name,
        1,
        1,
        "<file>",
        f"the file is {size} bytes, more than the {limits.max_file_bytes} a machine or scenario "
        "may have (limit max_file_bytes; see docs/machine-language.md#limits to widen it)",
    )
