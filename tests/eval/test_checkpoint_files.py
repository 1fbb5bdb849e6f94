"""A damaged LeRobot checkpoint given to ``trossen-mujoco eval`` is one line naming the file and
what is wrong with it, exit status 2, before any episode runs, on both backends: weights
(``model.safetensors``) missing, empty, truncated or not safetensors; a saved processor file
missing; a normalizer state file missing or truncated; a processor step LeRobot does not know.
Weights overwritten with NaN stop the evaluation at the first action, on both backends alike.

The checkpoints are written here by hand (the files lerobot-train saves, tiny), except the one
with NaN weights, which LeRobot builds (an ACT policy of a few hundred weights): those tests
run where LeRobot is importable (the Python 3.12 leg, marker ``py312``)."""

from __future__ import annotations

import importlib.util
import json
import os
import socket
import struct
from pathlib import Path

import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.eval import lerobot_policy
from trossen_arm_mujoco.eval.checkpoint_files import (
    WEIGHTS_FILE,
    check_checkpoint_files,
    safetensors_problem,
)
from trossen_arm_mujoco.scripts import eval_policy

pytestmark = pytest.mark.py312  # the LeRobot tests run beside LeRobot; the rest on both legs

PRE_STATE = "policy_preprocessor_step_3_normalizer_processor.safetensors"
POST_STATE = "policy_postprocessor_step_0_unnormalizer_processor.safetensors"
#: What a state-based checkpoint of the transfer observes: the env's default cameras (none).
CONFIG = {
    "type": "act",
    "input_features": {
        "observation.state": {"type": "STATE", "shape": [14]},
        "observation.environment_state": {"type": "ENV", "shape": [7]},
    },
    "output_features": {"action": {"type": "ACTION", "shape": [14]}},
}


def write_safetensors(path: Path, tensors: dict[str, np.ndarray]) -> None:
    """``tensors`` as a safetensors file (F32), laid out as the safetensors package writes."""
    header, blobs, offset = {}, [], 0
    for name, value in tensors.items():
        blob = np.ascontiguousarray(value, dtype="<f4").tobytes()
        header[name] = {
            "dtype": "F32",
            "shape": list(np.shape(value)),
            "data_offsets": [offset, offset + len(blob)],
        }
        blobs.append(blob)
        offset += len(blob)
    raw = json.dumps(header).encode()
    raw += b" " * (-len(raw) % 8)
    path.write_bytes(struct.pack("<Q", len(raw)) + raw + b"".join(blobs))


def _stats(n: int) -> dict[str, np.ndarray]:
    return {"mean": np.zeros(n), "std": np.ones(n), "min": -np.ones(n), "max": np.ones(n)}


def fake_checkpoint(folder: Path, pre_steps: list | None = None) -> Path:
    """The files of a state-based ACT checkpoint as lerobot-train saves them (weights of no
    real model: what eval checks before loading one)."""
    folder.mkdir(parents=True)
    (folder / "config.json").write_text(json.dumps(CONFIG), encoding="utf-8")
    write_safetensors(
        folder / WEIGHTS_FILE, {"model.layer.weight": np.ones((4, 3)), "model.layer.bias": [0.5]}
    )
    state = {
        f"{key}.{stat}": value
        for key, n in (("observation.state", 14), ("observation.environment_state", 7))
        for stat, value in _stats(n).items()
    }
    write_safetensors(folder / PRE_STATE, state)
    write_safetensors(folder / POST_STATE, {f"action.{k}": v for k, v in _stats(14).items()})
    steps = pre_steps or [
        {"registry_name": "rename_observations_processor", "config": {"rename_map": {}}},
        {"registry_name": "to_batch_processor", "config": {}},
        {"registry_name": "device_processor", "config": {"device": "cpu"}},
        {"registry_name": "normalizer_processor", "config": {}, "state_file": PRE_STATE},
    ]
    pre = {"name": "policy_preprocessor", "steps": steps}
    post = {
        "name": "policy_postprocessor",
        "steps": [
            {"registry_name": "unnormalizer_processor", "config": {}, "state_file": POST_STATE},
            {"registry_name": "device_processor", "config": {"device": "cpu"}},
        ],
    }
    (folder / "policy_preprocessor.json").write_text(json.dumps(pre), encoding="utf-8")
    (folder / "policy_postprocessor.json").write_text(json.dumps(post), encoding="utf-8")
    return folder


def _cut(path: Path, keep: int) -> None:
    path.write_bytes(path.read_bytes()[:keep])


# -- the checks themselves (no LeRobot) -------------------------------------------------------
def test_a_whole_checkpoint_passes_and_its_safetensors_load(tmp_path):
    ckpt = fake_checkpoint(tmp_path / "ckpt")
    check_checkpoint_files(ckpt)
    for name in (WEIGHTS_FILE, PRE_STATE, POST_STATE):
        assert safetensors_problem(ckpt / name) is None
    st = pytest.importorskip("safetensors.numpy")  # the writer above writes what it reads
    loaded = st.load_file(str(ckpt / WEIGHTS_FILE))
    np.testing.assert_array_equal(loaded["model.layer.weight"], np.ones((4, 3)))


@pytest.mark.parametrize(
    ("damage", "expected"),
    [
        (lambda p: p.unlink(), "is missing"),
        (lambda p: p.write_bytes(b""), "is empty (0 bytes)"),
        (lambda p: _cut(p, 5), "is truncated (5 bytes: not even its 8-byte header length)"),
        (lambda p: _cut(p, 20), "is truncated (20 bytes; its header alone needs"),
        (lambda p: _cut(p, p.stat().st_size - 4), "is truncated ("),
        (lambda p: p.write_bytes(p.read_bytes() + b"\0" * 8), "8 bytes after its last tensor"),
        (lambda p: p.write_bytes(b"PK\x03\x04" + bytes(60)), "not a safetensors file (no JSON"),
        (
            lambda p: p.write_bytes(struct.pack("<Q", 4) + b"[1] "),
            "not a safetensors file (no JSON",
        ),
        (lambda p: p.write_bytes(struct.pack("<Q", 4) + b"{{{{"), "header is not JSON"),
    ],
)
def test_each_damage_is_named_and_the_safetensors_package_agrees(tmp_path, damage, expected):
    path = fake_checkpoint(tmp_path / "ckpt") / WEIGHTS_FILE
    damage(path)
    problem = safetensors_problem(path)
    assert problem is not None and expected in problem, problem
    st = pytest.importorskip("safetensors.numpy")
    with pytest.raises(Exception):  # noqa: B017  (what it raises differs by damage)
        st.load_file(str(path))


def test_a_header_whose_byte_ranges_do_not_fit_is_damaged(tmp_path):
    path = tmp_path / "w.safetensors"
    header = json.dumps({"w": {"dtype": "F32", "shape": [2, 2], "data_offsets": [0, 12]}}).encode()
    path.write_bytes(struct.pack("<Q", len(header)) + header + bytes(12))
    assert "does not fit its F32 shape [2, 2]" in safetensors_problem(path)


# -- through the command line, both backends ---------------------------------------------------
def _lerobot_in_process() -> None:
    if importlib.util.find_spec("lerobot") is None and os.environ.get("TROSSEN_LEROBOT_PYTHON"):
        pytest.skip("run by the Python 3.12 leg of tools/run_tests.sh (marker py312)")
    pytest.importorskip("lerobot")


@pytest.fixture
def lerobot_here() -> None:
    """Skips the test where LeRobot cannot be imported in this process (before the fixtures
    after it in the test's arguments are built)."""
    _lerobot_in_process()


@pytest.fixture
def lerobot_or_not(monkeypatch):
    """Where LeRobot is not importable (Python 3.11), eval's own file checks run all the same:
    only the import that would refuse the run first is skipped."""
    if importlib.util.find_spec("lerobot") is None:
        monkeypatch.setattr(lerobot_policy, "import_lerobot", lambda: None)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _eval(ckpt: Path, out: Path, backend: str, capsys, *extra: str) -> tuple[int, str]:
    """Run eval on ``ckpt``; (exit status, its only stderr line, which must be an error)."""
    wire = ["--backend", "wire", "--camera_port", str(_free_port())] if backend == "wire" else []
    rc = eval_policy.cli(
        ["--policy", str(ckpt), "--num_episodes", "1", "--output_dir", str(out), *wire, *extra]
    )
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err, captured.err
    errors = [line for line in captured.err.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, captured.err
    return rc, errors[0]


DAMAGES = {
    "weights missing": (
        lambda c: (c / WEIGHTS_FILE).unlink(),
        "no model.safetensors in {c} (the policy's weights)",
    ),
    "weights empty": (
        lambda c: (c / WEIGHTS_FILE).write_bytes(b""),
        "{c}/model.safetensors is empty (0 bytes); copy the checkpoint again",
    ),
    "weights truncated": (
        lambda c: _cut(c / WEIGHTS_FILE, (c / WEIGHTS_FILE).stat().st_size - 10),
        "{c}/model.safetensors is truncated (",
    ),
    "postprocessor missing": (
        lambda c: (c / "policy_postprocessor.json").unlink(),
        "{c}: no policy_postprocessor.json; give a LeRobot checkpoint folder",
    ),
    "normalizer state missing": (
        lambda c: (c / PRE_STATE).unlink(),
        f"{{c}}/{PRE_STATE}, the state of step 3 (normalizer_processor) of "
        "policy_preprocessor.json, is missing",
    ),
    "unnormalizer state truncated": (
        lambda c: _cut(c / POST_STATE, 100),
        f"{{c}}/{POST_STATE}, the state of step 0 (unnormalizer_processor) of "
        "policy_postprocessor.json, is truncated",
    ),
}


@pytest.mark.parametrize("backend", ["sim", "wire"])
@pytest.mark.parametrize("damage", list(DAMAGES))
def test_a_damaged_checkpoint_is_one_line_before_any_episode(
    damage, backend, tmp_path, capsys, lerobot_or_not
):
    ckpt = fake_checkpoint(tmp_path / "ckpt")
    spoil, expected = DAMAGES[damage]
    spoil(ckpt)
    out = tmp_path / "eval"
    rc, line = _eval(ckpt, out, backend, capsys)
    assert rc == 2
    assert line.startswith(f"error: --policy {ckpt}: "), line
    assert expected.format(c=ckpt) in line, line
    assert not out.exists() or not any(out.iterdir())  # no episode ran, nothing written


@pytest.mark.parametrize("backend", ["sim", "wire"])
def test_a_processor_step_lerobot_does_not_know_is_one_line(backend, tmp_path, capsys):
    _lerobot_in_process()
    steps = [
        {"registry_name": "device_processor", "config": {"device": "cpu"}},
        {"registry_name": "my_plugin_step", "config": {}},
    ]
    ckpt = fake_checkpoint(tmp_path / "ckpt", pre_steps=steps)
    rc, line = _eval(ckpt, tmp_path / "eval", backend, capsys)
    assert rc == 2
    assert (
        f"step 1 of {ckpt / 'policy_preprocessor.json'} is 'my_plugin_step', a processor " in line
    )
    assert "step this LeRobot does not know" in line
    steps[1] = {"class": "no_such_module.Step", "config": {}}
    ckpt = fake_checkpoint(tmp_path / "ckpt2", pre_steps=steps)
    rc, line = _eval(ckpt, tmp_path / "eval2", backend, capsys)
    assert rc == 2 and "is the class 'no_such_module.Step', which cannot be imported" in line


def test_the_policy_checks_its_files_itself(tmp_path):
    """Built without the command line (a worker, the Python API): the same line."""
    _lerobot_in_process()
    from trossen_arm_mujoco.eval.env import KitPolicyEnv

    ckpt = fake_checkpoint(tmp_path / "ckpt")
    (ckpt / WEIGHTS_FILE).write_bytes(b"")
    env = KitPolicyEnv(render_mode=None)
    try:
        with pytest.raises(UserError, match="model.safetensors is empty"):
            lerobot_policy.LeRobotPolicy(ckpt, env)
    finally:
        env.close()


# -- weights overwritten with NaN: both backends stop at the first action ---------------------
def act_checkpoint(folder: Path, weights: float | None = None) -> Path:
    """A state-based ACT checkpoint of a few hundred weights, saved as lerobot-train saves
    it (weights, processors with their statistics); ``weights``: every weight set to it."""
    import torch
    from lerobot.configs.types import FeatureType, PolicyFeature
    from lerobot.policies.act.configuration_act import ACTConfig
    from lerobot.policies.act.modeling_act import ACTPolicy
    from lerobot.policies.factory import make_pre_post_processors

    features = {
        "observation.state": PolicyFeature(FeatureType.STATE, (14,)),
        "observation.environment_state": PolicyFeature(FeatureType.ENV, (7,)),
    }
    cfg = ACTConfig(
        input_features=features,
        output_features={"action": PolicyFeature(FeatureType.ACTION, (14,))},
        device="cpu",
        chunk_size=2,
        n_action_steps=2,
        dim_model=8,
        n_heads=1,
        dim_feedforward=8,
        n_encoder_layers=1,
        n_decoder_layers=1,
        use_vae=False,
        pretrained_backbone_weights=None,
        push_to_hub=False,
    )
    policy = ACTPolicy(cfg)
    if weights is not None:
        with torch.no_grad():
            for p in policy.parameters():
                p.fill_(weights)
    policy.save_pretrained(folder)
    stats = {
        key: {k: torch.as_tensor(v, dtype=torch.float32) for k, v in _stats(n).items()}
        for key, n in (
            ("observation.state", 14),
            ("observation.environment_state", 7),
            ("action", 14),
        )
    }
    pre, post = make_pre_post_processors(cfg, dataset_stats=stats)
    pre.save_pretrained(folder)
    post.save_pretrained(folder)
    return folder


@pytest.fixture
def served_kit():
    """A served kit in this process (no cameras) and its control channel: the flags of
    ``eval --backend wire --connect``."""
    pytest.importorskip("trossen_arm_sim")
    pytest.importorskip("trossen_arm")
    from trossen_arm_mujoco.twin.episode_control import EpisodeControl
    from trossen_arm_mujoco.twin.kit_world import KitWorld
    from trossen_arm_mujoco.twin.served_kit import ServedKit

    left, right, port = "127.0.0.161", "127.0.0.162", _free_port()
    world = KitWorld()
    kit = ServedKit(world, {"left": left, "right": right})
    control = EpisodeControl(world, port)
    try:
        kit.start()
        control.start()
        yield [
            "--connect",
            "--left_ip",
            left,
            "--right_ip",
            right,
            "--control_port",
            str(port),
        ]
    finally:
        control.stop()
        kit.close()


def test_nan_weights_stop_both_backends_with_the_same_line(
    lerobot_here, tmp_path, capsys, served_kit
):
    ckpt = act_checkpoint(tmp_path / "nan", weights=float("nan"))
    check_checkpoint_files(ckpt)  # whole files: only the numbers are wrong
    lines = {}
    for backend in ("sim", "wire"):
        out = tmp_path / f"eval_{backend}"
        extra = served_kit if backend == "wire" else []
        rc, lines[backend] = _eval(ckpt, out, backend, capsys, "--episode_length", "5", *extra)
        assert rc == 2
        assert not (out / "eval_info.json").exists()
    assert lines["sim"] == lines["wire"]
    assert lines["sim"] == (
        f"error: the policy {ckpt} produced a non-finite action at episode 0 step 0: NaN in "
        "14 of 14 values; the checkpoint's weights may be damaged (overwritten, or trained "
        "into NaN): evaluate another checkpoint or train again"
    )


def test_a_whole_act_checkpoint_passes_the_checks_and_evaluates(tmp_path, capsys):
    """The same tiny checkpoint with finite weights: the checks pass what LeRobot saved."""
    _lerobot_in_process()
    ckpt = act_checkpoint(tmp_path / "ok", weights=0.01)
    lerobot_policy.check_loadable(ckpt)
    out = tmp_path / "eval"
    rc = eval_policy.cli(
        ["--policy", str(ckpt), "--num_episodes", "1", "--episode_length", "3"]
        + ["--output_dir", str(out)]
    )
    err = capsys.readouterr().err
    assert rc == 0, err
    assert json.loads((out / "eval_info.json").read_text())["aggregated"]["n_episodes"] == 1
