"""Every robot model compiles with every bundled scenario's scene and steps cleanly."""

from __future__ import annotations

import functools

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


@pytest.mark.parametrize("name", sorted(n for n, r in ROBOTS.items() if len(r.finger_joints) == 2))
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


# -- the robot test: every registered robot, held to its own datasheet (mujoco_menagerie's
# pattern: one parameterized test over every model) ------------------------------------------


@functools.cache
def _compiled(name):
    """The robot alone, compiled once per test session (a mesh-heavy arm takes seconds)."""
    return get_robot(name).build_spec().compile()


def _alone(name):
    """The robot alone: its model compiled, data at the home keyframe, arm/finger indices.
    The model is shared between tests: none changes it."""
    robot = get_robot(name)
    model = _compiled(name)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    arm_q = np.array([model.jnt_qposadr[model.joint(j).id] for j in robot.arm_joints])
    arm_v = np.array([model.jnt_dofadr[model.joint(j).id] for j in robot.arm_joints])
    return robot, model, data, arm_q, arm_v


def _random_q(robot, model, rng, spread_rad=None):
    """Arm joint angles drawn inside the model's joint ranges (within `spread_rad` of home)."""
    lo = np.array([model.jnt_range[model.joint(j).id, 0] for j in robot.arm_joints])
    hi = np.array([model.jnt_range[model.joint(j).id, 1] for j in robot.arm_joints])
    if spread_rad is not None:  # a mobile base stays where it stands: the arm reaches
        home = np.array(robot.home)
        spread = np.array([0.0 if j in robot.base_joints else spread_rad for j in robot.arm_joints])
        lo, hi = np.maximum(lo, home - spread), np.minimum(hi, home + spread)
    return rng.uniform(lo, hi)


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_robot_holds_home_under_gravity(name):
    """The controller (its own pinocchio model) holds the home pose for 2 s: the TCP drifts
    less than 1 mm."""
    from orchestrator.robots import Controller

    robot, model, data, arm_q, arm_v = _alone(name)
    ctl = Controller(robot, dt=model.opt.timestep)
    ctl.hold(np.array(robot.home))
    tcp = model.site(robot.tcp_site).id
    joints = [model.joint(j) for j in (*robot.arm_joints, *robot.finger_joints)]
    all_q = np.array([j.qposadr[0] for j in joints])
    all_v = np.array([j.dofadr[0] for j in joints])
    start = data.site_xpos[tcp].copy()
    drift = 0.0
    for _ in range(round(2.0 / model.opt.timestep)):
        data.ctrl[: robot.n_arm] = ctl.compute(data.qpos[all_q], data.qvel[all_v])
        mujoco.mj_step(model, data)
        drift = max(drift, float(np.linalg.norm(data.site_xpos[tcp] - start)))
    assert drift < 1e-3, f"{name}: the TCP drifted {drift * 1000:.2f} mm holding home"


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_pinocchio_and_mujoco_agree_on_kinematics_masses_and_inertias(name):
    """The controller's model (pinocchio, from the URDF) and the plant (MuJoCo, from the same
    URDF through MjSpec) place the TCP alike, weigh the same and have the same joint-space
    inertia at random configurations."""
    import pinocchio as pin

    robot, model, data, arm_q, arm_v = _alone(name)
    pm = robot.pinocchio_model()
    pd = pm.createData()
    frame = pm.getFrameId(robot.tcp_frame)
    tcp = model.site(robot.tcp_site).id
    root = model.body(robot.root_body).id
    # pinocchio fixes the root link to its universe: the moving mass is the rest
    moving = model.body_subtreemass[root] - model.body_mass[root]
    assert moving == pytest.approx(pin.computeTotalMass(pm), rel=1e-6)
    pin_q = {pm.names[j]: pm.idx_qs[j] for j in range(1, pm.njoints)}
    pin_v = {pm.names[j]: pm.idx_vs[j] for j in range(1, pm.njoints)}
    rng = np.random.default_rng(44)
    for _ in range(10):
        q = _random_q(robot, model, rng)
        data.qpos[arm_q] = q
        mujoco.mj_forward(model, data)
        qp = pin.neutral(pm)
        for j, value in zip(robot.arm_joints, q, strict=True):
            qp[pin_q[j]] = value
        for j in robot.finger_joints:
            qp[pin_q[j]] = data.qpos[model.joint(j).qposadr[0]]
        pin.framesForwardKinematics(pm, pd, qp)
        np.testing.assert_allclose(data.site_xpos[tcp], pd.oMf[frame].translation, atol=1e-6)
        np.testing.assert_allclose(
            data.site_xmat[tcp].reshape(3, 3), pd.oMf[frame].rotation, atol=1e-6
        )
        full = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, full)
        mass = pin.crba(pm, pd, qp)
        mass = np.triu(mass) + np.triu(mass, 1).T
        pv = [pin_v[j] for j in robot.arm_joints]
        np.testing.assert_allclose(
            full[np.ix_(arm_v, arm_v)], mass[np.ix_(pv, pv)], rtol=1e-3, atol=1e-4
        )


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_twenty_random_reachable_poses_within_a_millimetre(name):
    """The project's IK (skills/ik.py) takes the TCP, from home, to 20 poses the arm reaches
    (forward kinematics of random joint angles around home) within 1 mm and 0.01 rad."""
    from orchestrator.skills.ik import IKSolver

    from orchestrator.world.world import robot_only_model

    robot, model, data, arm_q, arm_v = _alone(name)
    ik_model = robot_only_model(name)
    tcp = model.site(robot.tcp_site).id
    rng = np.random.default_rng(20)
    misses = []
    for i in range(20):
        data.qpos[arm_q] = _random_q(robot, model, rng, spread_rad=0.6)
        mujoco.mj_kinematics(model, data)
        pos, rot = data.site_xpos[tcp].copy(), data.site_xmat[tcp].reshape(3, 3).copy()
        ik = IKSolver(robot, ik_model, dt=0.01, base_pos=np.zeros(3))
        ik.reset(np.array(robot.home))
        for _ in range(1500):
            ik.reference_step(pos, rot, 0.01)
            err = ik.error
            if np.linalg.norm(err[:3]) < 1e-4 and np.linalg.norm(err[3:]) < 1e-3:
                break
        if np.linalg.norm(ik.error[:3]) >= 1e-3 or np.linalg.norm(ik.error[3:]) >= 1e-2:
            misses.append((i, float(np.linalg.norm(ik.error[:3]))))
    assert not misses, f"{name}: poses the IK missed (index, error [m]): {misses}"


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_joint_limits_are_the_datasheets(name):
    """The plant's joint ranges and motor torque limits, and the controller's speed limits,
    are the maker's figures (`Robot.datasheet`)."""
    robot, model, *_ = _alone(name)
    sheet = robot.datasheet
    assert sheet is not None, f"{name} declares no datasheet limits"
    assert len(sheet.position) == len(sheet.velocity) == len(sheet.torque) == robot.n_arm
    for i, j in enumerate(robot.arm_joints):
        jid = model.joint(j).id
        assert model.jnt_limited[jid], f"{name}: joint {j} has no range"
        np.testing.assert_allclose(model.jnt_range[jid], sheet.position[i], atol=1e-4, err_msg=j)
    motors = model.actuator_forcerange[: robot.n_arm, 1]
    np.testing.assert_allclose(motors, sheet.torque, rtol=1e-6)
    np.testing.assert_allclose(robot.joint_velocity_limits(), sheet.velocity, rtol=1e-6)
    assert len(robot.acceleration_limits) == len(robot.jerk_limits) == robot.n_arm


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_no_self_collision_at_home(name):
    """At home no two collision geoms of links that are not neighbours on the chain overlap
    (mesh to mesh, what the capsule proxies stand in for at run time)."""
    robot, model, data, *_ = _alone(name)
    root = model.body(robot.root_body).id
    geoms = [
        g
        for g in range(model.ngeom)
        if (model.geom_contype[g] or model.geom_conaffinity[g])
        and model.geom_group[g] != 4  # not the self-collision proxies themselves
        and model.geom_bodyid[g] != 0
    ]

    def near(a, b):  # the same body, or joined by at most one joint (welds collapse)
        up_a = {a, int(model.body_parentid[a]), int(model.body_parentid[model.body_parentid[a]])}
        up_b = {b, int(model.body_parentid[b]), int(model.body_parentid[model.body_parentid[b]])}
        return b in up_a or a in up_b or int(model.body_parentid[a]) == int(model.body_parentid[b])

    overlaps = []
    fromto = np.zeros(6)
    for i, ga in enumerate(geoms):
        for gb in geoms[i + 1 :]:
            ba, bb = int(model.geom_bodyid[ga]), int(model.geom_bodyid[gb])
            if near(ba, bb) or root in (ba, bb) and model.body_parentid[max(ba, bb)] == root:
                continue
            if mujoco.mj_geomDistance(model, data, ga, gb, 0.01, fromto) < 0.0:
                overlaps.append((model.body(ba).name, model.body(bb).name))
    assert not overlaps, f"{name}: links overlapping at home: {sorted(set(overlaps))}"


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_gripper_opens_and_closes_to_its_stroke_at_its_speed(name):
    """The hand's motor at full voltage opens the fingers from closed to the end of their
    travel and closes them again, each side at the stated speed (`gripper_speed_mps`, within
    10 %) while moving freely. A slide gripper's travel is its stated stroke
    (`gripper_open_m` each); a revolute jaw's `gripper_open_m` is a set point inside it. All
    in metres of each side's opening (`finger_m_per_unit`: a jaw's angle times half its
    radius)."""
    robot, model, data, arm_q, arm_v = _alone(name)
    fingers = [model.joint(j).qposadr[0] for j in robot.finger_joints]
    lo, hi = model.jnt_range[model.joint(robot.finger_joints[0]).id] * robot.finger_m_per_unit
    if len(fingers) == 2:
        assert (lo, hi) == pytest.approx((0.0, robot.gripper_open_m))
    else:
        assert lo < robot.gripper_open_m < hi
    act = model.actuator(robot.gripper_actuator).id
    data.qpos[fingers] = lo / robot.finger_m_per_unit
    mujoco.mj_forward(model, data)
    dt = model.opt.timestep
    stroke_s = (hi - lo) / robot.gripper_speed_mps
    for command, end in ((1.0, hi), (-1.0, lo)):
        speeds = []
        for _ in range(round(1.5 * stroke_s / dt)):
            data.ctrl[: robot.n_arm] = data.qfrc_bias[arm_v]  # the arm held against gravity
            data.ctrl[act] = command
            before = data.qpos[fingers[0]]
            mujoco.mj_step(model, data)
            speeds.append(abs(data.qpos[fingers[0]] - before) / dt * robot.finger_m_per_unit)
        opening = data.qpos[fingers] * robot.finger_m_per_unit
        assert opening == pytest.approx([end] * len(fingers), abs=1e-3), command
        cruise = np.median(speeds[round(0.2 * stroke_s / dt) : round(0.8 * stroke_s / dt)])
        assert cruise == pytest.approx(robot.gripper_speed_mps, rel=0.1), command


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_hand_drive_closes_free_fingers_within_its_moving_limit(name):
    """The hand's drive (robots/hand.py) closes free fingers (nothing between them) from open
    to a third of it at its moving pace: a finger still spinning up (a servo jaw's rotor,
    `gripper_time_constant_s`) is not one an object holds back, so the drive never squeezes
    with the full voltage on the way, and each side stays under the gripper's speed."""
    from orchestrator.robots.hand import GRIP_SPEED_MARGIN, HandDrive

    from orchestrator.world.indexing import as_index

    robot, model, data, arm_q, arm_v = _alone(name)
    fingers = np.array([model.joint(j).qposadr[0] for j in robot.finger_joints])
    finger_v = np.array([model.joint(j).dofadr[0] for j in robot.finger_joints])
    act = model.actuator(robot.gripper_actuator).id
    dt_control = 0.01
    drive = HandDrive(robot, data.qpos, as_index(fingers), data.ctrl, act, dt_control)
    target = robot.gripper_open_m / 3.0
    voltage, speed = 0.0, 0.0
    ticks = round(1.5 * (robot.gripper_open_m - target) / robot.gripper_speed_mps / dt_control)
    for tick in range(-20, ticks + 20):  # held open for 0.2 s (as a grasp finds them), closed
        drive.target = robot.gripper_open_m if tick < 0 else target
        drive.advance()
        voltage = max(voltage, abs(float(data.ctrl[act])) if tick >= 0 else 0.0)
        for _ in range(round(dt_control / model.opt.timestep)):
            data.ctrl[: robot.n_arm] = data.qfrc_bias[arm_v]  # the arm held against gravity
            mujoco.mj_step(model, data)
            speed = max(speed, float(np.max(np.abs(data.qvel[finger_v]))) * robot.finger_m_per_unit)
    assert 0.5 * drive.width() == pytest.approx(target, abs=5e-4)
    assert voltage <= GRIP_SPEED_MARGIN, f"{name}: the drive squeezed free fingers ({voltage:.3f})"
    assert speed <= robot.gripper_speed_mps, f"{name}: {speed:.5f} m/s a side"


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_show_robot_prints_its_joints_limits_and_their_source(cli, name):
    robot = get_robot(name)
    res = cli("show", "robot", name)
    assert res.exit_code == 0, res.stdout
    for joint in robot.arm_joints:
        assert f"| `{joint}` |" in res.stdout
    assert robot.datasheet is not None and robot.datasheet.source in res.stdout


def test_show_robot_names_the_valid_robots_for_an_unknown_one(cli):
    res = cli("show", "robot", "no_such_arm")
    assert res.exit_code == 2
    assert all(name in res.stderr for name in ROBOTS)
