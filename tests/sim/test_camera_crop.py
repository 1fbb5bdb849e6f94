"""Camera crops: a camera shows one rectangle of its 480x640 frame, drawn at any image size."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.sim.camera_crop import CameraCrop, apply_crops, parse_crop, parse_crops
from trossen_arm_mujoco.sim.cameras import CameraSet
from trossen_arm_mujoco.sim.looks import SceneLooks

#: A floor of coloured tiles seen from above: every rectangle of the frame looks different.
SCENE = """
<mujoco>
  <visual><global offwidth="640" offheight="480"/></visual>
  <worldbody>
    <light pos="0 0 3" dir="0 0 -1" castshadow="false"/>
    <camera name="top" pos="0 0 1" fovy="60"/>
    <camera name="other" pos="0 0 1" fovy="60"/>
    {tiles}
  </worldbody>
</mujoco>
"""


def tiles() -> str:
    rng = np.random.default_rng(0)
    rows = []
    for i in range(-6, 6):
        for j in range(-8, 8):
            r, g, b = rng.uniform(0, 1, 3)
            rows.append(
                f'<geom type="box" size="0.045 0.045 0.01" pos="{0.1 * j + 0.05} '
                f'{0.1 * i + 0.05} 0" rgba="{r:.3f} {g:.3f} {b:.3f} 1"/>'
            )
    return "\n".join(rows)


@pytest.fixture(scope="module")
def xml() -> str:
    return SCENE.format(tiles=tiles())


def render(model: mujoco.MjModel, camera: str, h: int, w: int) -> np.ndarray:
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    cams = CameraSet(model, [camera], h, w)
    try:
        return cams.render(data, camera).astype(int)
    finally:
        cams.close()


def test_a_crop_draws_the_rectangle_of_the_full_frame(xml):
    full = render(mujoco.MjModel.from_xml_string(xml), "top", 480, 640)
    crop = CameraCrop("top", top=100, left=330, height=120, width=160)
    model = mujoco.MjModel.from_xml_string(xml)
    apply_crops(model, (crop,))
    image = render(model, "top", 120, 160)
    same = full[100:220, 330:490]
    assert np.abs(image - same).mean() < 3.0  # edge pixels of the tiles may round apart
    elsewhere = full[300:420, 40:200]  # a different rectangle looks different
    assert np.abs(image - elsewhere).mean() > 20.0
    # the other camera keeps its whole frame
    assert np.abs(render(model, "other", 480, 640) - full).mean() < 1e-9


def test_a_crop_drawn_smaller_is_the_rectangle_scaled(xml):
    full = render(mujoco.MjModel.from_xml_string(xml), "top", 480, 640)
    model = mujoco.MjModel.from_xml_string(xml)
    apply_crops(model, (parse_crop("top:60,80,240,320"),))
    half = render(model, "top", 120, 160)
    scaled = full[60:300, 80:400].reshape(120, 2, 160, 2, 3).mean(axis=(1, 3))
    assert np.abs(half - scaled).mean() < 12.0  # tile edges fall on either pixel


def test_scene_looks_carry_crops_into_compiled_models(tmp_path, xml):
    from trossen_arm_mujoco.sim.looks import compile_model

    path = tmp_path / "scene.xml"
    path.write_text(xml)
    crop = parse_crop("top:0,0,240,320")
    model = compile_model(path, SceneLooks(crops=(crop,)))
    cid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "top")
    assert tuple(model.cam_sensorsize[cid]) == (320, 240)
    assert model.cam_intrinsic[cid][2:].tolist() == [-160.0, -120.0]
    assert not compile_model(path, SceneLooks()).cam_sensorsize.any()


@pytest.mark.parametrize(
    "text, message",
    [
        ("top", "must look like"),
        ("top:1,2,3", "must look like"),
        ("top:a,2,3,4", "must look like"),
        ("top:-1,0,10,10", "top, left >= 0"),
        ("top:0,0,0,10", "positive size"),
        ("top:400,0,100,10", "reaches past"),
        ("top:0,600,10,50", "reaches past"),
    ],
)
def test_bad_crops_are_one_line_errors(text, message):
    with pytest.raises(UserError, match=message):
        parse_crop(text)


def test_one_crop_per_camera_and_known_cameras(xml):
    with pytest.raises(UserError, match="one --crop per camera"):
        parse_crops(["top:0,0,10,10", "top:5,5,10,10"])
    with pytest.raises(UserError, match="one crop per camera"):
        SceneLooks(crops=(parse_crop("top:0,0,10,10"), parse_crop("top:1,1,10,10")))
    with pytest.raises(UserError, match="CameraCrop"):
        SceneLooks(crops=("top:0,0,10,10",))
    model = mujoco.MjModel.from_xml_string(xml)
    with pytest.raises(UserError, match="other"):  # the error lists the model's cameras
        apply_crops(model, (parse_crop("cam_high:0,0,10,10"),))
    assert parse_crops(None) == () and parse_crops("top:1,2,3,4")[0].text() == "top:1,2,3,4"
    two = parse_crops("top:1,2,3,4;other:5,6,7,8")  # the form of the files' `crops` attribute
    assert [c.text() for c in two] == ["top:1,2,3,4", "other:5,6,7,8"]


def test_cropping_a_whole_frame_gives_what_the_cropped_camera_draws(xml):
    """A deployed policy's images (a whole frame, cut and averaged down by ``crop_frame``)
    match the cropped camera's own render at the policy's size, as the served kit's whole
    frames must for ``eval --backend wire``."""
    from trossen_arm_mujoco.sim.camera_crop import crop_frame

    full = render(mujoco.MjModel.from_xml_string(xml), "top", 480, 640).astype(np.uint8)
    crop = parse_crop("top:90,150,150,200")
    model = mujoco.MjModel.from_xml_string(xml)
    apply_crops(model, (crop,))
    drawn = render(model, "top", 96, 128)
    made = crop_frame(full, crop, (96, 128))
    assert made.shape == (96, 128, 3) and made.dtype == np.uint8
    assert np.abs(made.astype(int) - drawn).mean() < 12.0  # tile edges fall on either pixel
    other = crop_frame(full, parse_crop("top:300,40,150,200"), (96, 128))
    assert np.abs(other.astype(int) - drawn).mean() > 20.0
    # a frame streamed at half size: the rectangle is scaled with it
    half = full.reshape(240, 2, 320, 2, 3).mean(axis=(1, 3)).astype(np.uint8)
    assert np.abs(crop_frame(half, crop, (96, 128)).astype(int) - drawn).mean() < 12.0
    assert crop_frame(full, None, (480, 640)) is full
