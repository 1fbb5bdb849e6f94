"""Scene looks: shadows on/off, and the Menagerie meshes swapped in for drawing only."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.sim.looks import (
    MENAGERIE_ENV,
    MENAGERIE_MESHES,
    SceneLooks,
    menagerie_folder,
)
from trossen_arm_mujoco.sim.scene import load_model, load_physics
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings

ASSETS = Path(ASSETS_DIR)
PUSH = ASSETS / "wxai/scene_push.xml"
KIT = ASSETS / "stationary_ai/trossen_ai_scene_joint.xml"
MENAGERIE = SceneLooks(visual="menagerie")


def geom_rows(model: mujoco.MjModel, colliding: bool) -> list[tuple]:
    """Everything about the geoms that do (or do not) collide, by body, in order."""
    rows = []
    for g in range(model.ngeom):
        collides = bool(model.geom_contype[g] or model.geom_conaffinity[g])
        if collides == colliding:
            rows.append(
                (
                    model.body(model.geom_bodyid[g]).name,
                    model.geom(g).name,
                    int(model.geom_type[g]),
                    *np.round(model.geom_size[g], 12),
                    *np.round(model.geom_pos[g], 12),
                    *np.round(model.geom_quat[g], 12),
                    int(model.geom_contype[g]),
                    int(model.geom_conaffinity[g]),
                    *model.geom_friction[g],
                    int(model.geom_condim[g]),
                )
            )
    return rows


def test_looks_are_checked():
    with pytest.raises(UserError, match="menagerie, own") as err:
        SceneLooks(visual="pretty")
    assert "\n" not in str(err.value)
    with pytest.raises(UserError, match="True or False"):
        SceneLooks(shadows="no")


@pytest.mark.parametrize("xml", [PUSH, KIT], ids=["single-arm", "kit"])
def test_shadows_off_turns_every_light_off(xml):
    on = load_model(xml)
    assert on.light_castshadow.sum() == 1  # the key light only
    off = load_model(xml, SceneLooks(shadows=False))
    assert off.nlight == on.nlight and not off.light_castshadow.any()


def test_the_look_travels_as_an_argument():
    """Front door -> sampler -> Scene -> load_model, like seed and randomize; nothing
    else (no ambient setting) changes what a scene loads with."""
    from trossen_arm_mujoco.gym.env import TrossenMujocoEnv
    from trossen_arm_mujoco.sim.scene import Scene
    from trossen_arm_mujoco.tasks import registry

    assert load_model(PUSH).light_castshadow.any()  # default: SceneLooks()
    assert not Scene(PUSH, looks=SceneLooks(shadows=False)).model.light_castshadow.any()
    with registry.make_sampler("push", SamplerSettings(looks=SceneLooks(shadows=False))) as sampler:
        assert not sampler.scene.model.light_castshadow.any()
    with registry.make_sampler("push") as sampler:  # the one before left nothing behind
        assert sampler.scene.model.light_castshadow.any()
    env = TrossenMujocoEnv("push", shadows=False)
    assert not env.scene.model.light_castshadow.any()
    env.close()
    with pytest.raises(UserError, match="looks must be a SceneLooks") as err:
        registry.make_sampler("push", SamplerSettings(looks={"shadows": False}))
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("xml", [PUSH, KIT], ids=["single-arm", "kit"])
def test_menagerie_swaps_only_what_is_drawn(xml, fake_menagerie):
    own = load_model(xml)
    men = load_model(xml, MENAGERIE)
    # contacts, bodies, joints, inertia and actuators are the project's own either way
    assert geom_rows(men, colliding=True) == geom_rows(own, colliding=True)
    for field in (
        "body_pos",
        "body_quat",
        "body_mass",
        "body_inertia",
        "body_ipos",
        "jnt_axis",
        "jnt_range",
        "actuator_gainprm",
        "actuator_biasprm",
    ):
        np.testing.assert_array_equal(getattr(men, field), getattr(own, field), err_msg=field)
    # drawn: one Menagerie mesh per vendor link mesh, in every arm
    drawn = (men.geom_type == mujoco.mjtGeom.mjGEOM_MESH) & (men.geom_contype == 0)
    meshes = {men.mesh(men.geom_dataid[g]).name for g in np.flatnonzero(drawn)}
    stems = {stem for parts in MENAGERIE_MESHES.values() for stem, _ in parts}
    assert {f"menagerie_{s}" for s in stems} <= meshes
    assert not any(m.startswith("wxai_link") for m in meshes)  # own link shapes are gone
    assert "wxai_d405" in meshes  # the wrist camera body stays (the Menagerie draws a box)
    arms = 2 if xml == KIT else 1
    n_men = sum(1 for r in geom_rows(men, colliding=False) if r[0].endswith("link_6"))
    assert n_men == arms * 3  # link_6, camera mount, own D405


@pytest.mark.parametrize("xml", [PUSH, KIT], ids=["single-arm", "kit"])
def test_menagerie_physics_is_bit_identical(xml, fake_menagerie):
    models = [load_model(xml), load_model(xml, MENAGERIE)]
    rng = np.random.default_rng(0)
    ctrl = rng.uniform(-0.3, 0.3, (50, models[0].nu))
    final = []
    for model in models:
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, 0)
        for u in ctrl:
            data.ctrl[:] = data.ctrl + u * 0.01
            mujoco.mj_step(model, data, 5)
        final.append(data.qpos.copy())
    np.testing.assert_array_equal(final[0], final[1])


def test_menagerie_renders_and_loads_in_dm_control(fake_menagerie):
    physics = load_physics(KIT, MENAGERIE)
    assert "menagerie_link_2" in [physics.model.mesh(i).name for i in range(physics.model.nmesh)]
    model = load_model(PUSH, SceneLooks(visual="menagerie", shadows=False))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    with mujoco.Renderer(model, 24, 32) as renderer:
        renderer.update_scene(data, "overview")
        assert renderer.render().std() > 0


def test_older_menagerie_layout_and_model_folder(tmp_path, monkeypatch, make_fake_menagerie):
    root = make_fake_menagerie(tmp_path / "menagerie", layout="old")
    monkeypatch.setenv(MENAGERIE_ENV, str(root / "trossen_wxai"))  # the model folder itself
    assert menagerie_folder() == root / "trossen_wxai"
    assert load_model(PUSH, MENAGERIE).nmesh > load_model(PUSH).nmesh


def test_missing_menagerie_is_a_one_line_error(tmp_path, monkeypatch, make_fake_menagerie):
    monkeypatch.delenv(MENAGERIE_ENV, raising=False)
    with pytest.raises(UserError, match=MENAGERIE_ENV) as err:
        load_model(PUSH, MENAGERIE)
    assert "\n" not in str(err.value) and "visual='own'" in str(err.value)
    monkeypatch.setenv(MENAGERIE_ENV, str(tmp_path))
    with pytest.raises(UserError, match="no trossen_wxai/ folder"):
        load_model(PUSH, MENAGERIE)
    root = make_fake_menagerie(tmp_path / "m")
    (root / "trossen_wxai/assets/meshes/wxai/link_3.obj").unlink()
    monkeypatch.setenv(MENAGERIE_ENV, str(root))
    with pytest.raises(UserError, match=r"link_3\.obj not found") as err:
        load_model(PUSH, MENAGERIE)
    assert "\n" not in str(err.value)


def test_menagerie_texture_is_used_when_present(fake_menagerie):
    from PIL import Image

    texture = fake_menagerie / "trossen_wxai/assets/materials/1k_textures/trossen_BaseColor.png"
    texture.parent.mkdir(parents=True)
    Image.fromarray(np.full((8, 8, 3), 60, np.uint8)).save(texture)
    model = load_model(PUSH, MENAGERIE)
    mat = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_MATERIAL, "menagerie_trossen")
    assert model.mat_texid[mat, mujoco.mjtTextureRole.mjTEXROLE_RGB] >= 0
