"""The guard bank (guards/bank.py): the active guards tested against their envelopes at once,
their full checks run only when a value leaves — with the same violation on the same step as
checking every guard in full every step."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from orchestrator.robots import Controller

from orchestrator.engine.blackboard import Blackboard
from orchestrator.engine.cell import Cell
from orchestrator.engine.context import Context
from orchestrator.engine.executor import Executor
from orchestrator.engine.runner import run_episode
from orchestrator.guards import (
    GraspLost,
    JointTorque,
    JointVelocity,
)
from orchestrator.guards.bank import GuardBank
from orchestrator.guards.base import Guard
from orchestrator.language.load import load_scenario
from orchestrator.world import World
from orchestrator.world.sensors import WristForceFault
from tests.guard_set import carrying_guards


def _ctx() -> Context:
    world = World.build(load_scenario("pick_place").scenario, seed=0)
    ctrl = Controller(world.robot, float(world.model.opt.timestep))
    ctrl.hold(world.home)
    ctx = Context(Cell(world, ctrl, 0), Blackboard())
    ctrl.tau[:] = world.data.ctrl[world.arm_act]  # what the runner does every step
    mujoco.mj_forward(world.model, world.data)
    return ctx


def _guards(ctx: Context) -> list[Guard]:
    return carrying_guards(ctx)


def _first(guards: list[Guard], ctx: Context):
    for guard in guards:
        violation = guard.check(ctx)
        if violation is not None:
            return violation
    return None


def _new_instant(ctx: Context) -> None:
    """A new physics step for the readings cached per instant (the wrist force)."""
    ctx.world.step_clock.t += ctx.dt_physics


# -- the exact step ---------------------------------------------------------------------------


def test_joint_velocity_fires_through_the_bank_on_the_step_its_speed_crosses_the_limit():
    ctx = _ctx()
    guards = _guards(ctx)
    bank = GuardBank(guards, ctx)
    limit = next(g for g in guards if isinstance(g, JointVelocity))._lim[3]
    dof = ctx.world.arm_dof[3]
    # a speed ramp that reaches the limit exactly, then the next float above it
    ramp = [0.5 * limit, 0.99 * limit, limit, float(np.nextafter(limit, math.inf))]
    fired_at = None
    for step, speed in enumerate(ramp):
        _new_instant(ctx)
        ctx.data.qvel[dof] = speed
        violation = bank.check(ctx)
        if violation is not None:
            fired_at = step
            break
    assert fired_at == 3  # at the limit is allowed; one float above it is not
    assert violation is not None and violation.guard == "joint_velocity"
    assert violation.message.startswith("joint 4 at ")
    assert violation == _first(_guards(ctx), ctx)  # the same violation, word for word


def test_joint_torque_counts_from_the_limit_itself_through_the_bank():
    ctx = _ctx()
    guards = _guards(ctx)
    torque = next(g for g in guards if isinstance(g, JointTorque))
    bank = GuardBank(guards, ctx)
    limit = torque._limit[0]
    tau = ctx.controller.tau
    tau[0] = float(np.nextafter(limit, 0.0))  # the largest torque below the limit: quiet
    for _ in range(10):
        _new_instant(ctx)
        ctx.data.actuator_force[ctx.world.arm_act[0]] = tau[0]  # the motor delivers it
        assert bank.check(ctx) is None
    fired = []
    for step in range(10):  # at the limit: it counts, and fires after duration_ms (3 steps)
        _new_instant(ctx)
        tau[0] = limit
        ctx.data.actuator_force[ctx.world.arm_act[0]] = limit
        violation = bank.check(ctx)
        if violation is not None:
            fired.append((step, violation.guard))
            break
    assert fired == [(2, "joint_torque")]


def test_grasp_lost_fires_through_the_bank_on_the_exact_width_with_uneven_fingers():
    ctx = _ctx()
    fingers = ctx.data.qpos[ctx.world.finger_qpos[0] : ctx.world.finger_qpos[-1] + 1]
    fingers[:] = [0.025, 0.025]
    guards = _guards(ctx)  # activated holding 50 mm: fires below 45 mm
    bank = GuardBank(guards, ctx)
    held_min = next(g for g in guards if isinstance(g, GraspLost))._min
    # one finger far in, the other far out: outside the per-finger envelope, but the width
    # is still exactly the smallest allowed — the full check says quiet
    fingers[:] = [0.004, held_min - 0.004]
    if fingers.sum() < held_min:  # rounding: nudge the outer finger up to the exact bound
        fingers[1] = np.nextafter(fingers[1], 1.0)
    _new_instant(ctx)
    assert bank.check(ctx) is None
    fingers[1] = np.nextafter(fingers[1], 0.0)
    while float(fingers[0] + fingers[1]) >= held_min:
        fingers[1] = np.nextafter(fingers[1], 0.0)
    _new_instant(ctx)
    violation = bank.check(ctx)
    assert violation is not None and violation.guard == "grasp_lost"


def test_a_sensor_fault_sends_every_step_to_the_full_checks():
    ctx = _ctx()
    bank = GuardBank(_guards(ctx), ctx)
    _new_instant(ctx)
    assert bank.check(ctx) is None and bank.full_checks == 0
    ctx.cell.wrist.fault = WristForceFault("ft_dropout", ctx.t, (0.0, 0.0, 0.0), math.inf)
    fired = None
    for _ in range(20):  # stale after 10 ms: the 6th step after the dropout
        _new_instant(ctx)
        fired = bank.check(ctx)
        if fired is not None:
            break
    assert bank.full_checks >= 5
    assert fired is not None and "stale" in fired.message


@pytest.mark.parametrize("with_torque_bound", [True, False])
@pytest.mark.parametrize(("bad", "fires"), [(math.nan, True), (0.75, True), (0.25, False)])
def test_a_motor_that_does_not_deliver_fires_on_its_step_with_or_without_a_torque_bound(
    with_torque_bound: bool, bad: float, fires: bool
):
    """sensor_health's commanded == measured pair is compared as bytes when joint_torque bounds
    the command (the bound keeps a NaN out), as floats when it does not: a NaN in both, or a
    motor short of its command by more than the tolerance (0.5 Nm), fires on its step either
    way; a -0.0 against a 0.0 or a motor within the tolerance does not."""
    ctx = _ctx()
    guards = [g for g in _guards(ctx) if with_torque_bound or not isinstance(g, JointTorque)]
    bank = GuardBank(guards, ctx)
    assert (len(bank._equal_bytes), len(bank._equal)) == ((1, 0) if with_torque_bound else (0, 1))
    tau, measured = ctx.controller.tau, ctx.data.actuator_force[ctx.world.arm_act]
    tau[5], measured[5] = 0.0, -0.0  # equal floats, different bits: quiet (the full checks)
    ctx.data.actuator_force[ctx.world.arm_act] = measured
    _new_instant(ctx)
    assert bank.check(ctx) is None
    _new_instant(ctx)
    tau[5] = bad
    ctx.data.actuator_force[ctx.world.arm_act[5]] = math.nan if math.isnan(bad) else 0.0
    violation, in_full = bank.check(ctx), _first(guards, ctx)
    if not fires:
        # the -0.0 step went to the full checks only where the pair is compared as bytes
        assert violation is None and in_full is None
        assert bank.full_checks == (2 if with_torque_bound else 1)
        return
    assert violation is not None and in_full is not None
    assert violation.guard == "sensor_health"  # it outranks joint_torque
    assert violation.message == in_full.message  # word for word (a NaN value is not == NaN)
    assert "joint 6 motor delivers" in violation.message


# -- the same as every guard in full, every step --------------------------------------------------


def test_the_bank_returns_what_the_guards_in_full_return_on_random_states():
    """Two sets of the same guards on one context, one behind a bank, one checked in full,
    stepped through random states near and across their limits: the same answer each step."""
    ctx = _ctx()
    rng = np.random.default_rng(7)
    banked, plain = _guards(ctx), _guards(ctx)
    bank = GuardBank(banked, ctx)
    d, w = ctx.data, ctx.world
    q0 = d.qpos[w.arm_qpos].copy()
    speed = np.asarray(next(g for g in plain if isinstance(g, JointVelocity))._lim)
    torque = np.asarray(next(g for g in plain if isinstance(g, JointTorque))._limit)
    fired = set()
    full = 0
    for step in range(800):
        _new_instant(ctx)
        if step % 8 == 0:  # a new state held for 8 steps (long enough for joint_torque's 3)
            d.qpos[w.arm_qpos] = q0 + rng.normal(0.0, 0.4, 7) * (rng.random(7) < 0.3)
            d.qvel[w.arm_dof] = speed * rng.uniform(-1.01, 1.01, 7)
            ctx.controller.tau[:] = torque * rng.uniform(-1.02, 1.02, 7)
        d.actuator_force[w.arm_act] = ctx.controller.tau
        if rng.random() < 0.05:  # a motor that does not deliver
            d.actuator_force[w.arm_act[2]] += 1.0
        mujoco.mj_kinematics(ctx.model, d)  # the TCP follows the joints (workspace)
        expected = _first(plain, ctx)
        got = bank.check(ctx)
        assert got == expected
        if expected is not None:
            fired.add(expected.guard)
        full = bank.full_checks
    # the states did cross the limits, and the bank did let most steps through on envelopes
    assert {"joint_velocity", "joint_torque", "joint_limits"} <= fired
    assert 0 < full < 800


# -- in an episode --------------------------------------------------------------------------------


def _checks_in_full(self: Executor) -> None:
    """The executor as it was before the bank: every guard's check, every step."""
    self.guard_bank = None
    self.active_checks = tuple(g.check for g in self.active_guards)


@pytest.mark.parametrize(
    ("override", "guard"),
    [
        ("guards.joint_velocity.scale=0.35", "joint_velocity"),
        # the pad's side of the box cut short: crossed in TRANSPORT (a floor above the grasp
        # pose is now refused by `grasp_pose` before the approach)
        ("guards.workspace.max=[0.95,0.15,1.2]", "workspace"),
        ("guards.contact_force.max_n=2.0", "contact_force"),
    ],
)
def test_an_episode_aborts_on_the_same_step_with_and_without_the_bank(
    override: str, guard: str, monkeypatch: pytest.MonkeyPatch
):
    from orchestrator.language.load import load_scenario as load

    loaded = load("pick_place", overrides=[override])
    banked = run_episode(loaded, 3).to_json_dict()
    monkeypatch.setattr(Executor, "_bind_checks", _checks_in_full)
    plain = run_episode(loaded, 3).to_json_dict()
    banked.pop("wall_time")
    plain.pop("wall_time")
    assert banked["reason"] is not None and banked["reason"]["guard"] == guard
    assert banked == plain


def test_a_state_change_keeps_the_bank_unless_its_guards_change(monkeypatch: pytest.MonkeyPatch):
    """A bank is built when the set of active guards changes (or one is activated again), not
    at every state change: the envelopes only change on activation."""
    from orchestrator.language.load import load_scenario as load

    built: list[tuple[str, ...]] = []
    bind = Executor._bind_checks

    def counting(self: Executor) -> None:
        bind(self)
        built.append(tuple(g.name for g in self.active_guards))

    monkeypatch.setattr(Executor, "_bind_checks", counting)
    result = run_episode(load("pick_place"), 0)
    assert result.outcome == "succeeded"
    assert len(built) < len(result.transitions)  # most state changes kept their bank
    assert all(a != b for a, b in zip(built, built[1:], strict=False))  # each build changed it
    assert any("grasp_lost" in names for names in built)  # the carrying state's own guard
