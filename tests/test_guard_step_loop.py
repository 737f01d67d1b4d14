"""The step loop's invariants (engine/step.py), measured on whole runs: the active guards are
checked on every physics step, once; a violation's controlled stop starts on the very next
physics step, watched by the response guards only; observers see every physics step. And the
`joint_acceleration` guard: it fires on the step MuJoCo's acceleration crosses its limit, its
limits are refused above the robot's datasheet, and the controlled stop's own deceleration
(above the datasheet) is its one exemption."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from orchestrator.robots import Controller

from orchestrator.engine.blackboard import Blackboard
from orchestrator.engine.cell import Cell
from orchestrator.engine.context import Context
from orchestrator.engine.runner import run_episode
from orchestrator.engine.safety_stop import SafetyStop
from orchestrator.exceptions import OrchestratorError
from orchestrator.guards import JointAcceleration
from orchestrator.guards.bank import GuardBank
from orchestrator.language.load import load_scenario
from orchestrator.world import World


class _Steps:
    """An observer: the simulated time of every physics step it is shown."""

    def __init__(self) -> None:
        self.times: list[float] = []

    def on_start(self, ctx, executor) -> None:
        self.dt = ctx.dt_physics

    def on_step(self, ctx) -> None:
        self.times.append(ctx.world.step_clock.t)

    def on_tick(self, ctx, executor) -> None:
        pass

    def on_end(self, *args) -> None:
        pass


def _record_checks(monkeypatch: pytest.MonkeyPatch) -> list[tuple[float, bool, set[str]]]:
    """(simulated time, fired, the bank's guards) of every `GuardBank.check` of the process
    from now on."""
    calls: list[tuple[float, bool, set[str]]] = []
    check = GuardBank.check

    def counted(self: GuardBank, ctx: Context):
        violation = check(self, ctx)
        calls.append((ctx.world.step_clock.t, violation is not None, {g.name for g in self.guards}))
        return violation

    monkeypatch.setattr(GuardBank, "check", counted)
    return calls


def test_guards_are_checked_on_every_physics_step_and_observers_see_every_step(monkeypatch):
    calls = _record_checks(monkeypatch)
    steps = _Steps()
    result = run_episode(load_scenario("reach_random"), 0, [steps])
    assert result.outcome == "succeeded"
    n_steps = round(result.sim_time / steps.dt)
    # every physics step shown to the observers, once, in order
    assert len(steps.times) == n_steps
    assert steps.times == sorted(set(steps.times))
    # the guards checked once on every one of them while the machine runs (the scenario's
    # guards are always active); after its final state only the end's gentle stop settles
    # the arm, at half the datasheet acceleration
    checked = [t for t, _, _ in calls]
    assert checked == steps.times[: len(checked)]
    final_t = result.transitions[-1]["t"]
    assert abs(checked[-1] - final_t) <= steps.dt


def test_an_abort_stops_on_the_next_physics_step_watched_by_the_response_guards(monkeypatch):
    calls = _record_checks(monkeypatch)
    stop_steps: list[float] = []
    step = SafetyStop.step

    def stepped(self: SafetyStop) -> None:
        stop_steps.append(self.ctx.world.step_clock.t)
        step(self)

    monkeypatch.setattr(SafetyStop, "step", stepped)
    steps = _Steps()
    # a third of the datasheet acceleration: the first reach trips it
    loaded = load_scenario("reach_random", ["guards.joint_acceleration.scale=0.3"])
    result = run_episode(loaded, 0, [steps])
    assert result.outcome == "aborted"
    assert result.reason is not None and "joint_acceleration" in str(result.reason)
    fired = [t for t, hit, _ in calls if hit]
    assert len(fired) == 1
    i = steps.times.index(fired[0])
    assert stop_steps, "the controlled stop never ran"
    assert stop_steps[0] == steps.times[i + 1]  # the physics step right after the violation
    # while the controlled stop runs only the response guards (the joint limits) watch it:
    # its deceleration is exempt from joint_acceleration and the other motion guards
    during = [names for t, _, names in calls if t in set(stop_steps)]
    assert len(stop_steps) > 3 and len(during) == len(stop_steps)
    assert all(names == {"joint_limits"} for names in during), during[:3]


# -- joint_acceleration -----------------------------------------------------------------------


def _ctx() -> Context:
    world = World.build(load_scenario("pick_place").scenario, seed=0)
    ctrl = Controller(world.robot, float(world.model.opt.timestep))
    ctrl.hold(world.home)
    ctx = Context(Cell(world, ctrl, 0), Blackboard())
    ctrl.tau[:] = world.data.ctrl[world.arm_act]
    mujoco.mj_forward(world.model, world.data)
    return ctx


def _guard(ctx: Context, **params) -> JointAcceleration:
    guard = JointAcceleration(JointAcceleration.Params.model_validate(params))
    guard.bind(ctx)
    guard.activate(ctx)
    return guard


def test_joint_acceleration_fires_on_the_step_its_acceleration_crosses_the_datasheet_limit():
    ctx = _ctx()
    guard = _guard(ctx)
    bank = GuardBank([guard], ctx)
    datasheet = ctx.robot.acceleration_limits
    dof = ctx.world.arm_dof[1]
    ctx.data.qacc[:] = 0.0
    rng = np.random.default_rng(4)
    for _ in range(200):  # random accelerations of every joint, inside and beyond the limits
        ctx.data.qacc[ctx.world.arm_dof] = np.asarray(datasheet) * rng.uniform(-1.05, 1.05, 7)
        beyond = np.abs(ctx.data.qacc[ctx.world.arm_dof]) > np.asarray(datasheet)
        violation = bank.check(ctx)
        assert (violation is not None) == bool(beyond.any())
        if violation is not None:
            assert violation.guard == "joint_acceleration"
            assert violation.message.startswith(f"joint {int(np.argmax(beyond)) + 1} at ")
    ctx.data.qacc[:] = 0.0
    # exactly at the limit is inside, the next float above it fires, either sign; NaN never
    # fires (divergence is the runner's to report) but sends the step to the full check
    for value, fires in (
        (datasheet[1], False),
        (-datasheet[1], False),
        (float(np.nextafter(datasheet[1], math.inf)), True),
        (float(np.nextafter(-datasheet[1], -math.inf)), True),
        (math.nan, False),
    ):
        ctx.data.qacc[dof] = value
        full = bank.full_checks
        violation = bank.check(ctx)
        assert (violation is not None) is fires, value
        assert bank.inside() is (not fires and not math.isnan(value)), value
        if math.isnan(value):
            assert bank.full_checks == full + 1
        if fires:
            assert violation.value == round(value, 4) and violation.limit == datasheet[1]
            assert "joint 2" in violation.message and "rad/s^2" in violation.message


def test_joint_acceleration_limits_are_at_most_the_datasheet():
    ctx = _ctx()
    tighter = [v / 2 for v in ctx.robot.acceleration_limits]
    assert _guard(ctx, limits_rad_s2=tighter)._lim == tighter
    assert _guard(ctx, scale=0.5)._lim == tighter
    looser = list(ctx.robot.acceleration_limits)
    looser[6] += 1.0
    with pytest.raises(ValueError, match=r"joint 7's limit 21 rad/s\^2 is above .* datasheet"):
        _guard(ctx, limits_rad_s2=looser)
    with pytest.raises(ValueError, match="7 values"):
        _guard(ctx, limits_rad_s2=[1.0, 2.0])


@pytest.mark.parametrize(
    ("value", "fragment"),
    [
        ("guards.joint_acceleration.limits_rad_s2=[15,7.5,10,12.5,15,20,25]", "datasheet"),
        ("guards.joint_acceleration.limits_rad_s2=[1,2]", "7 values"),
        ("guards.joint_acceleration.scale=1.5", "joint_acceleration.scale"),
        ("guards.joint_velocity.limits_rad_s=[1,2]", "7 values"),
    ],
)
def test_a_limit_the_robot_cannot_take_is_a_clean_error(cli, value: str, fragment: str):
    res = cli("run", "reach_random", "--set", value)
    assert res.exit_code == 2, (res.stdout, res.stderr)
    assert "Traceback" not in res.stderr + res.stdout
    assert "<--set>" in res.stderr and fragment in res.stderr
    with pytest.raises(OrchestratorError):
        load_scenario("reach_random", [value])


def test_the_controlled_stop_may_brake_beyond_the_datasheet_acceleration(monkeypatch):
    """An e-stop mid-reach brakes at the safety stop's 50 rad/s^2, beyond every joint's
    datasheet acceleration: the run ends on the e-stop, not on `joint_acceleration`."""
    peak: list[float] = []
    step = SafetyStop.step

    def stepped(self: SafetyStop) -> None:
        step(self)
        ctx = self.ctx
        qdd = np.abs(ctx.data.qacc[ctx.world.arm_dof]) / np.asarray(ctx.robot.acceleration_limits)
        peak.append(float(qdd.max()))

    monkeypatch.setattr(SafetyStop, "step", stepped)
    result = run_episode(load_scenario("reach_random", faults=["estop@0.4"]), 0)
    assert result.outcome == "aborted"
    assert "estop" in str(result.reason) and "joint_acceleration" not in str(result.reason)
    assert max(peak) > 1.0  # the stop did brake beyond the datasheet
