"""The architecture stays visible in the folders: imports only go down the layers, no cycles.

Every `import` of every module of the package (orchestrator/, skills/ and robots/, which are
installed as `orchestrator.skills` and `orchestrator.robots`) is read with `ast`, wherever it
is written (module level, in a function, under `if TYPE_CHECKING:`).

* Run-time imports must follow `ALLOWED`: a layer imports only the layers below it.
* Type-only imports (under `if TYPE_CHECKING:`) may name a type of a higher layer — a skill is
  handed the engine's `Context`, the world is handed the language's `Scenario` — but, counted
  as edges like any other import, they must not close a cycle between modules.
* Run-time imports, with the package `__init__` that importing a submodule executes, must not
  form a cycle either: that is an import-order bug waiting to happen.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
SOURCES = {"orchestrator": REPO / "orchestrator", "orchestrator.skills": REPO / "skills",
           "orchestrator.robots": REPO / "robots"}  # fmt: skip

ALLOWED: dict[str, set[str]] = {
    "cli": {
        "explore", "batch", "live", "recording", "engine", "language", "success", "skills",
        "guards", "perception", "world", "robots", "exceptions",
    },
    "explore": {"batch", "recording", "engine", "language", "world", "robots", "exceptions"},
    "batch": {"recording", "engine", "language", "world", "robots", "exceptions"},
    "live": {"recording", "engine", "language", "world", "robots", "exceptions"},
    "recording": {"engine", "language", "guards", "world", "robots", "exceptions"},
    "engine": {
        "language", "success", "skills", "guards", "perception", "world", "robots", "exceptions",
    },
    "language": {"success", "skills", "guards", "perception", "world", "robots", "exceptions"},
    "success": {"skills", "perception", "world", "robots", "exceptions"},
    "skills": {"perception", "world", "robots", "exceptions"},
    "guards": {"world", "robots", "exceptions"},
    "perception": {"world", "robots", "exceptions"},
    "world": {"robots", "exceptions"},
    "robots": {"exceptions"},
    "exceptions": set(),
}  # fmt: skip
"""Layer -> the layers its modules may import at run time (besides its own)."""

LIFETIME_MODULES = {
    "orchestrator.engine.cell": "engine",  # what lives as long as the world, built once
    "orchestrator.engine.hardware": "engine",  # what an episode's Context reads of it
    "orchestrator.engine.context": "engine",  # the episode
    "orchestrator.robots.hand": "robots",  # the hand's current-limited drive
    "orchestrator.world.wrist": "world",  # the wrist force sensor (C or Python, chosen once)
}
"""The modules of the three lifetimes (docs/architecture.md, "Lifetimes") and their layers:
the hand's drive may import nothing of the world or the engine, the wrist sensor nothing of
the engine, and the context must not name the cell's class (the cell builds the step loop,
which is handed the context: a cycle)."""

LOOSE_MODULES = {"orchestrator", "orchestrator.exceptions"}
"""Modules outside a layer folder (docs/architecture.md says why each is there)."""
DATA_PACKAGES = {"orchestrator.schemas"}
"""Packages that hold data files only (the generated JSON Schemas)."""


@dataclass(frozen=True)
class Import:
    source: str
    target: str
    type_only: bool
    line: int


def _modules() -> dict[str, Path]:
    out: dict[str, Path] = {}
    for prefix, root in SOURCES.items():
        for path in root.rglob("*.py"):
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join([prefix, *parts])] = path
    return out


MODULES = _modules()


def layer_of(module: str) -> str:
    parts = module.split(".")
    if len(parts) == 1:
        return "root"
    return parts[1]


def _type_checking_lines(tree: ast.Module) -> set[int]:
    lines: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and (
            (isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING")
            or (isinstance(node.test, ast.Attribute) and node.test.attr == "TYPE_CHECKING")
        ):
            for child in node.body:
                for sub in ast.walk(child):
                    if hasattr(sub, "lineno"):
                        lines.add(sub.lineno)
    return lines


def _resolve(module: str, is_package: bool, level: int, name: str | None) -> str:
    base = module.split(".") if is_package else module.split(".")[:-1]
    if level > 1:
        base = base[: len(base) - (level - 1)]
    return ".".join(base + ([name] if name else []))


def imports_of(module: str) -> Iterator[Import]:
    path = MODULES[module]
    tree = ast.parse(path.read_text(), str(path))
    type_only = _type_checking_lines(tree)
    is_package = path.name == "__init__.py"
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                target = _resolve(module, is_package, node.level, node.module)
            else:
                target = node.module or ""
            # `from pkg import submodule` imports the submodule
            names = [
                f"{target}.{a.name}" if f"{target}.{a.name}" in MODULES else target
                for a in node.names
            ]
        else:
            continue
        for name in names:
            if name == "orchestrator" or name.startswith("orchestrator."):
                target = name
                while target not in MODULES and "." in target:
                    target = target.rsplit(".", 1)[0]  # `orchestrator.x.Name` -> `orchestrator.x`
                yield Import(module, target, node.lineno in type_only, node.lineno)


@pytest.fixture(scope="module")
def imports() -> list[Import]:
    """Every import of every module (read once, by the tests that use it: not at collection,
    which every xdist worker repeats)."""
    return [imp for module in sorted(MODULES) for imp in imports_of(module)]


def _find_cycle(edges: dict[str, set[str]]) -> list[str] | None:
    """One cycle of the directed graph, or None (iterative DFS, white/grey/black)."""
    colour: dict[str, int] = {}
    for start in sorted(edges):
        if colour.get(start):
            continue
        stack: list[tuple[str, Iterator[str]]] = [(start, iter(sorted(edges.get(start, ()))))]
        colour[start] = 1
        path = [start]
        while stack:
            node, children = stack[-1]
            child = next(children, None)
            if child is None:
                colour[node] = 2
                stack.pop()
                path.pop()
                continue
            if colour.get(child) == 1:
                return [*path[path.index(child) :], child]
            if not colour.get(child):
                colour[child] = 1
                path.append(child)
                stack.append((child, iter(sorted(edges.get(child, ())))))
    return None


def test_the_lifetime_modules_sit_in_their_layers(imports):
    for module, layer in LIFETIME_MODULES.items():
        assert module in MODULES, f"{module} is missing"
        assert layer_of(module) == layer, module
    hand = {i.target for i in imports if i.source == "orchestrator.robots.hand"}
    assert all(layer_of(t) in {"robots", "exceptions"} for t in hand), sorted(hand)
    wrist = {i.target for i in imports if i.source == "orchestrator.world.wrist"}
    assert all(layer_of(t) in ALLOWED["world"] | {"world"} for t in wrist), sorted(wrist)
    context = {i.target for i in imports if i.source == "orchestrator.engine.context"}
    assert "orchestrator.engine.cell" not in context, "the context names the Cell class"


def test_the_package_has_the_layer_folders():
    layers = {layer_of(m) for m in MODULES if m not in LOOSE_MODULES | DATA_PACKAGES}
    assert {"language", "engine", "world", "guards", "recording", "batch"} <= layers
    assert layers <= set(ALLOWED), f"modules outside a known layer: {layers - set(ALLOWED)}"


def test_no_module_outside_a_layer_folder():
    loose = {m for m in MODULES if m.count(".") == 1 and not MODULES[m].name == "__init__.py"}
    assert loose <= LOOSE_MODULES, f"not in a layer folder: {sorted(loose - LOOSE_MODULES)}"


def test_run_time_imports_only_go_down(imports):
    upward = []
    for imp in imports:
        if imp.type_only or imp.source in LOOSE_MODULES - {"orchestrator.exceptions"}:
            continue
        src, dst = layer_of(imp.source), layer_of(imp.target)
        if src != dst and dst not in ALLOWED.get(src, set()):
            upward.append(f"{MODULES[imp.source]}:{imp.line}: {imp.source} -> {imp.target}")
    assert not upward, "imports that go up a layer:\n" + "\n".join(upward)


def test_no_import_cycles_between_modules(imports):
    edges: dict[str, set[str]] = {}
    for imp in imports:
        if imp.target != imp.source:
            edges.setdefault(imp.source, set()).add(imp.target)
    cycle = _find_cycle(edges)
    assert cycle is None, "import cycle (type-only imports count): " + " -> ".join(cycle or [])


def test_no_run_time_import_cycles_through_packages(imports):
    edges: dict[str, set[str]] = {}
    for imp in imports:
        if imp.type_only:
            continue
        # importing a.b.c first executes a/__init__ and a/b/__init__
        parts = imp.target.split(".")
        for i in range(1, len(parts) + 1):
            target = ".".join(parts[:i])
            if (
                target in MODULES
                and target != imp.source
                and not imp.source.startswith(target + ".")
            ):
                edges.setdefault(imp.source, set()).add(target)
    cycle = _find_cycle(edges)
    assert cycle is None, "run-time import cycle: " + " -> ".join(cycle or [])


@pytest.mark.parametrize(
    ("source", "target", "bad"),
    [
        ("orchestrator.language.validation", "orchestrator.engine.runner", True),
        ("orchestrator.world.world", "orchestrator.engine.context", True),
        ("orchestrator.engine.runner", "orchestrator.language.load", False),
        ("orchestrator.skills.move", "orchestrator.world.pose", False),
    ],
)
def test_the_layer_table_says_what_may_import_what(source, target, bad):
    src, dst = layer_of(source), layer_of(target)
    assert (dst not in ALLOWED[src]) is bad


def test_the_cycle_finder_finds_a_cycle():
    assert _find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None
