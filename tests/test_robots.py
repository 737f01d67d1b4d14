"""Every robot model compiles with every bundled scenario's scene and steps cleanly."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from orchestrator.robots import ROBOTS, get_robot

from orchestrator.language.bundled import bundled_names
from orchestrator.language.load import load_scenario
from orchestrator.world import World


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_robot_alone_compiles_with_actuators_sites_and_home(name):
    robot = get_robot(name)
    model = robot.build_spec().compile()
    assert model.nu == robot.n_arm + 1
    assert model.site(robot.tcp_site).id >= 0 and model.site(robot.wrist_site).id >= 0
    assert model.key("home").id == 0
    # actuator limits are the URDF effort limits
    pin_model = robot.pinocchio_model()
    np.testing.assert_allclose(
        model.actuator_ctrlrange[: robot.n_arm, 1], pin_model.effortLimit[: robot.n_arm]
    )


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_one_equality_couples_the_fingers_and_holds_them_together(name):
    """The URDF's <mimic> is not kept beside `finger_mimic` (the same constraint twice, one row
    more for every step's solver): one finger pushed shut with 5 N, the other follows it."""
    robot = get_robot(name)
    model = robot.build_spec().compile()
    data = mujoco.MjData(model)
    j1, j2 = (model.joint(j) for j in robot.finger_joints)
    coupling = [
        model.eq(i).name
        for i in range(model.neq)
        if model.eq_type[i] == mujoco.mjtEq.mjEQ_JOINT
        and {int(model.eq_obj1id[i]), int(model.eq_obj2id[i])} == {j1.id, j2.id}
    ]
    assert coupling == ["finger_mimic"]
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    arm = [model.jnt_dofadr[model.joint(j).id] for j in robot.arm_joints]
    q1, q2 = j1.qposadr[0], j2.qposadr[0]
    gap = 0.0
    for _ in range(500):  # 1 s
        data.ctrl[: robot.n_arm] = data.qfrc_bias[arm]  # the arm held against gravity
        data.qfrc_applied[j1.dofadr[0]] = -5.0
        mujoco.mj_step(model, data)
        gap = max(gap, abs(data.qpos[q1] - data.qpos[q2]))
    assert robot.gripper_open_m - data.qpos[q2] > 0.005  # the other finger followed
    assert gap < 0.0005  # within half a millimetre all the way (0.33 mm measured)


@pytest.mark.parametrize("scenario", bundled_names("scenarios"))
def test_scene_steps_one_second_with_noise_without_warnings(scenario):
    loaded = load_scenario(scenario)
    world = World.build(loaded.scenario, seed=0)
    m, d = world.model, world.data
    rng = np.random.default_rng(0)
    for _ in range(round(1.0 / m.opt.timestep)):
        d.ctrl[world.arm_act] = rng.normal(0.0, 1.0, len(world.arm_act))
        mujoco.mj_step(m, d)
    assert all(w.number == 0 for w in d.warning), [
        mujoco.mjtWarning(i).name for i, w in enumerate(d.warning) if w.number
    ]
    assert np.all(np.isfinite(d.qpos))


def test_urdf_comes_from_the_installed_distribution():
    from orchestrator.robots.panda import panda_urdf_path

    path = panda_urdf_path()
    assert path.is_file() and "example-robot-data" in str(path)


def test_nothing_called_skills_or_robots_at_the_top_level(tmp_path):
    """Installed, only `orchestrator` is importable; its subpackages map the repo folders."""
    import subprocess
    import sys

    code = (
        "import importlib.util as u, json;"
        "import orchestrator.skills, orchestrator.robots, orchestrator.machines;"
        "print(json.dumps([u.find_spec(n) is None for n in "
        "('skills', 'robots', 'machines', 'scenarios')]))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == "[true, true, true, true]", out.stdout + out.stderr
