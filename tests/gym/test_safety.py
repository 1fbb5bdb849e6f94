"""Per-link safety floor (``robot.safety_floor``): lowest points of geoms, links held above the
table, the gym envs' reports, and the same floor behind the dm_control joint env."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.robot.floor_points import CYLINDER_SIDES, geom_points
from trossen_arm_mujoco.robot.kinematics import Kinematics
from trossen_arm_mujoco.robot.layout import VENDOR16_LAYOUT
from trossen_arm_mujoco.robot.move_group import MoveGroup
from trossen_arm_mujoco.robot.safety_floor import SafetyFloor

REACH = "TrossenMujoco/WXAIReach-v0"
#: shoulder far forward, elbow nearly straight, wrist bent up: the tool frame stays 0.17 m
#: above the table while link_4 (the forearm, past the elbow) goes 7 cm into it.
ELBOW_DOWN = np.array([0.0, 3.0, 0.4, -1.5, 0.0, 0.0])

ARM_XML = """
<mujoco>
  <asset><mesh name="tetra" vertex="0 0 0  0.1 0 0  0 0.1 0  0 0 0.1"/></asset>
  <worldbody>
    <body name="base" pos="0 0 0.5">
      <geom type="box" size="0.05 0.05 0.05"/>
      <body name="link" pos="0 0 0">
        <joint name="hinge" type="hinge" axis="0 1 0"/>
        <geom name="capsule" type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
        <body name="tip" pos="0.3 0 0" euler="0 30 0">
          <geom name="box" type="box" size="0.01 0.02 0.04"/>
          <geom name="ball" type="sphere" size="0.03" pos="0.05 0 0"/>
          <geom name="cyl" type="cylinder" size="0.03 0.05" pos="0.1 0 0" euler="40 0 0"/>
          <geom name="mesh" type="mesh" mesh="tetra" pos="0.2 0 0"/>
          <geom name="ghost" type="sphere" size="0.5" contype="0" conaffinity="0"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _exact_lowest(model, data, geom: int) -> float:
    """Lowest world z of one geom, from its type's closed form (mesh: its vertices)."""
    r = data.geom_xmat[geom].reshape(3, 3)[2]  # world z of the geom's axes
    z, size = data.geom_xpos[geom, 2], model.geom_size[geom]
    kind = mujoco.mjtGeom(int(model.geom_type[geom]))
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return z - np.abs(r) @ size
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return z - size[0]
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        return z - abs(r[2]) * size[1] - size[0]
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return z - abs(r[2]) * size[1] - size[0] * math.sqrt(max(0.0, 1 - r[2] ** 2))
    mesh = int(model.geom_dataid[geom])
    verts = model.mesh_vert[
        model.mesh_vertadr[mesh] : model.mesh_vertadr[mesh] + model.mesh_vertnum[mesh]
    ]
    return z + float((verts @ r).min())


@pytest.mark.parametrize("angle", [-2.0, -0.7, 0.0, 0.4, 1.3, 2.9])
def test_lowest_point_of_every_geom_type(angle):
    model = mujoco.MjModel.from_xml_string(ARM_XML)
    data = mujoco.MjData(model)
    floor = SafetyFloor(model, [MoveGroup(model, "arm", ["hinge"])], floor_z=0.0)
    z, body = floor.lowest(data.qpos, "arm", np.array([angle]))
    data.qpos[0] = angle
    mujoco.mj_kinematics(model, data)
    moving = [model.geom(n).id for n in ("capsule", "box", "ball", "cyl", "mesh")]
    exact = {g: _exact_lowest(model, data, g) for g in moving}
    lowest = min(exact, key=exact.get)
    # cylinders are 16-gons around their discs: at most r (1 / cos(pi / 16) - 1) lower
    slack = 0.03 * (1 / math.cos(math.pi / CYLINDER_SIDES) - 1)
    assert exact[lowest] - slack - 1e-12 <= z <= exact[lowest] + 1e-12
    assert body == model.geom_bodyid[lowest]  # the base's box and the ghost sphere ignored


def test_geom_points_cover_a_cylinder_from_outside():
    model = mujoco.MjModel.from_xml_string(ARM_XML)
    points, radius = geom_points(model, model.geom("cyl").id)
    assert radius == 0.0 and points.shape == (2 * CYLINDER_SIDES, 3)
    assert np.all(np.hypot(points[:, 0], points[:, 1]) >= 0.03)


KIT = "TrossenMujoco/StationaryAITransferCube-v0"


def _joint_action(env, target: np.ndarray, gripper: float = 1.0) -> np.ndarray:
    low, high = env.unwrapped.task.arm.ctrl_limits.T
    return np.append(2 * (target - low) / (high - low) - 1, gripper)


def _robot(env):
    u = env.unwrapped
    return u.scene.robots[u.sampler.robot_name]


def _floor(env) -> SafetyFloor:
    return _robot(env).safety_floor


def _tool_kinematics(env, arm) -> Kinematics:
    model = env.unwrapped.scene.model
    return Kinematics(model, arm.frame_site_id, arm.qpos_idx, arm.dof_idx, arm.joint_range)


def test_the_gym_floor_is_the_robots_at_the_configs_margin(make_env):
    env = make_env(REACH)
    u = env.unwrapped
    floor = _floor(env)
    assert floor is u.actions.robot.safety_floor
    assert floor.floor_z == pytest.approx(u.config["table_height"] + u.config["safety_margin"])
    assert _floor(make_env(REACH, safety_margin=0.1)).floor_z == pytest.approx(0.1)
    _, info = env.reset(seed=0)
    assert info["safety_clipped"] is False and info["safety_links"] == ""


def test_elbow_into_the_table_is_clipped_and_reported(make_env):
    env = make_env(REACH, action_mode="joint_position")
    env.reset(seed=0)
    u = env.unwrapped
    floor, data = _floor(env), u.scene.data
    # the tool frame alone would pass: only a link below it goes under the table
    kin = _tool_kinematics(env, u.task.arm)
    assert kin.site_position(data.qpos, ELBOW_DOWN)[2] > floor.floor_z + 0.1
    z, body = floor.lowest(data.qpos, "arm", ELBOW_DOWN)
    assert z < floor.floor_z - 0.05 and floor.link_name(body) == "link_4"
    # the arm moves toward the target at its speed limits (the fast wrist first, so the path
    # is not the straight one) until a tick would take a link under the floor; from then on
    # every step is held and reported
    reports = []
    for _ in range(80):
        _, _, _, _, info = env.step(_joint_action(env, ELBOW_DOWN))
        reports.append(info["safety_links"] if info["safety_clipped"] else "")
        assert floor.lowest(data.qpos, "arm")[0] > floor.floor_z - 0.005
    assert reports[0] == "" and all(reports[-20:])
    assert _robot(env).floor_report.links == reports[-1].split(",")


def test_the_floor_checks_where_the_joint_targets_end_the_tick(make_env, monkeypatch):
    """What the floor checks is exactly the joint target the controller reaches in the tick
    (the applied control moved toward the commanded target at the speed limits)."""
    env = make_env(REACH, action_mode="joint_position")
    env.reset(seed=0)
    u = env.unwrapped
    floor = _floor(env)
    checked = []
    kinematics = mujoco.mj_kinematics

    def spy(model, data):  # the arm's joints in the floor's forward kinematics
        if data is floor._data:
            checked.append(data.qpos[floor.arms["arm"].qpos_sel].copy())
        return kinematics(model, data)

    monkeypatch.setattr(mujoco, "mj_kinematics", spy)
    arm = u.task.arm
    far = arm.get_qpos(u.scene.data) + np.array([1.0, -1.0, 1.0, -2.0, 2.0, -2.0])
    for _ in range(3):
        before = len(checked)
        env.step(_joint_action(env, far))
        assert len(checked) == before + 1  # one pass per tick (one tick per Reach step)
        assert np.array_equal(checked[-1], arm.get_ctrl(u.scene.data))
    assert not np.allclose(checked[-1], np.clip(far, *arm.ctrl_limits.T))  # not the target


def test_normal_action_is_not_clipped(make_env):
    env = make_env(REACH, action_mode="joint_position")
    env.reset(seed=0)
    u = env.unwrapped
    here = u.task.arm.get_qpos(u.scene.data)
    for target in (here, here + [0.3, -0.2, 0.2, 0.3, 0.3, 0.5]):
        _, _, _, _, info = env.step(_joint_action(env, target))
        assert not info["safety_clipped"] and info["safety_links"] == ""


def test_both_arms_are_checked(make_env):
    env = make_env(KIT, action_mode="joint_rel_position")
    env.reset(seed=0)
    u = env.unwrapped
    floor = _floor(env)
    down = np.zeros(14)
    down[7:13] = [0.0, 1.0, -1.0, 0.0, 0.0, 0.0]  # right arm: shoulder forward, elbow open
    down[13] = 1.0
    rounds = []
    for _ in range(30):
        _, _, _, _, info = env.step(down)
        rounds.append(info["safety_links"])
        for arm in ("left_arm", "right_arm"):
            assert floor.lowest(u.scene.data.qpos, arm)[0] > floor.floor_z - 0.005
    held = [r for r in rounds if r]
    assert held and all(r.startswith("right/") for r in held)


def _put(env, q: np.ndarray) -> None:
    """The single arm at joints ``q`` (rad), at rest, every control holding it."""
    u = env.unwrapped
    data = u.scene.data
    u.task.arm.set_qpos(data, q)
    data.qvel[:] = 0.0
    mujoco.mj_forward(u.scene.model, data)
    u.task.robot.hold(data)


def test_an_arm_below_the_floor_may_move_up_but_not_down(make_env):
    env = make_env(REACH, action_mode="joint_position")
    env.reset(seed=0)
    u = env.unwrapped
    data, arm, floor = u.scene.data, u.task.arm, _floor(env)
    below = ELBOW_DOWN.copy()
    _put(env, below)  # put it there (as a collision could), holding it
    z_now = floor.lowest(data.qpos, "arm")[0]
    assert z_now < floor.floor_z
    up = below + [0.0, -0.3, -0.3, 0.0, 0.0, 0.0]  # shoulder and elbow back: no point sinks
    _, _, _, _, info = env.step(_joint_action(env, up))
    assert not info["safety_clipped"]
    # the rule on whole moves (``safe_fraction``): shoulder back alone lifts the lowest
    # link, but takes the wrist (above the floor now) below it: every point counts
    _put(env, below)
    z_before = floor.heights(data.qpos, "arm")
    wrist_down = below + [0.0, -0.3, 0.0, 0.0, 0.0, 0.0]
    z_after = floor.heights(data.qpos, "arm", wrist_down)
    assert z_after.min() > z_now and ((z_after < floor.floor_z) & (z_before >= floor.floor_z)).any()
    fraction, link = floor.safe_fraction(data.qpos, "arm", below, wrist_down)
    assert fraction < 1 and link
    further = below + [0.0, 0.1, 0.0, 0.0, 0.0, 0.0]
    _put(env, below)
    start = arm.get_ctrl(data)
    robot = u.task.robot
    robot.update_control({"arm": further, "gripper": [0.044]})
    robot.compute_control()  # one tick, no physics: the held control is the new target
    assert robot.floor_report.clipped
    held = arm.get_ctrl(data)
    assert floor.lowest(data.qpos, "arm", held)[0] >= z_now - 1e-9
    assert np.array_equal(held, start)  # every part of the move sinks a point: none of it


def test_ee_delta_down_reports_the_link(make_env):
    env = make_env("TrossenMujoco/WXAIPush-v0", action_mode="ee_delta")
    env.reset(seed=0)
    u = env.unwrapped
    floor = _floor(env)
    links = set()
    for _ in range(40):
        _, _, _, _, info = env.step(np.array([0.0, 0.0, -1.0, 0.0]))
        links.add(info["safety_links"])
        assert floor.lowest(u.scene.data.qpos, "arm")[0] > floor.floor_z - 0.005
    assert links - {""}


@pytest.mark.parametrize("env_id", [REACH, KIT])
def test_below_flags_exactly_the_arms_with_a_point_under_the_floor(make_env, env_id):
    """``below`` (one FK pass for every arm) agrees with forward kinematics arm by arm, over
    random states and targets, and leaves the caller's data alone."""
    env = make_env(env_id)
    env.reset(seed=0)
    base = env.unwrapped
    floor, data = _floor(env), base.scene.data
    view = base.task.robot.view
    rng = np.random.default_rng(3)
    flagged = 0
    for _ in range(200):
        targets = {}
        for name in sorted(floor.arms):
            low, high = view.get_move_group(name).joint_range.T
            targets[name] = rng.uniform(low, high)
        qpos = data.qpos.copy()
        below = floor.below(data.qpos, targets)
        assert np.array_equal(data.qpos, qpos)
        for name, q in targets.items():
            moving = ~floor.arms[name].fixed_height
            z = floor.heights(data.qpos, name, q)[moving]
            assert (name in below) == bool(z.min() < floor.floor_z)
            flagged += name in below
    assert 0 < flagged < 200 * len(floor.arms)


def test_dm_control_joint_env_and_gym_env_clip_alike(make_env):
    """One floor for every front door: the same elbow-into-the-table command from the same
    state ends in the same held control, bit for bit, in the dm_control joint env and in the
    gym env (both at the table top: the gym env with ``safety_margin=0``)."""
    from trossen_arm_mujoco.sim_env import TransferCubeTask
    from trossen_arm_mujoco.utils import make_sim_env

    gym_env = make_env(KIT, action_mode="joint_position", safety_margin=0.0)
    gym_env.reset(seed=0)
    dm_env = make_sim_env(TransferCubeTask, cam_list=[], random=0)
    dm_env.reset()
    u = gym_env.unwrapped
    worlds = [
        (u.scene.model, u.scene.data, u.task.robot),
        (dm_env.physics.model.ptr, dm_env.physics.data.ptr, dm_env.task.robot(dm_env.physics)),
    ]
    groups = VENDOR16_LAYOUT.groups  # both arms and grippers
    start = {g: u.task.robot.view.get_move_group(g).get_qpos(u.scene.data) for g in groups}
    for model, data, robot in worlds:  # the same arms, at rest, holding
        for g, q in start.items():
            robot.view.get_move_group(g).set_qpos(data, q)
        data.qvel[:] = 0.0
        mujoco.mj_forward(model, data)
        robot.hold(data)
    floor = worlds[0][2].safety_floor
    assert worlds[1][2].safety_floor.floor_z == floor.floor_z == 0.02
    # right arm: elbow into the table; left arm where it is
    low, high = u.task.robot.view.get_move_group("right_arm").ctrl_limits.T
    target = np.clip(ELBOW_DOWN, low, high)
    assert floor.lowest(u.scene.data.qpos, "right_arm", target)[0] < floor.floor_z - 0.03
    action = np.zeros(14)
    action[7:13] = 2 * (target - low) / (high - low) - 1
    action[[6, 13]] = 1.0
    commands = u.actions(u.scene.data, action)  # what the gym env asks of the robot
    # the same commands as a dm_control action: the 14 values of the real kit's layout (per
    # arm 6 joints, then the gripper), which the joint env takes as well as the 16
    dm_action = np.concatenate(
        [commands[g] for g in ("left_arm", "left_gripper", "right_arm", "right_gripper")]
    )
    held = []
    for _ in range(40):
        _, _, _, _, info = gym_env.step(action)
        dm_env.step(dm_action)
        ctrls = [data.ctrl.copy() for _, data, _ in worlds]
        assert np.array_equal(ctrls[0], ctrls[1])
        reports = [robot.floor_report.links for _, _, robot in worlds]
        assert reports[0] == reports[1] == (info["safety_links"].split(",") if reports[0] else [])
        held.append(bool(reports[0]))
        assert floor.lowest(u.scene.data.qpos, "right_arm")[0] > floor.floor_z - 0.005
    assert not held[0] and held[-1]
