"""By default an export is what ``lerobot-record`` writes with Trossen's LeRobot plugin robot
of its layout: the plugin's ``robot_type``, 30 fps, ``action``, ``observation.state`` and the
cameras with the plugin's names and order, nothing else; ``--sim_features`` adds the
simulation's features.

The plugin's features are written down here as facts (``PLUGIN``), read from
TrossenRobotics/lerobot_trossen at commit ca54910f09d3bb24bc1901fe8104e7fdaa674683,
packages/lerobot_robot_trossen/src/lerobot_robot_trossen/: ``widowxai_follower.py`` (a
follower's observation is ``<joint>.pos`` for ``config.joint_names`` = ``joint_0`` ..
``joint_5``, ``left_carriage_joint``, then with ``include_velocity`` every ``<joint>.vel``,
with ``include_effort`` every ``<joint>.eff``, with ``include_external_effort`` every
``<joint>.ext_eff``; its action the ``.pos`` values), ``bi_widowxai_follower.py`` (the left
follower's with a ``left_`` prefix, then the right's), ``mobileai.py`` (the bimanual arms',
then ``x.vel``, ``theta.vel``, in both observation and action), ``config_*.py``
(``loop_rate`` 30; the names registered). ``lerobot-record`` gathers a robot's float values
into ``observation.state`` / ``action`` in that order and stores ``robot.name`` as
``robot_type``. Where the plugin is installed in the LeRobot venv
(``TROSSEN_LEROBOT_PYTHON``), ``plugin_features_check.py`` asks it directly.
"""

from __future__ import annotations

import itertools
import json
import os
import subprocess
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.export import lerobot_format as fmt
from trossen_arm_mujoco.export.lerobot_frames import controller_actions
from trossen_arm_mujoco.export.lerobot_plan import resolve_layout
from trossen_arm_mujoco.export.lerobot_state import (
    STATE_EXTRAS,
    check_state_extras,
    state_names,
    state_source,
)

#: A WidowX AI follower's joints (config_widowxai_follower.py, ``joint_names``).
JOINTS = [*(f"joint_{i}" for i in range(6)), "left_carriage_joint"]
BASE = ["x.vel", "theta.vel"]
#: The plugin's robot of each layout: (robot name, arm prefixes, base values).
PLUGIN = {
    "widowxai": ("widowxai_follower_robot", [""], []),
    "kit14": ("bi_widowxai_follower_robot", ["left_", "right_"], []),
    "mobileai": ("mobileai_robot", ["left_", "right_"], BASE),
}
#: The plugin's flags in the order its observation adds them.
FLAGS = {
    "include_velocity": "vel",
    "include_effort": "eff",
    "include_external_effort": "ext_eff",
}
LOOP_RATE = 30
SIM = ["observation.velocity", "observation.environment_state", "next.reward", "next.success"]
INDEX = ["timestamp", "frame_index", "episode_index", "index", "task_index"]


def plugin_observation(layout: str, flags: dict[str, bool]) -> list[str]:
    """The float observation names of the plugin's robot, in order."""
    _, prefixes, base = PLUGIN[layout]
    names: list[str] = []
    for prefix in prefixes:
        kinds = ["pos"] + [kind for flag, kind in FLAGS.items() if flags.get(flag)]
        names += [f"{prefix}{joint}.{kind}" for kind in kinds for joint in JOINTS]
    return names + base


def plugin_action(layout: str) -> list[str]:
    _, prefixes, base = PLUGIN[layout]
    return [f"{prefix}{joint}.pos" for prefix in prefixes for joint in JOINTS] + base


def _flag_sets() -> list[dict[str, bool]]:
    return [dict(zip(FLAGS, bits)) for bits in itertools.product((False, True), repeat=3)]


def test_the_flags_are_the_plugins():
    assert dict(zip(FLAGS, FLAGS.values())) == {v: k for k, v in STATE_EXTRAS.items()}


@pytest.mark.parametrize("layout", list(PLUGIN))
def test_features_of_every_robot_and_flag_set_are_the_plugins(layout):
    for flags in _flag_sets():
        extras = tuple(kind for flag, kind in FLAGS.items() if flags[flag])
        assert check_state_extras(layout, extras) == extras
        names = state_names(layout, extras) if extras else None
        feats = fmt.build_features(
            {"cam_high": (48, 64, 3)}, {"cam_high": {}}, True, layout, [], names
        )
        assert list(feats) == ["action", "observation.state", "observation.images.cam_high", *INDEX]
        assert feats["observation.state"]["names"] == plugin_observation(layout, flags)
        assert feats["action"]["names"] == plugin_action(layout)
        assert feats["observation.state"]["shape"] == [len(plugin_observation(layout, flags))]
    info = fmt.build_info(feats, LOOP_RATE, 1, 1, 1, layout)
    assert info["robot_type"] == PLUGIN[layout][0]


def test_sim_features_add_exactly_the_simulations():
    feats = fmt.build_features({}, {}, True, "kit14", ["box_x"], None, sim_features=True)
    assert list(feats) == ["action", "observation.state", *SIM, *INDEX]
    assert list(fmt.SIM_FEATURES) == SIM
    assert feats["observation.velocity"]["names"] == [
        n.replace(".pos", ".vel") for n in plugin_action("kit14")
    ]


def test_vendor16_has_no_plugin_names():
    with pytest.raises(UserError, match="leave out --layout vendor16 or the flag"):
        check_state_extras("vendor16", ("ext_eff",))
    assert fmt.ROBOT_TYPES["vendor16"] == "trossen_ai_stationary"


def _single_arm(steps: int = 6) -> SimpleNamespace:
    """A single arm's recording as the loader gives it (``data.schema``: layout attribute
    ``widowxai``, 7 values a row: 6 joints, the gripper carriage)."""
    rng = np.random.default_rng(0)
    qpos = np.tile([0.0, 0.3, 0.3, 0.0, 0.0, 0.0, 0.03], (steps, 1))
    qpos[:, :6] += rng.normal(scale=0.01, size=(steps, 6))
    return SimpleNamespace(
        qpos=qpos,
        qvel=np.zeros((steps, 7)),
        action=qpos.copy(),
        dt=0.02,
        attrs={"layout": "widowxai"},
        path=Path("episode_0.hdf5"),
    )


def test_a_single_arm_recording_exports_as_widowxai():
    ep = _single_arm()
    assert resolve_layout([ep], None) == "widowxai"
    with pytest.raises(UserError, match=r"--layout kit14 does not fit .* \(one WidowX AI arm\)"):
        resolve_layout([ep], "kit14")
    extras = ("vel", "eff", "ext_eff")
    state = state_source(ep, "widowxai", extras)
    assert state.shape == (6, 28)
    np.testing.assert_array_equal(state[:, :7], ep.qpos)
    np.testing.assert_array_equal(state[:, 7:14], 0.0)
    assert np.abs(state[:, 14:20]).max() > 0.1  # the arm holds against gravity
    assert state_names("widowxai", extras) == plugin_observation(
        "widowxai", dict.fromkeys(FLAGS, True)
    )
    assert fmt.layout_values("widowxai", ep.action).shape == (6, 7)
    opened = np.full((2, 7), 0.044)  # the gripper as the arm controller executes it
    np.testing.assert_array_equal(controller_actions(opened, "widowxai")[:, 6], 0.04)
    np.testing.assert_array_equal(controller_actions(opened, "widowxai")[:, :6], 0.044)


def test_a_recorded_single_arm_episode_exports_as_the_plugins_follower(tmp_path):
    """``record --task_name push`` (one arm, 7 values a row), exported by default and with
    every per-joint flag: the single follower's robot type, names and order; the arm moves in
    free space, so its external efforts are about zero while it holds against gravity."""
    pytest.importorskip("pyarrow")
    pytest.importorskip("av")
    from trossen_arm_mujoco.scripts.export_dataset import cli
    from trossen_arm_mujoco.scripts.record_sim_episodes import cli as record_cli

    data = tmp_path / "eps"
    args = ["--task_name", "push", "--data_dir", str(data), "--num_episodes", "1"]
    assert record_cli([*args, "--episode_len", "30", "--cam_names", "none"]) in (0, 1)
    base = ["--data_dir", str(data), "--repo_id", "me/arm"]
    assert cli([*base, "--output", str(tmp_path / "plain")]) == 0
    info = json.loads((tmp_path / "plain/meta/info.json").read_text())
    assert (info["robot_type"], info["fps"]) == ("widowxai_follower_robot", LOOP_RATE)
    assert list(info["features"]) == ["action", "observation.state", *INDEX]
    assert info["features"]["observation.state"]["names"] == plugin_observation("widowxai", {})
    assert info["features"]["action"]["names"] == plugin_action("widowxai")
    flags = [f"--{flag}" for flag in FLAGS]
    assert cli([*base, "--output", str(tmp_path / "all"), *flags]) == 0
    info = json.loads((tmp_path / "all/meta/info.json").read_text())
    every = dict.fromkeys(FLAGS, True)
    assert info["features"]["observation.state"]["names"] == plugin_observation("widowxai", every)
    pq = pytest.importorskip("pyarrow.parquet")
    state = np.array(
        pq.read_table(tmp_path / "all/data/chunk-000/file-000.parquet")[
            "observation.state"
        ].to_pylist()
    )
    assert state.shape == (18, 28)  # floor(30 * 30 / 50) frames
    assert np.abs(state[:, 14:21]).max() > 1.0 and np.abs(state[:, 21:28]).max() < 0.01


def test_the_default_export_is_the_plugins_and_the_flag_adds_the_sims(recorded, tmp_path):
    pytest.importorskip("pyarrow")
    pytest.importorskip("av")
    from trossen_arm_mujoco.scripts.export_dataset import cli

    cams = ["observation.images.cam_high", "observation.images.cam_left_wrist"]
    base = ["--data_dir", str(recorded), "--repo_id", "me/ds", "--vcodec", "h264"]
    assert cli([*base, "--output", str(tmp_path / "plain")]) == 0
    info = json.loads((tmp_path / "plain/meta/info.json").read_text())
    assert (info["robot_type"], info["fps"]) == ("bi_widowxai_follower_robot", LOOP_RATE)
    assert list(info["features"]) == ["action", "observation.state", *cams, *INDEX]
    assert info["features"]["observation.state"]["names"] == plugin_observation("kit14", {})
    assert info["trossen_arm_mujoco"]["sim_features"] is False

    assert cli([*base, "--output", str(tmp_path / "sim"), "--sim_features"]) == 0
    info = json.loads((tmp_path / "sim/meta/info.json").read_text())
    assert info["fps"] == LOOP_RATE
    assert list(info["features"]) == ["action", "observation.state", *cams, *SIM, *INDEX]
    assert info["trossen_arm_mujoco"]["sim_features"] is True


@pytest.mark.once
def test_the_plugin_itself_agrees(tmp_path):
    """Where Trossen's plugin is importable in the LeRobot venv, its robots' own feature
    dicts (through LeRobot's ``hw_to_dataset_features``) are the export's."""
    python = os.environ.get("TROSSEN_LEROBOT_PYTHON", "")
    if not python or not Path(python).is_file():
        pytest.skip("TROSSEN_LEROBOT_PYTHON is not set to a Python with LeRobot")
    check = Path(__file__).with_name("plugin_features_check.py")
    env = {**os.environ, "HF_LEROBOT_CALIBRATION": str(tmp_path / "calibration")}
    proc = subprocess.run(
        [python, str(check)], capture_output=True, text=True, timeout=300, env=env
    )
    lines = [line for line in proc.stdout.splitlines() if line.startswith("RESULT ")]
    assert proc.returncode == 0 and lines, proc.stderr[-3000:]
    got = json.loads(lines[-1][len("RESULT ") :])
    if "unavailable" in got:
        pytest.skip(f"Trossen's plugin is not importable there: {got['unavailable']}")
    for layout, (robot, _, _) in PLUGIN.items():
        for flags in _flag_sets():
            key = f"{robot}:{','.join(f for f, on in flags.items() if on)}"
            extras = tuple(kind for flag, kind in FLAGS.items() if flags[flag])
            ours = fmt.build_features({}, {}, False, layout, None, state_names(layout, extras))
            theirs = got["features"][key]
            assert theirs["name"] == robot and theirs["loop_rate"] == LOOP_RATE
            for feature in ("action", "observation.state"):
                assert theirs[feature]["names"] == ours[feature]["names"], (key, feature)
                assert list(theirs[feature]["shape"]) == ours[feature]["shape"], (key, feature)
