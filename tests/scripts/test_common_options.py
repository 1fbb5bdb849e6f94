"""The flags several commands share are declared once (``scripts.common_options``): the same
type, default and help shape in every command that takes them."""

from __future__ import annotations

import argparse

import pytest

from trossen_arm_mujoco.constants import ROOT_DIR
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.scripts import (
    common_options,
    eval_policy,
    export_dataset,
    record_args,
    serve,
    teleop,
)

PARSERS = {
    "record": record_args.build_parser,
    "teleop": teleop.build_parser,
    "serve": serve.build_parser,
    "export": export_dataset.build_parser,
    "eval": eval_policy.build_parser,
}


def actions(command: str) -> dict[str, argparse.Action]:
    parser = PARSERS[command]()
    return {a.option_strings[0]: a for a in parser._actions if a.option_strings}


@pytest.mark.parametrize(
    "flag, commands, default, kind",
    [
        ("--task_name", ("record", "teleop", "serve"), "sim_transfer_cube", None),
        ("--seed", ("record", "teleop", "serve", "eval"), 0, int),
        ("--root_dir", ("record", "teleop", "serve", "export"), ROOT_DIR, None),
        ("--cam_names", ("record", "teleop", "serve", "eval"), None, None),
        ("--fps", ("teleop", "serve", "eval"), None, float),
        ("--compression", ("record", "teleop", "serve"), common_options.DEFAULT_COMPRESSION, None),
    ],
)
def test_shared_flags_agree(flag, commands, default, kind):
    for command in commands:
        action = actions(command)[flag]
        assert action.default == default, command
        assert action.type is kind, command
        assert action.help.endswith(")") and "(default: " in action.help, (command, action.help)


def test_image_size_defaults():
    for command in ("record", "teleop", "serve"):
        assert actions(command)["--image_size"].default == "480x640"
    assert actions("eval")["--image_size"].default is None  # the checkpoint's
    assert actions("eval")["--task_name"].default is None  # the checkpoint's, else the transfer
    assert "else sim_transfer_cube)" in actions("eval")["--task_name"].help


def test_data_dir_is_required_where_it_is_taken():
    for command in ("record", "teleop", "export"):
        assert actions(command)["--data_dir"].required


def test_check_seed():
    assert common_options.check_seed(0) == 0
    assert common_options.check_seed(2**63 - 1) == 2**63 - 1
    with pytest.raises(UserError, match=r"--seed must be in 0 \.\. 2\*\*63-1, got -1"):
        common_options.check_seed(-1)
    with pytest.raises(UserError, match=r"--seed must be in 0 \.\. 10, got 11"):
        common_options.check_seed(11, most=10)


def test_scene_looks_without_a_visual_flag():
    args = argparse.Namespace(no_shadows=True)  # teleop has --no_shadows only
    looks = common_options.scene_looks(args)
    assert (looks.shadows, looks.visual) == (False, "own")
