"""How a loaded scene looks: shadows on or off, antialiasing, crops and which meshes draw the
arms.

:class:`SceneLooks`: the arms drawn with ``"own"`` (this project's shapes) or ``"menagerie"``
(the official Trossen meshes of a MuJoCo Menagerie checkout named by
``TROSSEN_MENAGERIE_DIR``); only visual geoms change, so physics is the same whatever the
look. ``shadows=False`` turns shadow casting off on every light; ``antialias=False`` draws
one sample a pixel instead of 4x multisampling; ``crops`` set cameras' intrinsics
(``sim.camera_crop``). The look travels as an argument, like a seed: ``SamplerSettings(looks=
...)`` -> ``sim.scene.Scene`` -> ``sim.scene.load_model`` (or ``load_physics``); default
``SceneLooks()`` (own meshes, shadows on).

Docs: docs/gym/index.md (options); cost: docs/benchmarks.md (Rendering cost).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import mujoco

from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.sim.camera_crop import CameraCrop, apply_crops
from trossen_arm_mujoco.sim.scene_edit import SceneEdit, compile_composed, compose_spec

__all__ = [
    "KEPT_OWN_MESHES",
    "MENAGERIE_ENV",
    "MENAGERIE_MESHES",
    "MENAGERIE_MESH_DIRS",
    "MENAGERIE_MODEL",
    "MENAGERIE_TEXTURE",
    "OWN_VISUAL_CLASS",
    "VISUALS",
    "SceneLooks",
    "apply_antialias",
    "apply_shadows",
    "checked_looks",
    "compile_model",
    "menagerie_folder",
    "menagerie_mesh",
    "menagerie_meshes",
    "use_menagerie_visuals",
]

#: Arm looks: this project's shapes, or the official meshes of a Menagerie checkout.
VISUALS: tuple[str, ...] = ("own", "menagerie")
#: Environment variable naming the MuJoCo Menagerie checkout (or its trossen_wxai folder).
MENAGERIE_ENV = "TROSSEN_MENAGERIE_DIR"
MENAGERIE_MODEL = "trossen_wxai"
#: Where the arm meshes live inside trossen_wxai/, newest layout first.
MENAGERIE_MESH_DIRS = ("assets/meshes/wxai", "assets/meshes/d405", "assets/meshes")
MENAGERIE_TEXTURE = "assets/materials/1k_textures/trossen_BaseColor.png"
#: Arm body -> Menagerie visual meshes drawn in it: (mesh file stem, pos in the body frame, m).
#: The meshes are in the link frames of the vendor model, which are this model's body frames.
MENAGERIE_MESHES: dict[str, tuple[tuple[str, tuple[float, float, float]], ...]] = {
    "base_link": (("base_link", (0, 0, 0)),),
    "link_1": (("link_1", (0, 0, 0)),),
    "link_2": (("link_2", (0, 0, 0)),),
    "link_3": (("link_3", (0, 0, 0)),),
    "link_4": (("link_4", (0, 0, 0)),),
    "link_5": (("link_5", (0, 0, 0)),),
    "link_6": (("link_6", (0, 0, 0)), ("camera_mount_d405", (0.012, 0, 0))),
    "carriage_right": (("carriage_right", (0, 0, 0)), ("gripper_right", (0, 0, 0))),
    "carriage_left": (("carriage_left", (0, 0, 0)), ("gripper_left", (0, 0, 0))),
}
#: The own visual geoms carry this default class; the wrist camera's mesh is kept either way
#: (the Menagerie model draws the D405 as a box too).
OWN_VISUAL_CLASS = "wxai_visual"
KEPT_OWN_MESHES = ("wxai_d405",)


@dataclass(frozen=True)
class SceneLooks:
    """How scenes are loaded for rendering.

    Attributes:
        shadows: whether the key light casts shadows (False: no light does).
        antialias: whether edges are smoothed by multisampling (False: one sample a pixel).
        visual: ``"own"`` or ``"menagerie"`` (needs ``TROSSEN_MENAGERIE_DIR``).
        crops: cameras that show a rectangle of their frame (``sim.camera_crop``; a tuple
            of ``CameraCrop``, one per camera at most); default none.
    """

    shadows: bool = True
    visual: str = "own"
    crops: tuple[CameraCrop, ...] = ()
    antialias: bool = True

    def __post_init__(self) -> None:
        if not isinstance(self.shadows, bool):
            raise UserError(f"shadows must be True or False, got {self.shadows!r}")
        if not isinstance(self.antialias, bool):
            raise UserError(f"antialias must be True or False, got {self.antialias!r}")
        if self.visual not in VISUALS:
            raise unknown_name_error("visual", str(self.visual), VISUALS)
        crops = tuple(self.crops or ())
        if not all(isinstance(c, CameraCrop) for c in crops):
            raise UserError("crops must be CameraCrop values (sim.camera_crop.parse_crop)")
        cameras = [c.camera for c in crops]
        if len(set(cameras)) != len(cameras):
            raise UserError(f"one crop per camera, got {', '.join(cameras)}")
        object.__setattr__(self, "crops", crops)


def checked_looks(looks: SceneLooks | None) -> SceneLooks:
    """``looks``, or ``SceneLooks()`` for None; a one-line UserError for anything else."""
    if looks is None:
        return SceneLooks()
    if not isinstance(looks, SceneLooks):
        raise UserError(f"looks must be a SceneLooks (sim.looks), got {type(looks).__name__}")
    return looks


def apply_shadows(model: mujoco.MjModel, shadows: bool) -> None:
    """``shadows=False``: no light of ``model`` casts shadows; True leaves the model's own
    setting (the key light casts them)."""
    if not shadows:
        model.light_castshadow[:] = 0


def apply_antialias(model: mujoco.MjModel, antialias: bool) -> None:
    """``antialias=False``: the renderers made for ``model`` draw one sample a pixel (no
    multisampling); True leaves the model's own setting."""
    if not antialias:
        model.vis.quality.offsamples = 0


# ----------------------------------------------------------------------------- menagerie
def menagerie_folder(root: str | Path | None = None) -> Path:
    """The ``trossen_wxai`` folder of the Menagerie checkout at ``root`` (default:
    ``$TROSSEN_MENAGERIE_DIR``); a one-line UserError when it is not there."""
    fix = (
        f"set {MENAGERIE_ENV} to a MuJoCo Menagerie checkout "
        "(git clone https://github.com/google-deepmind/mujoco_menagerie), or use the own "
        "meshes (visual='own')"
    )
    if root is None:
        root = os.environ.get(MENAGERIE_ENV, "").strip()
        if not root:
            raise UserError(f"visual 'menagerie' needs the Trossen meshes: {fix}")
    path = Path(root).expanduser()
    folder = path if path.name == MENAGERIE_MODEL else path / MENAGERIE_MODEL
    if not folder.is_dir():
        raise UserError(f"no {MENAGERIE_MODEL}/ folder in {path}: {fix}")
    return folder


def menagerie_mesh(folder: Path, stem: str) -> Path:
    """Path of the Menagerie mesh ``stem`` (.obj) under ``folder`` (trossen_wxai/)."""
    for sub in MENAGERIE_MESH_DIRS:
        path = folder / sub / f"{stem}.obj"
        if path.is_file():
            return path
    raise UserError(
        f"mesh {stem}.obj not found in {folder}/{MENAGERIE_MESH_DIRS[0]} (nor in "
        f"{', '.join(MENAGERIE_MESH_DIRS[1:])}); update the Menagerie checkout or use "
        "visual='own'"
    )


def menagerie_meshes(folder: Path | None = None) -> dict[str, Path]:
    """Mesh file stem -> path of every Menagerie mesh the arms use (``folder``: the
    trossen_wxai/ folder, default ``menagerie_folder()``); a UserError when one is missing."""
    folder = folder or menagerie_folder()
    return {
        stem: menagerie_mesh(folder, stem)
        for parts in MENAGERIE_MESHES.values()
        for stem, _ in parts
    }


def use_menagerie_visuals(spec: mujoco.MjSpec, folder: Path) -> int:
    """Swap the own visual geoms of every wxai arm in ``spec`` for the Menagerie meshes under
    ``folder`` (trossen_wxai/). Returns the number of bodies changed."""
    files = menagerie_meshes(folder)
    texture = folder / MENAGERIE_TEXTURE
    material = spec.add_material(name="menagerie_trossen", rgba=[0.25, 0.25, 0.26, 1])
    if texture.is_file():
        spec.add_texture(
            name="menagerie_trossen", type=mujoco.mjtTexture.mjTEXTURE_2D, file=str(texture)
        )
        material.rgba = [1, 1, 1, 1]
        material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "menagerie_trossen"
    for stem, path in files.items():
        spec.add_mesh(name=f"menagerie_{stem}", file=str(path))
    changed = 0
    for body in spec.bodies:
        parts = MENAGERIE_MESHES.get(body.name.rsplit("/", 1)[-1])
        if parts is None or not _is_arm_body(body):
            continue
        for geom in list(body.geoms):
            if _is_own_visual(geom) and geom.meshname not in KEPT_OWN_MESHES:
                spec.delete(geom)
        for stem, pos in parts:
            body.add_geom(
                type=mujoco.mjtGeom.mjGEOM_MESH,
                meshname=f"menagerie_{stem}",
                pos=list(pos),
                contype=0,
                conaffinity=0,
                group=2,
                density=0,
                material="menagerie_trossen",
            )
        changed += 1
    return changed


def _is_arm_body(body) -> bool:
    return any(_is_own_visual(g) for g in body.geoms)


def _is_own_visual(geom) -> bool:
    cls = geom.classname
    return cls is not None and cls.name == OWN_VISUAL_CLASS


def compile_model(path: Path, looks: SceneLooks, edit: SceneEdit | None = None) -> mujoco.MjModel:
    """Compile an MJCF file with a look; mujoco errors propagate.

    Args:
        path: the MJCF file.
        looks: shadows, antialiasing, crops and arm meshes.
        edit: a task's own scene objects (``sim.scene_edit``); None: none.
    """
    if edit:
        spec = compose_spec(path, edit)
        if looks.visual == "menagerie" and use_menagerie_visuals(spec, menagerie_folder()) == 0:
            raise UserError(f"{path.name} has no wxai arm to draw with the Menagerie meshes")
        model = compile_composed(spec, path)
    elif looks.visual == "menagerie":
        folder = menagerie_folder()
        spec = mujoco.MjSpec.from_file(str(path))
        if use_menagerie_visuals(spec, folder) == 0:
            raise UserError(f"{path.name} has no wxai arm to draw with the Menagerie meshes")
        model = spec.compile()
    else:
        model = mujoco.MjModel.from_xml_path(str(path))
    apply_shadows(model, looks.shadows)
    apply_antialias(model, looks.antialias)
    apply_crops(model, looks.crops)
    return model
