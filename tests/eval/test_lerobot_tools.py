"""LeRobot's own tools on our data and our sim (LeRobot needs Python >= 3.12).

One recorded-and-exported dataset (2 transfer episodes, 30 steps, one 24x32 camera) trains
an ACT policy for 3 steps with ``lerobot-train``; then

- ``lerobot-eval --env.type=trossen`` (the plugin in ``plugins/lerobot_env_trossen``) runs it
  with no ``--rename_map``, two envs in spawned worker processes (``AsyncVectorEnv``), and
  ``trossen-mujoco eval`` scores the same seeds alike;
- with ``--eval.recording=true`` and no camera, lerobot-eval's recorded joint states equal the
  ones ``trossen-mujoco eval``'s loop sees for the same seed (same episode, same policy path);
- a checkpoint evaluated with other cameras than it was trained on is one line, exit 2.

The tools run in ``TROSSEN_LEROBOT_PYTHON`` (``.ci/run`` builds that venv with the project,
the plugin and ``lerobot[dataset,training]``).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.once  # LeRobot runs in TROSSEN_LEROBOT_PYTHON whatever runs pytest

pytest.importorskip("pyarrow")
pytest.importorskip("av")

from trossen_arm_mujoco.export import VideoSettings, export_lerobot  # noqa: E402
from trossen_arm_mujoco.scripts.record_sim_episodes import cli as record_cli  # noqa: E402

ENV = "TROSSEN_LEROBOT_PYTHON"
AGREE = Path(__file__).with_name("lerobot_agree.py")
STEPS, SEED, EVAL_LEN = 30, 7, 25
CROP = "cam_high:217,243,150,200"


def _python() -> str:
    python = os.environ.get(ENV, "")
    if not python or not Path(python).is_file():
        pytest.skip(f"{ENV} is not set to a Python >= 3.12 with LeRobot (bash .ci/run sets it)")
    return python


def _run(args: list[str], cwd: Path, timeout: int = 600) -> subprocess.CompletedProcess:
    env = {**os.environ, "HF_HUB_OFFLINE": "1", "MUJOCO_GL": "egl", "WANDB_MODE": "disabled"}
    return subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


def _train(python: str, dataset: Path, out: Path, cwd: Path, extra: tuple = ()) -> Path:
    proc = _run(
        [
            python,
            "-m",
            "lerobot.scripts.lerobot_train",
            "--dataset.repo_id=local/transfer",
            f"--dataset.root={dataset}",
            "--policy.type=act",
            "--policy.device=cpu",
            "--policy.push_to_hub=false",
            "--policy.pretrained_backbone_weights=null",
            "--policy.use_vae=false",
            "--policy.chunk_size=10",
            "--policy.n_action_steps=10",
            "--policy.dim_model=32",
            "--policy.dim_feedforward=64",
            "--policy.n_encoder_layers=1",
            "--policy.n_decoder_layers=1",
            "--steps=3",
            "--batch_size=2",
            "--num_workers=0",
            "--save_freq=3",
            "--log_freq=1",
            "--wandb.enable=false",
            f"--output_dir={out}",
            *extra,
        ],
        cwd,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    checkpoint = out / "checkpoints" / "last" / "pretrained_model"
    assert (checkpoint / "config.json").is_file()
    return checkpoint


@pytest.fixture(scope="module")
def trained(tmp_path_factory) -> dict[str, Path]:
    """Checkpoints trained with lerobot-train: with camera cam_high, and state only."""
    python = _python()
    root = tmp_path_factory.mktemp("loop")
    out = {}
    for name, cams, crop in (
        ("camera", "cam_high", []),
        ("state", "none", []),
        ("cropped", "cam_high", ["--crop", CROP]),
    ):
        rc = record_cli(
            [
                "--data_dir",
                name,
                "--root_dir",
                str(root),
                "--num_episodes",
                "2",
                "--episode_len",
                str(STEPS),
                "--cam_names",
                cams,
                "--image_size",
                "24x32",
                *crop,
            ]
        )
        assert rc in (0, 1)  # 30 steps are too few to succeed: the episodes are kept
        dataset = root / f"ds_{name}"
        export_lerobot(
            root / name,
            dataset,
            "local/transfer",
            progress=False,
            video=VideoSettings(codec="h264"),
            fps=50,  # the recording rate, as these checks were made for
            sim_features=True,  # the cube's pose: the state-only policy's input
        )
        out[name] = _train(python, dataset, root / f"train_{name}", root)
    out["root"] = root
    return out


def test_lerobot_eval_runs_the_plugin_and_agrees_with_ours(trained):
    python, root = _python(), trained["root"]
    ckpt = trained["camera"]
    ours_dir, theirs_dir = root / "ours", root / "theirs"
    theirs = _run(
        [
            python,
            "-m",
            "lerobot.scripts.lerobot_eval",
            f"--policy.path={ckpt}",
            "--env.type=trossen",
            "--env.task=sim_transfer_cube",
            "--env.cam_names=cam_high",
            "--env.image_size=24x32",
            f"--env.episode_length={EVAL_LEN}",
            "--eval.n_episodes=2",
            "--eval.batch_size=2",
            "--eval.use_async_envs=true",
            f"--seed={SEED}",
            f"--output_dir={theirs_dir}",
        ],
        root,
    )
    assert theirs.returncode == 0, theirs.stderr[-3000:]
    ours = _run(
        [
            python,
            "-m",
            "trossen_arm_mujoco.cli",
            "eval",
            "--policy",
            str(ckpt),
            "--num_episodes",
            "2",
            "--seed",
            str(SEED),
            "--episode_length",
            str(EVAL_LEN),
            "--output_dir",
            str(ours_dir),
        ],
        root,
    )
    assert ours.returncode == 0, ours.stderr[-3000:]
    metrics = json.loads((theirs_dir / "eval_info.json").read_text())["per_task"][0]["metrics"]
    mine = json.loads((ours_dir / "eval_info.json").read_text())
    assert mine["run"]["cam_names"] == ["cam_high"]  # taken from the checkpoint
    assert mine["deployment"]["sim_only"] is True  # its inputs hold the cube's exact pose
    assert mine["deployment"]["settings_source"].endswith("info.json")  # through its dataset
    assert mine["controller"]["checks"] is True
    assert [e["success"] for e in mine["per_episode"]] == metrics["successes"]
    assert [e["sum_reward"] for e in mine["per_episode"]] == metrics["sum_rewards"]
    assert [e["max_reward"] for e in mine["per_episode"]] == metrics["max_rewards"]
    assert [e["seed"] for e in mine["per_episode"]] == [SEED, SEED + 1]


def test_recorded_rollout_equals_our_loop(trained):
    """Same seed, same episode, same actions: lerobot-eval's recording (state-only policy)
    holds the joint states our eval loop sees (the controller's checks off on both sides: the
    3-step policy's first action is a jump the controller refuses)."""
    python, root = _python(), trained["root"]
    ckpt, out = trained["state"], root / "recorded"
    proc = _run(
        [
            python,
            "-m",
            "lerobot.scripts.lerobot_eval",
            f"--policy.path={ckpt}",
            "--env.type=trossen",
            "--env.task=sim_transfer_cube",
            "--env.cam_names=none",
            f"--env.episode_length={EVAL_LEN}",
            "--eval.n_episodes=1",
            "--eval.batch_size=1",
            f"--seed={SEED}",
            "--eval.recording=true",
            f"--output_dir={out}",
            "--env.controller_checks=false",  # the untrained policy's first jump would end it
        ],
        root,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    import pyarrow.parquet as pq

    files = sorted((out / "recordings").rglob("data/**/*.parquet"))
    assert files, list((out / "recordings").rglob("*"))
    table = pq.read_table(files[0]).to_pydict()
    recorded = np.array(table["agent_pos"], dtype=np.float32)
    mine = _run([python, str(AGREE), str(ckpt), str(SEED), str(EVAL_LEN)], root)
    assert mine.returncode == 0, mine.stderr[-3000:]
    line = next(x for x in mine.stdout.splitlines() if x.startswith("RESULT "))
    ours = np.array(json.loads(line[7:])["agent_pos"], dtype=np.float32)
    assert recorded.shape == ours.shape == (EVAL_LEN, 14)
    np.testing.assert_allclose(recorded, ours, atol=1e-6)


def test_checkpoint_for_other_cameras_is_one_line(trained):
    python, root = _python(), trained["root"]
    proc = _run(
        [
            python,
            "-m",
            "trossen_arm_mujoco.cli",
            "eval",
            "--policy",
            str(trained["camera"]),
            "--cam_names",
            "cam_low",
            "--image_size",
            "24x32",
            "--num_episodes",
            "1",
            "--output_dir",
            str(root / "mismatch"),
        ],
        root,
    )
    assert proc.returncode == 2
    lines = [x for x in proc.stderr.splitlines() if x.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), proc.stderr
    assert "--cam_names cam_low contradicts the checkpoint, trained with cam_high" in lines[0]
    assert "Traceback" not in proc.stderr


def test_missing_lerobot_is_one_line(tmp_path):
    """Without LeRobot (hidden from imports where it is installed), a checkpoint policy is
    refused with one line."""
    ckpt = tmp_path / "ckpt"
    ckpt.mkdir()
    (ckpt / "config.json").write_text(
        json.dumps({"type": "act", "input_features": {}, "output_features": {}})
    )
    hide = (
        "import sys; sys.modules['lerobot'] = None; from trossen_arm_mujoco.cli import main; "
        "sys.exit(main(sys.argv[1:]))"
    )
    proc = _run(
        [
            sys.executable,
            "-c",
            hide,
            "eval",
            "--policy",
            str(ckpt),
            "--num_episodes",
            "1",
            "--output_dir",
            str(tmp_path / "o"),
        ],
        tmp_path,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip().startswith("error: ") and "LeRobot" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_a_cropped_checkpoint_evaluates_with_its_crop_on_both_backends(trained):
    """Trained on a cropped dataset: eval needs no --crop (the checkpoint's dataset carries
    it) and says which it used; through the wire the served kit streams whole 480x640 frames,
    as real cameras do, and eval cuts the crop out of them."""
    python, root = _python(), trained["root"]
    ckpt = trained["cropped"]
    common = [
        "--policy",
        str(ckpt),
        "--num_episodes",
        "1",
        "--episode_length",
        "8",
        "--controller_checks",
        "off",
    ]
    sim = _run(
        [
            python,
            "-m",
            "trossen_arm_mujoco.cli",
            "eval",
            *common,
            "--output_dir",
            str(root / "crop_sim"),
        ],
        root,
    )
    assert sim.returncode == 0, sim.stderr[-3000:]
    info = json.loads((root / "crop_sim" / "eval_info.json").read_text())
    assert info["run"]["crops"] == [CROP] and info["run"]["image_size"] == [24, 32]
    assert info["deployment"]["settings_source"].endswith("info.json")
    wire = _run(
        [
            python,
            "-m",
            "trossen_arm_mujoco.cli",
            "eval",
            "--backend",
            "wire",
            "--policy",
            str(ckpt),
            "--num_episodes",
            "1",
            "--episode_length",
            "8",
            "--left_ip",
            "127.0.0.151",
            "--right_ip",
            "127.0.0.152",
            "--camera_port",
            "47151",
            "--control_port",
            "47152",
            "--output_dir",
            str(root / "crop_wire"),
        ],
        root,
        timeout=300,
    )
    assert wire.returncode == 0, wire.stderr[-3000:]
    winfo = json.loads((root / "crop_wire" / "eval_info.json").read_text())
    assert winfo["run"]["crops"] == [CROP] and winfo["aggregated"]["n_episodes"] == 1
    assert any("cameras:" in line for line in winfo["timing"]["kit"]), winfo["timing"]


def test_trossens_plugin_rolls_out_a_prepared_checkpoint_on_the_served_kit(trained):
    """lerobot-rollout with Trossen's own robot (bi_widowxai_follower_robot) runs a camera
    checkpoint (the state and a cropped cam_high only, as a real kit gives) against the
    served kit streaming whole 480x640 frames: ``benchmarks/plugin_rollout.py``, one short
    episode, no fault, its control loop running."""
    python, root = _python(), trained["root"]
    probe = _run([python, "-c", "import lerobot_robot_trossen"], root)
    if probe.returncode != 0:
        pytest.skip(
            "Trossen's robot plugin package is not installed in that venv (install it "
            "from its GitHub repository: docs/rehearsal.md)"
        )
    inputs = {
        "observation.state": {"type": "STATE", "shape": [14]},
        "observation.images.cam_high": {"type": "VISUAL", "shape": [3, 24, 32]},
    }
    ckpt = _train(
        python,
        root / "ds_cropped",
        root / "train_deployable",
        root,
        ("--policy.input_features=" + json.dumps(inputs),),
    )
    script = Path(__file__).parents[2] / "benchmarks" / "plugin_rollout.py"
    env_ports = [str(p) for p in (_free_port(), _free_port())]
    proc = _run(
        [
            sys.executable,
            str(script),
            "--policy",
            str(ckpt),
            "--episodes",
            "1",
            "--duration",
            "3",
            "--no_return_to_initial",  # the plugin's shutdown, docs/rehearsal.md
            "--camera_port",
            env_ports[0],
            "--control_port",
            env_ports[1],
        ],
        root,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    row = json.loads(next(line for line in proc.stdout.splitlines() if line.startswith("{")))
    # its control loop ran on the streamed whole frames for the episode's seconds (a 3-step
    # policy's gripper may still be moving when the plugin's disconnect sends the arm to its
    # staged pose, which the served controller may refuse: counted as a fault, not asserted)
    assert row["loops"] > 5 and row["seconds"] >= 2.0, row
    assert "max_reward" in row and isinstance(row["fault"], bool)
    steps = json.loads((ckpt / "policy_preprocessor.json").read_text())["steps"]
    assert "trossen_camera_image" in [s.get("registry_name") for s in steps]  # whole frames in


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]
