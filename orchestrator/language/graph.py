"""Draw a machine tree as a Mermaid flowchart or a Graphviz DOT graph.

States are nodes, transitions are edges labelled with their outcome, nested machines and
parallel branches are clusters, final states are rounded, and the abort path (any state ->
`on_abort` or the built-in safe stop) is a dashed edge from a guard node.
"""

from __future__ import annotations

import re

from .loading import MachineNode
from .machine import SAFE_STOP, BranchSpec, StateSpec

__all__ = ["to_dot", "to_mermaid"]


def _id(path: str) -> str:
    return "s_" + re.sub(r"[^A-Za-z0-9_]", "_", path.replace(".", "__"))


def _label(name: str, st: StateSpec | BranchSpec) -> str:
    if isinstance(st, StateSpec) and st.final is not None:
        return f"{name}: {st.final}"
    extra = []
    if st.skill is not None:
        extra.append(st.skill)
    if isinstance(st, StateSpec):
        if st.retry:
            extra.append(f"retry {st.retry}")
        if st.timeout is not None:
            extra.append(f"timeout {st.timeout:g} s")
        if st.parallel is not None:
            extra.append(f"parallel, {st.rule}")
    return name + (f" ({', '.join(extra)})" if extra else "")


def _escape(text: str) -> str:
    return text.replace('"', "'")


def _exits(node: MachineNode, name: str, outcome: str, prefix: str) -> list[str]:
    """Paths of the final states of the machine nested in state `name` that end it with
    `outcome`: its transition on `outcome` is drawn from them, not from the nested machine's
    entry, so a reader follows the arrow forwards out of the state that ended it."""
    child = node.children.get(name)
    if child is None:
        return []
    return [
        f"{prefix}{name}.{final}"
        for final, st in child.states.items()
        if st.final is not None and st.final == outcome
    ]


class _Mermaid:
    def __init__(self) -> None:
        self.lines = ["flowchart TD"]
        self.finals: list[str] = []

    def machine(self, node: MachineNode, prefix: str, indent: str) -> None:
        start = _id(prefix + "__start")
        self.lines.append(f"{indent}{start}(( ))")
        self.lines.append(f"{indent}{start} --> {_id(prefix + node.initial)}")
        for name, st in node.states.items():
            path = prefix + name
            nid = _id(path)
            if name in node.children:
                self.lines.append(f'{indent}subgraph {nid}["{_escape(_label(name, st))}"]')
                self.machine(node.children[name], path + ".", indent + "  ")
                self.lines.append(f"{indent}end")
            elif st.parallel is not None:
                self.lines.append(f'{indent}subgraph {nid}["{_escape(_label(name, st))}"]')
                for bname, branch in node.branches.get(name, {}).items():
                    bpath = f"{path}.{bname}"
                    if isinstance(branch, MachineNode):
                        self.lines.append(f'{indent}  subgraph {_id(bpath)}["{bname}"]')
                        self.machine(branch, bpath + ".", indent + "    ")
                        self.lines.append(f"{indent}  end")
                    else:
                        self.lines.append(
                            f'{indent}  {_id(bpath)}["{_escape(_label(bname, branch))}"]'
                        )
                self.lines.append(f"{indent}end")
            elif st.final is not None:
                self.lines.append(f'{indent}{nid}(["{_escape(_label(name, st))}"])')
                self.finals.append(nid)
            else:
                self.lines.append(f'{indent}{nid}["{_escape(_label(name, st))}"]')
        for name, st in node.states.items():
            for outcome, target in st.transitions.items():
                for src in _exits(node, name, outcome, prefix) or [prefix + name]:
                    self.lines.append(f"{indent}{_id(src)} -->|{outcome}| {_id(prefix + target)}")


def to_mermaid(node: MachineNode) -> str:
    """A Mermaid `flowchart` of the machine (renders on GitHub, in mermaid.live, in VS Code)."""
    m = _Mermaid()
    m.machine(node, "", "  ")
    guard = _id("__guard")
    m.lines.append(f"  {guard}{{{{guard fires}}}}")
    if node.on_abort is not None:
        m.lines.append(f"  {guard} -.->|abort| {_id(node.on_abort)}")
    else:
        stop = _id(SAFE_STOP)
        m.lines.append(f'  {stop}(["{SAFE_STOP}: aborted"])')
        m.lines.append(f"  {guard} -.->|abort| {stop}")
        m.finals.append(stop)
    m.lines.append("  classDef final fill:#e8f5e9,stroke:#2e7d32")
    m.lines.append("  classDef guard fill:#ffebee,stroke:#c62828")
    if m.finals:
        m.lines.append(f"  class {','.join(m.finals)} final")
    m.lines.append(f"  class {guard} guard")
    return "\n".join(m.lines) + "\n"


class _Dot:
    def __init__(self) -> None:
        self.lines = [
            "digraph machine {",
            "  compound=true; rankdir=TB;",
            '  node [shape=box, style="rounded,filled", fillcolor="#f5f5f5",'
            ' fontname="Helvetica"];',
            '  edge [fontname="Helvetica", fontsize=10];',
        ]

    def anchor(self, path: str, node: MachineNode | None) -> tuple[str, str]:
        """A node to attach edges to, and the cluster to clip them at (if any)."""
        if node is None:
            return _id(path), ""
        return _id(path + ".__start"), "cluster_" + _id(path)

    def machine(self, node: MachineNode, prefix: str, indent: str) -> None:
        start = _id(prefix + "__start")
        self.lines.append(f'{indent}{start} [shape=point, width=0.12, label=""];')
        first, _ = self.anchor(prefix + node.initial, node.children.get(node.initial))
        self.lines.append(f"{indent}{start} -> {first};")
        for name, st in node.states.items():
            path = prefix + name
            if name in node.children or st.parallel is not None:
                self.lines.append(f"{indent}subgraph cluster_{_id(path)} {{")
                self.lines.append(f'{indent}  label="{_escape(_label(name, st))}"; style=rounded;')
                if name in node.children:
                    self.machine(node.children[name], path + ".", indent + "  ")
                else:
                    self.lines.append(
                        f'{indent}  {_id(path + ".__start")} [shape=point, label=""];'
                    )
                    for bname, branch in node.branches.get(name, {}).items():
                        bpath = f"{path}.{bname}"
                        if isinstance(branch, MachineNode):
                            self.lines.append(f"{indent}  subgraph cluster_{_id(bpath)} {{")
                            self.lines.append(f'{indent}    label="{bname}";')
                            self.machine(branch, bpath + ".", indent + "    ")
                            self.lines.append(f"{indent}  }}")
                        else:
                            label = _escape(_label(bname, branch))
                            self.lines.append(f'{indent}  {_id(bpath)} [label="{label}"];')
                self.lines.append(f"{indent}}}")
            elif st.final is not None:
                self.lines.append(
                    f'{indent}{_id(path)} [label="{_escape(_label(name, st))}", shape=oval, '
                    'fillcolor="#e8f5e9"];'
                )
            else:
                self.lines.append(f'{indent}{_id(path)} [label="{_escape(_label(name, st))}"];')
        for name, st in node.states.items():
            anchor = self.anchor(
                prefix + name,
                node.children.get(name) or (node if st.parallel is not None else None),
            )
            for outcome, target in st.transitions.items():
                dst, lhead = self.anchor(
                    prefix + target,
                    node.children.get(target)
                    or (node if node.states[target].parallel is not None else None),
                )
                # out of a nested machine: from the final states it ended in; out of a
                # parallel state: from its cluster's border
                exits = [(_id(p), "") for p in _exits(node, name, outcome, prefix)]
                for src, ltail in exits or [anchor]:
                    attrs = [f'label="{outcome}"']
                    if ltail:
                        attrs.append(f"ltail={ltail}")
                    if lhead:
                        attrs.append(f"lhead={lhead}")
                    self.lines.append(f"{indent}{src} -> {dst} [{', '.join(attrs)}];")


def to_dot(node: MachineNode) -> str:
    """A Graphviz DOT digraph of the machine (`dot -Tsvg`)."""
    d = _Dot()
    d.machine(node, "", "  ")
    guard = _id("__guard")
    d.lines.append(f'  {guard} [label="guard fires", shape=hexagon, fillcolor="#ffebee"];')
    target = node.on_abort or SAFE_STOP
    if node.on_abort is None:
        d.lines.append(
            f'  {_id(SAFE_STOP)} [label="{SAFE_STOP}: aborted", shape=oval, fillcolor="#ffebee"];'
        )
    dst, lhead = d.anchor(target, node.children.get(target) if node.on_abort else None)
    extra = f", lhead={lhead}" if lhead else ""
    d.lines.append(f'  {guard} -> {dst} [label="abort", style=dashed, color="#c62828"{extra}];')
    d.lines.append("}")
    return "\n".join(d.lines) + "\n"
