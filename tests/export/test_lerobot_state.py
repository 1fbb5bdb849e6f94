"""``export --include_velocity / --include_effort``: each joint's ``.vel`` and ``.eff`` in
``observation.state``, named as Trossen's LeRobot plugin names a WidowX AI follower's values,
velocities from the recorded qvel and efforts equal to the simulation's actuator forces."""

from __future__ import annotations

import copy
import json
import os
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.collect.pipeline import EpisodeRecorder, RecordSettings
from trossen_arm_mujoco.data.reader import load_episode
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.export.dataset_settings import DatasetSettings
from trossen_arm_mujoco.export.joint_efforts import derived_efforts, derived_external_efforts
from trossen_arm_mujoco.export.lerobot import frame_values
from trossen_arm_mujoco.export.lerobot_state import check_state_extras, state_names

#: The plugin's names (lerobot_robot_trossen: a follower's ``<joint>.pos``, then with
#: include_velocity ``<joint>.vel``, with include_effort ``<joint>.eff``, for joint_0..5 and
#: left_carriage_joint; the kit prefixes the left follower's with ``left_``, then the right's).
JOINTS = [*(f"joint_{i}" for i in range(6)), "left_carriage_joint"]
PLUGIN_NAMES = [
    f"{side}_{joint}.{kind}"
    for side in ("left", "right")
    for kind in ("pos", "vel", "eff")
    for joint in JOINTS
]
#: Where each kit value comes from in the HDF5 files' 16 (per arm: 6 joints, the actuated finger).
KIT14_FROM_16 = [0, 1, 2, 3, 4, 5, 7, 8, 9, 10, 11, 12, 13, 15]
STEPS = 60


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """A 60-step transfer-cube episode (no cameras) and the simulation's actuator forces at
    each recorded observation (``qfrc_actuator`` of the state the file holds for step t)."""
    root = tmp_path_factory.mktemp("state") / "eps"
    root.mkdir()
    live: dict[int, np.ndarray] = {}

    def hook(t, obs, scene):  # the observation of step t + 1: forces at that state
        data = copy.copy(scene.data)  # the recording's own data stays untouched
        mujoco.mj_forward(scene.model, data)
        live[t + 1] = data.qfrc_actuator.copy()

    recorder = EpisodeRecorder(RecordSettings(episode_len=STEPS), step_hook=hook)
    try:
        recorder.record(0, root / "episode_0.hdf5")
        model = recorder.joint_scene.model
    finally:
        recorder.close()
    names = [
        f"{side}/{joint}"
        for side in ("left", "right")
        for joint in (*JOINTS[:6], "right_carriage_joint", "left_carriage_joint")
    ]
    dofs = [int(model.joint(n).dofadr[0]) for n in names]
    forces = {t: f[dofs] for t, f in live.items()}
    return root, load_episode(root / "episode_0.hdf5"), forces


def test_names_are_the_plugins():
    assert state_names("kit14", ("vel", "eff")) == PLUGIN_NAMES
    assert state_names("kit14", ("vel",)) == [n for n in PLUGIN_NAMES if not n.endswith(".eff")]
    assert state_names("kit14", ("eff",)) == [n for n in PLUGIN_NAMES if not n.endswith(".vel")]
    assert state_names("kit14") == [n for n in PLUGIN_NAMES if n.endswith(".pos")]


def test_extras_need_the_kit_layout():
    with pytest.raises(UserError, match="--include_velocity and --include_effort name the"):
        check_state_extras("vendor16", ("vel", "eff"))
    with pytest.raises(UserError, match="in order"):
        check_state_extras("kit14", ("eff", "vel"))


def test_efforts_are_the_simulations_actuator_forces(recording):
    _, ep, live = recording
    eff = derived_efforts(ep.qpos, ep.qvel, ep.action)
    steps = sorted(t for t in live if t < ep.num_steps)
    assert len(steps) == STEPS - 1
    expected = np.array([live[t] for t in steps])
    # the arms move and hold against gravity: efforts of several Nm, all of them matched
    assert np.abs(expected).max() > 2.0 and np.abs(expected).std(axis=0).max() > 1.0
    np.testing.assert_allclose(eff[steps], expected, rtol=1e-3, atol=2e-3)


def test_frame_values_hold_positions_velocities_efforts(recording):
    _, ep, _ = recording
    values = frame_values(ep, fps=50, extras=("vel", "eff"))  # the recording rate
    state = values["observation.state"]
    assert state.shape == (ep.num_steps, 42) and state.dtype == np.float32
    eff = derived_efforts(ep.qpos, ep.qvel, ep.action)[:, KIT14_FROM_16]
    for side in range(2):
        block = state[:, 21 * side : 21 * (side + 1)]
        cols = KIT14_FROM_16[7 * side : 7 * (side + 1)]
        assert np.array_equal(block[:, :7], np.float32(ep.qpos)[:, cols])
        assert np.array_equal(block[:, 7:14], np.float32(ep.qvel)[:, cols])
        assert np.array_equal(block[:, 14:], np.float32(eff[:, 7 * side : 7 * (side + 1)]))
    plain = frame_values(ep, fps=50)
    assert np.array_equal(plain["action"], values["action"])
    assert plain["observation.state"].shape == (ep.num_steps, 14)


def test_settings_carry_the_extras():
    s = DatasetSettings(fps=30, layout="kit14", state_extras=("vel", "eff"))
    assert DatasetSettings.from_json(s.to_json(), "x") == s
    assert DatasetSettings.from_json({"fps": 30, "layout": "kit14"}, "x").state_extras == ()


@pytest.mark.once
def test_lerobot_loads_the_export_with_both_flags(recording, tmp_path):
    pytest.importorskip("pyarrow")
    python = os.environ.get("TROSSEN_LEROBOT_PYTHON", "")
    if not python or not Path(python).is_file():
        pytest.skip("TROSSEN_LEROBOT_PYTHON is not set to a Python with lerobot[dataset]")
    root, ep, _ = recording
    out = tmp_path / "ds"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "trossen_arm_mujoco.scripts.export_dataset",
            "--data_dir",
            str(root),
            "--output",
            str(out),
            "--repo_id",
            "test/state",
            "--include_velocity",
            "--include_effort",
            "--fps",
            "50",  # the recording rate: the velocities are the file's
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    assert "the state with <joint>.vel, <joint>.eff" in proc.stdout
    env = {**os.environ, "HF_HUB_OFFLINE": "1", "HF_HOME": str(tmp_path / "hf_home")}
    check = Path(__file__).with_name("lerobot_state_check.py")
    proc = subprocess.run(
        [python, str(check), str(out), "test/state"],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    lines = [line for line in proc.stdout.splitlines() if line.startswith("RESULT ")]
    assert proc.returncode == 0 and lines, proc.stderr[-3000:]
    got = json.loads(lines[-1][len("RESULT ") :])
    assert got["names"] == PLUGIN_NAMES and got["shape"] == [42]
    assert got["action_names"] == [n for n in PLUGIN_NAMES if n.endswith(".pos")]
    state = np.array(got["state"], dtype=np.float32)
    values = frame_values(ep, fps=50, extras=("vel", "eff"))
    assert np.array_equal(state, values["observation.state"])
    vel = state[:, [PLUGIN_NAMES.index(f"left_joint_{i}.vel") for i in range(6)]]
    assert np.array_equal(vel, np.float32(ep.qvel)[:, :6])
    info = json.loads((out / "meta" / "info.json").read_text())
    assert info["trossen_arm_mujoco"]["state_extras"] == ["vel", "eff"]


def test_eval_refuses_a_checkpoint_trained_on_the_wider_state(tmp_path, capsys):
    from trossen_arm_mujoco.export.dataset_settings import write_checkpoint_settings
    from trossen_arm_mujoco.scripts.eval_policy import cli as eval_cli

    folder = tmp_path / "pretrained_model"
    folder.mkdir()
    (folder / "config.json").write_text(
        json.dumps(
            {
                "input_features": {"observation.state": {"type": "STATE", "shape": [42]}},
                "output_features": {"action": {"type": "ACTION", "shape": [14]}},
            }
        )
    )
    settings = DatasetSettings(fps=50, layout="kit14", state_extras=("vel", "eff"))
    write_checkpoint_settings(folder, settings)
    rc = eval_cli(["--policy", str(folder), "--output_dir", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1, err
    assert "per-joint vel/eff values" in err[0] and "--include_velocity" in err[0]


def test_external_efforts_are_zero_in_free_motion_and_see_a_push(recording):
    """The 60 recorded steps touch nothing: the arms' own model explains every velocity, so
    the external effort is zero (float32 rounding of the file aside) while the efforts are
    several Nm. A velocity the model cannot explain shows as M dv / dt on its joints."""
    _, ep, _ = recording
    ext = derived_external_efforts(ep.qpos, ep.qvel, ep.action, ep.dt)
    assert ext.shape == (ep.num_steps, 16) and np.all(ext[0] == 0)
    assert np.abs(ext).max() < 1e-3
    pushed = np.array(ep.qvel, dtype=np.float64)
    pushed[30, 1] += 0.05  # left joint_1 faster than the arm could make itself
    kicked = derived_external_efforts(ep.qpos, pushed, ep.action, ep.dt)
    assert (
        abs(kicked[30, 1]) > 0.05 and np.abs(kicked[30, 8:]).max() < 1e-3  # the right arm
    )
    values = frame_values(ep, fps=50, extras=("ext_eff",))
    names = state_names("kit14", ("ext_eff",))
    assert names[7:14] == [f"left_{j}.ext_eff" for j in JOINTS]
    np.testing.assert_array_equal(
        values["observation.state"][:, 7:14], ext[:, KIT14_FROM_16[:7]].astype(np.float32)
    )
