"""The Trossen Mobile AI model (MJCF), generated from public facts; called by build_models.py.

``files(bm)`` returns {relative path under assets/: generator} for ``assets/mobile_ai/``;
``bm`` holds the names of the ``build_models`` module, whose arm facts and MJCF pieces (the
WidowX AI arm tree, defaults, actuators, gripper coupling) are reused so both arms are the
same arm as everywhere else in this project.

Sources (each number below names its source; docs/concepts/models.md lists them):

- URDF: TrossenRobotics/trossen_arm_description ``urdf/generated/mobile_ai.urdf``
  (stored version @0f23717): base_footprint -> base_link offset, wheel and caster joint
  origins and axes, wheel effort/velocity limits, link masses and inertias, the arm mounts,
  the ``cam_high`` mount.
- SLATE spec: TrossenRobotics/slate_docs ``docs/specifications.rst`` (@11f93e1): the base's
  500 x 500 x 222 mm body, 165 mm wheels, 392 mm tread, 3.6 km/h top speed.
- trossen_slate SDK: Interbotix/trossen_slate ``include/trossen_slate/trossen_slate.hpp``
  (@0857ccd): ``set_cmd_vel`` clips x to +-1.0 m/s and theta to +-1.0 rad/s.

Frames: body ``base_link`` is the URDF ``base_link``, 0.211 m above the floor at rest (site
``base_footprint`` marks the floor point between the wheels); x forward, z up.
"""

from __future__ import annotations

from typing import Any

import numpy as np

# ----------------------------------------------------------------------------- facts
#: URDF base_footprint_joint: base_link is this high above the floor (m).
BASE_LINK_HEIGHT = 0.211
#: URDF base_link inertial: mass (kg), com (base_link frame, m), inertia tensor (kg m^2)
#: [ixx, iyy, izz, ixy, ixz, iyz] in the inertial frame rotated rpy (pi/2, 0, 0).
BASE_MASS = 80.0
BASE_COM = (0.01556204, 0.00159774, 0.22495608)
BASE_INERTIA_URDF = (
    0.800607899578097,
    0.631097301133464,
    0.560183616098452,
    -0.000448278451746243,
    -1.46448934897976e-05,
    -1.76432150020805e-05,
)
#: URDF left_wheel / right_wheel origins in base_link: y = +-0.192, z = -0.1259 (the axle
#: is 0.0851 m above the floor, which makes the rolling radius 0.0851 m; the SLATE spec's
#: 165 mm wheel would be 0.0825). Axis +y for both: positive speed drives forward.
WHEEL_Y = 0.192
WHEEL_Z = -0.1259
WHEEL_RADIUS = BASE_LINK_HEIGHT + WHEEL_Z
#: URDF left_wheel_link inertial (the right wheel's URDF mass, 0.98 kg, is taken to be a
#: typo: same wheel, same inertia tensor); diag in the wheel frame, axle along y.
WHEEL_MASS = 3.0
WHEEL_DIAG = (0.00165792997375718, 0.00291162000439156, 0.00165792997375718)
#: URDF wheel joint limits: effort (N m), velocity (rad/s, 4 pi).
WHEEL_EFFORT = 4.0
WHEEL_MAX_SPEED = 12.566370614359172
#: Velocity servo gain of the wheel actuators (N m s/rad): own choice (not published), stiff
#: enough that rolling holds the wheels within 0.002 rad/s of their command (20 left 0.01 and
#: a 1 % slow turn); the torque saturates at WHEEL_EFFORT for speed errors above 0.04 rad/s.
WHEEL_KV = 100.0
#: URDF caster swivel joints in base_link (x, y, z); axis z, then the caster wheel at
#: (-0.0345, 0, -0.066) in the swivel (axis y): the caster wheel's rolling radius is its
#: axle height, 0.211 - 0.107 - 0.066 = 0.038 m.
CASTERS = {
    "front_left": (0.168, 0.17, -0.107),
    "front_right": (0.16843, -0.17, -0.107),
    "rear_left": (-0.16783, 0.17, -0.107),
    "rear_right": (-0.168, -0.17, -0.107),
}
CASTER_WHEEL_OFFSET = (-0.0345, 0.0, -0.066)
CASTER_RADIUS = BASE_LINK_HEIGHT + CASTERS["front_left"][2] + CASTER_WHEEL_OFFSET[2]
#: URDF caster_swivel_* inertial: mass, com, inertia [ixx, iyy, izz, ixy, ixz, iyz].
SWIVEL_MASS = 0.1
SWIVEL_COM = (-0.00642926, 0.0, -0.02324376)
SWIVEL_INERTIA = (
    3.29304410034736e-05,
    3.55223730522351e-05,
    2.57879736183465e-05,
    0.0,
    7.8716764062508e-06,
    0.0,
)
#: URDF caster_wheel_* inertial: mass, diag (axle along y).
CASTER_WHEEL_MASS = 0.535
CASTER_WHEEL_DIAG = (3.50667612783944e-05, 6.42430517058348e-05, 3.50667612783944e-05)
#: URDF follower_{left,right}/mount_joint: the arm bases in base_link, identity rotation
#: (both arms face forward, +x).
ARM_MOUNTS = {"left": (0.331, 0.3, 0.831), "right": (0.331, -0.3, 0.831)}
#: URDF cam_high_joint (xyz, pitch about y) then cam_high_link_joint (xyz): the D405's
#: colour frame (x forward) in base_link.
CAM_HIGH_MOUNT = ((0.209805, 0.0, 1.031778), 0.6457718232379019)
CAM_HIGH_OFFSET = (0.01085, 0.009, 0.021)
#: Vertical field of view of cam_high (deg): the URDF gives none; it is the same D405 as the
#: wrist cameras, so their value (build_models.WRIST_FOVY).
CAM_HIGH_FOVY = 87

#: Collision/visual boxes of the base (own primitives; footprint frame, z up from the
#: floor): the SLATE body from its spec (500 x 500 x 222 mm, 31 mm ground clearance), and
#: the kit's tower, arm plates and camera post sized to carry the URDF mounts above.
#: (name, half-size, centre (x, y, z above the floor), material)
BASE_BOXES = [
    ("slate", (0.25, 0.25, 0.0955), (0.0, 0.0, 0.1265), "slate_body"),
    ("tower", (0.15, 0.2, 0.3), (-0.05, 0.0, 0.522), "slate_body"),
    ("upright_left", (0.02, 0.02, 0.1), (0.14, 0.2, 0.922), "frame"),
    ("upright_right", (0.02, 0.02, 0.1), (0.14, -0.2, 0.922), "frame"),
    ("crossbar", (0.03, 0.37, 0.01), (0.15, 0.0, 1.032), "frame"),
    ("plate_left", (0.09, 0.05, 0.01), (0.27, 0.3, 1.032), "frame"),
    ("plate_right", (0.09, 0.05, 0.01), (0.27, -0.3, 1.032), "frame"),
    ("camera_post", (0.01, 0.02, 0.095), (0.19, 0.0, 1.137), "frame"),
]
#: D405 housing of cam_high (half-size, in the camera's colour frame, behind the lens).
D405_HALF = (0.0115, 0.021, 0.021)

#: The pick-and-place scene: a table in front of the robot and a 50 mm cube on it.
TABLE_TOP_Z = 0.75
TABLE_HALF = (0.4, 0.6, 0.02)
TABLE_POS = (1.2, 0.0)
CUBE_HALF = 0.025
CUBE_HOME = (0.95, 0.15)
TARGET_HOME = (0.95, 0.0)

#: qpos of the home keyframe: the base at rest at the origin.
BASE_HOME = (0.0, 0.0, BASE_LINK_HEIGHT, 1.0, 0.0, 0.0, 0.0)


#: Attributes of visual-only geoms (no contact, no mass) and of the wheels' contact shapes.
VISUAL = 'contype="0" conaffinity="0" group="2" density="0"'
CONTACT_SHAPE = 'group="3" density="0" rgba="0.3 0.3 0.3 0.3"'
Q_Y = "0.707107 0.707107 0 0"  # a cylinder's axis along the body's y
MATERIALS = """    <material name="frame" rgba="0.72 0.73 0.75 1" specular="0.5" shininess="0.6"/>
    <material name="slate_body" rgba="0.22 0.23 0.25 1" specular="0.3" shininess="0.3"/>
    <material name="tyre" rgba="0.06 0.06 0.06 1" specular="0.1" shininess="0.1"/>
"""
FLOOR = '    <geom name="floor" type="plane" size="0 0 0.05" material="groundplane"/>'


def _fmt(v) -> str:
    return " ".join(f"{float(x):.9g}" for x in v)


def base_inertia() -> tuple[float, ...]:
    """The URDF base inertia in the base_link frame, MJCF ``fullinertia`` order
    (ixx iyy izz ixy ixz iyz): the URDF tensor is given in a frame rotated rpy (pi/2, 0, 0)."""
    ixx, iyy, izz, ixy, ixz, iyz = BASE_INERTIA_URDF
    tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    c, s = np.cos(np.pi / 2), np.sin(np.pi / 2)
    rot = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    full = rot @ tensor @ rot.T
    return (full[0, 0], full[1, 1], full[2, 2], full[0, 1], full[0, 2], full[1, 2])


def cam_high_pose() -> tuple[np.ndarray, np.ndarray]:
    """(pos, quat) of the cam_high colour frame (x forward) in base_link."""
    (x, y, z), pitch = CAM_HIGH_MOUNT
    c, s = np.cos(pitch), np.sin(pitch)
    rot = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    pos = np.array([x, y, z]) + rot @ np.asarray(CAM_HIGH_OFFSET)
    return pos, np.array([np.cos(pitch / 2), 0.0, np.sin(pitch / 2), 0.0])


def quat_mul(a, b) -> np.ndarray:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ]
    )


#: A MuJoCo camera looks along its -z with +y up; a URDF colour frame looks along +x with
#: +z up: camera quat = frame quat * this (facts sheet D4).
FRAME_TO_CAMERA = (0.5, 0.5, -0.5, -0.5)


def _in_base(pos) -> tuple[float, float, float]:
    """A footprint-frame point in the base_link frame."""
    return (pos[0], pos[1], pos[2] - BASE_LINK_HEIGHT)


def _base_geoms(sp: str, rigid: str) -> list[str]:
    """The base's boxes, in contact as stiff as the table's (``rigid``: build_models'
    RIGID_CONTACT attributes)."""
    out = []
    for name, half, centre, material in BASE_BOXES:
        out.append(
            f'{sp}<geom name="base_{name}" type="box" size="{_fmt(half)}" '
            f'pos="{_fmt(_in_base(centre))}" material="{material}" {rigid}/>'
        )
    return out


def _wheel(side: str, sp: str) -> str:
    y = WHEEL_Y if side == "left" else -WHEEL_Y
    r = WHEEL_RADIUS
    return f"""{sp}<body name="{side}_wheel_link" pos="0 {y:g} {WHEEL_Z:g}">
{sp}  <inertial pos="0 0 0" mass="{WHEEL_MASS:g}" diaginertia="{_fmt(WHEEL_DIAG)}"/>
{sp}  <joint name="{side}_wheel" type="hinge" axis="0 1 0"/>
{sp}  <geom name="{side}_wheel_tyre" type="cylinder" size="{r:.6g} 0.025" quat="{Q_Y}"
{sp}        material="tyre" {VISUAL}/>
{sp}  <geom name="{side}_wheel_hub" type="cylinder" size="0.045 0.0255" quat="{Q_Y}"
{sp}        material="frame" {VISUAL}/>
{sp}  <geom name="{side}_wheel" type="sphere" size="{r:.6g}" {CONTACT_SHAPE}/>
{sp}</body>"""


def _caster(name: str, pos, sp: str) -> str:
    r = CASTER_RADIUS
    return f"""{sp}<body name="caster_swivel_{name}" pos="{_fmt(pos)}">
{sp}  <inertial pos="{_fmt(SWIVEL_COM)}" mass="{SWIVEL_MASS:g}"
{sp}            fullinertia="{_fmt(SWIVEL_INERTIA)}"/>
{sp}  <joint name="caster_swivel_{name}" type="hinge" axis="0 0 1" damping="0.001"/>
{sp}  <geom type="box" size="0.02 0.015 0.02" pos="-0.015 0 -0.03" material="frame" {VISUAL}/>
{sp}  <body name="caster_wheel_{name}" pos="{_fmt(CASTER_WHEEL_OFFSET)}">
{sp}    <inertial pos="0 0 0" mass="{CASTER_WHEEL_MASS:g}" diaginertia="{_fmt(CASTER_WHEEL_DIAG)}"/>
{sp}    <joint name="caster_wheel_{name}" type="hinge" axis="0 1 0" damping="0.0001"/>
{sp}    <geom type="cylinder" size="{r:.6g} 0.012" quat="{Q_Y}" material="tyre" {VISUAL}/>
{sp}    <geom name="caster_{name}" type="sphere" size="{r:.6g}" {CONTACT_SHAPE}/>
{sp}  </body>
{sp}</body>"""


ROBOT_NOTE = f"""Trossen Mobile AI: a SLATE differential-drive base (two driven wheels, four
     casters) carrying two wxai follower arms and three cameras (cam_high on the frame, one
     per wrist).
     Generated by tools/build_models.py (tools/mobile_ai_model.py); do not edit by hand.
     Facts: the Mobile AI URDF (wheels, casters, masses, arm and camera mounts), the SLATE
     spec (body size) and SDK (velocity limits); see docs/concepts/models.md.
     World frame: the floor at z = 0. Body base_link (free joint base_joint) is the URDF
     base_link, {BASE_LINK_HEIGHT} m above the floor at rest; x forward, z up.
     qpos: base_joint (7), left arm (8), right arm (8), wheels (2), casters (8);
     ctrl: left arm (7), right arm (7), left_wheel, right_wheel (velocity servos, rad/s)."""


def robot_xml(bm: Any, model: str, note: str, assets: str = "", world: str = "", objects=()) -> str:
    """The Mobile AI on a floor with its actuators and keyframe ``home`` (robot at rest at
    the origin, arms at START_ARM_POSE); ``assets``/``world`` add MJCF, ``objects`` the qpos
    of the free bodies ``world`` adds (they come after the robot's in qpos)."""
    sp = "      "
    cam_pos, frame_quat = cam_high_pose()
    cam_quat = quat_mul(frame_quat, FRAME_TO_CAMERA)
    pitch = CAM_HIGH_MOUNT[1]
    housing = cam_pos + 0.0078 * np.array([-np.cos(pitch), 0.0, np.sin(pitch)])
    arms = "".join(
        bm.mjcf_arm(f"{side}/", pos, (1, 0, 0, 0), f"cam_{side}_wrist", 6)
        for side, pos in ARM_MOUNTS.items()
    )
    wheels = "\n".join(_wheel(s, sp) for s in ("left", "right"))
    casters = "\n".join(_caster(n, p, sp) for n, p in CASTERS.items())
    excludes = "".join(
        f'    <exclude body1="base_link" body2="caster_wheel_{n}"/>\n' for n in CASTERS
    )
    wheel_act = "".join(
        f'    <velocity name="{s}_wheel" joint="{s}_wheel" kv="{WHEEL_KV:g}" '
        f'ctrlrange="{-WHEEL_MAX_SPEED:.9g} {WHEEL_MAX_SPEED:.9g}" '
        f'forcerange="{-WHEEL_EFFORT:g} {WHEEL_EFFORT:g}"/>\n'
        for s in ("left", "right")
    )
    arm_home = bm.START_Q + (bm.GRIPPER_OPEN, bm.GRIPPER_OPEN)
    qpos = BASE_HOME + arm_home + arm_home + (0.0,) * (2 + 2 * len(CASTERS)) + tuple(objects)
    arm_ctrl = bm.START_Q + (bm.GRIPPER_OPEN,)
    ctrl = arm_ctrl + arm_ctrl + (0.0, 0.0)
    return f"""<!-- {note} -->
<mujoco model="{model}">
{bm.OPTIONS}  <visual>
    <global offwidth="640" offheight="480" azimuth="150" elevation="-20"/>
    {bm.looks.QUALITY}
    {bm.looks.HEADLIGHT}
    <map znear="0.01"/>
  </visual>
{bm.mjcf_defaults()}
  <asset>
{bm.mjcf_arm_assets()}{MATERIALS}
    <texture name="sky" type="skybox" builtin="gradient" rgb1="0.55 0.62 0.70" rgb2="0.12 0.13 0.15"
             width="32" height="512"/>
    <texture name="groundplane" type="2d" builtin="checker" rgb1="0.30 0.32 0.35"
             rgb2="0.25 0.27 0.30" width="300" height="300"/>
    <material name="groundplane" texture="groundplane" texuniform="true" texrepeat="4 4"/>
{assets}  </asset>

  <worldbody>
{bm.looks.mjcf_lights((1.0, 0.0))}{FLOOR}
    <body name="base_link" pos="{_fmt(BASE_HOME[:3])}">
      <freejoint name="base_joint"/>
      <inertial pos="{_fmt(BASE_COM)}" mass="{BASE_MASS:g}" fullinertia="{_fmt(base_inertia())}"/>
      <site name="base_footprint" pos="0 0 {-BASE_LINK_HEIGHT:g}" size="0.01" rgba="1 0.3 0.1 0.6"
            group="4"/>
{chr(10).join(_base_geoms(sp, bm.RIGID_CONTACT))}
      <geom name="cam_high_housing" type="box" size="{_fmt(D405_HALF)}" pos="{_fmt(housing)}"
            quat="{_fmt(frame_quat)}" material="wxai_grey"/>
      <site name="cam_high_color_frame" pos="{_fmt(cam_pos)}" quat="{_fmt(frame_quat)}"
            size="0.005" group="4"/>
      <camera name="cam_high" pos="{_fmt(cam_pos)}" quat="{_fmt(cam_quat)}" fovy="{CAM_HIGH_FOVY}"/>
{arms}{wheels}
{casters}
    </body>
{world}  </worldbody>

  <contact>
{excludes}  </contact>

  <equality>
{bm.mjcf_gripper_equality("left/")}{bm.mjcf_gripper_equality("right/")}  </equality>

  <actuator>
{bm.mjcf_actuators("left/")}{bm.mjcf_actuators("right/")}{wheel_act}  </actuator>

  <keyframe>
    <key name="home" qpos="{_fmt(qpos)}"
         ctrl="{_fmt(ctrl)}"/>
  </keyframe>
</mujoco>
"""


def mobile_ai_xml(bm: Any) -> str:
    """``assets/mobile_ai/mobile_ai.xml``: the robot on an empty floor."""
    return robot_xml(bm, "mobile_ai", ROBOT_NOTE)


def mobile_ai_scene_xml(bm: Any) -> str:
    """``assets/mobile_ai/mobile_ai_scene.xml``: the robot, a table ahead of it, a cube on the
    table and a place target (site ``target_site``)."""
    tx, ty = TABLE_POS
    top = TABLE_TOP_Z
    leg_half = (top - 2 * TABLE_HALF[2]) / 2
    legs = "\n".join(
        f'      <geom name="table_leg_{k}" type="cylinder" size="0.025 {leg_half:.6g}" '
        f'pos="{x:g} {y:g} {leg_half - top:.6g}" material="frame"/>'
        for k, (x, y) in enumerate(((0.35, 0.55), (0.35, -0.55), (-0.35, 0.55), (-0.35, -0.55)))
    )
    cube_z = top + CUBE_HALF
    assets = """    <texture name="maple" type="2d" builtin="flat" rgb1="0.80 0.64 0.45"
             rgb2="0.72 0.55 0.38" mark="random" random="0.015" markrgb="0.74 0.58 0.40"
             width="256" height="256"/>
    <material name="maple" texture="maple" texrepeat="2 2" specular="0.15" shininess="0.2"/>
"""
    world = f"""    <body name="table_body" pos="{tx:g} {ty:g} {top:g}">
      <geom name="table" type="box" size="{_fmt(TABLE_HALF)}" pos="0 0 {-TABLE_HALF[2]:g}"
            material="maple" friction="1 0.005 0.0001" {bm.RIGID_CONTACT}/>
{legs}
    </body>
    <body name="cube" pos="{CUBE_HOME[0]:g} {CUBE_HOME[1]:g} {cube_z:g}">
      <joint name="cube_joint" type="free" frictionloss="0.0005"/>
      <geom name="cube" type="box" size="{CUBE_HALF} {CUBE_HALF} {CUBE_HALF}" mass="0.05"
            condim="4" friction="1.5 0.02 0.0001" rgba="0.85 0.08 0.08 1"/>
    </body>
    <site name="target_site" pos="{TARGET_HOME[0]:g} {TARGET_HOME[1]:g} {top:g}" type="cylinder"
          size="0.04 0.0005" rgba="0.1 0.7 0.2 0.5"/>
"""
    note = (
        ROBOT_NOTE
        + f"""
     Scene: a table ahead of the robot (geom "table", top at z = {top} m, front edge at
     x = {tx - TABLE_HALF[0]:g} m), a 50 mm, 50 g cube on it (body "cube", geom "cube", free
     joint cube_joint: qpos 33..39) and a place target (site "target_site")."""
    )
    return robot_xml(
        bm, "mobile_ai_scene", note, assets, world, (CUBE_HOME[0], CUBE_HOME[1], cube_z, 1, 0, 0, 0)
    )


def files(bm: Any) -> dict:
    """{relative path under assets/: zero-argument generator} of the Mobile AI models."""
    return {
        "mobile_ai/mobile_ai.xml": lambda: mobile_ai_xml(bm),
        "mobile_ai/mobile_ai_scene.xml": lambda: mobile_ai_scene_xml(bm),
    }
