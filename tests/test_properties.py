"""Property-based tests: generated machines, and mutations of the bundled YAML files."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, assume, event, given, settings
from hypothesis import strategies as st

from orchestrator.engine.executor import Executor
from orchestrator.engine.runner import initial_blackboard
from orchestrator.language.load import load_machine

from .scripted import FakeContext, InstantStop, Scripted, register

REPO = Path(__file__).resolve().parent.parent
OUTCOMES = ("done", "failed", "other")
SETTINGS = settings(
    max_examples=60,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)


@st.composite
def machines(draw, depth: int = 0, prefix: str = "m") -> dict:
    """A valid machine: state i's `done` leads on to state i+1, so every state is reachable and
    can finish; the other outcomes go anywhere. Scripts end in `done`, so every run ends."""
    n = draw(st.integers(1, 4))
    names = [f"S{i}" for i in range(n)]
    finals = {"OK": "done" if depth else "succeeded", "KO": "failed"}
    targets = names + list(finals)
    states: dict = {}
    for i, name in enumerate(names):
        nxt = names[i + 1] if i + 1 < n else "OK"
        nested = depth < 2 and draw(st.booleans()) and draw(st.booleans())
        state: dict
        if nested:
            inner = draw(machines(depth=depth + 1, prefix=f"{prefix}_{name}"))
            state = {"initial": inner["initial"], "states": inner["states"]}
            outcomes = ["done", "failed"]
        else:
            script = draw(st.lists(st.sampled_from(OUTCOMES), max_size=3)) + ["done"]
            ticks = draw(st.integers(1, 3))
            state = {
                "skill": "scripted",
                "with": {"script": script, "ticks": ticks, "key": f"{prefix}_{name}"},
            }
            outcomes = list(OUTCOMES)
        transitions = {o: draw(st.sampled_from(targets)) for o in outcomes}
        transitions["done"] = nxt
        if i + 1 == n:
            transitions["failed"] = "KO"  # so that KO is reachable too
        if draw(st.booleans()):
            state["retry"] = draw(st.integers(1, 2))
        if draw(st.integers(0, 4)) == 0:
            state["timeout"] = draw(st.sampled_from([0.02, 0.05, 0.5]))
            transitions["timeout"] = nxt
        state["transitions"] = transitions
        states[name] = state
    for name, outcome in finals.items():
        states[name] = {"final": outcome}
    return {"name": prefix, "initial": names[0], "states": states}


def _paths(spec: dict, prefix: str = "") -> set[str]:
    out = set()
    for name, state in spec["states"].items():
        out.add(prefix + name)
        if "states" in state:
            out |= _paths(state, prefix + name + ".")
    return out


@SETTINGS
@given(spec=machines())
def test_generated_machines_validate_and_run_to_a_final_state(tmp_path_factory, spec):
    register()
    Scripted.stopped.clear()
    path = tmp_path_factory.mktemp("gen") / "m.yaml"
    path.write_text(yaml.safe_dump(spec, sort_keys=False))
    node = load_machine(str(path))  # must validate
    ctx = FakeContext()
    ctx.blackboard = initial_blackboard(node, {})
    ex = Executor(node, ctx, [], InstantStop, hold_s=0.05)
    ex.start()
    for _ in range(20_000):
        if ex.done:
            break
        ex.tick()
        ctx.t = round(ctx.t + 0.01, 9)
    assert ex.done, "the machine did not finish"
    declared = _paths(spec)
    visited = {t["to"] for t in ex.transitions} | {t["from"] for t in ex.transitions}
    assert visited <= declared
    assert spec["states"][ex.final_state]["final"] in ("succeeded", "failed")
    # every skill that was started was stopped exactly once (finished, timed out or retried)
    started = sum(v for k, v in ctx.blackboard.as_dict().items() if k.startswith("m_") or k == "m")
    assert started == len(Scripted.stopped) > 0


BUNDLED = {
    "machines/pick_place.yaml": (REPO / "machines" / "pick_place.yaml").read_text(),
    "machines/grasp.yaml": (REPO / "machines" / "grasp.yaml").read_text(),
    "scenarios/pick_place.yaml": (REPO / "scenarios" / "pick_place.yaml").read_text(),
}


@st.composite
def mutations(draw) -> tuple[str, str]:
    """(which file, its mutated text): deleted or duplicated lines, renamed states, wrong
    types, truncation, swapped lines."""
    which = draw(st.sampled_from(sorted(BUNDLED)))
    lines = BUNDLED[which].splitlines(keepends=True)
    kind = draw(st.sampled_from(["delete", "duplicate", "rename", "retype", "truncate", "swap"]))
    i = draw(st.integers(0, len(lines) - 1))
    if kind == "delete":
        del lines[i]
    elif kind == "duplicate":
        lines.insert(i, lines[i])
    elif kind == "swap":
        j = draw(st.integers(0, len(lines) - 1))
        lines[i], lines[j] = lines[j], lines[i]
    elif kind == "truncate":
        text = "".join(lines)
        return which, text[: draw(st.integers(0, len(text)))]
    elif kind == "rename":
        words = sorted(
            {
                w
                for w in (
                    "SEARCH",
                    "GRASP",
                    "PICK",
                    "DONE",
                    "FAILED",
                    "TRANSPORT",
                    "OPEN",
                    "CLOSE",
                    "VERIFY",
                    "MISSED",
                    "cube",
                    "pad",
                    "move",
                    "release",
                )
                if w in BUNDLED[which]
            }
        )
        word = draw(st.sampled_from(words))
        new = draw(st.sampled_from([word.lower(), word + "X", "", "on"]))
        return which, BUNDLED[which].replace(word, new, 1)
    else:  # retype a value
        line = lines[i]
        if ":" in line:
            key, _, _ = line.partition(":")
            value = draw(
                st.sampled_from(["yes", "-1", "[1, 2]", "{a: 1}", "null", "'text'", "1e9"])
            )
            lines[i] = f"{key}: {value}\n"
    return which, "".join(lines)


def _run_mutation(tmp_path_factory, cli, mutation) -> None:
    which, text = mutation
    root = tmp_path_factory.mktemp("mut")
    for name, original in BUNDLED.items():
        dst = root / name
        dst.parent.mkdir(exist_ok=True)
        dst.write_text(original)
    scenario = root / "scenarios" / "pick_place.yaml"
    scenario.write_text(
        scenario.read_text().replace("machine: pick_place", "machine: ../machines/pick_place.yaml")
    )
    target = root / which
    if which.startswith("scenarios"):
        text = text.replace("machine: pick_place", "machine: ../machines/pick_place.yaml")
    target.write_text(text)
    assume(text != BUNDLED[which])
    res = cli(
        "run", str(scenario), "--json", "--set", "physics.time_limit_s=8", "--allow-path", str(root)
    )
    assert res.exception is None, f"traceback for mutation of {which}: {res.exception!r}"
    assert "Traceback" not in res.stderr
    assert res.exit_code in (0, 1, 2, 3)
    event(f"exit {res.exit_code}")
    if res.exit_code == 2:
        assert res.stderr.strip(), "exit 2 without a message"
    else:
        assert res.json["outcome"] in ("succeeded", "failed", "aborted")


@settings(SETTINGS, max_examples=20)
@given(mutation=mutations())
def test_mutated_bundled_files_exit_2_or_run_never_a_traceback(tmp_path_factory, cli, mutation):
    """20 mutations (each a run of up to 8 s simulated); the slow suite tries 60."""
    _run_mutation(tmp_path_factory, cli, mutation)


@pytest.mark.slow
@SETTINGS
@given(mutation=mutations())
def test_60_mutated_bundled_files_exit_2_or_run_never_a_traceback(tmp_path_factory, cli, mutation):
    _run_mutation(tmp_path_factory, cli, mutation)


def test_a_mutation_that_breaks_the_machine_is_reported(cli, tmp_path):
    for name, original in BUNDLED.items():
        (tmp_path / Path(name).name).write_text(original)
    (tmp_path / "pick_place.yaml").write_text(
        BUNDLED["machines/pick_place.yaml"].replace("OPEN:", "OPN:")
    )
    res = cli("validate", str(tmp_path / "pick_place.yaml"))
    assert res.exit_code == 2 and "unknown state 'OPEN'" in res.stderr
