"""YAML loading that remembers where every key and value came from."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from ..exceptions import ConfigError
from .diagnostics import Diagnostic, format_path
from .yaml_errors import explain_yaml_error

__all__ = ["SourceMap", "YamlDocument", "load_yaml", "parse_yaml"]

Path_ = tuple[str | int, ...]

# Plain scalars that YAML 1.1 turns into booleans. As mapping keys they are almost always a
# mistake: `on: {found: APPROACH}` is read as `True: {...}`.
_YAML11_BOOLS = {"on", "off", "yes", "no", "y", "n", "true", "false"}


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


class _Builder:
    def __init__(self, source: SourceMap) -> None:
        self.source = source
        self.loader = yaml.SafeLoader("")
        self.problems: list[Diagnostic] = []

    def build(self, node: yaml.Node, path: Path_) -> Any:
        self.source.marks.setdefault(path, (node.start_mark.line + 1, node.start_mark.column + 1))
        if isinstance(node, yaml.MappingNode):
            out: dict[Any, Any] = {}
            self.loader.flatten_mapping(node)
            for key_node, value_node in node.value:
                key = self.loader.construct_object(key_node, deep=True)
                kpos = (key_node.start_mark.line + 1, key_node.start_mark.column + 1)
                if isinstance(key, bool) and isinstance(key_node, yaml.ScalarNode):
                    raw = key_node.value
                    if raw.lower() in _YAML11_BOOLS and raw.lower() not in ("true", "false"):
                        hint = " — use `transitions:` for outcome -> state" if raw == "on" else ""
                        self.source.marks[(*path, str(raw))] = kpos
                        self.problems.append(
                            self.source.diag(
                                (*path, str(raw)),
                                f"key `{raw}` is read by YAML 1.1 as the boolean {key}, not as"
                                f" the name {raw!r}{hint}; quote it if you mean the word",
                            )
                        )
                    key = str(raw)
                if not isinstance(key, (str, int)):
                    key = str(key)
                kpath = (*path, key)
                if key in out:
                    self.source.marks[kpath] = kpos
                    self.problems.append(
                        Diagnostic(
                            self.source.file,
                            *kpos,
                            format_path(kpath),
                            "duplicate key; the later one would silently win — remove one",
                        )
                    )
                self.source.marks[kpath] = kpos
                out[key] = self.build(value_node, kpath)
                self.source.marks.setdefault(kpath, kpos)
            return out
        if isinstance(node, yaml.SequenceNode):
            return [self.build(child, (*path, i)) for i, child in enumerate(node.value)]
        return self.loader.construct_object(node, deep=True)


def parse_yaml(text: str, file: str) -> YamlDocument:
    """Parse YAML `text`; syntax errors raise ConfigError naming `file:line:col`."""
    source = SourceMap(file)
    try:
        node = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.MarkedYAMLError as exc:
        line, col, message = explain_yaml_error(exc, text)
        raise ConfigError([Diagnostic(file, line, col, "<yaml>", message)]) from None
    except yaml.YAMLError as exc:  # pragma: no cover - non-marked errors are rare
        raise ConfigError([Diagnostic(file, 0, 0, "<yaml>", f"YAML error: {exc}")]) from None
    if node is None:
        return YamlDocument(None, source)
    builder = _Builder(source)
    try:
        data = builder.build(node, ())
    except yaml.constructor.ConstructorError as exc:
        mark = exc.problem_mark
        line, col = (mark.line + 1, mark.column + 1) if mark else (0, 0)
        raise ConfigError(
            [Diagnostic(file, line, col, "<yaml>", f"YAML error: {exc.problem}")]
        ) from None
    return YamlDocument(data, source, builder.problems)


def load_yaml(path: Path) -> YamlDocument:
    """Read and parse a YAML file."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError([Diagnostic(str(path), 0, 0, "<file>", "file not found")]) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError([Diagnostic(str(path), 0, 0, "<file>", f"cannot read: {exc}")]) from None
    return parse_yaml(text, str(path))
