"""How the generated models look: the scenes' lights and the arm's own visual shapes.

Imported by ``build_models.py``; nothing here changes kinematics, inertia or contacts (every
shape is a visual geom: group 2, contype = conaffinity = 0, density 0).

Lights: every scene has one key light that casts shadows and fill lights that do not. MuJoCo
draws shadow-casting lights in extra passes added on top of the other lighting, so the
budget is split to keep a lit table at about its own colour: ambient + headlight + fills
~0.5 and the key ~0.45 (at the table's normal). A full-strength extra shadow light, as the
single-arm scenes had, saturates the table to near-white and costs one more shadow pass per
frame.

Floors are not reflective: MuJoCo draws a reflection by rendering the scene a second time
(a 0.05 reflectance was barely visible and made every frame about 1.5x as expensive).

Arm shapes: WidowX AI links are black aluminium with rounded ends, sized here from the
bounding boxes of the vendor link meshes (facts sheet C1, body frames). Each rounded part is
the convex hull of a few circles extruded with a small bevel ("capsule-like hull"), written as
an inline vertex mesh: MuJoCo computes the hull, so no mesh files are shipped. Motors are
cylinders. The finger pads are drawn where the finger collision boxes are.
"""

from __future__ import annotations

import numpy as np

#: Points on a full circle of a rounded profile.
SEGMENTS = 12

# ----------------------------------------------------------------------------- lights
#: Headlight of every scene (also the viewer's): a little ambient, a little diffuse.
HEADLIGHT = '<headlight diffuse="0.1 0.1 0.1" ambient="0.22 0.22 0.23" specular="0 0 0"/>'

#: (name, (forward, left, up) direction the light travels, diffuse, specular, castshadow).
#: Directions are relative to the scene's main camera: forward = horizontal viewing
#: direction, left = to its left. The key comes from above, over the camera's right
#: shoulder; two weak fills come from the sides without shadows.
LIGHTS = (
    ("key", (0.35, 0.25, -1.0), 0.45, 0.25, True),
    ("fill_left", (0.2, -0.8, -0.6), 0.14, 0.0, False),
    ("fill_right", (0.2, 0.8, -0.6), 0.14, 0.0, False),
)

#: Shadow map size (pixels) for 640x480 frames (smaller images get a smaller one,
#: ``sim.cameras.shadow_map_size``); docs/benchmarks.md "Rendering cost" measures the sizes.
SHADOW_SIZE = 1024
#: How finely MuJoCo's renderer cuts its built-in shapes: box faces and planes in
#: ``numquads`` x ``numquads`` quads, cylinders and spheres in ``numslices`` x ``numstacks``.
#: MuJoCo's defaults (4, 28, 16) made the boxes and motor cylinders several times the
#: triangles of every mesh; with software rendering each triangle costs CPU in every pass
#: (docs/benchmarks.md, "Rendering cost"). The lights are directional, so the coarser
#: grids light the same.
NUMQUADS, NUMSLICES, NUMSTACKS = 1, 16, 2
#: The ``<quality>`` element of every generated scene.
QUALITY = (
    f'<quality shadowsize="{SHADOW_SIZE}" numquads="{NUMQUADS}" numslices="{NUMSLICES}" '
    f'numstacks="{NUMSTACKS}"/>'
)

#: The floor plane as drawn: half-size and grid spacing (m). MuJoCo collides with a plane as
#: infinite whatever its size, but draws an infinite one as a fine grid that cost more than
#: the arms; a finite one of this size fills every camera's view to the horizon.
FLOOR_HALF_SIZE = 20
FLOOR_GRID = 2
#: The floor plane as the generator writes it first (infinite), replaced by ``finite_floor``.
INFINITE_FLOOR = 'type="plane" size="0 0 0.05"'


def finite_floor(text: str) -> str:
    """``text`` (a standalone MJCF model with an infinite floor plane) with a finite floor of
    ``FLOOR_HALF_SIZE`` and a ``<statistic>`` pinned to the infinite floor's: the finite
    plane would change the model's extent, and with it the cameras' near plane and the
    shadow frustum."""
    import mujoco

    if INFINITE_FLOOR not in text:
        return text
    stat = mujoco.MjModel.from_xml_string(text).stat
    floor = f'type="plane" size="{FLOOR_HALF_SIZE} {FLOOR_HALF_SIZE} {FLOOR_GRID}"'
    statistic = f'  <statistic extent="{stat.extent:.6g}" center="{_f6(stat.center)}"/>\n'
    head, sep, rest = text.partition("\n<mujoco model=")
    line, nl, body = rest.partition("\n")
    return head + sep + line + nl + statistic + body.replace(INFINITE_FLOOR, floor)


def _f6(v) -> str:
    return " ".join(f"{float(x):.6g}" for x in v)


def mjcf_lights(forward: tuple[float, float], height: float = 2.0, indent: int = 4) -> str:
    """The scene lights as MJCF. ``forward``: horizontal viewing direction (world x, y) of the
    scene's main camera. Lights are directional: ``height`` only places the shadow frustum."""
    f = np.array([forward[0], forward[1], 0.0]) / np.hypot(*forward)
    left = np.array([-f[1], f[0], 0.0])
    pad = " " * indent
    out = []
    for name, (a, b, c), diffuse, specular, shadow in LIGHTS:
        d = a * f + b * left + np.array([0.0, 0.0, c])
        d /= np.linalg.norm(d)
        out.append(
            f'{pad}<light name="{name}" pos="{_f(-d * height)}" dir="{_f(d)}"\n'
            f'{pad}       directional="true" castshadow="{str(shadow).lower()}" '
            f'diffuse="{_f((diffuse,) * 3)}" specular="{_f((specular,) * 3)}"/>'
        )
    return "\n".join(out) + "\n"


# ----------------------------------------------------------------------------- shapes
def _f(v) -> str:
    return " ".join(f"{float(x):.4g}" for x in v)


def _hull_2d(points: np.ndarray) -> np.ndarray:
    """Convex hull (k, 2) of 2-D points, counter-clockwise (monotone chain)."""
    pts = sorted(set(map(tuple, np.round(points, 6))))

    def half(seq):
        out: list = []
        for p in seq:
            while len(out) >= 2:
                (ax, ay), (bx, by) = out[-2], out[-1]
                if (bx - ax) * (p[1] - ay) - (by - ay) * (p[0] - ax) > 1e-12:
                    break
                out.pop()
            out.append(p)
        return out[:-1]

    return np.array(half(pts) + half(reversed(pts)))


def _circle_points(circles, shrink: float) -> np.ndarray:
    angles = np.linspace(0, 2 * np.pi, SEGMENTS, endpoint=False)
    ring = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    return np.concatenate([np.asarray(c[:2]) + (c[2] - shrink) * ring for c in circles])


#: Extrusion planes: profile coordinates (u, v) and extrusion coordinate w -> body (x, y, z).
PLANES = {"xz": (0, 2, 1), "yz": (1, 2, 0), "xy": (0, 1, 2)}


def rounded_prism(circles, plane: str, w0: float, w1: float, bevel: float) -> np.ndarray:
    """Vertices (n, 3) of the hull of ``circles`` [(u, v, r)] extruded from ``w0`` to ``w1``
    along the axis normal to ``plane``, edges bevelled by ``bevel`` (m)."""
    u, v, w = PLANES[plane]
    layers = []
    for shrink, ws in ((0.0, (w0 + bevel, w1 - bevel)), (bevel, (w0, w1))):
        ring = _hull_2d(_circle_points(circles, shrink))
        for wv in ws:
            pts = np.zeros((len(ring), 3))
            pts[:, u], pts[:, v], pts[:, w] = ring[:, 0], ring[:, 1], wv
            layers.append(pts)
    return np.concatenate(layers)


def mirror_y(points: np.ndarray) -> np.ndarray:
    return points * np.array([1.0, -1.0, 1.0])


def mirror_yz(points: np.ndarray) -> np.ndarray:
    return points * np.array([1.0, -1.0, -1.0])


# ----------------------------------------------------------------------------- arm parts
Q_Y = (0.707107, 0.707107, 0, 0)  # cylinder axis along body y
Q_X = (0.707107, 0, 0.707107, 0)  # along body x
D405_POSE = ((0.0513206, 0, 0.0569399), (0.984808, 0, 0.173648, 0))  # +20 deg pitch


def corners(u0: float, u1: float, v0: float, v1: float, r: float) -> list[tuple]:
    """Circles of radius ``r`` in the corners of the rectangle [u0, u1] x [v0, v1]: their
    hull is that rectangle with rounded corners."""
    return [(u, v, r) for u in (u0 + r, u1 - r) for v in (v0 + r, v1 - r)]


def _finger_meshes() -> dict[str, np.ndarray]:
    """Carriage and finger of the right side (carriage frame): a mount block behind a
    tapered blade that carries the pads; the left side is the mirror image."""
    carriage = rounded_prism(
        corners(-0.0145, 0.012, -0.015, 0.0243, 0.004), "yz", -0.0185, -0.0005, 0.002
    )
    mount = rounded_prism(corners(-0.0134, 0.0094, -0.029, 0.029, 0.003), "yz", 0.0, 0.014, 0.0015)
    blade_profile = [
        (0.004, 0.026, 0.004),
        (0.004, -0.026, 0.004),
        (0.062, 0.004, 0.005),
        (0.062, -0.006, 0.005),
    ]
    blade = rounded_prism(blade_profile, "xz", 0.0014, 0.0094, 0.0015)
    return {
        "wxai_carriage_right": carriage,
        "wxai_carriage_left": mirror_yz(carriage),
        "wxai_finger_mount_right": mount,
        "wxai_finger_mount_left": mirror_y(mount),
        "wxai_finger_blade_right": blade,
        "wxai_finger_blade_left": mirror_y(blade),
    }


def arm_meshes() -> dict[str, np.ndarray]:
    """Inline vertex meshes of the arm (name -> (n, 3) body-frame vertices, m)."""
    link1_cheek = [(-0.022, 0.006, 0.006), (0.030, 0.006, 0.006), (0.020, 0.04625, 0.018)]
    link3_cheek = [(0.0, 0.0, 0.0175), (0.03, 0.06, 0.0285)]
    link4_bracket = [(0, 0, 0.0175), (0.012, 0.082, 0.0195), (0.06775, 0.082, 0.0195)]
    return {
        # base: a bevelled puck with the cable connector at +x
        "wxai_base": rounded_prism([(0, 0, 0.0325)], "xy", 0.0, 0.056, 0.003),
        "wxai_base_connector": rounded_prism(
            corners(0.02, 0.037, 0.006, 0.036, 0.006), "xz", -0.011, 0.011, 0.002
        ),
        # link_1: turntable and the shoulder fork (motor side +y)
        "wxai_link1_table": rounded_prism([(0, 0, 0.031)], "xy", 0.0, 0.010, 0.002),
        "wxai_link1_cheek_motor": rounded_prism(link1_cheek, "xz", 0.037, 0.048, 0.002),
        "wxai_link1_cheek": rounded_prism(link1_cheek, "xz", -0.041, -0.037, 0.001),
        # link_2: upper arm, shoulder and elbow hubs joined by a slimmer beam
        "wxai_link2_shoulder": rounded_prism([(0, 0, 0.0285)], "xz", -0.0363, 0.0363, 0.003),
        "wxai_link2_elbow": rounded_prism([(-0.264, 0, 0.0285)], "xz", -0.0363, 0.0363, 0.003),
        "wxai_link2_beam": rounded_prism(
            [(0, 0.004, 0.022), (-0.264, 0.004, 0.022)], "xz", -0.027, 0.027, 0.003
        ),
        # link_3: forearm, elbow cheeks rising to a beam that ends in the wrist motor
        "wxai_link3_cheek_left": rounded_prism(link3_cheek, "xz", 0.0368, 0.0413, 0.001),
        "wxai_link3_cheek_right": rounded_prism(link3_cheek, "xz", -0.0413, -0.0368, 0.001),
        "wxai_link3_beam": rounded_prism(
            [(0.03, 0.06, 0.024), (0.245, 0.06, 0.024)], "xz", -0.026, 0.026, 0.003
        ),
        "wxai_link3_wrist": rounded_prism([(0.245, 0.06, 0.0285)], "xz", -0.03, 0.03, 0.003),
        # link_4: wrist bracket around joint_3 carrying the joint_4 motor
        "wxai_link4_bracket": rounded_prism(link4_bracket, "xz", -0.0377, 0.0437, 0.003),
        # link_5: housing of the roll motor
        "wxai_link5": rounded_prism(
            corners(-0.040, 0.022, -0.092, 0.0, 0.012), "xz", -0.0285, 0.0285, 0.003
        ),
        # link_6: the gripper's rail housing (wide along y) and the camera bracket
        "wxai_gripper_rail": rounded_prism(
            corners(-0.0933, 0.0933, -0.0308, 0.0308, 0.012), "yz", 0.048, 0.068, 0.003
        ),
        "wxai_camera_bracket": rounded_prism(
            [(0.024, 0.031, 0.004), (0.064, 0.031, 0.004)], "xz", -0.022, 0.022, 0.001
        ),
        # the D405 (23 x 42 x 42 mm) in its own frame, placed at D405_POSE
        "wxai_d405": rounded_prism(
            corners(-0.0115, 0.0115, -0.021, 0.021, 0.004), "xz", -0.021, 0.021, 0.002
        ),
        **_finger_meshes(),
    }


#: Visual parts: (body, kind, what, pos, quat, material). kind "mesh": what = mesh name;
#: "cylinder"/"box": what = size. pos/quat: geom pose in the body frame (None = identity).
ARM_PARTS: tuple = (
    ("base_link", "mesh", "wxai_base", None, None, "wxai_black"),
    ("base_link", "mesh", "wxai_base_connector", None, None, "wxai_black"),
    ("link_1", "mesh", "wxai_link1_table", None, None, "wxai_black"),
    ("link_1", "mesh", "wxai_link1_cheek_motor", None, None, "wxai_black"),
    ("link_1", "mesh", "wxai_link1_cheek", None, None, "wxai_black"),
    ("link_2", "mesh", "wxai_link2_shoulder", None, None, "wxai_black"),
    ("link_2", "mesh", "wxai_link2_elbow", None, None, "wxai_black"),
    ("link_2", "mesh", "wxai_link2_beam", None, None, "wxai_black"),
    ("link_3", "mesh", "wxai_link3_cheek_left", None, None, "wxai_black"),
    ("link_3", "mesh", "wxai_link3_cheek_right", None, None, "wxai_black"),
    ("link_3", "mesh", "wxai_link3_beam", None, None, "wxai_black"),
    ("link_3", "mesh", "wxai_link3_wrist", None, None, "wxai_black"),
    ("link_4", "mesh", "wxai_link4_bracket", None, None, "wxai_black"),
    ("link_4", "cylinder", (0.026, 0.0275), (0.06775, 0, 0.074), None, "wxai_black"),
    ("link_5", "mesh", "wxai_link5", None, None, "wxai_black"),
    ("link_5", "cylinder", (0.026, 0.0035), (0.0255, 0, -0.0455), Q_X, "wxai_black"),
    ("link_6", "cylinder", (0.029, 0.025), (0.025, 0, 0), Q_X, "wxai_black"),
    ("link_6", "mesh", "wxai_gripper_rail", None, None, "wxai_black"),
    ("link_6", "mesh", "wxai_camera_bracket", None, None, "wxai_black"),
    ("link_6", "mesh", "wxai_d405", *D405_POSE, "wxai_grey"),
    ("carriage_right", "mesh", "wxai_carriage_right", None, None, "wxai_black"),
    ("carriage_right", "mesh", "wxai_finger_mount_right", None, None, "wxai_grey"),
    ("carriage_right", "mesh", "wxai_finger_blade_right", None, None, "wxai_grey"),
    ("carriage_left", "mesh", "wxai_carriage_left", None, None, "wxai_black"),
    ("carriage_left", "mesh", "wxai_finger_mount_left", None, None, "wxai_grey"),
    ("carriage_left", "mesh", "wxai_finger_blade_left", None, None, "wxai_grey"),
)
#: The visual part that is the wrist camera (kept when other visuals are swapped).
WRIST_CAMERA_MESH = "wxai_d405"

#: Arm materials: black anodised aluminium, grey metal (fingers, camera), rubber pads.
MATERIALS = (
    '<material name="wxai_black" rgba="0.13 0.13 0.14 1" specular="0.5" shininess="0.5"/>',
    '<material name="wxai_grey" rgba="0.42 0.43 0.45 1" specular="0.4" shininess="0.5"/>',
    '<material name="wxai_rubber" rgba="0.05 0.05 0.05 1" specular="0.1" shininess="0.1"/>',
)


def mesh_vertex_text(points: np.ndarray) -> str:
    """Vertices as MJCF text, 0.1 mm resolution."""
    return "  ".join(" ".join(f"{x:.4f}".rstrip("0").rstrip(".") for x in p) for p in points)
