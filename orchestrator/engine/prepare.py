"""The front door: every entry point prepares a run the same way.

`orchestrator run`, `batch` (each episode, and once before any runs), `faults` (each row),
`serve` (the session's world) and time travel (`run --break`; `run --from` checks its goals
with `check_resumed_goals`) all go through `prepare`:

1. the `--set` texts are parsed once (`parse_override`), and the loader applies what they say;
2. the scenario, its machine and every option are validated (`load_scenario`'s checks);
3. the world is compiled once, for the run's seed: the compile that proves MuJoCo builds the
   scene is the world the run then steps (`Prepared.new_run` hands it over);
4. every value a `--set` gives a key that becomes a position (a target, a via point, an
   offset, a position hint) goes through the goal guardrail (engine/guardrail.py) on that
   world, from the arm's home configuration.

So one input is refused the same way everywhere: a `ConfigError` whose diagnostics the
command line prints the same way, exit 2, before anything moves. A goal refused is said
`<--set>: goal rejected: KEY = VALUE: where it is used: why`.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from ..exceptions import ConfigError
from ..language.diagnostics import Diagnostic
from ..language.load import LoadedScenario, compile_world, load_world
from ..language.overrides import Override, parse_override
from ..world.world import World
from .guardrail import GoalRejected, check_goals, posed_keys
from .result import RunResult
from .runner import Observer, RunState, drive, new_run

__all__ = ["GOAL_REJECTED", "Prepared", "check_resumed_goals", "goal_refused", "prepare"]

GOAL_REJECTED = "goal rejected"
"""What a refused goal's diagnostic says before the guardrail's reason."""


@dataclass
class Prepared:
    """A run ready to start: validated, its goals checked, its world compiled for its seed.

    Attributes:
        loaded: The scenario with the run's `--set`, `--fault` and `--event`.
        seed: The episode seed.
        goal_keys: The blackboard keys the `--set` values set that take part in a position
            (each was checked; another seed's world checks them again, `reseeded`).
        world: The world built for `seed`, never stepped; the first `new_run` takes it (None
            afterwards: a second run of the same episode builds its own).
    """

    loaded: LoadedScenario
    seed: int
    goal_keys: tuple[str, ...]
    world: World | None

    def new_run(self) -> RunState:
        """The run, its machine not started yet (on the prepared world the first time)."""
        world, self.world = self.world, None
        return new_run(self.loaded, self.seed, world)

    def run_episode(
        self, observers: Sequence[Observer] | None = None, max_wall_s: float | None = None
    ) -> RunResult:
        """Run the episode to its end (`runner.drive`).

        Raises:
            WallTimeExceeded: The episode ran past `max_wall_s`.
        """
        result = drive(self.new_run(), observers, max_wall_s)
        assert result is not None
        return result

    def reseeded(self, seed: int) -> Prepared:
        """The same scenario and values for `seed`: its world compiled, its goals checked on
        it (objects drawn elsewhere may put a goal inside one). The world this one holds is
        handed over when the seed is its own.

        Raises:
            ConfigError: The scene drawn for `seed` does not compile, or a goal is refused.
        """
        if seed == self.seed and self.world is not None:
            world, self.world = self.world, None
        else:
            world = compile_world(self.loaded, seed)
            _check_goals(self.loaded, self.goal_keys, world)
        return Prepared(self.loaded, seed, self.goal_keys, world)


def prepare(
    ref: str,
    seed: int = 0,
    sets: Iterable[str] = (),
    faults: Iterable[str] = (),
    events: Iterable[str] = (),
    allow_paths: Sequence[Path | str] = (),
) -> Prepared:
    """Prepare one run of `ref` for `seed`: the front door of every entry point.

    Args:
        ref: Scenario file or bundled name, or a machine file (run in the default scene).
        seed: Episode seed.
        sets: `--set KEY=VALUE` texts.
        faults: `--fault SPEC` texts.
        events: `--event T:NAME` texts.
        allow_paths: Directories outside the scenario's tree its files may name.

    Raises:
        ConfigError: Every problem with the scenario and the options, or the first goal the
            guardrail refuses (nothing was built that runs).
    """
    parsed = [parse_override(text) for text in sets]
    loaded, world = load_world(ref, seed, parsed, list(faults), allow_paths, list(events))
    keys = tuple(posed_keys(loaded, set_keys(parsed)))
    _check_goals(loaded, keys, world)
    return Prepared(loaded, seed, keys, world)


def set_keys(parsed: Iterable[Override | Diagnostic]) -> list[str]:
    """The blackboard keys parsed `--set`s write: `KEY=...`, `blackboard.KEY...=...`, and
    each key of `blackboard={...}` (a scenario value's path names no blackboard key)."""
    keys: list[str] = []
    for ov in parsed:
        if not isinstance(ov, Override) or not ov.path:
            continue
        if ov.path[0] != "blackboard":
            keys.append(ov.path[0])
        elif len(ov.path) > 1:
            keys.append(ov.path[1])
        elif isinstance(ov.value, dict):
            keys += [str(k) for k in ov.value]
    return keys


def goal_refused(exc: GoalRejected) -> ConfigError:
    """The refusal of a goal, as every entry point reports it (`<--set>: goal rejected: ...`)."""
    return ConfigError([Diagnostic("<--set>", 0, 0, GOAL_REJECTED, str(exc))])


def _check_goals(loaded: LoadedScenario, keys: Sequence[str], world: World) -> None:
    """The guardrail on `world` with the arm at home, where the run starts."""
    if not keys:
        return
    try:
        check_goals(loaded, keys, world, world.home)
    except GoalRejected as exc:
        raise goal_refused(exc) from None


def check_resumed_goals(run: RunState, sets: Sequence[str]) -> None:
    """`run --from SNAPSHOT --set`: the positions the new values take part in go through the
    guardrail from where the arm is (as a live session's goals do). `sets` were applied to the
    run's blackboard already (`open_run` checked each names a blackboard key).

    Raises:
        ConfigError: The first goal refused (`<--set>: goal rejected: ...`).
    """
    from dataclasses import replace

    keys = [text.partition("=")[0].strip() for text in sets]  # KEY=VALUE, checked by open_run
    keys = posed_keys(run.loaded, keys)
    if not keys:
        return
    world, scn = run.ctx.world, run.loaded.scenario
    now = {**scn.blackboard, **{k: run.ctx.blackboard.get(k) for k in keys}}
    loaded = replace(run.loaded, scenario=scn.model_copy(update={"blackboard": now}))
    try:
        check_goals(loaded, keys, world, world.data.qpos[world.arm_qpos].copy())
    except GoalRejected as exc:
        raise goal_refused(exc) from None
