"""``eval --backend wire`` of the single WidowX AI arm's tasks: eval starts ``serve --task_name
pick_place --ip ...`` (one arm, ``twin.arm_world``), drives it through the ``trossen_arm``
driver in wall-clock time and scores it by the kit's episode control channel (which takes the
in-process eval's cube and goal). On 127.0.0.181 .. 127.0.0.189 and free loopback ports
only. The scripted pick_place (8 s of wall-clock time) and a jump that faults the arm."""

from __future__ import annotations

import importlib
import json
import socket
import textwrap
import uuid
from pathlib import Path

import pytest

pytest.importorskip("trossen_arm_sim")
pytest.importorskip("trossen_arm")
pytest.importorskip("zmq")

from trossen_arm_mujoco.scripts import eval_policy  # noqa: E402

POLICIES = """
JUMPS = []

def jump_reset():
    JUMPS.clear()

def jump(obs):
    # hold still, then at step 5 ask joint_1 to jump by 1 rad
    assert len(obs["agent_pos"]) == 7 and len(obs["goal"]) == 3
    JUMPS.append(len(JUMPS))
    q = [float(v) for v in obs["agent_pos"]]
    if len(JUMPS) == 6:
        q[1] += 1.0
    return q

jump.reset = jump_reset
"""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def run_eval(tmp_path: Path, ip: str, *flags: str) -> tuple[int, dict | None]:
    out = tmp_path / f"out_{uuid.uuid4().hex[:6]}"
    rc = eval_policy.cli(
        [
            "--backend",
            "wire",
            "--task_name",
            "pick_place",
            "--left_ip",
            ip,
            "--camera_port",
            str(free_port()),
            "--control_port",
            str(free_port()),
            "--output_dir",
            str(out),
            *flags,
        ]
    )
    info = out / "eval_info.json"
    return rc, json.loads(info.read_text()) if info.exists() else None


def test_scripted_pick_place_through_the_served_arm_succeeds(tmp_path) -> None:
    rc, info = run_eval(
        tmp_path,
        "127.0.0.181",
        "--policy",
        "scripted",
        "--num_episodes",
        "1",
        "--episode_length",
        "400",  # the plan's 320 steps and a margin for periods a loaded machine misses
        "--cam_names",
        "cam",
        "--image_size",
        "48x64",
    )
    assert rc == 0 and info is not None
    assert info["run"]["backend"] == "wire" and info["run"]["layout"] == "widowxai"
    row = info["per_episode"][0]
    assert row["success"] and row["fault"] is None, info["timing"]["failures"]
    assert info["timing"]["actions"] >= 340  # of 400 (periods missed under load aside)
    peak = info["controller"]["peak_speed_fraction"]
    assert list(peak) == [*(f"joint_{i}" for i in range(6)), "gripper"]


def test_a_jump_faults_the_served_arm_and_names_its_joint(tmp_path, monkeypatch) -> None:
    name = f"arm_wire_policies_{uuid.uuid4().hex[:8]}"
    (tmp_path / f"{name}.py").write_text(textwrap.dedent(POLICIES), encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    importlib.import_module(name)
    rc, info = run_eval(
        tmp_path,
        "127.0.0.182",
        "--policy",
        f"{name}:jump",
        "--num_episodes",
        "1",
        "--episode_length",
        "30",
    )
    assert rc == 0 and info is not None
    row = info["per_episode"][0]
    assert not row["success"] and row["fault"] is not None
    assert row["fault"]["joint"] == "joint_1", row["fault"]
    assert row["max_reward"] < 0  # the shaped reward of a cube far from its goal, not 0
    assert info["controller"]["faulted_episodes"] == 1
