"""PyYAML's syntax errors, said as the mistake a person made and its fix.

PyYAML reports what its parser expected ("expected <block end>, but found '<block mapping
start>'"); a user wants to know that a line is indented wrongly or holds a tab. The common
cases are translated here, with the line to look at; anything else keeps PyYAML's words.
"""

from __future__ import annotations

import yaml

__all__ = ["explain_yaml_error"]


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip(" "))


def _previous(lines: list[str], row: int) -> int | None:
    """0-based index of the nearest line above `row` that holds something."""
    for i in range(row - 1, -1, -1):
        text = lines[i].strip()
        if text and not text.startswith("#"):
            return i
    return None


def explain_yaml_error(exc: yaml.MarkedYAMLError, text: str) -> tuple[int, int, str]:
    """(1-based line, column, message) for a PyYAML syntax error in `text`."""
    mark = exc.problem_mark or exc.context_mark
    line, col = (mark.line + 1, mark.column + 1) if mark else (0, 0)
    problem = exc.problem or "syntax error"
    lines = text.splitlines()
    row = line - 1
    here_line = lines[row] if 0 <= row < len(lines) else ""
    leading = here_line[: len(here_line) - len(here_line.lstrip(" \t"))]
    if "'\\t'" in problem or "\t" in problem or "\t" in leading:
        return line, col, "a tab character: YAML indents with spaces only — replace it by spaces"
    # PyYAML's words, or libyaml's (the C parser) for the same mistake
    if problem.startswith(("expected <block end>", "did not find expected key")) and (
        0 <= row < len(lines)
    ):
        prev = _previous(lines, row)
        here = _indent(lines[row])
        above = f"line {prev + 1} is indented by {_indent(lines[prev])}" if prev is not None else ""
        return (
            line,
            col,
            f"inconsistent indentation: this line is indented by {here} spaces, which lines up "
            f"with no key above it ({above}); indent it exactly like the key it belongs beside "
            "(if the line above is the one out of place, fix that one)",
        )
    # PyYAML says "here", libyaml (the C parser) "in this context": the same mistake
    if problem.startswith("mapping values are not allowed") and 0 <= row < len(lines):
        prev = _previous(lines, row)
        if prev is not None and _indent(lines[row]) > _indent(lines[prev]) and ":" in lines[row]:
            if not lines[prev].rstrip().endswith(":"):
                return (
                    line,
                    _indent(lines[row]) + 1,
                    f"this line is indented deeper than line {prev + 1} above it, whose key "
                    "already has a value: indent it like that key, or move the value of line "
                    f"{prev + 1} under it",
                )
        return (
            line,
            col,
            "a second `: ` on one line: quote the value if it contains ': ' "
            '(`message: "a: b"`), or put the nested key on its own line',
        )
    if exc.context and exc.context.startswith("while parsing a flow") and exc.context_mark:
        opener = "{" if "mapping" in exc.context else "["
        closer = "}" if opener == "{" else "]"
        cm = exc.context_mark
        return (
            cm.line + 1,
            cm.column + 1,
            f"the `{opener}` opened at line {cm.line + 1}, column {cm.column + 1} is not closed: "
            f"add `{closer}` (or a `,` between items) — PyYAML: {problem}",
        )
    context = ""
    if exc.context:
        context = f" ({exc.context}"
        cm = exc.context_mark
        if cm is not None and exc.problem_mark is not None and cm.line != exc.problem_mark.line:
            context += f" that starts at line {cm.line + 1}, column {cm.column + 1}"
        context += ")"
    return line, col, f"YAML syntax error: {problem}{context}"
