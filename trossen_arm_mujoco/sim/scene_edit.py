"""A task's own objects, composed into a shipped scene at load time (no model file is
written or regenerated).

A ``SceneEdit`` names bodies of the base scene to remove and MJCF fragments to add to its
``<worldbody>`` (the text of ``<body>`` elements, optionally after an ``<asset>`` block, or a
file holding it). Keyframes keep the base scene's values of every joint still there; added
bodies start at the pose their MJCF gives::

    >>> edit = SceneEdit(add=('<body name="ball" pos="0 0 0.05"><freejoint name="ball_joint"/>'
    ...                       '<geom name="ball" type="sphere" size="0.02" mass="0.03"/></body>',),
    ...                  remove=("box",))
    >>> model = compose_model(Path("stationary_ai/trossen_ai_scene_joint.xml"), edit)

Docs: docs/writing-a-task.md.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import mujoco

from trossen_arm_mujoco.errors import UserError

__all__ = ["SceneEdit", "compose_spec", "restore_keyframes"]


@dataclass(frozen=True)
class SceneEdit:
    """Bodies added to and removed from a scene at load time.

    Attributes:
        add: MJCF fragments (``<body>`` elements, an optional ``<asset>`` block first), as
            text or as paths of files holding them; added to the world body.
        remove: names of top-level bodies of the base scene to remove (with their joints,
            geoms and children).
    """

    add: tuple[str | Path, ...] = ()
    remove: tuple[str, ...] = ()

    def __bool__(self) -> bool:
        return bool(self.add or self.remove)


def _fragment_text(fragment: str | Path) -> tuple[str, str]:
    """(text, where) of a fragment given as text or as a file path."""
    if isinstance(fragment, Path) or (isinstance(fragment, str) and "<" not in fragment):
        path = Path(fragment)
        if not path.is_file():
            raise UserError(f"scene object file not found: {path}")
        return path.read_text(encoding="utf-8"), str(path)
    return str(fragment), "scene object fragment"


def _split(fragment: str | Path) -> tuple[str, str]:
    """(assets, bodies) MJCF of a fragment, checked on its own (a one-line UserError naming
    it when MuJoCo cannot read it)."""
    text, where = _fragment_text(fragment)
    head, sep, bodies = text.partition("</asset>")
    assets, bodies = (head + sep, bodies) if sep else ("", text)
    try:
        mujoco.MjSpec.from_string(f"<mujoco>{assets}<worldbody>{bodies}</worldbody></mujoco>")
    except Exception as exc:  # mujoco raises ValueError with its parser's message
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise UserError(f"cannot read {where}: {first}") from None
    return assets, bodies


_INCLUDE = re.compile(r"<include\s+file\s*=\s*[\"']([^\"']+)[\"']")


def _includes(text: str, folder: Path, found: dict[str, bytes]) -> dict[str, bytes]:
    """Every file ``text`` includes (recursively), by the name it is included as; MuJoCo
    resolves includes relative to the main model's folder."""
    for name in _INCLUDE.findall(text):
        if name not in found:
            data = (folder / name).read_bytes()
            found[name] = data
            _includes(data.decode("utf-8"), folder, found)
    return found


def compose_spec(path: Path, edit: SceneEdit) -> mujoco.MjSpec:
    """The scene at ``path`` as an ``MjSpec`` with ``edit`` applied: the fragments are
    added as extra ``<asset>`` / ``<worldbody>`` sections of the scene's text (MJCF merges
    repeated sections), the removed bodies deleted; keyframes are fixed after compiling
    (``restore_keyframes``)."""
    text = path.read_text(encoding="utf-8")
    extra = "".join(f"{a}<worldbody>{b}</worldbody>" for a, b in map(_split, edit.add))
    end = text.rindex("</mujoco>")
    spec = mujoco.MjSpec.from_string(
        text[:end] + extra + text[end:], include=_includes(text, path.parent, {})
    )
    spec.modelfiledir = str(path.parent)  # meshes and textures relative to the scene
    for name in edit.remove:
        body = spec.body(name)
        if body is None:
            valid = ", ".join(b.name for b in spec.worldbody.bodies)
            raise UserError(
                f"scene {path.name} has no body '{name}' to remove; top-level bodies: {valid}"
            )
        spec.delete(body)
    for key in spec.keys:  # sized again after compiling (restore_keyframes)
        key.qpos = []
        key.qvel = []
    return spec


def compile_composed(spec: mujoco.MjSpec, base: Path) -> mujoco.MjModel:
    """Compile a ``compose_spec`` result, keyframes restored from the scene at ``base``."""
    model = spec.compile()
    restore_keyframes(model, mujoco.MjModel.from_xml_path(str(base)))
    return model


def restore_keyframes(model: mujoco.MjModel, base: mujoco.MjModel) -> None:
    """Keyframes of ``model`` (composed from ``base``) given ``base``'s qpos of every joint
    the two share by name; the other joints keep ``qpos0`` (their MJCF pose)."""
    sizes = {int(mujoco.mjtJoint.mjJNT_FREE): 7, int(mujoco.mjtJoint.mjJNT_BALL): 4}
    for k in range(min(model.nkey, base.nkey)):
        model.key_qpos[k] = model.qpos0
        for j in range(model.njnt):
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
            jb = mujoco.mj_name2id(base, mujoco.mjtObj.mjOBJ_JOINT, name) if name else -1
            if jb < 0:
                continue
            n = sizes.get(int(model.jnt_type[j]), 1)
            a, b = int(model.jnt_qposadr[j]), int(base.jnt_qposadr[jb])
            model.key_qpos[k, a : a + n] = base.key_qpos[k, b : b + n]
