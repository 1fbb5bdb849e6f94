"""Recorded episodes read the way ACT-style training code reads them.

ACT's ``EpisodicDataset`` opens each ``episode_<k>.hdf5`` with h5py and reads
``root.attrs['sim']``, ``/observations/qpos`` and ``/observations/qvel`` at a random start
step, the images of each camera at that step and ``/action`` from that step on; its
normalization statistics are means and standard deviations over all episodes. The network
is float32, so float64 data (schema version 1) breaks it with a dtype error while float32
data (schema version 2, as the vendor files) goes through. The loader below is written
from that description, not copied.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

torch = pytest.importorskip("torch")

from trossen_arm_mujoco.collect.pipeline import EpisodeRecorder, RecordSettings  # noqa: E402
from trossen_arm_mujoco.data.reader import load_episode  # noqa: E402

CAMS = ("cam_high",)
FIXTURES = Path(__file__).parents[1] / "fixtures"


@pytest.fixture(scope="module")
def dataset(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("act")
    rec = EpisodeRecorder(RecordSettings(episode_len=30, cam_names=CAMS, height=24, width=32))
    try:
        for k in range(2):
            rec.record(k, folder / f"episode_{k}.hdf5")
    finally:
        rec.close()
    return folder


def norm_stats(paths: list[Path]) -> dict[str, np.ndarray]:
    """Mean and std of qpos and action over every step of every episode (std >= 0.01)."""
    qpos, action = [], []
    for path in paths:
        with h5py.File(path, "r") as root:
            qpos.append(torch.from_numpy(root["/observations/qpos"][()]))
            action.append(torch.from_numpy(root["/action"][()]))
    stats = {}
    for name, data in (("qpos", torch.stack(qpos)), ("action", torch.stack(action))):
        stats[f"{name}_mean"] = data.mean(dim=(0, 1)).numpy()
        stats[f"{name}_std"] = torch.clip(data.std(dim=(0, 1)), 1e-2, None).numpy()
    return stats


def act_item(path: Path, cams, stats, rng: np.random.Generator):
    """(image (K, 3, H, W), normalized qpos (16,), normalized padded action (T, 16), pad)."""
    with h5py.File(path, "r") as root:
        assert bool(root.attrs["sim"])
        episode_len = root["/action"].shape[0]
        start_ts = int(rng.integers(episode_len))
        qpos = root["/observations/qpos"][start_ts]
        root["/observations/qvel"][start_ts]  # read as ACT does, unused by the policy
        images = [root[f"/observations/images/{cam}"][start_ts] for cam in cams]
        action = root["/action"][start_ts:]
    padded = np.zeros((episode_len, action.shape[1]), dtype=np.float32)
    padded[: len(action)] = action
    is_pad = np.arange(episode_len) >= len(action)
    image = torch.einsum("khwc->kchw", torch.from_numpy(np.stack(images))).float() / 255.0
    s = {name: torch.from_numpy(value) for name, value in stats.items()}
    qpos_t = (torch.from_numpy(qpos).float() - s["qpos_mean"]) / s["qpos_std"]
    action_t = (torch.from_numpy(padded) - s["action_mean"]) / s["action_std"]
    return image, qpos_t, action_t, torch.from_numpy(is_pad)


def _feed(paths: list[Path], cams) -> None:
    stats = norm_stats(paths)
    rng = np.random.default_rng(0)
    qpos_layer = torch.nn.Linear(16, 8)  # float32, like ACT's input projections
    action_layer = torch.nn.Linear(16, 8)
    for path in paths:
        image, qpos, action, is_pad = act_item(path, cams, stats, rng)
        assert qpos_layer(qpos).dtype == torch.float32
        assert action_layer(action).dtype == torch.float32
        assert image.dtype == torch.float32 and image.shape[1] == 3
        assert bool(is_pad[0]) is False


def test_recorded_episodes_feed_a_float32_network(dataset):
    paths = sorted(dataset.glob("episode_*.hdf5"))
    with h5py.File(paths[0], "r") as root:
        for name in ("/observations/qpos", "/observations/qvel", "/action"):
            assert root[name].dtype == np.float32, name
        assert root["/observations/images/cam_high"].dtype == np.uint8
    _feed(paths, CAMS)


def test_vendor_files_feed_the_same_loader():
    _feed([FIXTURES / "vendor_episode_5steps_4cams.hdf5"], ("cam_high", "cam_left_wrist"))


def test_float64_files_break_that_loader(dataset, tmp_path):
    """Why the dtype matters: the same loader on a schema-1 (float64) copy fails."""
    old = tmp_path / "episode_0.hdf5"
    with h5py.File(dataset / "episode_0.hdf5", "r") as src, h5py.File(old, "w") as dst:
        for name in ("observations/qpos", "observations/qvel", "action"):
            dst[name] = src[name][()].astype(np.float64)
        dst["observations/images/cam_high"] = src["observations/images/cam_high"][()]
        dst.attrs["sim"] = True
    with pytest.raises(RuntimeError, match="dtype"):
        _feed([old], CAMS)


def test_real_replay_validates_the_float32_episodes(dataset, capsys):
    from trossen_arm_mujoco.real.validate import validate_actions
    from trossen_arm_mujoco.scripts.replay_episode_real import main as replay_main

    for k in range(2):
        ep = load_episode(dataset / f"episode_{k}.hdf5")
        assert ep.attrs["real_replay_checked"]  # checked on the stored float32 actions
        validate_actions(ep.action, 50.0)
    rc = replay_main(["--data_dir", str(dataset), "--episode_idx", "1", "--dry_run"])
    assert rc in (0, None), capsys.readouterr().err
