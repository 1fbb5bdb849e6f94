"""SamplerSettings: one checked object describes how every front door builds a sampler."""

import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.sim.looks import SceneLooks
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings


def test_defaults_build_the_plain_joint_world():
    s = SamplerSettings()
    assert (s.command_mode, s.flavour, s.camera_names) == ("joint_position", "joint", ())
    assert (s.height, s.width, s.randomize, s.floor_margin) == (480, 640, False, 0.0)
    assert s.looks == SceneLooks()


def test_values_are_normalised():
    s = SamplerSettings(camera_names=["cam_high"], floor_margin=0)
    assert s.camera_names == ("cam_high",) and isinstance(s.floor_margin, float)
    assert SamplerSettings(camera_names="cam_low").camera_names == ("cam_low",)
    assert SamplerSettings(looks=None).looks == SceneLooks()


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"flavour": "mocap"}, "flavour"),
        ({"height": 0}, "height must be in"),
        ({"width": 2.5}, "width must be a whole number"),
        ({"height": True}, "height must be a whole number"),
        ({"randomize": "yes"}, "randomize must be True or False"),
        ({"floor_margin": -0.01}, "safety margin"),
        ({"floor_margin": float("nan")}, "floor_margin"),
        ({"camera_names": [1]}, "camera_names"),
        ({"looks": {"shadows": False}}, "looks must be a SceneLooks"),
        ({"command_mode": 3}, "command_mode"),
    ],
)
def test_bad_values_are_one_line_user_errors(kwargs, message):
    with pytest.raises(UserError, match=message) as err:
        SamplerSettings(**kwargs)
    assert "\n" not in str(err.value)


def test_replace_checks_names_and_values():
    s = SamplerSettings().replace(flavour="ee", randomize=True)
    assert (s.flavour, s.randomize) == ("ee", True)
    with pytest.raises(UserError, match="camera_names"):
        SamplerSettings().replace(cameras=["cam_high"])
    with pytest.raises(UserError, match="height"):
        SamplerSettings().replace(height=-1)


def test_make_sampler_takes_settings_not_loose_keywords():
    with registry.make_sampler("reach", SamplerSettings(command_mode="ee_delta")) as sampler:
        assert sampler.settings.command_mode == "ee_delta"
        assert sampler.scene.robots["wxai"].config.command_mode["arm"] == "ee_delta"
    with pytest.raises(UserError, match="command_mode is a sampler setting"):
        registry.make_sampler("reach", command_mode="ee_delta")
    with pytest.raises(UserError, match="settings must be a SamplerSettings"):
        registry.make_sampler("reach", {"flavour": "joint"})
