"""The record command's arguments: each checked alone, one line per mistake, and together into
the run's settings (no episode recorded here)."""

from __future__ import annotations

import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.scripts.common_options import (
    MAX_EPISODE_LEN,
    camera_names,
    dataset_folder,
    image_size,
)
from trossen_arm_mujoco.scripts.record_args import build_parser, record_options


def _args(*extra: str):
    return build_parser().parse_args(["--data_dir", "d", *extra])


def test_image_size():
    assert image_size("480x640") == (480, 640) and image_size("12X16") == (12, 16)
    for bad, match in [
        ("big", "must look like 480x640"),
        ("481x640", "within 1x1"),
        ("0x5", "within 1x1"),
    ]:
        with pytest.raises(UserError, match=match):
            image_size(bad)


def test_camera_names():
    assert camera_names(None, "sim_transfer_cube")[0] == "cam_high"
    assert camera_names("none", "sim_transfer_cube") == ()
    assert camera_names(" cam_low ,cam_high", "sim_transfer_cube") == ("cam_low", "cam_high")
    with pytest.raises(UserError, match="unknown camera 'cam_top'.*cam_high"):
        camera_names("cam_top", "sim_transfer_cube")
    with pytest.raises(UserError, match="twice"):
        camera_names("cam_low,cam_low", "sim_transfer_cube")
    with pytest.raises(UserError, match="empty"):
        camera_names(" , ", "sim_transfer_cube")


def test_dataset_folder_is_created_under_the_root(tmp_path):
    folder = dataset_folder(str(tmp_path), "a/b")
    assert folder == tmp_path / "a" / "b" and folder.is_dir()
    (tmp_path / "file").write_text("")
    with pytest.raises(UserError, match="cannot write to"):
        dataset_folder(str(tmp_path / "file"), "d")


def test_options_from_the_task_config_and_the_flags():
    args = _args("--task_name", "transfer_cube", "--cam_names", "none", "--seed", "7")
    options = record_options(args)
    assert args.task_name == "sim_transfer_cube"  # the alias, resolved
    s = options.settings
    assert (s.task_name, s.episode_len, s.cam_names, s.base_seed) == (
        "sim_transfer_cube",
        600,
        (),
        7,
    )
    assert options.num_episodes == 1 and not options.onscreen


@pytest.mark.parametrize(
    ("extra", "match"),
    [
        (["--task_name", "sim_stack"], "unknown task 'sim_stack'"),
        (["--episode_len", str(MAX_EPISODE_LEN + 1)], "--episode_len must be in 1 .. "),
        (["--num_episodes", "0"], "--num_episodes must be in 1 .. "),
        (["--seed", "-1"], "--seed must be in 0 .. 2\\*\\*63-1"),
        (["--num_workers", "0"], "--num_workers must be at least 1"),
        (["--ray_address", "auto"], "--ray_address needs --engine ray"),
        (["--onscreen_render", "--num_workers", "2"], "--onscreen_render needs --engine local"),
        (["--image_size", "1x"], "--image_size"),
    ],
)
def test_each_mistake_is_one_line(extra, match):
    with pytest.raises(UserError, match=match) as err:
        record_options(_args(*extra))
    assert "\n" not in str(err.value)
