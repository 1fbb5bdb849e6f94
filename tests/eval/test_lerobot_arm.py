"""LeRobot's tools on the single WidowX AI arm (LeRobot needs Python >= 3.12: they run in
``TROSSEN_LEROBOT_PYTHON``, with the plugin ``plugins/lerobot_env_trossen``):

- the plugin's ``--env.task=pick_place`` builds ``ArmPolicyEnv`` vector envs: 7-value state
  and action, the ``overview`` / ``cam`` cameras, LeRobot's own observation preprocessing;
- ``lerobot-eval --env.type=trossen --env.task=pick_place`` runs an (untrained) 7-value ACT
  checkpoint, and ``trossen-mujoco eval`` scores the same seed alike;
- ``lerobot-rollout --robot.type=widowxai_follower_robot`` (Trossen's robot plugin,
  ``lerobot_robot_trossen``; skipped where it is not installed) drives the served arm
  (``serve --task_name pick_place --ip 127.0.0.191``) and its ZMQ camera for one short
  episode with a checkpoint that holds the arm at the plugin's staged pose: no fault.
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
from pathlib import Path

import pytest

pytestmark = pytest.mark.once  # LeRobot runs in TROSSEN_LEROBOT_PYTHON whatever runs pytest

ENV = "TROSSEN_LEROBOT_PYTHON"
MAKE_CHECKPOINT = Path(__file__).with_name("lerobot_arm_checkpoint.py")
SEED, LENGTH = 7, 10
#: The plugin's staged pose of a WidowX AI follower (lerobot_robot_trossen's default).
STAGED = "0,1.0471976,0.5235988,0.6283185,0,0,0"
IP = "127.0.0.191"

PLUGIN_CHECK = """
import json
import lerobot_env_trossen as plug
from lerobot.envs.utils import preprocess_observation

cfg = plug.TrossenEnvConfig(task="pick_place", image_size="24x32", cam_names="cam",
                            episode_length=3)
vec = cfg.create_envs(2)["trossen"][0]
obs, _ = vec.reset(seed=[3, 4])
batch = preprocess_observation(obs)
for _ in range(3):
    obs, reward, terminated, truncated, info = vec.step(obs["agent_pos"])
print(json.dumps({
    "layout": cfg.layout,
    "default_cams": plug.TrossenEnvConfig(task="push").cam_names,
    "features": {k: [v.type.name, list(v.shape)] for k, v in cfg.features.items()},
    "batch": {k: list(v.shape) for k, v in batch.items()},
    "truncated": truncated.tolist(),
    "faulted": [bool(f) for f in terminated],
    "description": vec.call("task_description")[0],
}))
vec.close()
"""


def _python() -> str:
    python = os.environ.get(ENV, "")
    if not python or not Path(python).is_file():
        pytest.skip(f"{ENV} is not set to a Python >= 3.12 with LeRobot (bash .ci/run sets it)")
    return python


def _run(args: list[str], cwd: Path, timeout: int = 600) -> subprocess.CompletedProcess:
    env = {**os.environ, "HF_HUB_OFFLINE": "1", "MUJOCO_GL": "egl", "WANDB_MODE": "disabled"}
    return subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


def _checkpoint(python: str, out: Path, *extra: str) -> Path:
    proc = _run(
        [python, str(MAKE_CHECKPOINT), str(out), "--image_size", "24x32", *extra], out.parent
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    return out


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_the_plugin_steps_the_single_arm_in_its_seven_values(tmp_path) -> None:
    proc = _run([_python(), "-c", PLUGIN_CHECK], tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["layout"] == "widowxai" and out["default_cams"] == "overview,cam"
    assert out["features"]["action"] == ["ACTION", [7]]
    assert out["features"]["agent_pos"] == ["STATE", [7]]
    assert out["features"]["observation.images.cam"] == ["VISUAL", [24, 32, 3]]
    assert out["batch"]["observation.state"] == [2, 7]
    assert out["batch"]["observation.images.cam"] == [2, 3, 24, 32]
    assert out["truncated"] == [True, True] and out["faulted"] == [False, False]
    assert out["description"].startswith("pick up the red cube and place it at (")


def test_lerobot_eval_runs_a_seven_value_checkpoint_and_agrees_with_ours(tmp_path) -> None:
    python = _python()
    ckpt = _checkpoint(python, tmp_path / "ckpt")
    theirs, ours = tmp_path / "theirs", tmp_path / "ours"
    proc = _run(
        [
            python,
            "-m",
            "lerobot.scripts.lerobot_eval",
            f"--policy.path={ckpt}",
            "--policy.device=cpu",
            "--env.type=trossen",
            "--env.task=pick_place",
            "--env.cam_names=cam",
            "--env.image_size=24x32",
            f"--env.episode_length={LENGTH}",
            "--eval.n_episodes=1",
            "--eval.batch_size=1",
            f"--seed={SEED}",
            f"--output_dir={theirs}",
        ],
        tmp_path,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    proc = _run(
        [
            python,
            "-m",
            "trossen_arm_mujoco.cli",
            "eval",
            "--policy",
            str(ckpt),
            "--task_name",
            "pick_place",
            "--num_episodes",
            "1",
            "--episode_length",
            str(LENGTH),
            "--seed",
            str(SEED),
            "--output_dir",
            str(ours),
        ],
        tmp_path,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    metrics = json.loads((theirs / "eval_info.json").read_text())["per_task"][0]["metrics"]
    mine = json.loads((ours / "eval_info.json").read_text())
    assert mine["run"]["layout"] == "widowxai" and mine["run"]["cam_names"] == ["cam"]
    row = mine["per_episode"][0]
    assert metrics["successes"] == [row["success"]]
    assert metrics["sum_rewards"][0] == pytest.approx(row["sum_reward"], abs=1e-6)
    assert metrics["max_rewards"][0] == pytest.approx(row["max_reward"], abs=1e-6)


def test_lerobot_rollout_drives_the_served_arm(tmp_path) -> None:
    python = _python()
    probe = _run([python, "-c", "import lerobot_robot_trossen"], tmp_path)
    if probe.returncode != 0:
        pytest.skip(
            "Trossen's robot plugin package is not installed in that venv (install it "
            "from its GitHub repository: docs/rehearsal.md)"
        )
    pytest.importorskip("trossen_arm_sim")
    pytest.importorskip("zmq")
    from trossen_arm_mujoco.eval.wire_link import KitLink, start_kit, stop_kit

    ckpt = _checkpoint(python, tmp_path / "hold", "--hold", STAGED)
    link = KitLink(left_ip=IP, camera_port=_free_port(), control_port=_free_port()).checked()
    kit = start_kit(link, "pick_place", ("cam",), (24, 32), 30)
    cameras = (
        f"{{cam: {{type: zmq, server_address: {link.host}, port: {link.camera_port}, "
        "camera_name: cam, width: 32, height: 24, fps: 30}}"
    )
    try:
        proc = _run(
            [
                python,
                "-m",
                "lerobot.scripts.lerobot_rollout",
                "--strategy.type=base",
                f"--policy.path={ckpt}",
                "--policy.device=cpu",
                "--robot.type=widowxai_follower_robot",
                f"--robot.ip_address={IP}",
                f"--robot.cameras={cameras}",
                "--task=pick up the red cube",
                "--duration=3",
                "--fps=30",
            ],
            tmp_path,
            timeout=300,
        )
    finally:
        stop_kit(kit)
    lines = kit.lines  # what serve printed
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Rollout finished" in proc.stdout + proc.stderr
    assert any(
        line.startswith(f"serving pick_place (seed 0, episode 0): the arm on {IP}")
        for line in lines
    )
    assert any(f"follower arm ({IP}): client connected" in line for line in lines), lines
    faults = [
        line
        for line in lines
        if " arm (" in line and not any(w in line for w in ("connected", "disconnected", "cleared"))
    ]
    assert not faults, faults
