"""A user's machine as long as validation allows a chain to be is drawn like any other: the
graph's layouts walk it without recursing once per state (a 1,500-state chain raised
RecursionError in the dot layout's main-path search, and in grandalf's search for the edges
closing a loop in the built-in layout used without Graphviz)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from orchestrator.language.load import load_machine
from orchestrator.recording.machine_graph import build_graph

STATES = 1500


def _chain(folder: Path) -> Path:
    lines = ["name: chain", "initial: S0", "states:"]
    for i in range(STATES):
        nxt = f"S{i + 1}" if i < STATES - 1 else "DONE"
        lines.append(
            f"  S{i}: {{skill: hold, with: {{duration_s: 0.01}}, transitions: {{held: {nxt}}}}}"
        )
    lines.append("  DONE: {final: succeeded}")
    path = folder / "chain.yaml"
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.skipif(shutil.which("dot") is None, reason="Graphviz's dot is not installed")
def test_a_chain_of_1500_states_is_laid_out_by_dot(tmp_path):
    graph = build_graph(load_machine(str(_chain(tmp_path))), use_dot=True)
    (view,) = graph.views.values()
    assert {f"S{i}" for i in range(STATES)} | {"DONE"} <= set(view.layout.positions)


def test_a_chain_of_1500_states_is_laid_out_without_dot(tmp_path):
    graph = build_graph(load_machine(str(_chain(tmp_path))), use_dot=False)
    (view,) = graph.views.values()
    pos = view.layout.positions
    assert {f"S{i}" for i in range(STATES)} | {"DONE"} <= set(pos)
    # top to bottom in flow order
    assert all(pos[f"S{i + 1}"][1] > pos[f"S{i}"][1] for i in range(STATES - 1))
