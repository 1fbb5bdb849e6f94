"""CameraSettings: the command line's camera flags parsed once, checked, and their file form
(sim.camera_settings)."""

from __future__ import annotations

import pickle

import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.sim.camera_crop import CameraCrop
from trossen_arm_mujoco.sim.camera_settings import (
    DEFAULT_SIZE,
    CameraSettings,
    camera_flags,
    parse_cameras,
    parse_image_size,
)

CROP = "cam_high:217,243,150,200"


def test_from_cli_parses_the_three_flags():
    cams = CameraSettings.from_cli("cam_high, cam_low", "60x80", CROP)
    assert cams.names == ("cam_high", "cam_low") and cams.size == (60, 80)
    assert cams.crops == (CameraCrop("cam_high", 217, 243, 150, 200),)
    assert cams.crop_of("cam_high").width == 200 and cams.crop_of("cam_low") is None
    assert cams.crop_texts() == (CROP,)
    # several --crop texts, or one with ';' between cameras; pairs and lists
    two = "cam_high:0,0,10,10;cam_low:5,5,20,20"
    both = ["cam_high", "cam_low"]
    assert CameraSettings.from_cli(both, (24, 32), two.split(";")) == CameraSettings(
        tuple(both), (24, 32), CameraSettings.from_cli(both, crops=two).crops
    )
    # a crop of a camera that is not observed is one line
    with pytest.raises(UserError, match="camera cam_low is not observed .cam_high.; add it"):
        CameraSettings.from_cli(["cam_high"], (24, 32), two)


def test_flags_not_given_take_the_defaults():
    assert CameraSettings.from_cli() == CameraSettings() == CameraSettings.from_cli("none", "", "")
    assert CameraSettings().size == DEFAULT_SIZE == (480, 640)
    assert CameraSettings().names == () and CameraSettings().crops == ()


def test_camera_flags_keep_not_given_apart_from_none():
    assert camera_flags(None, None, None) == {"cam_names": None, "image_size": None, "crops": None}
    given = camera_flags("none", "24X32", [CROP])
    assert given["cam_names"] == () and given["image_size"] == (24, 32)
    assert given["crops"][0].text() == CROP


@pytest.mark.parametrize(
    "kwargs,needle",
    [
        ({"image_size": "48by64"}, "image size must look like HxW"),
        ({"image_size": "0x64"}, "image size must look like HxW"),
        ({"image_size": "1x2x3"}, "image size must look like HxW"),
        ({"crops": "cam_high:1,2,3"}, "--crop must look like CAMERA:TOP,LEFT,HEIGHT,WIDTH"),
        ({"crops": "cam_high:400,0,100,10"}, "reaches past the 480x640 frame"),
        ({"crops": "cam_high:0,0,5,5;cam_high:1,1,5,5"}, "one --crop per camera"),
        ({"cam_names": "cam_high,cam_high"}, "camera cam_high is listed twice"),
    ],
)
def test_bad_flags_are_one_line_user_errors(kwargs, needle):
    with pytest.raises(UserError, match=needle) as err:
        CameraSettings.from_cli(**kwargs)
    assert "\n" not in str(err.value)


def test_the_object_checks_what_it_is_given():
    with pytest.raises(UserError, match="list of names"):
        CameraSettings(names="cam_high")
    with pytest.raises(UserError, match="non-empty strings"):
        CameraSettings(names=("cam_high", ""))
    with pytest.raises(UserError, match="CameraCrop values"):
        CameraSettings(names=("cam_high",), crops=(CROP,))
    with pytest.raises(UserError, match="image size"):
        CameraSettings(size=(0, 10))
    cams = CameraSettings(names=["cam_high"], size=[24, 32])  # lists become tuples
    assert cams.names == ("cam_high",) and cams.size == (24, 32)
    with pytest.raises(AttributeError):
        cams.size = (1, 1)  # frozen


def test_json_round_trip_and_the_file_form():
    cams = CameraSettings.from_cli("cam_high", "60x80", CROP)
    data = cams.to_json()
    assert data == {"cam_names": ["cam_high"], "image_size": [60, 80], "crops": [CROP]}
    assert CameraSettings.from_json(data, "f.json") == cams
    # no camera: no size in the file; reading it back gives the default
    assert CameraSettings().to_json() == {"cam_names": [], "image_size": None, "crops": []}
    assert CameraSettings.from_json({"image_size": None}, "f.json") == CameraSettings()
    assert CameraSettings.from_json({}, "f.json") == CameraSettings()
    assert pickle.loads(pickle.dumps(cams)) == cams  # travels to worker processes


def test_the_looks_travel_in_the_file_form_only_when_off():
    plain = CameraSettings(("cam_high",), (60, 80), shadows=False, antialias=False)
    data = plain.to_json()
    assert data["shadows"] is False and data["antialias"] is False
    assert CameraSettings.from_json(data, "f.json") == plain
    looks = plain.scene_looks()
    assert (looks.shadows, looks.antialias, looks.crops) == (False, False, ())
    assert (
        "antialias" not in CameraSettings(("cam_high",)).to_json()
    )  # older files stay as they were
    with pytest.raises(UserError, match=r"^f\.json: unreadable camera settings .*antialias"):
        CameraSettings.from_json({"antialias": "no"}, "f.json")


@pytest.mark.parametrize(
    "data",
    [
        {"cam_names": "cam_high"},
        {"cam_names": ["cam_high"], "image_size": [60]},
        {"cam_names": ["cam_high"], "image_size": "sixty"},
        {"crops": ["cam_high"]},
        {"crops": 5},
    ],
)
def test_an_unreadable_file_form_names_the_file(data):
    with pytest.raises(UserError, match=r"^ckpt/f\.json: unreadable camera settings") as err:
        CameraSettings.from_json(data, "ckpt/f.json")
    assert "\n" not in str(err.value)


def test_parse_helpers():
    assert parse_image_size("96X128") == (96, 128) and parse_image_size((24, 32)) == (24, 32)
    assert parse_cameras(None) == () and parse_cameras("None") == ()
    assert parse_cameras("cam_high, cam_low,") == ("cam_high", "cam_low")
