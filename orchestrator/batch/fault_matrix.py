"""The fault matrix: one episode per fault type, and what the safety layer made of it.

Each row injects one fault (a `--fault` spec) into the same seed of a scenario and records the
guard that fired, the exit code, the time from the fault to the abort, and the controlled
stop's time and distance. Every bundled scenario has a matrix that injects each fault where it
matters (the sensor and motor faults while the arm approaches what it grasps, or while the
probe traces the incision; the world's faults while an object is carried, lifted or
perceived), with the guard expected to catch it and the latency within which it must; any
other scenario gets the generic matrix, every fault at t = 1 s, with no expectation.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, replace

from ..engine.prepare import prepare
from ..engine.result import EXIT_CODES
from ..language.load import LoadedScenario
from ..language.machine import ESTOP, guard_entries

__all__ = [
    "DETECTED_BY",
    "MATRICES",
    "MatrixRow",
    "RowResult",
    "blind_kinds",
    "expected",
    "matrix_for",
    "run_matrix",
]


@dataclass(frozen=True)
class MatrixRow:
    """One fault of a matrix.

    Attributes:
        fault: The `--fault` spec.
        expect: The guard expected to catch it, or `flow:<outcome>` when the machine itself
            handles the fault (a perception miss is retried; `flow:handled`: it ends without
            an abort, whatever its outcome), or `a|b` for either, or "" for no expectation.
        within_s: Longest time from the fault to its detection the row accepts [s] (None:
            any); the latency docs/safety.md states for it.
    """

    fault: str
    expect: str = ""
    within_s: float | None = None


@dataclass(frozen=True)
class RowResult:
    """What happened to one row (the `--json` row)."""

    fault: str
    expect: str
    outcome: str
    guard: str | None
    exit_code: int
    fault_t: float | None
    detect_s: float | None
    stop_time_s: float | None
    stop_distance_mm: float | None
    ok: bool | None
    message: str
    within_s: float | None = None
    stop_distance_min_mm: float | None = None
    undetected: bool = False
    """A guard should have caught the fault and none did (the run ended without an abort)."""
    blind: bool = False
    """No guard of the scenario can catch this kind of fault (`DETECTED_BY`): whatever the
    run did, the safety layer could not have seen it."""

    def to_dict(self) -> dict:
        return asdict(self)


def _sensor_rows(when: str, joint: int | None = None, saturate: float = 0.05) -> list[MatrixRow]:
    """The sensor and motor faults, injected at `when` (while the arm moves), on arm joint
    `joint` (the fault's default, 2, if None), each with the latency its detection takes
    there (measured on seed 0, with margin: docs/safety.md)."""
    j = "" if joint is None else f"joint={joint},"
    js = "" if joint is None else f":joint={joint}"
    return [
        MatrixRow(f"estop@{when}", "estop", 0.002),
        MatrixRow(f"ft_dropout@{when}", "sensor_health", 0.02),
        MatrixRow(f"ft_bias@{when}", "contact_force", 0.002),
        MatrixRow(f"ft_spike@{when}", "sensor_health", 0.002),
        MatrixRow(f"ft_nan@{when}", "sensor_health", 0.002),
        MatrixRow(f"encoder_freeze{js}@{when}", "sensor_health", 0.1),
        MatrixRow(f"encoder_noise{js}@{when}", "sensor_health", 0.002),
        MatrixRow(f"encoder_nan{js}@{when}", "sensor_health", 0.002),
        MatrixRow(f"actuator_saturate:{j}fraction={saturate:g}@{when}", "sensor_health", 0.01),
        MatrixRow(f"actuator_lost{js}@{when}", "sensor_health", 0.01),
    ]


_APPROACH = "PICK.GRASP.APPROACH+0.75"
_TRACE = "EXECUTE.TRACE+0.5"
_SURGICAL = [
    MatrixRow(f"estop@{_TRACE}", "estop", 0.002),
    MatrixRow(f"ft_dropout@{_TRACE}", "sensor_health", 0.02),
    MatrixRow(f"ft_bias:force_n=[0,0,8]@{_TRACE}", "contact_force", 0.002),
    MatrixRow(f"ft_spike@{_TRACE}", "sensor_health", 0.002),
    MatrixRow(f"ft_nan@{_TRACE}", "sensor_health", 0.002),
    MatrixRow(f"encoder_freeze@{_TRACE}", "sensor_health", 1.0),
    MatrixRow(f"encoder_noise@{_TRACE}", "sensor_health", 0.002),
    MatrixRow(f"encoder_nan@{_TRACE}", "sensor_health", 0.002),
    MatrixRow(f"actuator_saturate@{_TRACE}", "sensor_health", 0.01),
    MatrixRow(f"actuator_lost@{_TRACE}", "sensor_health", 0.01),
    MatrixRow("obstacle:pos=[0.47,0.0,0.34],size=[0.03,0.08,0.03]@NAVIGATE", "collision", 1.5),
    MatrixRow("perception_miss@0", "flow:failed"),
]
_PICK_PLACE_WORLD = [
    MatrixRow(
        "obstacle:pos=[0.5,0.28,0.42],size=[0.08,0.03,0.08]@TRANSPORT+0.05", "collision", 1.0
    ),
    MatrixRow("slip:object=cube,factor=0.005@TRANSPORT", "grasp_lost", 0.3),
    MatrixRow(
        "push:object=cube,force_n=[0,0,-150],duration_ms=20@PICK.GRASP.VERIFY+0.04",
        "contact_force",
        0.01,
    ),
    MatrixRow("perception_miss@0", "flow:succeeded"),
    # the cube seen 2 cm into the table: the grasp plan refuses to put the fingertips there
    MatrixRow("perception_offset:offset_m=[0,0,-0.02]@0", "flow:failed"),
]
_SORTING_WORLD = [
    # a plate across the carry to the bins, in front of them, put there as the carry starts
    MatrixRow("obstacle:pos=[0.47,0.12,0.42],size=[0.36,0.03,0.1]@TO_BIN+0.05", "collision", 1.5),
    MatrixRow("slip:object=held,factor=0.005@TO_BIN", "grasp_lost", 0.3),
    # 150 N on the parcel in the hand: past the force limit, or (a heavy parcel) the
    # sensor's range in the same step
    MatrixRow(
        "push:object=held,force_n=[0,0,-150],duration_ms=20@PICK.VERIFY+0.02",
        "contact_force|sensor_health",
        0.01,
    ),
    MatrixRow("perception_miss@0", "flow:succeeded"),
    # every parcel seen 2 cm into the table: each grasp is refused, each parcel rejected
    MatrixRow("perception_offset:offset_m=[0,0,-0.02]@0", "flow:succeeded"),
]
_MOBILE = "GRASPING.APPROACH+0.5"
MATRICES: dict[str, list[MatrixRow]] = {
    "pick_place": [
        *_sensor_rows(_APPROACH),
        *_PICK_PLACE_WORLD,
    ],
    "pick_place_vision": [
        *_sensor_rows(_APPROACH),
        *_PICK_PLACE_WORLD,
    ],
    "sorting": [*_sensor_rows("PICK.APPROACH+0.5"), *_SORTING_WORLD],
    "sorting_conveyor": [*_sensor_rows("PICK.APPROACH+0.5"), *_SORTING_WORLD],
    "mobile_search": [
        *_sensor_rows(_MOBILE, joint=5),
        MatrixRow("slip:object=cube,factor=0.005@LIFT", "grasp_lost", 0.5),
        MatrixRow(
            "push:object=cube,force_n=[0,0,-150],duration_ms=20@GRASPING.VERIFY+0.02",
            "contact_force",
            0.01,
        ),
        # the block pushed away as the base closes in: the grasp misses, the flow backs out,
        # looks again and grasps (or, the block out of reach, gives up naming it)
        MatrixRow(
            "push:object=cube,force_n=[-2,0,0],duration_ms=300@APPROACHING.CLOSE_IN+0.5",
            "flow:handled",
        ),
        MatrixRow("perception_miss@0", "flow:succeeded"),
        # the block seen 2 cm low: on a table the grasp plan refuses the fingertips below its
        # top (the flow gives up, naming it); on the floor (no box) the fingers touch it
        MatrixRow("perception_offset:offset_m=[0,0,-0.02]@0", "collision|flow:failed", 30.0),
    ],
    "surgical": _SURGICAL,
    "surgical_complication": _SURGICAL,
    "stack": [
        *_sensor_rows("PICK.APPROACH+0.75"),
        # a plate across the carry from the top cube to the base, put there as it starts
        MatrixRow("obstacle:pos=[0.5,0.02,0.36],size=[0.1,0.02,0.1]@CARRY+0.05", "collision", 1.0),
        MatrixRow("slip:object=top,factor=0.005@CARRY", "grasp_lost", 0.3),
        MatrixRow(
            "push:object=top,force_n=[0,0,-150],duration_ms=20@PICK.VERIFY+0.04",
            "contact_force",
            0.01,
        ),
        MatrixRow("perception_miss@0", "flow:handled"),
        MatrixRow("perception_offset:offset_m=[0,0,-0.02]@0", "flow:failed"),
    ],
    "reach_random": _sensor_rows("REACH+0.3"),
    # issue 44: the same machines on other arms (the UR5's scenes are the Panda's)
    "pick_place_ur5": [
        *_sensor_rows(_APPROACH),
        # the plate across the carry, where the UR5's palm passes (at the Panda's plate, beside
        # the pad, the UR5's shorter hand went by: undetected)
        MatrixRow(
            "obstacle:pos=[0.5,0.05,0.42],size=[0.08,0.03,0.08]@TRANSPORT+0.05", "collision", 1.0
        ),
        *_PICK_PLACE_WORLD[1:],
    ],
    "sorting_ur5": [*_sensor_rows("PICK.APPROACH+0.5"), *_SORTING_WORLD],
    "pick_place_so101": [
        # a servo arm's small torques: 5 % of a 0.7 Nm command departs from it more slowly
        # (22 ms on seed 0) than a Panda's 5 % of tens of Nm
        *(
            replace(row, within_s=0.04) if row.fault.startswith("actuator_saturate") else row
            for row in _sensor_rows("PICK.GRASP.APPROACH+0.5")
        ),
        # a plate across the carry to the pad, 0.2 m from the arm's base, as it starts
        MatrixRow(
            "obstacle:pos=[0.2,0.02,0.29],size=[0.1,0.02,0.1]@TRANSPORT+0.05", "collision", 1.0
        ),
        MatrixRow("slip:object=cube,factor=0.005@TRANSPORT", "grasp_lost", 0.3),
        MatrixRow(
            "push:object=cube,force_n=[0,0,-150],duration_ms=20@PICK.GRASP.VERIFY+0.04",
            "contact_force|sensor_health",  # a 10 g cube: past the sensor's range at once
            0.01,
        ),
        MatrixRow("perception_miss@0", "flow:succeeded"),
        MatrixRow("perception_offset:offset_m=[0,0,-0.02]@0", "flow:failed"),
    ],
}
"""Matrices of the bundled scenarios, by scenario name."""

_GENERIC_KINDS = (
    "estop",
    "ft_dropout",
    "ft_bias",
    "ft_spike",
    "ft_nan",
    "encoder_freeze",
    "encoder_noise",
    "encoder_nan",
    "actuator_saturate",
    "actuator_lost",
    "perception_miss",
)


DETECTED_BY: dict[str, tuple[str, ...]] = {
    "estop": ("estop",),
    "ft_dropout": ("sensor_health",),
    "ft_bias": ("contact_force",),
    "ft_spike": ("sensor_health",),
    "ft_nan": ("sensor_health",),
    "encoder_freeze": ("sensor_health",),
    "encoder_noise": ("sensor_health",),
    "encoder_nan": ("sensor_health",),
    "actuator_saturate": ("sensor_health",),
    "actuator_lost": ("sensor_health",),
    "obstacle": ("collision",),
    "slip": ("grasp_lost",),
    "push": ("contact_force", "sensor_health"),
}
"""Fault kind -> the guards that catch it (the ones the bundled matrices expect; `estop` is
every machine's built-in event). The perception faults are for the flow to handle: none."""


def fault_kind(spec: str) -> str:
    """The kind of a `--fault` spec (`ft_bias:force_n=[0,0,8]@GRASP+0.5` -> `ft_bias`)."""
    return spec.split("@", 1)[0].split(":", 1)[0].strip()


def scenario_guards(loaded: LoadedScenario) -> set[str]:
    """Every guard a scenario can run: its own `guards:` and those of every machine level and
    state, with the built-in `estop`."""
    names = {name for _, name, _ in guard_entries(loaded.scenario.guards)} | {ESTOP}
    for node in loaded.machine.nodes():
        names |= {name for _, name, _ in guard_entries(node.guards)}
        for state in node.states.values():
            names |= {name for _, name, _ in guard_entries(state.guards or [])}
    return names


def blind_kinds(loaded: LoadedScenario, rows: list[MatrixRow]) -> dict[str, tuple[str, ...]]:
    """The fault kinds of `rows` that no guard of the scenario can catch, each with the guards
    that would (in the order of `rows`)."""
    have = scenario_guards(loaded)
    out: dict[str, tuple[str, ...]] = {}
    for row in rows:
        kind = fault_kind(row.fault)
        need = DETECTED_BY.get(kind)
        if need and not have.intersection(need):
            out[kind] = need
    return out


def expected(row: MatrixRow, guard: str | None, outcome: str, detect_s: float | None) -> bool:
    """Whether a run of `row` that ended `outcome`, aborted by `guard` (None: no abort)
    `detect_s` [s] after the fault, is what the row expects."""
    for want in row.expect.split("|"):
        if want.startswith("flow:"):
            if guard is None and want[5:] in ("handled", outcome):
                return True
        elif guard == want and outcome == "aborted":
            within = row.within_s is None or (
                detect_s is not None and detect_s <= row.within_s + 1e-9
            )
            if within:
                return True
    return False


def matrix_for(scenario_name: str) -> list[MatrixRow]:
    """The matrix of a scenario: its own if it is bundled, else every fault at t = 1 s."""
    if scenario_name in MATRICES:
        return MATRICES[scenario_name]
    return [MatrixRow(f"{kind}@1.0") for kind in _GENERIC_KINDS]


def run_matrix(
    scenario: str,
    seed: int = 0,
    overrides: list[str] | None = None,
    on_row: Callable[[RowResult], None] | None = None,
) -> list[RowResult]:
    """Run every row of `scenario`'s matrix; `on_row` is called as each row finishes.

    Raises:
        ConfigError: If the scenario, an override or a row's fault is invalid.
    """
    # the front door of `run`: what `run --set` refuses is refused here, before any row runs
    plain = prepare(scenario, seed, overrides or []).loaded
    matrix = matrix_for(plain.name)
    blind = blind_kinds(plain, matrix)
    rows = []
    for row in matrix:
        result = prepare(scenario, seed, overrides or [], [row.fault]).run_episode()
        m = result.metrics
        injected = m.get("faults") or []
        fault_t = injected[0]["t"] if injected else None
        abort_t = m.get("abort_t")
        guard = (result.reason or {}).get("guard")  # a time limit names no guard
        detect = None if abort_t is None or fault_t is None else round(abort_t - fault_t, 4)
        ok = expected(row, guard, result.outcome, detect) if row.expect else None
        undetected = bool(row.expect) and guard is None and not ok
        done = RowResult(
            fault=row.fault,
            expect=row.expect,
            outcome=result.outcome,
            guard=guard,
            exit_code=EXIT_CODES[result.outcome],
            fault_t=fault_t,
            detect_s=detect,
            stop_time_s=m.get("stop_time_s"),
            stop_distance_mm=m.get("stop_distance_mm"),
            ok=ok,
            message=result.reason["message"] if result.reason else "",
            within_s=row.within_s,
            stop_distance_min_mm=m.get("stop_distance_min_mm"),
            undetected=undetected,
            blind=fault_kind(row.fault) in blind,
        )
        rows.append(done)
        if on_row is not None:
            on_row(done)
    return rows
