"""A finished run said on the terminal: the result line and its transitions table, the
guard or the limit that stopped it, the success checks, a raising skill."""

import time
from pathlib import Path

import typer

from .console import err, escape, json_line, out
from .root import command_started

_TABLE_ENDS = 20
"""Transitions printed at each end of a long run's table."""


def finish(result, as_json: bool, debug: bool, rrd: Path | None, strict: bool = False) -> None:
    """Print a run's result and exit with its code (`strict`: 1 on an invariant violation,
    docs/invariants.md)."""
    if as_json:
        json_line(result.to_json_dict())
    else:
        print_result(result)
    if result.error is not None:
        print_skill_fault(result.error, debug)
    if rrd is not None:
        err.print(f"recording saved to {rrd} (open it with: rerun {rrd})", markup=False)
    violation = result.strict_violation if strict else None
    if violation is not None:
        err.print(f"invariant {violation['invariant']} violated: {violation['message']}",
                  markup=False, soft_wrap=True)  # fmt: skip
        raise typer.Exit(1)
    raise typer.Exit(result.exit_code)


def print_skill_fault(error: dict, debug: bool) -> None:
    """A skill raised: one line (skill, file:line, exception), the traceback with --debug."""
    from ..engine.skill_fault import SkillFault

    fault = SkillFault(**error)
    hint = "" if debug else "; --debug prints the traceback"
    line = f"error: {fault.line()}; the arm was brought to rest and held (exit 4{hint})"
    err.print(line, markup=False, soft_wrap=True)
    if debug:
        err.print(fault.traceback.rstrip(), markup=False, soft_wrap=True)


def print_result(result) -> None:
    style = {"succeeded": "green", "failed": "yellow", "aborted": "red", "error": "red"}[
        result.outcome
    ]
    from rich.table import Table  # here: `--version` and `validate` print no table

    rtf = result.sim_time / max(result.wall_time, 1e-9)
    command = time.perf_counter() - command_started()
    out.print(
        f"[bold]{escape(result.scenario)}[/] seed {result.seed}: [{style}]{result.outcome}[/] in "
        f"{escape(str(result.final_state))} after {result.sim_time:.2f} s simulated "
        f"({command:.2f} s for the command with its start-up: the episode {result.wall_time:.2f}"
        f" s wall, {rtf:.0f}x real time)"
    )
    table = Table(escape("t [s]"), "from", "to", "trigger", box=None, pad_edge=False)
    shown = result.transitions
    cut = len(shown) - 2 * _TABLE_ENDS
    if cut > 1:  # a retry loop can make thousands: the first and last ones tell the story
        shown = [*shown[:_TABLE_ENDS], None, *shown[-_TABLE_ENDS:]]
    for tr in shown:
        if tr is None:
            table.add_row("...", f"({cut} more transitions: --json lists them all)", "", "")
            continue
        trigger = tr["trigger"] + (f": {tr['detail']}" if tr.get("detail") else "")
        table.add_row(f"{tr['t']:.2f}", escape(tr["from"]), escape(tr["to"]), escape(trigger))
    out.print(table)
    r = result.reason
    if r and "guard" not in r:  # the time limit (or the wall-clock limit) cut the run short
        out.print(f"stopped by {r.get('kind')}: {r['message']}", markup=False, soft_wrap=True)
    elif r:
        out.print(
            f"[red]aborted by {escape(str(r['guard']))}[/]: {escape(str(r['message']))} "
            f"(value {r['value']}, limit {r['limit']})"
        )
    if result.success:
        marks = ", ".join(f"{k} {'ok' if v else 'FAILED'}" for k, v in result.success.items())
        out.print(f"success: {marks}", markup=False)
        for name, ok in result.success.items():
            if not ok:
                detail = result.success_detail.get(name, "")
                out.print(f"[yellow]{escape(name)} failed[/]: {escape(detail)}", soft_wrap=True)
    metrics = ", ".join(f"{k} {v}" for k, v in result.metrics.items())
    out.print(f"metrics: {metrics}", markup=False, soft_wrap=True)
    if result.retries:
        out.print(f"retries: {result.retries}", markup=False)
