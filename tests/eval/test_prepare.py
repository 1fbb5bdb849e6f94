"""``trossen-mujoco prepare``: a checkpoint carries every step a runner needs (its images cut
and scaled as trained, the pose encoder, the controller's limits), once; and (where LeRobot
is installed) what the steps do as LeRobot loads them."""

from __future__ import annotations

import importlib.util
import json
import os
from pathlib import Path

import numpy as np
import pytest

from trossen_arm_mujoco.cli import main as cli_main
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.eval import camera_pose_step, controller_limits_step
from trossen_arm_mujoco.eval.prepare import (
    ENCODER_FILE,
    IMAGE_STEP,
    carries_images,
    prepare_checkpoint,
)
from trossen_arm_mujoco.eval.processor_files import POSTPROCESSOR_FILE, PREPROCESSOR_FILE
from trossen_arm_mujoco.export.dataset_settings import (
    CHECKPOINT_FILE,
    DatasetSettings,
    write_checkpoint_settings,
)
from trossen_arm_mujoco.sim.camera_crop import CameraCrop, crop_frame
from trossen_arm_mujoco.sim.camera_settings import CameraSettings

CROP = CameraCrop("cam_high", top=217, left=243, height=150, width=200)


def _checkpoint(folder: Path, crops=(CROP,), size=(60, 80)) -> Path:
    """The files of a camera checkpoint that prepare touches (no weights)."""
    folder.mkdir(parents=True)
    config = {
        "input_features": {
            "observation.state": {"type": "STATE", "shape": [14]},
            "observation.images.cam_high": {"type": "VISUAL", "shape": [3, *size]},
        },
        "output_features": {"action": {"type": "ACTION", "shape": [14]}},
    }
    (folder / "config.json").write_text(json.dumps(config))
    pre = {
        "name": "policy_preprocessor",
        "steps": [
            {"registry_name": "to_batch_processor", "config": {}},
            {"registry_name": "normalizer_processor", "config": {}},
        ],
    }
    post = {
        "name": "policy_postprocessor",
        "steps": [{"registry_name": "unnormalizer_processor", "config": {}}],
    }
    (folder / PREPROCESSOR_FILE).write_text(json.dumps(pre))
    (folder / POSTPROCESSOR_FILE).write_text(json.dumps(post))
    cams = CameraSettings(names=("cam_high",), size=size, crops=crops)
    write_checkpoint_settings(
        folder, DatasetSettings(fps=30, layout="kit14", cameras=cams, task="sim_transfer_cube")
    )
    return folder


def _names(path: Path) -> list[str]:
    return [s["registry_name"] for s in json.loads(path.read_text())["steps"]]


def _files(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def test_prepare_adds_the_image_and_limit_steps_once(tmp_path):
    ckpt = _checkpoint(tmp_path / "run" / "pretrained_model")
    assert not carries_images(ckpt)
    changed = prepare_checkpoint(ckpt)
    assert changed == [IMAGE_STEP, controller_limits_step.REGISTRY_NAME]
    assert _names(ckpt / PREPROCESSOR_FILE) == [
        "to_batch_processor",
        IMAGE_STEP,
        controller_limits_step.MEASURED_NAME,
        "normalizer_processor",
    ]
    image = json.loads((ckpt / PREPROCESSOR_FILE).read_text())["steps"][1]["config"]
    assert image == {"cameras": {"cam_high": {"size": [60, 80], "crop": [217, 243, 150, 200]}}}
    assert carries_images(ckpt) and carries_images(ckpt.parent)  # or its parent folder
    before = _files(ckpt)
    assert prepare_checkpoint(ckpt) == []  # twice: as once
    assert _files(ckpt) == before


def test_whole_frames_need_no_image_step(tmp_path):
    ckpt = _checkpoint(tmp_path / "ckpt", crops=(), size=(480, 640))
    assert prepare_checkpoint(ckpt) == [controller_limits_step.REGISTRY_NAME]
    assert IMAGE_STEP not in _names(ckpt / PREPROCESSOR_FILE)


def test_the_training_datasets_encoder_goes_in_after_the_image_step(tmp_path):
    pytest.importorskip("torch")
    pytest.importorskip("safetensors")
    from trossen_arm_mujoco.train.pose_encoder import _module, save_encoder

    ckpt = _checkpoint(tmp_path / "ckpt")
    dataset = tmp_path / "derived"
    (dataset / "meta").mkdir(parents=True)
    save_encoder(_module(7), dataset / ENCODER_FILE)
    (ckpt / "train_config.json").write_text(json.dumps({"dataset": {"root": str(dataset)}}))
    changed = prepare_checkpoint(ckpt)
    assert camera_pose_step.REGISTRY_NAME in changed
    names = _names(ckpt / PREPROCESSOR_FILE)
    assert names.index(IMAGE_STEP) < names.index(camera_pose_step.REGISTRY_NAME)
    assert names.index(camera_pose_step.REGISTRY_NAME) < names.index("normalizer_processor")
    before = _files(ckpt)
    assert prepare_checkpoint(ckpt) == []
    assert _files(ckpt) == before


def test_the_command_prepares_and_refuses_a_folder_that_is_no_checkpoint(tmp_path, capsys):
    ckpt = _checkpoint(tmp_path / "ckpt")
    assert cli_main(["prepare", str(ckpt)]) == 0
    assert "added trossen_camera_image" in capsys.readouterr().out
    assert cli_main(["prepare", str(ckpt)]) == 0
    assert "prepared already" in capsys.readouterr().out
    assert cli_main(["prepare", str(tmp_path / "nowhere")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no config.json" in err[0]


def _lerobot_in_process() -> None:
    if importlib.util.find_spec("lerobot") is None and os.environ.get("TROSSEN_LEROBOT_PYTHON"):
        pytest.skip("run by the Python 3.12 leg of tools/run_tests.sh (marker py312)")
    pytest.importorskip("lerobot")


def _pipeline(ckpt: Path, filename: str):
    """The saved pipeline as LeRobot loads it, less the (un)normalizer this test checkpoint
    has no statistics for."""
    from lerobot.processor import DataProcessorPipeline

    path = ckpt / filename
    saved = json.loads(path.read_text())
    saved["steps"] = [s for s in saved["steps"] if "normalizer" not in s["registry_name"]]
    path.write_text(json.dumps(saved))

    import trossen_arm_mujoco.eval.steps  # noqa: F401  (registers the steps)

    return DataProcessorPipeline.from_pretrained(str(ckpt), config_filename=filename)


def test_the_checkpoints_own_preprocessor_turns_a_whole_frame_into_the_trained_image(tmp_path):
    torch = pytest.importorskip("torch")
    _lerobot_in_process()
    ckpt = _checkpoint(tmp_path / "ckpt")
    prepare_checkpoint(ckpt)
    pre = _pipeline(ckpt, PREPROCESSOR_FILE)
    rng = np.random.default_rng(0)
    frame = rng.integers(0, 256, (480, 640, 3), dtype=np.uint8)
    whole = torch.from_numpy(frame).permute(2, 0, 1).float().unsqueeze(0) / 255.0
    out = pre({"observation.images.cam_high": whole, "observation.state": torch.zeros(1, 14)})
    image = out["observation.images.cam_high"]
    assert tuple(image.shape) == (1, 3, 60, 80)
    expected = crop_frame(frame, CROP, (60, 80)).astype(np.float32) / 255.0
    np.testing.assert_allclose(image[0].permute(1, 2, 0).numpy(), expected, atol=1e-6)
    # an image at the trained size passes as it is (the in-process env renders it so)
    small = torch.rand(1, 3, 60, 80)
    kept = pre({"observation.images.cam_high": small, "observation.state": torch.zeros(1, 14)})
    assert torch.equal(kept["observation.images.cam_high"], small)
    # half the frame's size is the whole frame too; another shape is refused
    half = torch.nn.functional.interpolate(whole, size=(240, 320), mode="area")
    out = pre({"observation.images.cam_high": half, "observation.state": torch.zeros(1, 14)})
    assert tuple(out["observation.images.cam_high"].shape) == (1, 3, 60, 80)
    with pytest.raises(ValueError, match="whole 4:3 frame"):
        pre(
            {
                "observation.images.cam_high": torch.rand(1, 3, 100, 100),
                "observation.state": torch.zeros(1, 14),
            }
        )


def test_two_policies_from_one_checkpoint_keep_their_own_measured_joints(tmp_path):
    torch = pytest.importorskip("torch")
    _lerobot_in_process()
    ckpt = _checkpoint(tmp_path / "ckpt")
    prepare_checkpoint(ckpt)
    pre1, post1 = _pipeline(ckpt, PREPROCESSOR_FILE), _pipeline(ckpt, POSTPROCESSOR_FILE)
    pre2, post2 = _pipeline(ckpt, PREPROCESSOR_FILE), _pipeline(ckpt, POSTPROCESSOR_FILE)
    home = torch.tensor([[0.0, 0.2618, 0.2618, 0.0, 0.0, 0.0, 0.02] * 2])
    moved = home.clone()
    moved[0, 0] = moved[0, 7] = 1.0
    pre1({"observation.state": home})
    pre2({"observation.state": moved})
    target = home.clone()
    target[0, 0] = target[0, 7] = 0.5  # between the two measured positions
    step = controller_limits_step.joint_steps(14, 30)[0]
    from lerobot.processor import TransitionKey

    def act(post):  # the limits step of the loaded postprocessor
        step = next(s for s in post.steps if type(s).__name__ == "ControllerLimitsStep")
        return step({TransitionKey.ACTION: target.clone()})[TransitionKey.ACTION]

    a1, a2 = act(post1), act(post2)
    assert a1[0, 0].item() == pytest.approx(step, abs=1e-6)  # held near its own joints
    assert a2[0, 0].item() == pytest.approx(1.0 - step, abs=1e-6)


@pytest.mark.parametrize(
    "damage, words",
    [
        ('{"steps": "to_batch_processor"}', "its 'steps' is not a list"),
        ('{"steps": {"a": 1}}', "its 'steps' is not a list"),
        ('{"steps": null}', "its 'steps' is not a list"),
        ("[" * 100_000 + "]" * 100_000, "cannot read it as JSON"),
        ('{"steps": [{"config": {}}]}', "step 0 is not a named step"),
        ("", "cannot read it as JSON"),
    ],
)
def test_a_damaged_processor_file_is_one_line_and_nothing_changes(tmp_path, damage, words):
    ckpt = _checkpoint(tmp_path / "ckpt")
    (ckpt / POSTPROCESSOR_FILE).write_text(damage)
    before = _files(ckpt)
    with pytest.raises(UserError, match=words) as e:
        prepare_checkpoint(ckpt)
    assert "\n" not in str(e.value) and POSTPROCESSOR_FILE in str(e.value)
    assert _files(ckpt) == before


def test_an_unreadable_rate_is_one_line(tmp_path):
    ckpt = _checkpoint(tmp_path / "ckpt")
    settings = ckpt / CHECKPOINT_FILE
    settings.write_text(settings.read_text().replace('"fps": 30', '"fps": 1e999'))
    with pytest.raises(UserError, match="unreadable dataset settings"):
        prepare_checkpoint(ckpt)


def test_a_failed_write_leaves_both_files_as_they_were(tmp_path, monkeypatch):
    """The postprocessor cannot be replaced (read-only, immutable): the preprocessor,
    replaced first, is put back, and the error is one line."""
    ckpt = _checkpoint(tmp_path / "ckpt")
    before = _files(ckpt)
    real_replace = os.replace

    def refuse_post(src, dst):
        if str(dst).endswith(POSTPROCESSOR_FILE):
            raise PermissionError(1, "Operation not permitted")
        return real_replace(src, dst)

    monkeypatch.setattr(os, "replace", refuse_post)
    with pytest.raises(UserError, match="cannot write its processors .* nothing was changed"):
        prepare_checkpoint(ckpt)
    assert _files(ckpt) == before  # no temp file left behind either


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_a_read_only_checkpoint_is_one_line(tmp_path):
    ckpt = _checkpoint(tmp_path / "ckpt")
    ckpt.chmod(0o555)
    try:
        with pytest.raises(UserError, match="cannot write its processors"):
            prepare_checkpoint(ckpt)
    finally:
        ckpt.chmod(0o755)


def test_ctrl_c_between_the_renames_leaves_both_files_as_they_were(tmp_path, monkeypatch):
    ckpt = _checkpoint(tmp_path / "ckpt")
    before = _files(ckpt)
    real_replace = os.replace

    def interrupted(src, dst):
        if str(dst).endswith(POSTPROCESSOR_FILE):
            raise KeyboardInterrupt
        return real_replace(src, dst)

    monkeypatch.setattr(os, "replace", interrupted)
    with pytest.raises(KeyboardInterrupt):
        prepare_checkpoint(ckpt)
    assert _files(ckpt) == before


def test_two_preparations_of_one_checkpoint_write_the_same_link(tmp_path):
    a, b = _checkpoint(tmp_path / "a"), _checkpoint(tmp_path / "b")  # the same config.json
    prepare_checkpoint(a)
    prepare_checkpoint(b)
    assert (a / PREPROCESSOR_FILE).read_text() == (b / PREPROCESSOR_FILE).read_text()
    assert (a / POSTPROCESSOR_FILE).read_text() == (b / POSTPROCESSOR_FILE).read_text()
