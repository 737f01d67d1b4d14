"""The fault matrix: one episode per fault type, and what the safety layer made of it.

Each row injects one fault (a `--fault` spec) into the same seed of a scenario and records the
guard that fired, the exit code, the time from the fault to the abort, and the controlled
stop's time and distance. The bundled scenarios have matrices that inject each fault where it
matters (pick_place: on the approach to the cube, the transport for world faults; surgical:
while the probe traces the incision); any other scenario gets the generic matrix, every fault
at t = 1 s, with no expectation.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass

from ..engine.result import EXIT_CODES
from ..engine.runner import run_episode
from ..language.load import load_scenario

__all__ = ["MATRICES", "MatrixRow", "RowResult", "matrix_for", "run_matrix"]


@dataclass(frozen=True)
class MatrixRow:
    """One fault of a matrix.

    Attributes:
        fault: The `--fault` spec.
        expect: The guard expected to catch it, or `flow:<outcome>` when the machine itself
            handles the fault (a perception miss is retried), or "" for no expectation.
    """

    fault: str
    expect: str = ""


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

    def to_dict(self) -> dict:
        return asdict(self)


_APPROACH = "PICK.GRASP.APPROACH+0.75"
_TRACE = "EXECUTE.TRACE+0.5"
_SURGICAL = [
    MatrixRow(f"estop@{_TRACE}", "estop"),
    MatrixRow(f"ft_dropout@{_TRACE}", "sensor_health"),
    MatrixRow(f"ft_bias:force_n=[0,0,8]@{_TRACE}", "contact_force"),
    MatrixRow(f"ft_spike@{_TRACE}", "sensor_health"),
    MatrixRow(f"ft_nan@{_TRACE}", "sensor_health"),
    MatrixRow(f"encoder_freeze@{_TRACE}", "sensor_health"),
    MatrixRow(f"encoder_noise@{_TRACE}", "sensor_health"),
    MatrixRow(f"encoder_nan@{_TRACE}", "sensor_health"),
    MatrixRow(f"actuator_saturate@{_TRACE}", "sensor_health"),
    MatrixRow(f"actuator_lost@{_TRACE}", "sensor_health"),
    MatrixRow("obstacle:pos=[0.47,0.0,0.34],size=[0.03,0.08,0.03]@NAVIGATE", "collision"),
    MatrixRow("perception_miss@0", "flow:failed"),
]
MATRICES: dict[str, list[MatrixRow]] = {
    "pick_place": [
        MatrixRow(f"estop@{_APPROACH}", "estop"),
        MatrixRow(f"ft_dropout@{_APPROACH}", "sensor_health"),
        MatrixRow(f"ft_bias@{_APPROACH}", "contact_force"),
        MatrixRow(f"ft_spike@{_APPROACH}", "sensor_health"),
        MatrixRow(f"ft_nan@{_APPROACH}", "sensor_health"),
        MatrixRow(f"encoder_freeze@{_APPROACH}", "sensor_health"),
        MatrixRow(f"encoder_noise@{_APPROACH}", "sensor_health"),
        MatrixRow(f"encoder_nan@{_APPROACH}", "sensor_health"),
        MatrixRow(f"actuator_saturate:fraction=0.05@{_APPROACH}", "sensor_health"),
        MatrixRow(f"actuator_lost@{_APPROACH}", "sensor_health"),
        MatrixRow("obstacle:pos=[0.5,0.28,0.42],size=[0.08,0.03,0.08]@TRANSPORT+0.05", "collision"),
        MatrixRow("slip:object=cube,factor=0.005@TRANSPORT", "grasp_lost"),
        MatrixRow(
            "push:object=cube,force_n=[0,0,-150],duration_ms=20@PICK.GRASP.VERIFY+0.04",
            "contact_force",
        ),
        MatrixRow("perception_miss@0", "flow:succeeded"),
        MatrixRow("perception_offset:offset_m=[0,0,-0.02]@0", "collision"),
    ],
    "surgical": _SURGICAL,
    "surgical_complication": _SURGICAL,
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
    name = load_scenario(scenario, overrides or []).name
    rows = []
    for row in matrix_for(name):
        loaded = load_scenario(scenario, overrides or [], [row.fault])
        result = run_episode(loaded, seed)
        m = result.metrics
        injected = m.get("faults") or []
        fault_t = injected[0]["t"] if injected else None
        abort_t = m.get("abort_t")
        guard = result.reason["guard"] if result.reason else None
        detect = None if abort_t is None or fault_t is None else round(abort_t - fault_t, 4)
        if row.expect.startswith("flow:"):
            ok: bool | None = guard is None and result.outcome == row.expect[5:]
        elif row.expect:
            ok = guard == row.expect and result.outcome == "aborted"
        else:
            ok = None
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
        )
        rows.append(done)
        if on_row is not None:
            on_row(done)
    return rows
