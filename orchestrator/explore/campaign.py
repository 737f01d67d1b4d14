"""`explore`: draw variations, run them on a batch backend, shrink each failure, write it down.

Files in the output directory:

* `explore.json`: what was explored (scenario, seed, N, the parameters and their ranges); a
  resumed exploration must match it;
* `results.jsonl`: one line per variation as it finishes (the variation, its failures, the
  run's result line);
* `counterexamples.jsonl`: one line per failing variation, shrunk: the minimal variation, the
  seed, the violated invariant or check and its message, the variation it was shrunk from,
  the snapshot just before the first violation and the Rerun recording of the minimal run;
* `counterexamples/<k>/`: that snapshot (`snapshots/`) and recording (`episodes/`);
* `summary.json`: counts per failure class.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..batch.backends import Backend, LocalBackend
from ..batch.config import BackendName, default_workers, portable_ref
from ..batch.exceptions import BatchError
from ..batch.progress import BatchProgress, NullProgress
from ..batch.task import EpisodeTask
from ..engine.strict_json import dumps
from ..exceptions import ConfigError
from ..language.load import LoadedScenario, load_scenario
from ..language.yamlio import parse_yaml
from .artifacts import keep_artifacts
from .params import Parameter, scenario_parameters
from .sampler import Variation, draw_variations
from .shrink import shrink
from .verdict import failures, message, primary, refused, run_variation

__all__ = ["ExploreConfig", "explore", "load_space"]

MANIFEST = "explore.json"
RESULTS = "results.jsonl"
COUNTEREXAMPLES = "counterexamples.jsonl"
SUMMARY = "summary.json"


@dataclass(frozen=True)
class ExploreConfig:
    """One `orchestrator explore`.

    Attributes:
        scenario: Scenario file or bundled name.
        n: Variations to draw.
        seed: The exploration's seed (same seed, same variations).
        out_dir: Output directory.
        workers: Worker processes (None: every core).
        backend: `local` or `ray`.
        address: Ray address.
        resume: Skip variations already in `results.jsonl`.
        max_wall_s: Wall-clock limit of one episode [s].
        allow_paths: `--allow-path` directories.
        shrink: Shrink each failure (False: file it as drawn).
    """

    scenario: str
    n: int
    out_dir: Path
    seed: int = 0
    workers: int | None = None
    backend: BackendName = "local"
    address: str | None = None
    resume: bool = False
    max_wall_s: float | None = 600.0
    allow_paths: tuple[str, ...] = ()
    shrink: bool = True


@dataclass
class Space:
    """A scenario's explored space: the scenario, its parameters, and its validation."""

    ref: str
    loaded: LoadedScenario
    params: list[Parameter]
    allow_paths: tuple[str, ...] = ()
    _accepted: dict[tuple[str, ...], bool] = field(default_factory=dict)

    @property
    def by_path(self) -> dict[str, Parameter]:
        return {p.path: p for p in self.params}

    def accepts(self, overrides: tuple[str, ...]) -> bool:
        """Validation accepts the scenario with these `--set` texts."""
        if overrides not in self._accepted:
            try:
                load_scenario(self.ref, list(overrides), allow_paths=self.allow_paths)
                self._accepted[overrides] = True
            except ConfigError:
                self._accepted[overrides] = False
        return self._accepted[overrides]


def load_space(ref: str, allow_paths: Sequence[str] = ()) -> Space:
    """The explored space of scenario `ref` (ConfigError: the scenario itself is invalid)."""
    loaded = load_scenario(ref, allow_paths=allow_paths)
    path = loaded.path
    raw = parse_yaml(path.read_text(), str(path)).data if path.is_file() else {}
    params = scenario_parameters(loaded.scenario, raw if isinstance(raw, dict) else {})
    return Space(portable_ref(ref), loaded, params, tuple(allow_paths))


class Runner:
    """Runs sets of variations on a backend, each line as it finishes."""

    def __init__(self, space: Space, config: ExploreConfig, backend: Backend) -> None:
        self.space, self.config, self.backend = space, config, backend
        self.out_dir = config.out_dir.resolve()

    def task(self, overrides: tuple[str, ...], seed: int, **kw: Any) -> EpisodeTask:
        return EpisodeTask(self.space.ref, overrides, seed, kw.pop("record", "none"),
                           str(kw.pop("out_dir", self.out_dir)), self.config.max_wall_s,
                           self.space.allow_paths, **kw)  # fmt: skip

    def lines(self, tasks: list[EpisodeTask]):
        return self.backend.run(tasks) if tasks else iter(())

    def fails_like(self, seed: int, name: str) -> Callable[[Sequence[dict]], list[bool]]:
        """Shrinking's question: which of these candidates still fail with `name`?"""

        params = self.space.by_path

        def fails(candidates: Sequence[dict[str, Any]]) -> list[bool]:
            texts = [Variation(0, seed, dict(c)).overrides(params) for c in candidates]
            verdict: dict[tuple[str, ...], bool] = {}
            todo = []
            for t in texts:
                if not self.space.accepts(t):
                    verdict[t] = False  # validation refuses it: not a smaller failure
                elif t not in verdict:
                    verdict[t] = False
                    todo.append(self.task(t, seed))
            for line in self.lines(todo):
                verdict[tuple(line["overrides"])] = name in failures(line)
            return [verdict[t] for t in texts]

        return fails


def _append(path: Path, line: dict[str, Any]) -> None:
    with path.open("a") as f:
        f.write(dumps(line) + "\n")


def _read_lines(path: Path) -> list[dict[str, Any]]:
    if not path.is_file():
        return []
    out = []
    for text in path.read_text().splitlines():
        try:
            out.append(json.loads(text))
        except ValueError:
            break  # a line torn by a crash: that variation runs again
    return out


def _manifest(space: Space, config: ExploreConfig) -> dict[str, Any]:
    return {
        "scenario": space.loaded.name,
        "scenario_ref": space.ref,
        "seed": config.seed,
        "n": config.n,
        "parameters": [
            {
                "path": p.path,
                "nominal": p.nominal,
                "lo": p.lo,
                "hi": p.hi,
                "choices": list(p.choices),
            }
            for p in space.params
        ],  # fmt: skip
    }


def explore(
    config: ExploreConfig,
    progress: BatchProgress | None = None,
    backend: Backend | None = None,
    warn: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Run an exploration (see the module docstring); returns the summary it writes.

    Raises:
        ConfigError: The scenario is invalid.
        BatchError: The output directory holds another exploration (or, without --resume,
            any), or the backend cannot be used.
    """
    progress = progress or NullProgress()
    space = load_space(config.scenario, config.allow_paths)
    out_dir = config.out_dir.resolve()
    manifest = _manifest(space, config)
    done = {line["k"]: line for line in _read_lines(out_dir / RESULTS)}
    if done and not config.resume:
        raise BatchError(
            f"{out_dir / RESULTS} already holds {len(done)} variations: pass --resume to "
            "continue that exploration, or choose another --out"
        )
    if (out_dir / MANIFEST).is_file():
        before = json.loads((out_dir / MANIFEST).read_text())
        if config.resume and before != manifest:
            raise BatchError(f"{out_dir} holds an exploration of another scenario, seed or N; "
                             "resume it with the same ones, or choose another --out")  # fmt: skip
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / MANIFEST).write_text(dumps(manifest, indent=2) + "\n")
    if backend is None:
        backend = _backend(config)
    variations = draw_variations(space.params, config.n, config.seed, space.accepts)
    if len(variations) < config.n and warn is not None:
        warn(f"{config.n - len(variations)} variations were left out: validation refused "
             "every draw of them")  # fmt: skip
    runner = Runner(space, config, backend)
    by_seed = {v.seed: v for v in variations}
    todo = [v for v in variations if v.k not in done]
    params = space.by_path
    tasks = [runner.task(v.overrides(params), v.seed) for v in todo]
    progress.start(len(variations), [done[k]["result"] for k in sorted(done)])
    try:
        for line in runner.lines(tasks):
            var = by_seed[line["seed"]]
            entry = {**var.to_dict(), "failures": failures(line), "primary": primary(line),
                     "refused": refused(line), "result": line}  # fmt: skip
            _append(out_dir / RESULTS, entry)
            done[var.k] = entry
            progress.advance(line)
    finally:
        progress.stop()
    examples = _counterexamples(runner, space, config, done, warn)
    summary = _summary(space, config, done, examples)
    (out_dir / SUMMARY).write_text(dumps(summary, indent=2) + "\n")
    return summary


def _backend(config: ExploreConfig) -> Backend:
    workers = config.workers if config.workers is not None else default_workers()
    if config.backend == "ray":
        from ..batch.backends.ray import RayBackend

        return RayBackend(config.workers, config.address, run_fn=run_variation)
    return LocalBackend(workers, run_fn=run_variation)


def _counterexamples(runner: Runner, space: Space, config: ExploreConfig,
                     done: dict[int, dict[str, Any]], warn: Callable[[str], None] | None
                     ) -> list[dict[str, Any]]:  # fmt: skip
    """Shrink every failing variation not shrunk before; the counterexamples, by k."""
    path = runner.out_dir / COUNTEREXAMPLES
    filed = {line["k"]: line for line in _read_lines(path)}
    for k in sorted(done):
        entry = done[k]
        name = entry.get("primary")
        if not name or k in filed:
            continue
        values = dict(entry["values"])
        runs = 0
        if config.shrink:
            shrunk = shrink(values, space.by_path, runner.fails_like(entry["seed"], name))
            values, runs = shrunk.values, shrunk.runs
        moved = Variation(k, entry["seed"], values)
        example = {
            "k": k, "seed": entry["seed"], "violated": name, "values": values,
            "moved": len(values), "drawn": entry["values"], "shrink_runs": runs,
            "message": message(entry["result"], name),
            "set": list(moved.overrides(space.by_path)),
            "replay": f"orchestrator explore {config.scenario} --out {config.out_dir} "
                      f"--replay {k}",
        }  # fmt: skip
        where = runner.out_dir / "counterexamples" / str(k)
        example.update(keep_artifacts(space.ref, moved, space.by_path, name, where, runner.out_dir,
                                      space.allow_paths, config.max_wall_s, warn))  # fmt: skip
        _append(path, example)
        filed[k] = example
    return [filed[k] for k in sorted(filed)]


def _summary(space: Space, config: ExploreConfig, done: dict[int, dict[str, Any]],
             examples: list[dict[str, Any]]) -> dict[str, Any]:  # fmt: skip
    classes: dict[str, int] = {}
    for e in done.values():
        if e.get("primary"):
            classes[e["primary"]] = classes.get(e["primary"], 0) + 1
    minimal: dict[str, list[list[str]]] = {}
    for ex in examples:
        moved = sorted(ex["values"])
        group = minimal.setdefault(ex["violated"], [])
        if moved not in group:
            group.append(moved)
    return {
        "scenario": space.loaded.name,
        "seed": config.seed,
        "variations": len(done),
        "parameters": len(space.params),
        "refused": sum(1 for e in done.values() if e.get("refused")),
        "passed": sum(1 for e in done.values() if not e.get("primary") and not e.get("refused")),
        "failed": sum(1 for e in done.values() if e.get("primary")),
        "classes": dict(sorted(classes.items())),
        "minimal_parameters": {k: v for k, v in sorted(minimal.items())},
        "counterexamples": len(examples),
    }
