"""The episode tools on Mobile AI recordings (``mobile_pick_place``, layout ``mobileai``):
``visualize`` plots them under the layout's names, ``replay-real`` refuses them in one line
before any driver exists (no address outside loopback is ever contacted), ``export
--include_velocity`` / ``--include_effort`` / ``--include_external_effort`` add the plugin's
per-joint values for them as for the kit, and ``record --inject_noise`` jitters the scripted
policy's grasp and place points."""

from __future__ import annotations

import json
import socket
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from trossen_arm_mujoco import cli
from trossen_arm_mujoco.data.reader import load_episode
from trossen_arm_mujoco.data.video import joint_labels
from trossen_arm_mujoco.real import driver as driver_module
from trossen_arm_mujoco.robot.layout import MOBILEAI_LAYOUT

TASK = "mobile_pick_place"


@pytest.fixture(autouse=True)
def offline(monkeypatch: pytest.MonkeyPatch) -> None:
    """Fail on a connection to any address outside loopback, and on configuring an arm."""

    def loopback(address: Any) -> bool:
        if isinstance(address, (str, bytes)):  # a unix socket
            return True
        host = str(address[0])
        return host in ("localhost", "::1") or host.startswith("127.")

    def guard(original):
        def connect(self, address, *args, **kwargs):
            if not loopback(address):
                pytest.fail(f"a test connected to {address}")
            return original(self, address, *args, **kwargs)

        return connect

    monkeypatch.setattr(socket.socket, "connect", guard(socket.socket.connect))
    monkeypatch.setattr(socket.socket, "connect_ex", guard(socket.socket.connect_ex))
    real_create = socket.create_connection

    def create_connection(address, *args, **kwargs):
        if not loopback(address):
            pytest.fail(f"a test connected to {address}")
        return real_create(address, *args, **kwargs)

    monkeypatch.setattr(socket, "create_connection", create_connection)
    monkeypatch.setattr(
        driver_module.TrossenArmDriver,
        "configure",
        lambda self, *a, **k: pytest.fail("an arm was configured"),
    )


def _record(root: Path, name: str, steps: int, *extra: str) -> Path:
    rc = cli.main(
        [
            "record",
            "--task_name",
            TASK,
            "--data_dir",
            name,
            "--root_dir",
            str(root),
            "--num_episodes",
            "1",
            "--episode_len",
            str(steps),
            *extra,
        ]
    )
    assert rc in (0, 1)  # too few steps to place the cube: record exits 1
    return root / name


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> Path:
    """One 12-step mobile_pick_place episode, its three cameras at 24x32."""
    root = tmp_path_factory.mktemp("mobile")
    return _record(root, "eps", 12, "--image_size", "24x32")


def _one_line(rc: int, capsys) -> str:
    out = capsys.readouterr()
    lines = [ln for ln in out.err.splitlines() if ln.strip()]
    assert rc == 2 and len(lines) == 1 and "Traceback" not in out.err, out.err
    return lines[0]


def test_visualize_plots_the_mobileai_values_under_their_names(recorded, tmp_path, capsys):
    ep = load_episode(recorded / "episode_0.hdf5")
    names, units = joint_labels(ep)
    assert names == MOBILEAI_LAYOUT.names and names[14:] == ("x.vel", "theta.vel")
    assert units[14:] == ("m/s", "rad/s")
    out = tmp_path / "vid"
    rc = cli.main(["visualize", "--data_dir", str(recorded), "--output_dir", str(out)])
    assert rc == 0, capsys.readouterr().err
    assert (out / "episode_0.mp4").stat().st_size > 0
    assert (out / "episode_0_joints.png").stat().st_size > 0


@pytest.mark.parametrize(
    "flags",
    [
        ["--backend", "sim"],
        ["--backend", "sim", "--dry_run"],
        ["--dry_run"],
        ["--backend", "trossen"],
    ],
    ids=["sim", "sim-dry", "trossen-dry", "trossen"],
)
def test_replay_real_refuses_a_mobile_recording_in_one_line(recorded, flags, capsys):
    rc = cli.main(["replay-real", "--data_dir", str(recorded), "--no_progress", *flags])
    line = _one_line(rc, capsys)
    if flags == ["--backend", "trossen"] and "Mobile AI" not in line:
        pytest.skip(f"the trossen backend stops earlier here: {line}")  # no trossen_arm
    assert "is a Mobile AI recording (layout mobileai" in line
    assert "has no base driver" in line


@pytest.mark.parametrize(
    ("flags", "kinds"),
    [
        (["--include_velocity"], ["vel"]),
        (["--include_effort", "--include_external_effort"], ["eff", "ext_eff"]),
    ],
)
def test_export_extras_name_a_mobile_recordings_values_as_the_plugin(
    recorded, tmp_path, flags, kinds, capsys
):
    pytest.importorskip("pyarrow")
    out = tmp_path / "ds"
    rc = cli.main(
        ["export", "--data_dir", str(recorded), "--output", str(out), "--repo_id", "me/m", *flags]
    )
    assert rc == 0, capsys.readouterr().err
    info = json.loads((out / "meta" / "info.json").read_text())
    arm = [*(f"joint_{i}" for i in range(6)), "left_carriage_joint"]
    # mobileai_robot: each arm's .pos, then its extras; then the base (lerobot_robot_trossen)
    expected = [
        f"{side}_{joint}.{kind}"
        for side in ("left", "right")
        for kind in ("pos", *kinds)
        for joint in arm
    ] + ["x.vel", "theta.vel"]
    assert info["features"]["observation.state"]["names"] == expected


def test_record_inject_noise_jitters_the_grasp_and_place_points(tmp_path):
    """Same seed with and without --inject_noise: the same drive (the noise is in the arm's
    IK targets only), then other arm targets once the arm is planned (by step 270)."""
    steps = 300
    plain = load_episode(
        _record(tmp_path, "plain", steps, "--cam_names", "none") / "episode_0.hdf5"
    )
    noisy = load_episode(
        _record(tmp_path, "noisy", steps, "--cam_names", "none", "--inject_noise")
        / "episode_0.hdf5"
    )
    assert bool(noisy.attrs["inject_noise"]) and not bool(plain.attrs["inject_noise"])
    np.testing.assert_array_equal(plain.action[:, 14:], noisy.action[:, 14:])  # the drive
    differ = np.flatnonzero(np.abs(plain.action[:, :7] - noisy.action[:, :7]).max(axis=1) > 0)
    assert differ.size and differ[0] <= 271, differ[:3]
    # a few mm on the tool, so small joint differences
    assert np.abs(plain.action[:, :6] - noisy.action[:, :6]).max() < 0.1
