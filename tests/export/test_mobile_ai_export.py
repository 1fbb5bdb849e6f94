"""The Mobile AI's recordings end to end: ``record --task_name mobile_pick_place`` (one phase:
the joint-space scripted policy acts, three cameras render) writes the ``mobileai`` layout,
and ``export`` writes it as Trossen's LeRobot plugin names the real Mobile AI's features
(``mobileai_robot``), choosing that layout by itself and refusing the kit's."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pyarrow")
pytest.importorskip("av")

from trossen_arm_mujoco.data.reader import load_episode  # noqa: E402
from trossen_arm_mujoco.export.joint_efforts import derived_external_efforts  # noqa: E402
from trossen_arm_mujoco.export.lerobot import frame_values  # noqa: E402
from trossen_arm_mujoco.robot.layout import KIT14_LAYOUT  # noqa: E402
from trossen_arm_mujoco.scripts.export_dataset import cli as export_cli  # noqa: E402
from trossen_arm_mujoco.scripts.record_sim_episodes import cli as record_cli  # noqa: E402

#: The features of Trossen's LeRobot plugin for the real Mobile AI, written down as facts
#: from TrossenRobotics/lerobot_trossen at commit ca54910f09d3bb24bc1901fe8104e7fdaa674683,
#: packages/lerobot_robot_trossen/src/lerobot_robot_trossen/mobileai.py
#: (``mobileai_robot``): observation = the bimanual arms' features (each WidowX AI
#: follower's ``joint_0.pos`` .. ``joint_5.pos``, ``left_carriage_joint.pos``, prefixed
#: ``left_`` then ``right_``; bi_widowxai_follower.py, config_widowxai_follower.py), then
#: the base's ``x.vel`` and ``theta.vel`` (``_base_ft``), then the cameras; action = the
#: arms' features then ``x.vel``, ``theta.vel``.
PLUGIN_VALUES = [
    *(f"left_joint_{i}.pos" for i in range(6)),
    "left_left_carriage_joint.pos",
    *(f"right_joint_{i}.pos" for i in range(6)),
    "right_left_carriage_joint.pos",
    "x.vel",
    "theta.vel",
]
#: The Mobile AI's cameras (Trossen's Mobile AI: cam_high on the frame, one per wrist).
CAMERAS = ["cam_high", "cam_left_wrist", "cam_right_wrist"]
H, W, STEPS = 24, 32, 12


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> Path:
    """One 12-step mobile_pick_place episode, its three cameras at 24x32."""
    root = tmp_path_factory.mktemp("mobile")
    rc = record_cli(
        [
            "--task_name",
            "mobile_pick_place",
            "--data_dir",
            "eps",
            "--root_dir",
            str(root),
            "--num_episodes",
            "1",
            "--episode_len",
            str(STEPS),
            "--image_size",
            f"{H}x{W}",
        ]
    )
    assert rc in (0, 1)  # 12 steps are too few to place the cube: record exits 1
    return root / "eps"


def test_record_writes_the_mobileai_layout(recorded):
    ep = load_episode(recorded / "episode_0.hdf5", load_images=True)
    assert ep.attrs["layout"] == "mobileai" and ep.attrs["task_name"] == "mobile_pick_place"
    assert ep.camera_names == CAMERAS
    for cam in CAMERAS:
        assert ep.images[cam].shape == (STEPS, H, W, 3) and ep.images[cam].any()
    assert ep.qpos.shape == ep.qvel.shape == ep.action.shape == (STEPS, 16)
    # the arms at their home pose, held: 6 joints and the open gripper per arm
    home = [0.0, np.pi / 12, np.pi / 12, 0.0, 0.0, 0.0, 0.044] * 2
    np.testing.assert_allclose(ep.qpos[0, :14], home, atol=1e-3)
    np.testing.assert_allclose(ep.action[:, :14], np.tile(home, (STEPS, 1)), atol=1e-3)
    # the base is driving to the table: commanded at 0.5 m/s, measured speeding up
    np.testing.assert_allclose(ep.action[:, 14], 0.5)
    assert np.all(np.abs(ep.action[:, 15]) <= 0.5)
    assert ep.qpos[0, 14] == pytest.approx(0.0, abs=1e-6) and ep.qpos[-1, 14] > 0.1
    np.testing.assert_array_equal(ep.qpos[:, 14:], ep.qvel[:, 14:])
    assert ep.env_state.shape == (STEPS, 7)


def test_export_has_the_plugins_mobileai_features(recorded, tmp_path, capsys):
    out = tmp_path / "ds"
    rc = export_cli(["--data_dir", str(recorded), "--output", str(out), "--repo_id", "me/mobile"])
    stdout = capsys.readouterr().out
    assert rc == 0 and "layout mobileai (robot_type mobileai_robot)" in stdout
    assert "measured base action" in stdout
    info = json.loads((out / "meta" / "info.json").read_text())
    feats = info["features"]
    assert feats["observation.state"]["names"] == PLUGIN_VALUES
    assert feats["action"]["names"] == PLUGIN_VALUES
    assert feats["observation.state"]["shape"] == [16]
    cams = [
        k.removeprefix("observation.images.") for k in feats if k.startswith("observation.images.")
    ]
    assert cams == CAMERAS
    assert [k for k in feats if not k.startswith("observation.images.")] == [
        "action",
        "observation.state",
        "timestamp",
        "frame_index",
        "episode_index",
        "index",
        "task_index",
    ]
    assert (info["robot_type"], info["fps"]) == ("mobileai_robot", 30)
    assert info["trossen_arm_mujoco"]["layout"] == "mobileai"
    assert info["trossen_arm_mujoco"]["base_action"] == "measured"
    ep = load_episode(recorded / "episode_0.hdf5")
    values = frame_values(ep, fps=50)
    np.testing.assert_array_equal(values["observation.state"], ep.qpos.astype(np.float32))
    # the base's action is its measured velocity, as lerobot-record stores the plugin's
    np.testing.assert_array_equal(values["action"][:, 14:], ep.qpos[:, 14:].astype(np.float32))
    assert values["action"][:, 6].max() <= 0.04  # the gripper as the controller executes it
    commanded = frame_values(ep, fps=50, base_action="commanded")
    np.testing.assert_allclose(commanded["action"][:, 14:], ep.action[:, 14:])
    np.testing.assert_array_equal(commanded["action"][:, :14], values["action"][:, :14])
    resampled = frame_values(ep)  # 30 fps: the measured base at each frame's time
    np.testing.assert_array_equal(
        resampled["action"][:, 14:], resampled["observation.state"][:, 14:]
    )


def test_commanded_base_action_and_the_per_joint_values(recorded, tmp_path, capsys):
    out = tmp_path / "ds"
    rc = export_cli(
        [
            "--data_dir",
            str(recorded),
            "--output",
            str(out),
            "--repo_id",
            "me/mobile",
            "--base_action",
            "commanded",
            "--include_velocity",
            "--include_effort",
            "--include_external_effort",
        ]
    )
    assert rc == 0, capsys.readouterr().err
    info = json.loads((out / "meta" / "info.json").read_text())
    names = info["features"]["observation.state"]["names"]
    arm = [*(f"joint_{i}" for i in range(6)), "left_carriage_joint"]
    expected = [
        f"{side}_{joint}.{kind}"
        for side in ("left", "right")
        for kind in ("pos", "vel", "eff", "ext_eff")
        for joint in arm
    ] + ["x.vel", "theta.vel"]
    assert names == expected and info["features"]["action"]["names"] == PLUGIN_VALUES
    assert info["trossen_arm_mujoco"]["base_action"] == "commanded"
    assert info["trossen_arm_mujoco"]["state_extras"] == ["vel", "eff", "ext_eff"]
    ep = load_episode(recorded / "episode_0.hdf5")
    values = frame_values(ep, fps=50, extras=("vel", "eff", "ext_eff"))
    state = values["observation.state"]
    np.testing.assert_array_equal(state[:, 7:14], ep.qvel[:, :7].astype(np.float32))
    np.testing.assert_array_equal(state[:, -2:], ep.qpos[:, 14:].astype(np.float32))
    assert np.abs(state[:, 14:21]).max() > 1.0  # the arms hold against gravity
    # the arms' 14 values on the kit's arm model (the same WidowX AI arms); the external
    # effort holds what that fixed model lacks, here the accelerating base's inertial pull
    arms = [KIT14_LAYOUT.to_vendor(x[:, :14]) for x in (ep.qpos, ep.qvel, ep.action)]
    ext = KIT14_LAYOUT.from_vendor(derived_external_efforts(*arms, ep.dt))
    np.testing.assert_array_equal(state[:, 21:28], ext[:, :7].astype(np.float32))
    np.testing.assert_array_equal(state[:, 49:56], ext[:, 7:].astype(np.float32))
    assert np.all(ext[0] == 0) and np.abs(ext).max() < 5.0


def test_base_action_is_refused_without_a_base(tmp_path, capsys, make_episode):
    make_episode(tmp_path / "eps" / "episode_0.hdf5", 4, [], seed=0)
    rc = export_cli(
        [
            "--data_dir",
            str(tmp_path / "eps"),
            "--output",
            str(tmp_path / "ds"),
            "--repo_id",
            "me/x",
            "--base_action",
            "commanded",
        ]
    )
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1
    assert "--base_action commanded is for Mobile AI recordings" in err


@pytest.mark.parametrize("layout", ["kit14", "vendor16"])
def test_the_kits_layouts_are_refused_in_one_line(recorded, tmp_path, capsys, layout):
    rc = export_cli(
        [
            "--data_dir",
            str(recorded),
            "--output",
            str(tmp_path / "x"),
            "--repo_id",
            "me/x",
            "--layout",
            layout,
        ]
    )
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1
    assert f"--layout {layout} does not fit" in err and "--layout mobileai" in err
