"""The parsed YAML of a file's text, kept per process: the same text is parsed once.

A scenario names a machine, the machine its includes: every `run`, every batch episode,
every `validate` of a `serve` and every reload read the same few files again, and parsing
them (assembling the document and the position of every key) was 2-5 ms a file, ~10-15 ms a
bundled scenario. The key is the file's name, its whole text and the input limits, so an
edited file is parsed anew; each caller gets its own copy of the data (the loaders change
what they are given) and of the positions. Only documents that parsed are kept (a refusal
is raised anew every time), and only files up to `MAX_TEXT` characters, `ENTRIES` of them.
"""

from __future__ import annotations

import copy
import threading
from collections import OrderedDict
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .limits import InputLimits

__all__ = ["ENTRIES", "MAX_TEXT", "parsed_once"]

ENTRIES = 128
"""Documents kept (least recently used dropped first)."""
MAX_TEXT = 256 * 1024
"""Longer texts are parsed every time (a few such files would hold the memory for nothing)."""

_memo: OrderedDict[tuple[str, str, InputLimits], Any] = OrderedDict()
"""(file name, text, limits) -> the `YamlDocument` parsed from them (yamlio's type: this
module is below yamlio, which calls it)."""
_lock = threading.Lock()


def parsed_once(
    text: str,
    name: str,
    limits: InputLimits,
    parse: Callable[[str, str, InputLimits], Any],
) -> Any:
    """`parse(text, name, limits)`, or a copy of what it returned for the same arguments."""
    if len(text) > MAX_TEXT:
        return parse(text, name, limits)
    key = (name, text, limits)
    with _lock:
        doc = _memo.get(key)
        if doc is not None:
            _memo.move_to_end(key)
    if doc is None:
        doc = parse(text, name, limits)  # raises ConfigError for what it refuses: not kept
        with _lock:
            _memo[key] = doc
            if len(_memo) > ENTRIES:
                _memo.popitem(last=False)
    return type(doc)(
        copy.deepcopy(doc.data),
        type(doc.source)(doc.source.file, dict(doc.source.marks)),
        list(doc.problems),
    )
