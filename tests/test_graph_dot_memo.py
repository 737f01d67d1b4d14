"""`dot` runs once per distinct source in a process: a batch's recordings draw the same
machines again, and each `dot` run is a process start."""

from __future__ import annotations

import shutil
import subprocess

import pytest

from orchestrator.recording import graph_dot

pytestmark = pytest.mark.skipif(
    shutil.which("dot") is None, reason="Graphviz's dot is not installed"
)

SOURCE = 'digraph { a [shape=box, width=1, height=0.5]; b; a -> b [label="LABEL"]; }\n'


def test_the_same_source_is_laid_out_once_and_each_caller_gets_its_own_copy(monkeypatch):
    runs = []
    real = subprocess.run
    monkeypatch.setattr(
        graph_dot.subprocess, "run", lambda *a, **k: runs.append(a) or real(*a, **k)
    )
    source = SOURCE.replace("LABEL", f"memo {id(runs)}")  # a source no other test laid out
    first = graph_dot.run_dot(source)
    first["objects"].clear()  # a caller may change what it got
    second = graph_dot.run_dot(source)
    assert len(runs) == 1
    assert {o["name"] for o in second["objects"]} == {"a", "b"}
    graph_dot.run_dot(source.replace("b;", "c;"))  # another graph is laid out anew
    assert len(runs) == 2


def test_a_source_dot_refuses_is_none_every_time_and_is_tried_again(monkeypatch):
    runs = []
    real = subprocess.run
    monkeypatch.setattr(
        graph_dot.subprocess, "run", lambda *a, **k: runs.append(a) or real(*a, **k)
    )
    assert graph_dot.run_dot("digraph { a -> }\n") is None
    assert graph_dot.run_dot("digraph { a -> }\n") is None
    assert len(runs) == 2  # a failure (a timeout on a loaded host) is not remembered
