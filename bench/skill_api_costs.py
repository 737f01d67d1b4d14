"""What the members of the skill API cost: microseconds per call, on the pick_place_vision
world at home (docs/skill-api.md quotes these figures).

    python bench/skill_api_costs.py            # prints one line per member

Each call is timed over many repetitions (best of 5) in the process that builds the world;
the figures are for orders of magnitude (a control tick lasts 10 ms), not for precision.
"""

from __future__ import annotations

import timeit

from orchestrator.robots import Controller

from orchestrator.engine.cell import Cell
from orchestrator.engine.context import Context
from orchestrator.engine.runner import initial_blackboard
from orchestrator.language.load import load_scenario
from orchestrator.world import World


def _context():
    loaded = load_scenario("pick_place_vision")
    world = World.build(loaded.scenario, 0)
    controller = Controller(world.robot, float(world.model.opt.timestep))
    controller.hold(world.home)
    blackboard = initial_blackboard(loaded.machine, loaded.scenario.blackboard)
    return Context(Cell(world, controller, 0), blackboard)


def _us(call, number: int) -> float:
    return min(timeit.repeat(call, number=number, repeat=5)) / number * 1e6


def main() -> None:
    ctx = _context()
    q = ctx.q
    pos, rot = ctx.tcp_pos.copy(), ctx.tcp_rot.copy()
    ctx.ik.reset(q)
    camera = ctx.scenario.cameras[0].name
    calls = {
        "t": (lambda: ctx.t, 20000),
        "clock": (lambda: ctx.clock, 20000),
        "q": (lambda: ctx.q, 20000),
        "qd": (lambda: ctx.qd, 20000),
        "robot_q()": (ctx.robot_q, 20000),
        "tcp_pos": (lambda: ctx.tcp_pos, 20000),
        "tcp_rot": (lambda: ctx.tcp_rot, 20000),
        "gripper_width": (lambda: ctx.gripper_width, 20000),
        "wrist_force()": (ctx.wrist_force, 20000),
        "joint_torque": (lambda: ctx.joint_torque, 20000),
        "object_pose(name)": (lambda: ctx.object_pose("cube"), 5000),
        "object_handle(name)": (lambda: ctx.object_handle("cube"), 20000),
        "blackboard.resolve($key)": (lambda: ctx.blackboard.resolve("$object"), 20000),
        "log(...)": (lambda: ctx.log("skill", "x"), 5000),
        "set_gripper(m)": (lambda: ctx.set_gripper(0.04), 20000),
        "controller.hold(q)": (lambda: ctx.controller.hold(q), 20000),
        "controller.set_joint_target(q)": (lambda: ctx.controller.set_joint_target(q), 20000),
        "ik.step(pos, rot)": (lambda: ctx.ik.step(pos, rot), 200),
        "cameras.capture(data, camera)": (lambda: ctx.cameras.capture(ctx.data, camera), 20),
    }
    ctx.cameras.capture(ctx.data, camera)  # the renderer opens on first use
    ctx.events.clear()
    for name, (call, number) in calls.items():
        print(f"{name:34s} {_us(call, number):10.2f} us")
    ctx.cell.close()


if __name__ == "__main__":
    main()
