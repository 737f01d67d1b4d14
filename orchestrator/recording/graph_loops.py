"""The edges that close a loop in a grandalf graph, found without recursing once per vertex.

grandalf's Sugiyama layout needs them to rank a graph with loops; its own search
(`graph_core.get_scs_with_feedback`) recurses once per vertex, and a user's 1,500-state chain
overflowed Python's stack. The built-in layout (graph_layout.py) hands it these instead.
"""

from __future__ import annotations

from grandalf.graphs import Edge, Vertex, graph_core

__all__ = ["feedback_edges"]


def feedback_edges(part: graph_core, roots: list[Vertex]) -> list[Edge]:
    """The edges that close a loop, found as grandalf's `get_scs_with_feedback` finds them (a
    depth-first walk from `roots`, then from each vertex not yet reached, each vertex's edges
    in their order; an edge to a vertex on the walk's path closes a loop), on an explicit
    stack: grandalf's walk recurses once per vertex, and a 1,500-state chain overflowed it."""
    seen: set[int] = set()
    on_path: set[int] = set()
    out: list[Edge] = []
    for start in [*roots, *part.sV]:
        if id(start) in seen:
            continue
        seen.add(id(start))
        on_path.add(id(start))
        stack = [(start, iter(start.e_out()))]
        while stack:
            v, ahead = stack[-1]
            for e in ahead:
                w = e.v[1]
                if id(w) not in seen:
                    seen.add(id(w))
                    on_path.add(id(w))
                    stack.append((w, iter(w.e_out())))
                    break
                if id(w) in on_path:
                    out.append(e)
            else:
                on_path.discard(id(v))
                stack.pop()
    return out
