"""`orchestrator graph`: Mermaid flowchart and DOT output of a machine."""

from __future__ import annotations

import re

import pytest

from orchestrator.language.graph import _id
from orchestrator.language.load import load_machine

NODE = re.compile(r"^\s*(\w+)(\[\"|\(\(|\(\[\"|\{\{)")
SUBGRAPH = re.compile(r"^\s*subgraph (\w+)\[\"")
EDGE = re.compile(r"^\s*(\w+) (-->|-\.->)(?:\|([^|]+)\|)? (\w+)$")
CLASS = re.compile(r"^\s*(classDef|class) ")


def parse_mermaid(text: str) -> tuple[set[str], list[tuple[str, str, str | None]]]:
    """A strict reader of the flowchart subset we emit: fails on any other line."""
    lines = text.splitlines()
    assert lines[0] == "flowchart TD"
    nodes: set[str] = set()
    edges = []
    depth = 0
    for line in lines[1:]:
        if m := SUBGRAPH.match(line):
            nodes.add(m.group(1))
            depth += 1
        elif line.strip() == "end":
            depth -= 1
            assert depth >= 0, "unbalanced `end`"
        elif m := EDGE.match(line):
            edges.append((m.group(1), m.group(4), m.group(3)))
        elif m := NODE.match(line):
            nodes.add(m.group(1))
        elif CLASS.match(line):
            continue
        else:
            raise AssertionError(f"not flowchart syntax we know: {line!r}")
    assert depth == 0, "unclosed subgraph"
    return nodes, edges


def test_pick_place_mermaid_declares_every_node_and_edge(cli):
    res = cli("graph", "pick_place", "--format", "mermaid")
    assert res.exit_code == 0
    nodes, edges = parse_mermaid(res.stdout)
    for src, dst, _ in edges:
        assert src in nodes and dst in nodes, (src, dst)
    machine = load_machine("pick_place")
    for path, st, node in machine.walk():
        assert _id(path) in nodes, path
        prefix = path.rsplit(".", 1)[0] + "." if "." in path else ""
        child = node.children.get(path.rsplit(".", 1)[-1])
        for outcome, target in st.transitions.items():
            # out of a nested machine: from each of its final states with that outcome
            sources = [
                f"{path}.{name}" for name, f in (child.states.items() if child else [])
                if f.final == outcome
            ] or [path]  # fmt: skip
            for src in sources:
                assert (_id(src), _id(prefix + target), outcome) in edges
    # nested machines are clusters, and the abort path is drawn
    assert "subgraph s_PICK__GRASP[" in res.stdout
    assert ("s___guard", "s_SAFE_STOP", "abort") in edges


def test_on_abort_is_the_abort_target(tmp_path, cli):
    text = tmp_path / "m.yaml"
    text.write_text(
        "name: m\ninitial: A\non_abort: HOLD\nstates:\n"
        "  A:\n    skill: release\n    transitions: {released: DONE, timeout: DONE}\n"
        "  HOLD:\n    skill: release\n    transitions: {released: DONE, timeout: DONE}\n"
        "  DONE: {final: succeeded}\n"
    )
    nodes, edges = parse_mermaid(cli("graph", str(text)).stdout)
    assert ("s___guard", "s_HOLD", "abort") in edges


def test_parallel_branches_are_clusters(tmp_path, cli):
    path = tmp_path / "p.yaml"
    path.write_text(
        "name: p\ninitial: P\nblackboard: {object: cube}\nstates:\n"
        "  P:\n    rule: any\n    parallel:\n"
        "      look: {skill: search, with: {object: $object}}\n"
        "      hold:\n        initial: H\n        states:\n"
        "          H:\n            skill: release\n"
        "            transitions: {released: OK, timeout: OK}\n"
        "          OK: {final: ok}\n"
        "    transitions: {succeeded: DONE, failed: DONE}\n"
        "  DONE: {final: succeeded}\n"
    )
    res = cli("graph", str(path))
    nodes, edges = parse_mermaid(res.stdout)
    assert {"s_P", "s_P__look", "s_P__hold", "s_P__hold__H"} <= nodes
    assert ("s_P__hold__H", "s_P__hold__OK", "released") in edges


def test_dot_output_is_a_balanced_digraph_with_every_transition(cli):
    res = cli("graph", "pick_place", "--format", "dot")
    assert res.exit_code == 0
    text = res.stdout
    assert text.startswith("digraph machine {") and text.count("{") == text.count("}")
    assert "subgraph cluster_s_PICK__GRASP {" in text
    for outcome in ("found", "grasped", "held", "picked", "released", "abort"):
        assert f'label="{outcome}"' in text


@pytest.mark.parametrize("fmt", ["svg", "png"])
def test_unknown_format_is_invalid_input(cli, fmt):
    res = cli("graph", "pick_place", "--format", fmt)
    assert res.exit_code == 2 and "valid: mermaid, dot" in res.stderr


def test_exits_of_a_nested_machine_start_at_its_final_states(cli):
    nodes, edges = parse_mermaid(cli("graph", "pick_place").stdout)
    assert ("s_PICK__PICKED", "s_TRANSPORT", "picked") in edges
    assert ("s_PICK__MISSED", "s_FAILED", "missed") in edges
    assert ("s_PICK__GRASP__GRASPED", "s_PICK__PICKED", "grasped") in edges
    assert not [e for e in edges if e[0] in ("s_PICK", "s_PICK__GRASP")]
    dot = cli("graph", "pick_place", "--format", "dot").stdout
    sources = {
        m.group(2): m.group(1)
        for m in re.finditer(r"^\s*(\w+) -> \w+ \[label=\"(picked|lost|grasped)\"", dot, re.M)
    }
    assert sources == {
        "picked": "s_PICK__PICKED", "lost": "s_PICK__LOST", "grasped": "s_PICK__GRASP__GRASPED",
    }  # fmt: skip
    # no edge leaves PICK (or its GRASP) from its entry point; a parallel state's outcomes
    # (the grasp's APPROACH) do leave its cluster
    assert not re.search(r"ltail=cluster_s_PICK(__GRASP)?[\],]", dot)
    assert "ltail=cluster_s_PICK__GRASP__APPROACH" in dot
