"""What a dataset was made with travels with it and with every checkpoint trained on it:
export writes it, refuses episodes that disagree, and readers take it back
(export.dataset_settings)."""

from __future__ import annotations

import json

import h5py
import pytest

from trossen_arm_mujoco import cli
from trossen_arm_mujoco.data.reader import load_episode
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.export.dataset_settings import (
    CHECKPOINT_FILE,
    INFO_KEY,
    DatasetSettings,
    checkpoint_settings,
    read_dataset_settings,
    reconcile,
    write_checkpoint_settings,
)
from trossen_arm_mujoco.export.lerobot_plan import plan_export
from trossen_arm_mujoco.sim.camera_crop import parse_crops
from trossen_arm_mujoco.sim.camera_settings import CameraSettings

CROP = "cam_high:217,243,150,200"


def _episode(tmp_path, make_episode, k, crops):
    path = tmp_path / f"episode_{k}.hdf5"
    make_episode(path, 3, ["cam_high"], seed=k, task_name="sim_transfer_cube")
    if crops:
        with h5py.File(path, "r+") as f:
            f.attrs["crops"] = crops
    return load_episode(path)


def test_the_plan_carries_rate_layout_cameras_size_crops_and_task(tmp_path, make_episode):
    eps = [_episode(tmp_path, make_episode, k, CROP) for k in range(2)]
    settings = plan_export(eps, None, fps=25).settings()
    assert settings == DatasetSettings(
        fps=25,
        layout="kit14",
        cameras=CameraSettings(("cam_high",), (48, 64), parse_crops(CROP)),
        task="sim_transfer_cube",
        sim_features=False,
    )
    assert DatasetSettings.from_json(settings.to_json(), "here") == settings


def test_the_plan_carries_how_the_frames_were_drawn(tmp_path, make_episode):
    eps = []
    for k in range(2):
        ep = _episode(tmp_path, make_episode, k, "")
        with h5py.File(ep.path, "r+") as f:
            f.attrs["antialias"] = False
        eps.append(load_episode(ep.path))
    cams = plan_export(eps, None).settings().cameras
    assert (cams.shadows, cams.antialias) == (True, False)
    plain = load_episode(_episode(tmp_path, make_episode, 2, "").path)
    with pytest.raises(UserError) as err:
        plan_export([*eps, plain], None)
    assert "\n" not in str(err.value)
    assert "episode_2.hdf5 was drawn with shadows on, antialiasing on but episode_0.hdf5" in str(
        err.value
    )


def test_episodes_with_other_crops_are_refused_in_one_line(tmp_path, make_episode):
    eps = [_episode(tmp_path, make_episode, 0, CROP), _episode(tmp_path, make_episode, 1, "")]
    with pytest.raises(UserError) as err:
        plan_export(eps, None)
    text = str(err.value)
    assert "\n" not in text
    assert f"episode_1.hdf5 was recorded with --crop none but episode_0.hdf5 with {CROP}" in text


def test_export_writes_the_settings_into_info_json(tmp_path, make_episode):
    data = tmp_path / "eps"
    data.mkdir()
    for k in range(2):
        _episode(data, make_episode, k, CROP)
    out = tmp_path / "ds"
    rc = cli.main(
        [
            "export",
            "--data_dir",
            str(data),
            "--output",
            str(out),
            "--repo_id",
            "me/ds",
            "--fps",
            "25",
        ]
    )
    assert rc == 0
    info = json.loads((out / "meta" / "info.json").read_text())
    assert info[INFO_KEY]["crops"] == [CROP] and info[INFO_KEY]["fps"] == 25
    assert read_dataset_settings(out).cameras.crops == parse_crops(CROP)


def test_a_checkpoint_finds_them_in_its_folder_or_through_its_dataset(tmp_path):
    cameras = CameraSettings.from_cli("cam_high", "96x128", CROP)
    settings = DatasetSettings(fps=30, layout="kit14", cameras=cameras)
    ds = tmp_path / "ds"
    (ds / "meta").mkdir(parents=True)
    (ds / "meta" / "info.json").write_text(json.dumps({"fps": 30, INFO_KEY: settings.to_json()}))
    ckpt = tmp_path / "pretrained_model"
    ckpt.mkdir()
    assert checkpoint_settings(ckpt)[0] is None
    (ckpt / "train_config.json").write_text(json.dumps({"dataset": {"root": str(ds)}}))
    found, source = checkpoint_settings(ckpt)
    assert found == settings and source.endswith("info.json")
    moved = DatasetSettings(fps=50, layout="kit14")
    write_checkpoint_settings(ckpt, moved)
    found, source = checkpoint_settings(ckpt)
    assert found == moved and source.endswith(CHECKPOINT_FILE)  # its own file first


def test_a_flag_that_repeats_is_accepted_one_that_contradicts_is_refused():
    cameras = CameraSettings.from_cli("cam_high", "96x128", CROP)
    settings = DatasetSettings(fps=30, layout="kit14", cameras=cameras)
    out = reconcile(settings, "ckpt", {"fps": None, "crops": None, "image_size": (96, 128)})
    assert out == {"fps": 30, "crops": parse_crops(CROP), "image_size": (96, 128)}
    assert reconcile(settings, "ckpt", {"fps": 30.0})["fps"] == 30
    cases = [
        ({"fps": 50.0}, "--fps 50 contradicts the checkpoint, trained with 30 (ckpt)"),
        ({"crops": ()}, f"--crop none contradicts the checkpoint, trained with {CROP}"),
        ({"image_size": (48, 64)}, "--image_size 48x64 contradicts"),
        ({"cam_names": ("cam_low",)}, "--cam_names cam_low contradicts"),
        ({"layout": "vendor16"}, "--layout vendor16 contradicts"),
    ]
    for flags, needle in cases:
        with pytest.raises(UserError, match=needle.replace("(", r"\(").replace(")", r"\)")):
            reconcile(settings, "ckpt", flags)
    assert reconcile(None, "none", {"fps": 50.0}) == {"fps": 50.0}


def test_eval_takes_the_checkpoints_settings_and_refuses_a_contradiction(tmp_path, capsys):
    ckpt = tmp_path / "pretrained_model"
    ckpt.mkdir()
    (ckpt / "config.json").write_text(
        json.dumps(
            {
                "type": "act",
                "input_features": {
                    "observation.state": {"type": "STATE", "shape": [14]},
                    "observation.images.cam_high": {"type": "VISUAL", "shape": [3, 48, 64]},
                },
                "output_features": {"action": {"type": "ACTION", "shape": [14]}},
            }
        )
    )
    write_checkpoint_settings(
        ckpt,
        DatasetSettings(
            fps=30,
            layout="kit14",
            cameras=CameraSettings.from_cli("cam_high", "48x64", CROP),
            task="sim_transfer_cube",
        ),
    )
    rc = cli.main(
        ["eval", "--policy", str(ckpt), "--fps", "50", "--output_dir", str(tmp_path / "e")]
    )
    err = capsys.readouterr().err
    assert rc == 2 and "Traceback" not in err
    assert "error: --fps 50 contradicts the checkpoint, trained with 30" in err
    from trossen_arm_mujoco.scripts.eval_policy import _settings, build_parser

    args = build_parser().parse_args(["--policy", str(ckpt), "--fps", "30"])
    settings, _ = _settings(args)
    assert settings.fps == 30 and settings.cameras.crop_texts() == (CROP,)
    assert settings.cameras.names == ("cam_high",) and settings.cameras.size == (48, 64)
    assert settings.extra["settings_source"].endswith(CHECKPOINT_FILE)


def test_the_files_of_before_the_camera_settings_object_read_the_same(tmp_path):
    """A checkpoint's trossen_settings.json as train_eval wrote it (state-only: null image
    size; cameras: a size and crops) reads into the same settings, and writes back the
    same keys."""
    old = [
        {
            "fps": 50,
            "layout": "kit14",
            "cam_names": [],
            "image_size": None,
            "crops": [],
            "task": "sim_transfer_cube",
        },
        {
            "fps": 30,
            "layout": "kit14",
            "cam_names": ["cam_high"],
            "image_size": [60, 80],
            "crops": [CROP],
            "task": "sim_transfer_cube",
            "state_extras": [],
        },
    ]
    for k, data in enumerate(old):
        ckpt = tmp_path / f"ckpt_{k}"
        ckpt.mkdir()
        (ckpt / CHECKPOINT_FILE).write_text(json.dumps(data))
        settings, _ = checkpoint_settings(ckpt)
        # written before these settings: the sim's features, no base action recorded
        assert settings.to_json() == {
            "state_extras": [],
            **data,
            "sim_features": True,
            "base_action": None,
        }
    assert settings.cameras == CameraSettings(("cam_high",), (60, 80), parse_crops(CROP))


def test_unreadable_camera_settings_are_one_line_naming_the_file(tmp_path):
    ckpt = tmp_path / "ckpt"
    ckpt.mkdir()
    for bad in ({"image_size": [0, 80]}, {"crops": ["cam_high:1,2"]}, {"cam_names": "cam_high"}):
        data = {"fps": 30, "layout": "kit14", "cam_names": ["cam_high"], **bad}
        (ckpt / CHECKPOINT_FILE).write_text(json.dumps(data))
        with pytest.raises(UserError, match="unreadable camera settings") as err:
            checkpoint_settings(ckpt)
        assert "\n" not in str(err.value) and CHECKPOINT_FILE in str(err.value)
