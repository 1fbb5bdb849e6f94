"""Generate this project's robot models (MJCF + URDF) from one table of robot facts.

The shipped files under ``trossen_arm_mujoco/assets`` are the output of this script;
``tests/assets/test_generated.py`` checks they are up to date. Run from the repo root:

    python tools/build_models.py

Numbers come from the public facts about the WidowX AI (wxai) arm and the Stationary AI
kit (link offsets, joint axes and limits, inertials, actuator gains, primitive geometry).
"""

from __future__ import annotations

import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the package, from the repo root
sys.path.insert(0, str(Path(__file__).resolve().parent))  # model_looks, beside this file
import mobile_ai_model  # noqa: E402
import model_looks as looks  # noqa: E402

from trossen_arm_mujoco.fileio import write_text  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
ASSETS = ROOT / "trossen_arm_mujoco" / "assets"

PI = 3.14159
START_Q = (0.0, 0.2617993877991494, 0.2617993877991494, 0.0, 0.0, 0.0)
GRIPPER_OPEN = 0.044

# ----------------------------------------------------------------------------- arm facts
# body: (parent, pos, inertial (mass, com, iquat, diaginertia))
BODIES = {
    "base_link": (
        None,
        (0, 0, 0),
        (
            0.45969858,
            (-0.00014175, -5.2280e-05, 0.03175177),
            (0.503748, -0.50738, -0.49423, -0.49451),
            (0.000213926, 0.000416701, 0.000448963),
        ),
    ),
    "link_1": (
        "base_link",
        (0, 0, 0.05725),
        (
            0.152704,
            (-0.00011075, 0.00171176, 0.0204459),
            (0.3139551, 0.3052381, -0.6435752, 0.6277522),
            (0.000203432, 0.000173907, 8.3521e-05),
        ),
    ),
    "link_2": (
        "link_1",
        (0.02, 0, 0.04625),
        (
            1.15316,
            (-0.131215, -0.00292583, 0.00021345),
            (-0.00123582, 0.7065461, -0.00109575, 0.7076651),
            (0.0179449, 0.0173612, 0.00102628),
        ),
    ),
    "link_3": (
        "link_2",
        (-0.264, 0, 0),
        (
            0.686666,
            (0.180836, -0.0009409, 0.0555494),
            (0.0103901, 0.669684, -0.0033175, 0.742566),
            (0.00566898, 0.00547578, 0.00059316),
        ),
    ),
    "link_4": (
        "link_3",
        (0.245, 0, 0.06),
        (
            0.457899,
            (0.0579784, 0.00027145, 0.0588445),
            (0.9486879, 0.0346237, 0.307828, 0.0635164),
            (0.000670827, 0.000661455, 0.000288648),
        ),
    ),
    "link_5": (
        "link_4",
        (0.06775, 0, 0.0455),
        (
            0.366939,
            (0.00412447, -1.1380e-05, -0.0428318),
            (0.4961438, 0.5021278, 0.5035948, 0.4980978),
            (0.000320622, 0.00026751, 0.000189108),
        ),
    ),
    "link_6": (
        "link_5",
        (0.02895, 0, -0.0455),
        (
            0.671874,
            (0.046841, 0.00145133, 0.00895674),
            (0.2758541, 0.2912551, -0.6919572, 0.6002252),
            (0.00118316, 0.00110863, 0.00078309),
        ),
    ),
    "carriage_right": (
        "link_6",
        (0.0865, -0.023, 0),
        (
            0.081271,
            (0.00169015, 0.00592793, 0.00201817),
            (-0.3709729, 0.7408857, -0.08477207, 0.5534268),
            (4.2957e-05, 3.8708e-05, 2.2153e-05),
        ),
    ),
    "carriage_left": (
        "link_6",
        (0.0865, 0.023, 0),
        (
            0.081271,
            (0.00169017, -0.00592796, -0.00365701),
            (-0.03826911, 0.6280222, -0.2551011, 0.7341982),
            (4.2111e-05, 3.6194e-05, 2.4000e-05),
        ),
    ),
}

# joint: (child body, type, axis, range, armature, actuator (kp, kv, force), urdf velocity, effort)
JOINTS = {
    "joint_0": ("link_1", "hinge", (0, 0, 1), (-3.05433, 3.05433), 0.032, (200, 10, 27), 3.375, 27),
    "joint_1": ("link_2", "hinge", (0, 1, 0), (0, PI), 0.032, (200, 10, 27), 3.375, 27),
    "joint_2": ("link_3", "hinge", (0, -1, 0), (0, 2.35619), 0.032, (200, 10, 27), 3.375, 27),
    "joint_3": ("link_4", "hinge", (0, -1, 0), (-1.5708, 1.5708), 0.0018, (100, 5, 7), 7.0, 7),
    "joint_4": ("link_5", "hinge", (0, 0, -1), (-1.5708, 1.5708), 0.0018, (50, 5, 7), 7.0, 7),
    "joint_5": ("link_6", "hinge", (1, 0, 0), (-PI, PI), 0.0018, (50, 5, 7), 7.0, 7),
    "right_carriage_joint": (
        "carriage_right",
        "slide",
        (0, -1, 0),
        (0, 0.044),
        0.1,
        None,
        0.0875,
        400,
    ),
    "left_carriage_joint": (
        "carriage_left",
        "slide",
        (0, 1, 0),
        (0, 0.044),
        0.1,
        (1000, 50, 400),
        0.0875,
        400,
    ),
}
ARM_JOINTS = [f"joint_{i}" for i in range(6)]

# URDF visuals: boxes at the vendor meshes' bounding boxes (body frame): (body, center,
# half-size). The MJCF draws the arm with the shapes of model_looks.ARM_PARTS.
VISUAL_BOXES = [
    ("base_link", (0.002359, 0, 0.030125), (0.034859, 0.0325, 0.030125)),
    ("link_1", (0.0042012, 0.0035, 0.031875), (0.033186, 0.044825, 0.031875)),
    ("link_2", (-0.132, 0, 0.0034211), (0.1605, 0.036325, 0.031921)),
    ("link_3", (0.128, 0, 0.0355), (0.1455, 0.041325, 0.053)),
    ("link_4", (0.039377, 0.003, 0.042005), (0.056873, 0.0407, 0.059495)),
    ("link_5", (-0.0056529, 0, -0.046089), (0.034603, 0.0285, 0.046089)),
    ("link_6", (0.04125, 0, 0), (0.04125, 0.0933, 0.0308)),
    ("link_6", (0.043082, 0.006775, 0.051848), (0.030082, 0.035775, 0.033348)),
    ("carriage_right", (-0.00925, 0.0314, 0.00465), (0.00925, 0.04585, 0.01965)),
    ("carriage_left", (-0.00925, -0.0314, -0.00465), (0.00925, 0.04585, 0.01965)),
]

Q_Y = (0.707107, 0.707107, 0, 0)  # capsule/cylinder axis along body y
Q_X = (0.707107, 0, 0.707107, 0)  # along body x
# Collision primitives: (body, type, size, pos, quat)
COLLISION = [
    ("base_link", "cylinder", (0.031, 0.0325), (0, 0, 0.0325), None),
    ("link_2", "capsule", (0.031, 0.015), (0, 0, 0), Q_Y),
    ("link_2", "box", (0.0975, 0.02, 0.02), (-0.131, 0, 0), None),
    ("link_3", "capsule", (0.031, 0.015), (0, 0, 0), Q_Y),
    ("link_3", "box", (0.08, 0.02, 0.02), (0.13, 0, 0.06), None),
    ("link_4", "capsule", (0.031, 0.015), (0, 0, 0), Q_Y),
    ("link_5", "cylinder", (0.031, 0.028), (0, 0, 0.03), None),
    ("link_6", "cylinder", (0.029, 0.05), (0, 0, 0), Q_X),
    ("link_6", "box", (0.0125, 0.094, 0.031), (0.0685, 0, 0), None),
    (
        "link_6",
        "box",
        (0.0155, 0.025, 0.025),
        (0.0513206, 0, 0.0569399),
        (0.984808, 0, 0.173648, 0),
    ),
]
# Finger collision geometry of the real gripper (facts C2): per finger two pads and a tip,
# as box-shaped convex meshes (carriage frame: half-size, pos, quat). Meshes sort after boxes
# in MuJoCo's contact ordering, so a contact with the box-shaped cube lists "red_box" first.
# The tip's flat inner face holds a grasped cube and carries the finger's documented name;
# the pads' names extend it.
PAD_HALF = (0.0275, 0.005, 0.01)
TIP_HALF = (0.00732, 0.00214, 0.00767)
FINGER_NAME = {"carriage_left": "gripper_follower_left", "carriage_right": "gripper_follower_right"}
FINGER_GEOMS = {  # body: [(name suffix, mesh, half-size, pos, quat)]
    "carriage_right": [
        ("", "wxai_finger_tip", TIP_HALF, (0.0622, 0.02083, -0.00105), (1, 0, 0, 0)),
        (
            "_pad_upper",
            "wxai_finger_pad",
            PAD_HALF,
            (0.0286, 0.01436, 0.0037),
            (0.99257, -0.00451, 0.10246, 0.06547),
        ),
        (
            "_pad_lower",
            "wxai_finger_pad",
            PAD_HALF,
            (0.0285, 0.01429, -0.00973),
            (0.98344, 0.0133, -0.16893, 0.06427),
        ),
    ],
    "carriage_left": [
        ("", "wxai_finger_tip", TIP_HALF, (0.0622, -0.02083, -0.00105), (1, 0, 0, 0)),
        (
            "_pad_upper",
            "wxai_finger_pad",
            PAD_HALF,
            (0.0286, -0.01436, 0.0037),
            (0.99257, 0.00451, 0.10246, -0.06547),
        ),
        (
            "_pad_lower",
            "wxai_finger_pad",
            PAD_HALF,
            (0.0285, -0.01429, -0.00973),
            (0.98344, -0.0133, -0.16893, -0.06427),
        ),
    ],
}
#: Box-shaped convex meshes: name -> half-size (m).
BOX_MESHES = {"wxai_finger_pad": PAD_HALF, "wxai_finger_tip": TIP_HALF}

EE_SITE = (0.156, 0, 0)
WRIST_CAM_POS = (0.05864, 0.009, 0.05427)
WRIST_CAM_QUAT = (0.579242, 0.40556, -0.40556, -0.579242)
WRIST_FOVY = 87


def fmt(v) -> str:
    return " ".join(f"{float(x):.9g}" for x in v)


def quat_to_mat(q) -> np.ndarray:
    w, x, y, z = np.asarray(q, float) / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def quat_to_rpy(q) -> tuple[float, float, float]:
    r = quat_to_mat(q)
    pitch = np.arcsin(-np.clip(r[2, 0], -1, 1))
    roll = np.arctan2(r[2, 1], r[2, 2])
    yaw = np.arctan2(r[1, 0], r[0, 0])
    return float(roll), float(pitch), float(yaw)


# ----------------------------------------------------------------------------- MJCF pieces
#: Contact between the table and the arms' collision geoms (issue 27): as stiff as MuJoCo
#: keeps stable (time constant 2 timesteps of 2 ms; default 0.02 s), so fingers pressed on
#: the table (arm driven into it, gripper closing over it) sink < 0.5 mm, not ~3 mm: a
#: wooden top and the aluminium fingers barely give. The actuators' forces are unchanged.
#: ``solmix="0"`` on both sides: two such geoms (table-arm, and arm-arm: the two arms'
#: fingers at a hand-over) use these parameters; against any other geom (the cube, peg,
#: socket, the frame: default solmix 1), the other geom's parameters, exactly, so the
#: contacts of the objects with the fingers and the table are what they were.
RIGID_CONTACT = 'solref="0.004 1" solmix="0"'


def mjcf_defaults() -> str:
    return f"""  <default>
    <default class="wxai">
      <joint frictionloss="0.1" actuatorgravcomp="true"/>
      <position inheritrange="1"/>
      <default class="wxai_visual">
        <geom type="box" group="2" contype="0" conaffinity="0" density="0" material="wxai_black"/>
      </default>
      <default class="wxai_collision">
        <geom group="3" density="0" rgba="0.5 0.5 0.5 0.3" {RIGID_CONTACT}/>
        <default class="wxai_pad">
          <geom type="mesh" condim="4" friction="1.5 0.02 0.0001" rgba="0.3 0.3 0.3 0.3"/>
        </default>
      </default>
    </default>
  </default>
"""


def box_mesh_vertices(half) -> str:
    """The 8 corners of a box of half-size ``half`` centred at the origin, as MJCF text."""
    hx, hy, hz = half
    corners = [(sx * hx, sy * hy, sz * hz) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    return "  ".join(fmt(c) for c in corners)


def mjcf_box_mesh(name: str, half) -> str:
    return f'    <mesh name="{name}" vertex="{box_mesh_vertices(half)}"/>\n'


def mjcf_arm_assets() -> str:
    """Arm materials, the finger pads' collision meshes and the visual meshes."""
    materials = "".join(f"    {m}\n" for m in looks.MATERIALS)
    meshes = "".join(mjcf_box_mesh(n, h) for n, h in BOX_MESHES.items())
    visual = "".join(
        f'    <mesh name="{n}"\n          vertex="{looks.mesh_vertex_text(v)}"/>\n'
        for n, v in looks.arm_meshes().items()
    )
    return materials + meshes + visual


def mjcf_visual_parts(name: str) -> list[str]:
    """Visual geoms of body ``name``: its parts in model_looks and the finger pads."""
    out = []
    for body, kind, what, pos, quat, material in looks.ARM_PARTS:
        if body != name:
            continue
        shape = f'mesh="{what}"' if kind == "mesh" else f'size="{fmt(what)}"'
        where = (f' pos="{fmt(pos)}"' if pos else "") + (f' quat="{fmt(quat)}"' if quat else "")
        out.append(
            f'<geom class="wxai_visual" type="{kind}" {shape}{where} material="{material}"/>'
        )
    for _suffix, _mesh, half, gpos, gquat in FINGER_GEOMS.get(name, []):
        out.append(
            f'<geom class="wxai_visual" size="{fmt(half)}" pos="{fmt(gpos)}" '
            f'quat="{fmt(gquat)}" material="wxai_rubber"/>'
        )
    return out


def mjcf_arm(prefix: str, pos, quat, camera_name: str, indent: int) -> str:
    """The arm body tree as MJCF text; element names get ``prefix``."""
    lines: list[str] = []
    sp = " " * indent

    def emit(depth: int, text: str) -> None:
        lines.append(sp + "  " * depth + text)

    def body(name: str, depth: int) -> None:
        parent, bpos, (mass, com, iquat, diag) = BODIES[name]
        if parent is None:
            attrs = f'pos="{fmt(pos)}" quat="{fmt(quat)}"'
        else:
            attrs = f'pos="{fmt(bpos)}"'
        cls = ' childclass="wxai"' if parent is None else ""
        emit(depth, f'<body name="{prefix}{name}" {attrs}{cls} gravcomp="1">')
        emit(
            depth + 1,
            f'<inertial pos="{fmt(com)}" quat="{fmt(iquat)}" mass="{mass:.9g}" '
            f'diaginertia="{fmt(diag)}"/>',
        )
        for jname, (child, jtype, axis, rng, arm, _act, _vel, _eff) in JOINTS.items():
            if child == name:
                emit(
                    depth + 1,
                    f'<joint name="{prefix}{jname}" type="{jtype}" axis="{fmt(axis)}" '
                    f'range="{fmt(rng)}" armature="{arm}"/>',
                )
        for geom in mjcf_visual_parts(name):
            emit(depth + 1, geom)
        for k, (b, gtype, size, gpos, gquat) in enumerate(COLLISION):
            if b == name:
                q = f' quat="{fmt(gquat)}"' if gquat else ""
                emit(
                    depth + 1,
                    f'<geom name="{prefix}{name}_collision_{k}" class="wxai_collision" '
                    f'type="{gtype}" size="{fmt(size)}" pos="{fmt(gpos)}"{q}/>',
                )
        for suffix, mesh, _half, gpos, gquat in FINGER_GEOMS.get(name, []):
            emit(
                depth + 1,
                f'<geom name="{prefix}{FINGER_NAME[name]}{suffix}" class="wxai_pad" '
                f'mesh="{mesh}" pos="{fmt(gpos)}" quat="{fmt(gquat)}"/>',
            )
        if name == "link_6":
            emit(
                depth + 1,
                f'<site name="{prefix}ee_site" pos="{fmt(EE_SITE)}" size="0.004" '
                f'rgba="1 0.3 0.1 0.6" group="4"/>',
            )
            emit(
                depth + 1,
                f'<camera name="{camera_name}" pos="{fmt(WRIST_CAM_POS)}" '
                f'quat="{fmt(WRIST_CAM_QUAT)}" fovy="{WRIST_FOVY}"/>',
            )
        for child_name, (parent, _p, _i) in BODIES.items():
            if parent == name:
                body(child_name, depth + 1)
        emit(depth, "</body>")

    body("base_link", 0)
    return "\n".join(lines) + "\n"


def mjcf_gripper_equality(prefix: str) -> str:
    return (
        f'    <joint name="{prefix}gripper_coupling" joint1="{prefix}right_carriage_joint" '
        f'joint2="{prefix}left_carriage_joint" polycoef="0 1 0 0 0"/>\n'
    )


def mjcf_actuators(prefix: str, arm: bool = True, gripper: bool = True) -> str:
    out = []
    for jname, (_c, _t, _a, _rng, _arm, act, _v, _e) in JOINTS.items():
        if act is None:
            continue
        is_gripper = jname == "left_carriage_joint"
        if (is_gripper and not gripper) or (not is_gripper and not arm):
            continue
        kp, kv, force = act
        aname = f"{prefix}gripper" if is_gripper else f"{prefix}{jname}"
        out.append(
            f'    <position name="{aname}" class="wxai" joint="{prefix}{jname}" kp="{kp}" '
            f'kv="{kv}" forcerange="{-force} {force}"/>'
        )
    return "\n".join(out) + "\n"


OPTIONS = """  <compiler angle="radian" autolimits="true"/>
  <option timestep="0.002" integrator="implicitfast" cone="elliptic" impratio="10" ls_iterations="50"/>
"""


def wxai_follower_xml() -> str:
    home = fmt(START_Q + (GRIPPER_OPEN, GRIPPER_OPEN))
    return f"""<!-- WidowX AI (wxai) follower arm with gripper and wrist camera.
     Generated by tools/build_models.py from the robot facts; do not edit by hand.
     Frames: base_link at the world origin; ee_site is the tool frame 0.156 m ahead of link_6.
     No lights: the scenes that include it light it (table_scene.xml). -->
<mujoco model="wxai_follower">
{OPTIONS}
{mjcf_defaults()}
  <asset>
{mjcf_arm_assets()}  </asset>

  <worldbody>
{mjcf_arm("", (0, 0, 0), (1, 0, 0, 0), "cam", 4)}  </worldbody>

  <equality>
{mjcf_gripper_equality("")}  </equality>

  <actuator>
{mjcf_actuators("")}  </actuator>

  <keyframe>
    <key name="home" qpos="{home}" ctrl="{fmt(START_Q + (GRIPPER_OPEN,))}"/>
  </keyframe>
</mujoco>
"""


# ----------------------------------------------------------------------------- single-arm table
#: The single-arm scenes' fixed camera "overview": (pos, xyaxes, fovy).
OVERVIEW_CAMERA = ((1.05, -0.6, 0.65), (0.6146, 0.7888, 0, -0.413, 0.3219, 0.8519), 50)


def camera_forward(xyaxes) -> tuple[float, float]:
    """Horizontal viewing direction (x, y) of a camera given by its xyaxes."""
    view = -np.cross(xyaxes[:3], xyaxes[3:])
    return float(view[0]), float(view[1])


def wxai_table_scene_xml() -> str:
    pos, xyaxes, fovy = OVERVIEW_CAMERA
    legs = "\n".join(
        f'      <geom name="table_leg_{k}" type="cylinder" size="0.025 0.355" '
        f'pos="{x:g} {y:g} -0.395"\n            material="table_leg" contype="0" conaffinity="0"/>'
        for k, (x, y) in enumerate(((0.4, 0.55), (0.4, -0.55), (-0.4, 0.55), (-0.4, -0.55)))
    )
    return f"""<!-- Shared surroundings of the single-arm wxai tasks (included by scene_*.xml).
     Generated by tools/build_models.py; do not edit by hand.
     World frame: the arm's base_link at the origin, on a table whose top is at z = 0;
     x forward (away from the base), z up. The floor is 0.75 m below the table top.
     Provides: offscreen buffer 640x480, lights (one shadow-casting key light, two fills
     without shadows), floor, table (geom "table") and a fixed overview camera ("overview"). -->
<mujoco model="wxai_table_scene">
  <visual>
    <global offwidth="640" offheight="480" azimuth="150" elevation="-25"/>
    {looks.QUALITY}
    {looks.HEADLIGHT}
    <map znear="0.01"/>
  </visual>

  <asset>
    <texture name="sky" type="skybox" builtin="gradient" rgb1="0.55 0.62 0.70"
             rgb2="0.12 0.13 0.15" width="32" height="512"/>
    <texture name="maple" type="2d" builtin="flat" rgb1="0.80 0.64 0.45"
             rgb2="0.72 0.55 0.38" mark="random" random="0.015" markrgb="0.74 0.58 0.40"
             width="256" height="256"/>
    <material name="maple" texture="maple" texrepeat="2 2" specular="0.15" shininess="0.2"/>
    <texture name="groundplane" type="2d" builtin="checker" rgb1="0.30 0.32 0.35"
             rgb2="0.25 0.27 0.30" width="300" height="300"/>
    <material name="groundplane" texture="groundplane" texuniform="true" texrepeat="4 4"/>
    <material name="table_leg" rgba="0.72 0.73 0.75 1" specular="0.5" shininess="0.6"/>
  </asset>

  <worldbody>
{looks.mjcf_lights(camera_forward(xyaxes))}    <geom name="floor" type="plane" size="0 0 0.05" pos="0 0 -0.75" material="groundplane"/>
    <body name="table_body" pos="0.25 0 0">
      <geom name="table" type="box" size="0.45 0.6 0.02" pos="0 0 -0.02" material="maple"
            friction="1 0.005 0.0001" {RIGID_CONTACT}/>
{legs}
    </body>
    <camera name="overview" pos="{fmt(pos)}" xyaxes="{fmt(xyaxes)}"
            fovy="{fovy}"/>
  </worldbody>
</mujoco>
"""


# ----------------------------------------------------------------------------- Stationary AI kit
ARM_MOUNTS = {
    "left": ((-0.019982, 0.4575, 0.039086), (0.707107, 0, 0, -0.707107)),
    "right": ((-0.019982, -0.4575, 0.039086), (0.707107, 0, 0, 0.707107)),
}
FRAME_BOXES = [  # (half-size, pos, quat) of the aluminium frame, tabletop frame
    ((0.3685, 0.0375, 0.01), (0, 0.457, 0.03), None),
    ((0.3685, 0.0375, 0.01), (0, -0.457, 0.03), None),
    ((0.01, 0.425, 0.01), (0.35, 0, 0.03), None),
    ((0.01, 0.5, 0.01), (-0.39, 0, 0.01), None),
    ((0.02, 0.445, 0.01), (-0.38, 0, 1.05), None),
    ((0.02, 0.01, 0.52), (-0.38, 0.42774, 0.54), None),
    ((0.02, 0.01, 0.52), (-0.38, -0.42774, 0.54), None),
    ((0.01, 0.01, 0.16), (-0.261, 0.43, 0.1425), (0.92388, 0, -0.382683, 0)),
    ((0.01, 0.01, 0.16), (-0.261, -0.43, 0.1425), (0.92388, 0, -0.382683, 0)),
]
CAMERA_BODIES = [  # D405 housings of the fixed cameras
    ((0.0115, 0.025, 0.025), (-0.328972, 0, 1.05484), (0.843391, 0, 0.5373, 0)),
    ((0.0115, 0.025, 0.025), (-0.388301, 0, 0.0513276), (0.998848, 0, -0.0479781, 0)),
]
#: Horizontal viewing direction of cam_high (world x, y): the kit's lights are set from it.
KIT_VIEW = (1.0, 0.0)
FIXED_CAMERAS = [
    ("cam_high", (-0.324675, 0.009, 1.04777), (-0.690358, -0.152991, 0.152991, 0.690358), 65),
    ("cam_low", (-0.378474, 0.009, 0.051132), (-0.475422, -0.523425, 0.523425, 0.475422), 125),
]


#: The table top (half-size, m): a 2 cm slab whose top is at z = 0.02. Its collision geom
#: "table" is a box-shaped convex mesh (contacts with the cube list "red_box" first); a
#: plain box of the same size draws it.
TABLE_HALF = (0.38, 0.61, 0.01)


def trossen_ai_xml() -> str:
    frame = []
    for k, (half, pos, quat) in enumerate(FRAME_BOXES + CAMERA_BODIES):
        q = f' quat="{fmt(quat)}"' if quat else ""
        # The camera housings enclose the fixed cameras: collision only (group 3, not drawn).
        look = 'material="frame"' if k < len(FRAME_BOXES) else 'material="wxai_black" group="3"'
        frame.append(
            f'      <geom name="frame_{k}" type="box" size="{fmt(half)}" pos="{fmt(pos)}"{q} '
            f"{look}/>"
        )
    cams = [
        f'      <camera name="{n}" pos="{fmt(p)}" quat="{fmt(q)}" fovy="{f}"/>'
        for n, p, q, f in FIXED_CAMERAS
    ]
    arms = "".join(
        mjcf_arm(f"{side}/", pos, quat, f"cam_{side}_wrist", 6)
        for side, (pos, quat) in ARM_MOUNTS.items()
    )
    return f"""<!-- Trossen AI Stationary kit: two wxai follower arms on a table with four cameras.
     Generated by tools/build_models.py; do not edit by hand.
     World frame = tabletop frame: origin at the table centre on the floor, x away from the
     cameras (cam_high/cam_low sit at x = -0.38), z up; the table top is at z = 0.02.
     Arm elements carry the prefixes left/ and right/. Actuation is added by the scenes:
     trossen_ai_scene.xml (mocap-driven arms) and trossen_ai_scene_joint.xml (joint actuators). -->
<mujoco model="trossen_ai">
{OPTIONS}  <visual>
    <global offwidth="640" offheight="480" azimuth="90" elevation="-20"/>
    {looks.QUALITY}
    {looks.HEADLIGHT}
    <map znear="0.01"/>
  </visual>
{mjcf_defaults()}
  <asset>
{mjcf_arm_assets()}{mjcf_box_mesh("table_top", TABLE_HALF)}    <material name="frame" rgba="0.72 0.73 0.75 1" specular="0.5" shininess="0.6"/>
    <texture name="sky" type="skybox" builtin="gradient" rgb1="0.55 0.62 0.70" rgb2="0.12 0.13 0.15"
             width="32" height="512"/>
    <texture name="maple" type="2d" builtin="flat" rgb1="0.80 0.64 0.45" rgb2="0.72 0.55 0.38"
             mark="random" random="0.015" markrgb="0.74 0.58 0.40" width="256" height="256"/>
    <material name="maple" texture="maple" texrepeat="2 2" specular="0.15" shininess="0.2"/>
    <texture name="groundplane" type="2d" builtin="checker" rgb1="0.30 0.32 0.35"
             rgb2="0.25 0.27 0.30" width="300" height="300"/>
    <material name="groundplane" texture="groundplane" texuniform="true" texrepeat="4 4"/>
  </asset>

  <worldbody>
{looks.mjcf_lights(KIT_VIEW)}    <geom name="ground" type="plane" size="0 0 0.05" material="groundplane"/>
    <body name="tabletop_link">
      <inertial pos="-0.0053748816 -0.00042686842 0.014104691" mass="15.2"
                quat="0.135549 0.672695 0.710793 0.154534"
                diaginertia="0.301156 0.287827 0.165329"/>
      <geom name="table_visual" type="box" size="{fmt(TABLE_HALF)}" pos="0 0 0.01" material="maple"
            contype="0" conaffinity="0"/>
      <geom name="table" type="mesh" mesh="table_top" pos="0 0 0.01" group="3" rgba="0.8 0.6 0.4 0.3"
            {RIGID_CONTACT}/>
{chr(10).join(frame)}
{chr(10).join(cams)}
{arms}    </body>
  </worldbody>

  <equality>
{mjcf_gripper_equality("left/")}{mjcf_gripper_equality("right/")}  </equality>
</mujoco>
"""


CUBE_HALF = 0.0125
TABLE_TOP = 0.02


def cube_xml() -> str:
    z = TABLE_TOP + CUBE_HALF
    return f"""    <body name="box" pos="0 0 {z:.6g}">
      <joint name="red_box_joint" type="free" frictionloss="0.0005"/>
      <geom name="red_box" type="box" size="{CUBE_HALF} {CUBE_HALF} {CUBE_HALF}" mass="0.03"
            condim="4" friction="1.5 0.02 0.0001" rgba="0.85 0.08 0.08 1"/>
    </body>
"""


def start_ee_pose(side: str) -> tuple[np.ndarray, np.ndarray]:
    """World pose of ``<side>/ee_site`` at START_ARM_POSE, from the kinematic facts."""
    mount_pos, mount_quat = ARM_MOUNTS[side]
    t = np.eye(4)
    t[:3, :3] = quat_to_mat(mount_quat)
    t[:3, 3] = mount_pos
    chain = ["link_1", "link_2", "link_3", "link_4", "link_5", "link_6"]
    for i, name in enumerate(chain):
        step = np.eye(4)
        step[:3, 3] = BODIES[name][1]
        t = t @ step
        axis = np.asarray(JOINTS[f"joint_{i}"][2], float)
        angle = START_Q[i]
        k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        rot = np.eye(4)
        rot[:3, :3] = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k
        t = t @ rot
    ee = np.eye(4)
    ee[:3, 3] = EE_SITE
    t = t @ ee
    r = t[:3, :3]
    w = np.sqrt(max(0.0, 1 + np.trace(r))) / 2
    quat = np.array(
        [
            w,
            (r[2, 1] - r[1, 2]) / (4 * w),
            (r[0, 2] - r[2, 0]) / (4 * w),
            (r[1, 0] - r[0, 1]) / (4 * w),
        ]
    )
    return t[:3, 3], quat


def home_key(objects_qpos: tuple, mocap: bool) -> str:
    """Keyframe ``home``: arms at START_ARM_POSE, then the free objects' qpos; controls (and
    the mocap bodies, in the mocap flavour) hold that pose."""
    arm = START_Q + (GRIPPER_OPEN, GRIPPER_OPEN)
    key = f'    <key name="home" qpos="{fmt(arm + arm + tuple(objects_qpos))}"'
    if mocap:
        (lp, lq), (rp, rq) = start_ee_pose("left"), start_ee_pose("right")
        key += (
            f'\n         mpos="{fmt(lp)} {fmt(rp)}"\n         mquat="{fmt(lq)} {fmt(rq)}"'
            f'\n         ctrl="{GRIPPER_OPEN} {GRIPPER_OPEN}"'
        )
    else:
        ctrl = START_Q + (GRIPPER_OPEN,)
        key += f'\n         ctrl="{fmt(ctrl + ctrl)}"'
    return key + "/>\n"


def scene_common_key(mocap: bool) -> str:
    """Keyframe of the cube scenes: the cube resting at the table centre."""
    return home_key((0, 0, TABLE_TOP + CUBE_HALF, 1, 0, 0, 0), mocap)


def mocap_bodies_and_welds() -> tuple[str, str]:
    """The two mocap bodies (at the ee_site poses of START_ARM_POSE) and their welds."""
    mocap = []
    welds = []
    for side in ("left", "right"):
        pos, quat = start_ee_pose(side)
        mocap.append(f"""    <body name="mocap_{side}" mocap="true" pos="{fmt(pos)}" quat="{fmt(quat)}">
      <site name="mocap_{side}_x" type="box" size="0.015 0.0008 0.0008" pos="0.015 0 0"
            rgba="1 0 0 0.6" group="4"/>
      <site name="mocap_{side}_y" type="box" size="0.0008 0.015 0.0008" pos="0 0.015 0"
            rgba="0 1 0 0.6" group="4"/>
      <site name="mocap_{side}_z" type="box" size="0.0008 0.0008 0.015" pos="0 0 0.015"
            rgba="0 0 1 0.6" group="4"/>
    </body>
""")
        # relpose: pose of link_6 in the mocap frame; the mocap frame is the ee_site frame.
        welds.append(
            f'    <weld name="mocap_{side}_weld" body1="mocap_{side}" body2="{side}/link_6" '
            f'relpose="{fmt((-EE_SITE[0], 0, 0))} 1 0 0 0" '
            f'solref="0.01 1"/>\n'
        )
    return "".join(mocap), "".join(welds)


def kit_scene_xml(model: str, comment: str, objects: str, key: str, mocap: bool) -> str:
    """A Stationary AI scene: ``trossen_ai.xml`` plus free ``objects`` and either mocap bodies
    welded to each link_6 with the 2 gripper actuators (``mocap``) or the 14 joint actuators."""
    if mocap:
        bodies, welds = mocap_bodies_and_welds()
        equality = f"\n  <equality>\n{welds}  </equality>\n"
        actuators = mjcf_actuators("left/", arm=False) + mjcf_actuators("right/", arm=False)
    else:
        bodies, equality = "", ""
        actuators = mjcf_actuators("left/") + mjcf_actuators("right/")
    return f"""<!-- {comment} -->
<mujoco model="{model}">
  <include file="trossen_ai.xml"/>

  <worldbody>
{bodies}{objects}  </worldbody>
{equality}
  <actuator>
{actuators}  </actuator>

  <keyframe>
{key}  </keyframe>
</mujoco>
"""


def trossen_ai_scene_xml() -> str:
    return kit_scene_xml(
        "trossen_ai_scene",
        "Stationary AI, end-effector flavour: each arm's link_6 is welded to a mocap body.\n     Generated by tools/build_models.py; do not edit by hand.\n     The mocap frame is the arm's ee_site frame (0.156 m ahead of link_6, same orientation), and\n     the initial mocap poses are the ee_site poses at START_ARM_POSE, so nothing jumps at reset.\n     The grippers are driven by their position actuators (ctrl 0..0.044 m).",
        cube_xml(),
        scene_common_key(mocap=True),
        mocap=True,
    )


def trossen_ai_scene_joint_xml() -> str:
    return kit_scene_xml(
        "trossen_ai_scene_joint",
        "Stationary AI, joint flavour: 14 position actuators (6 joints + gripper per arm),\n     as on the real arms. Generated by tools/build_models.py; do not edit by hand.",
        cube_xml(),
        scene_common_key(mocap=False),
        mocap=False,
    )


# ----------------------------------------------------------------------------- insertion
# Bimanual peg insertion: the right arm picks up the peg, the left arm the socket, and the
# peg goes into the socket above the table. Both lie on the table with their long axis
# along world y; the socket's open end faces -y (toward the right arm). World frame, m.
#: Peg: a 20 x 20 mm square bar, 120 mm long (half-sizes x, y, z); wood, 24 g.
PEG_HALF = (0.01, 0.06, 0.01)
PEG_DENSITY = 500.0
#: Socket: a square tube closed at +y (its bottom). Inner section 26 x 26 mm, so the peg has
#: 3 mm of clearance on every side; walls 3 mm (outer 32 x 32 mm), 60 mm long; PLA, 29 g
#: with the pin.
SOCKET_INNER_HALF = 0.013
SOCKET_WALL = 0.003
SOCKET_HALF_LENGTH = 0.03
SOCKET_DENSITY = 1240.0
#: Pin on the inside of the socket's bottom (half-sizes): 10 x 8 x 10 mm; the inserted peg's
#: tip touches it 49 mm inside the socket's mouth.
PIN_HALF = (0.005, 0.004, 0.005)
#: Contact of the objects: condim 4 (torsional friction for a stable grasp); sliding
#: friction 0.5, so the peg slides along the socket's walls (finger pads have 1.5 and the
#: larger coefficient of a pair wins, so grasps keep the pads' friction).
OBJECT_CONTACT = 'condim="4" friction="0.5 0.02 0.0001"'
#: Spawn poses of the home keyframe: peg on the right half of the table, socket on the left.
PEG_HOME = (0.05, -0.15, TABLE_TOP + PEG_HALF[2], 1, 0, 0, 0)
SOCKET_OUTER_HALF = SOCKET_INNER_HALF + SOCKET_WALL
SOCKET_HOME = (0.05, 0.15, TABLE_TOP + SOCKET_OUTER_HALF, 1, 0, 0, 0)


def peg_xml() -> str:
    x, y, z = PEG_HOME[:3]
    return f"""    <body name="peg" pos="{fmt((x, y, z))}">
      <joint name="peg_joint" type="free" frictionloss="0.0005"/>
      <geom name="peg" type="box" size="{fmt(PEG_HALF)}" density="{PEG_DENSITY:g}"
            {OBJECT_CONTACT} rgba="0.85 0.08 0.08 1"/>
    </body>
"""


def socket_geoms() -> list[tuple[str, tuple, tuple]]:
    """(name, half-size, pos) of the socket's boxes in the socket frame (centre of the tube,
    axis along y, open at -y)."""
    r, t, h = SOCKET_INNER_HALF, SOCKET_WALL, SOCKET_HALF_LENGTH
    o = r + t
    bottom_y = h - t / 2
    return [
        ("socket-1", (o, h, t / 2), (0, 0, -(r + t / 2))),  # lower wall (rests on the table)
        ("socket-2", (o, h, t / 2), (0, 0, r + t / 2)),  # upper wall
        ("socket-3", (t / 2, h, r), (r + t / 2, 0, 0)),  # +x side wall
        ("socket-4", (t / 2, h, r), (-(r + t / 2), 0, 0)),  # -x side wall
        ("socket-bottom", (r, t / 2, r), (0, bottom_y, 0)),  # closes the +y end
        ("pin", PIN_HALF, (0, bottom_y - t / 2 - PIN_HALF[1], 0)),
    ]


def socket_xml() -> str:
    x, y, z = SOCKET_HOME[:3]
    geoms = []
    for name, half, pos in socket_geoms():
        rgba = "0.9 0.9 0.9 1" if name == "pin" else "0.1 0.25 0.85 1"
        geoms.append(
            f'      <geom name="{name}" type="box" size="{fmt(half)}" pos="{fmt(pos)}"\n'
            f'            density="{SOCKET_DENSITY:g}" {OBJECT_CONTACT} rgba="{rgba}"/>\n'
        )
    return f"""    <body name="socket" pos="{fmt((x, y, z))}">
      <joint name="socket_joint" type="free" frictionloss="0.0005"/>
{"".join(geoms)}    </body>
"""


def insertion_key(mocap: bool) -> str:
    """Keyframe ``home``: arms at START_ARM_POSE, peg and socket resting on the table."""
    return home_key(PEG_HOME + SOCKET_HOME, mocap)


INSERTION_NOTE = """     Objects (qpos 16..22 peg, 23..29 socket): a red peg (geom "peg", 20 x 20 x 120 mm, 24 g)
     and a blue socket (square tube closed at +y: walls "socket-1".."socket-4", bottom
     "socket-bottom", and a "pin" inside at the bottom that the inserted peg's tip touches;
     inner section 26 x 26 mm, i.e. 3 mm of clearance around the peg; 60 mm long, 29 g).
     Both lie along world y; the socket opens toward the right arm (-y)."""


def trossen_ai_insertion_scene_xml() -> str:
    return kit_scene_xml(
        "trossen_ai_insertion_scene",
        "Stationary AI peg insertion, end-effector flavour: each arm's link_6 is welded to a\n     mocap body whose frame is the arm's ee_site frame (as in trossen_ai_scene.xml).\n     Generated by tools/build_models.py; do not edit by hand."
        + "\n"
        + INSERTION_NOTE,
        peg_xml() + socket_xml(),
        insertion_key(mocap=True),
        mocap=True,
    )


def trossen_ai_insertion_scene_joint_xml() -> str:
    return kit_scene_xml(
        "trossen_ai_insertion_scene_joint",
        "Stationary AI peg insertion, joint flavour: 14 position actuators (6 joints + gripper\n     per arm), as on the real arms. Generated by tools/build_models.py; do not edit by hand."
        + "\n"
        + INSERTION_NOTE,
        peg_xml() + socket_xml(),
        insertion_key(mocap=False),
        mocap=False,
    )


# ----------------------------------------------------------------------------- URDF
def urdf_inertia(iquat, diag) -> str:
    r = quat_to_mat(iquat)
    full = r @ np.diag(diag) @ r.T
    return (
        f'ixx="{full[0, 0]:.9g}" ixy="{full[0, 1]:.9g}" ixz="{full[0, 2]:.9g}" '
        f'iyy="{full[1, 1]:.9g}" iyz="{full[1, 2]:.9g}" izz="{full[2, 2]:.9g}"'
    )


def urdf_geometry(gtype: str, size) -> str:
    if gtype == "box":
        return f'<box size="{fmt(2 * np.asarray(size))}"/>'
    # URDF has no capsule in the core spec: a cylinder of the full length is used.
    length = 2 * size[1] + (2 * size[0] if gtype == "capsule" else 0)
    return f'<cylinder radius="{size[0]:.9g}" length="{length:.9g}"/>'


def wxai_follower_urdf() -> str:
    out = [
        '<?xml version="1.0"?>',
        "<!-- WidowX AI (wxai) follower arm. Generated by tools/build_models.py from the same",
        "     facts as wxai_follower.xml; joints, axes and limits are identical. -->",
        '<robot name="wxai_follower">',
        '  <material name="wxai_black"><color rgba="0.12 0.12 0.13 1"/></material>',
    ]
    for name, (_parent, _pos, (mass, com, iquat, diag)) in BODIES.items():
        out.append(f'  <link name="{name}">')
        out.append(
            f'    <inertial><origin xyz="{fmt(com)}" rpy="0 0 0"/><mass value="{mass:.9g}"/>'
            f"<inertia {urdf_inertia(iquat, diag)}/></inertial>"
        )
        for b, center, half in VISUAL_BOXES:
            if b == name:
                out.append(
                    f'    <visual><origin xyz="{fmt(center)}"/><geometry>'
                    f'<box size="{fmt(2 * np.asarray(half))}"/></geometry>'
                    f'<material name="wxai_black"/></visual>'
                )
        for b, gtype, size, gpos, gquat in COLLISION:
            if b == name:
                rpy = fmt(quat_to_rpy(gquat)) if gquat else "0 0 0"
                out.append(
                    f'    <collision><origin xyz="{fmt(gpos)}" rpy="{rpy}"/><geometry>'
                    f"{urdf_geometry(gtype, size)}</geometry></collision>"
                )
        for suffix, _mesh, half, gpos, gquat in FINGER_GEOMS.get(name, []):
            out.append(
                f'    <collision name="{FINGER_NAME[name]}{suffix}"><origin xyz="{fmt(gpos)}" '
                f'rpy="{fmt(quat_to_rpy(gquat))}"/><geometry>'
                f'<box size="{fmt(2 * np.asarray(half))}"/></geometry></collision>'
            )
        out.append("  </link>")
    for jname, (child, jtype, axis, rng, _arm, _act, vel, eff) in JOINTS.items():
        parent, pos, _ = BODIES[child]
        utype = "revolute" if jtype == "hinge" else "prismatic"
        out.append(f'  <joint name="{jname}" type="{utype}">')
        out.append(f'    <parent link="{parent}"/><child link="{child}"/>')
        out.append(f'    <origin xyz="{fmt(pos)}" rpy="0 0 0"/><axis xyz="{fmt(axis)}"/>')
        out.append(
            f'    <limit lower="{rng[0]:.9g}" upper="{rng[1]:.9g}" effort="{eff}" '
            f'velocity="{vel}"/>'
        )
        if jname == "right_carriage_joint":
            out.append('    <mimic joint="left_carriage_joint" multiplier="1" offset="0"/>')
        out.append("  </joint>")
    out.append('  <link name="ee_gripper_link"/>')
    out.append(
        '  <joint name="ee_gripper" type="fixed"><parent link="link_6"/>'
        f'<child link="ee_gripper_link"/><origin xyz="{fmt(EE_SITE)}" rpy="0 0 0"/></joint>'
    )
    out.append("</robot>")
    return "\n".join(out) + "\n"


FILES = {
    "wxai/wxai_follower.xml": wxai_follower_xml,
    "wxai/wxai_follower.urdf": wxai_follower_urdf,
    "wxai/table_scene.xml": wxai_table_scene_xml,
    "stationary_ai/trossen_ai.xml": trossen_ai_xml,
    "stationary_ai/trossen_ai_scene.xml": trossen_ai_scene_xml,
    "stationary_ai/trossen_ai_scene_joint.xml": trossen_ai_scene_joint_xml,
    "stationary_ai/trossen_ai_insertion_scene.xml": trossen_ai_insertion_scene_xml,
    "stationary_ai/trossen_ai_insertion_scene_joint.xml": trossen_ai_insertion_scene_joint_xml,
}
# the Mobile AI, from its own facts, with this module's arm facts and MJCF pieces
FILES.update(mobile_ai_model.files(SimpleNamespace(**globals())))


def generate() -> dict[str, str]:
    """Return {relative path under assets/: file text} for every generated model."""
    return {rel: looks.finite_floor(make()) for rel, make in FILES.items()}


def main() -> int:
    for rel, text in generate().items():
        path = ASSETS / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        write_text(path, text)  # atomic: temp file, then rename
        print(f"wrote {path.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
