"""``eval --backend wire``: policies driven through the served kit (the ``trossen_arm`` driver
and the ZMQ camera stream) in wall-clock time, on 127.0.0.131 .. 127.0.0.138 and free loopback
ports only. The scripted transfer over 10 episodes (9 s each: it transfers by about 8 s) takes
about 110 s; the other tests a few seconds each. The ``serve`` that eval starts stops with
SIGTERM even where SIGINT is ignored, and dies with its parent, even one killed (SIGKILL)."""

from __future__ import annotations

import importlib
import json
import os
import signal
import socket
import subprocess
import sys
import textwrap
import time
import uuid
from pathlib import Path

import pytest

pytest.importorskip("trossen_arm_sim")
pytest.importorskip("trossen_arm")
pytest.importorskip("zmq")

from trossen_arm_mujoco.scripts import eval_policy  # noqa: E402

POLICIES = """
import threading
import time

STALL_AT, STALL_S, STEPS = 5, 0.0, []
STREAM = None  # a CameraStream the policy stops at step 10 (set by the test)


def hold(obs):
    STEPS.append(len(STEPS))
    if len(STEPS) == STALL_AT:
        if STALL_S > 0:
            time.sleep(STALL_S)
        else:
            threading.Event().wait()  # never answers
    return obs["agent_pos"]


def raises(obs):
    STEPS.append(len(STEPS))
    if len(STEPS) == 3:
        raise ValueError("the policy broke")
    return obs["agent_pos"]


def text(obs):
    return "left"


def mapping(obs):
    return {"left": obs["agent_pos"]}


JUMPS = []


def jump_reset():
    JUMPS.clear()


def jump(obs):
    # hold still, then at step 5 ask the left joint_1 to jump by 1 rad
    JUMPS.append(len(JUMPS))
    q = [float(v) for v in obs["agent_pos"]]
    if len(JUMPS) == 6:
        q[1] += 1.0
    return q


jump.reset = jump_reset


def nan(obs):
    q = [float(v) for v in obs["agent_pos"]]
    q[3] = float("nan")
    return q


def stop_stream(obs):
    STEPS.append(len(STEPS))
    if len(STEPS) == 10:
        STREAM.stop()
    return obs["agent_pos"]
"""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def policies(tmp_path, monkeypatch):
    name = f"wire_policies_{uuid.uuid4().hex[:8]}"
    (tmp_path / f"{name}.py").write_text(textwrap.dedent(POLICIES), encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    return importlib.import_module(name)


def run_eval(tmp_path: Path, left: str, right: str, *flags: str) -> tuple[int, dict | None]:
    out = tmp_path / f"out_{uuid.uuid4().hex[:6]}"
    rc = eval_policy.cli(
        [
            "--backend",
            "wire",
            "--left_ip",
            left,
            "--right_ip",
            right,
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


@pytest.mark.once  # about 100 s of wall-clock time; run on one interpreter
@pytest.mark.long  # bash tools/run_tests.sh --long (and CI) run it: docs/testing.md
def test_scripted_transfer_through_the_wire_scores_90_percent(tmp_path) -> None:
    rc, info = run_eval(
        tmp_path,
        "127.0.0.131",
        "127.0.0.132",
        "--policy",
        "scripted",
        "--num_episodes",
        "10",
        "--episode_length",
        "450",
        "--cam_names",
        "cam_high",
        "--image_size",
        "48x64",
    )
    assert rc == 0 and info is not None
    assert info["aggregated"]["pc_success"] >= 90.0, info["per_episode"]
    assert [r["seed"] for r in info["per_episode"]] == list(range(10))  # eval's seeds
    timing = info["timing"]
    assert timing["actions"] >= 10 * 440 and timing["missed_periods"] <= 10 * 10
    assert timing["obs_age_ms_median_of_episodes"] < 1000
    assert timing["action_latency_ms_median_of_episodes"] < 20  # one 50 fps period
    assert info["run"]["backend"] == "wire"


def test_a_policy_that_stalls_fails_its_episode_with_the_reason(tmp_path, policies) -> None:
    policies.STALL_S = 0.5
    rc, info = run_eval(
        tmp_path,
        "127.0.0.133",
        "127.0.0.134",
        "--policy",
        f"{policies.__name__}:hold",
        "--num_episodes",
        "2",
        "--episode_length",
        "20",
        "--action_timeout",
        "0.3",
    )
    assert rc == 0 and info is not None
    first, second = info["per_episode"]
    assert not first["success"] and first["steps"] == 4
    assert "the policy sent no action for 0.3 s (step " in info["timing"]["failures"]["0"]
    # the policy answered again: the next episode ran whole (periods missed under load aside)
    timing = info["timing"]["per_episode"][1]
    assert "1" not in info["timing"]["failures"]
    assert second["steps"] == timing["actions"]
    assert timing["actions"] + timing["missed_periods"] == 20
    rollouts = json.loads((Path(info["run"]["output_dir"]) / "rollouts.json").read_text())
    assert "no action" in rollouts["episodes"][0]["failure"]


def test_a_policy_that_never_answers_is_reported_not_hung(tmp_path, policies, capsys) -> None:
    policies.STALL_S = 0.0  # blocks forever at its 5th call
    rc, info = run_eval(
        tmp_path,
        "127.0.0.133",
        "127.0.0.134",
        "--policy",
        f"{policies.__name__}:hold",
        "--num_episodes",
        "2",
        "--episode_length",
        "20",
        "--action_timeout",
        "0.3",
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and info is None
    assert err[-1].startswith("error: ") and "has not answered for more than 0.3 s" in err[-1]


def test_a_camera_stream_that_stops_fails_the_episode(tmp_path, policies) -> None:
    """``--connect`` to a kit served in this process; the policy stops its stream mid-way."""
    from trossen_arm_mujoco.twin.camera_stream import CameraStream
    from trossen_arm_mujoco.twin.episode_control import EpisodeControl
    from trossen_arm_mujoco.twin.kit_world import KitWorld
    from trossen_arm_mujoco.twin.served_kit import ServedKit

    left, right = "127.0.0.135", "127.0.0.136"
    cam_port, control_port = free_port(), free_port()
    world = KitWorld()
    kit = ServedKit(world, {"left": left, "right": right})
    stream = CameraStream(world, ["cam_high"], 48, 64, fps=25, port=cam_port)
    control = EpisodeControl(world, control_port)
    policies.STREAM = stream
    try:
        kit.start()
        stream.start()
        control.start()
        out = tmp_path / "out"
        rc = eval_policy.cli(
            [
                "--backend",
                "wire",
                "--connect",
                "--left_ip",
                left,
                "--right_ip",
                right,
                "--camera_port",
                str(cam_port),
                "--control_port",
                str(control_port),
                "--policy",
                f"{policies.__name__}:stop_stream",
                "--cam_names",
                "cam_high",
                "--image_size",
                "48x64",
                "--num_episodes",
                "1",
                "--episode_length",
                "200",
                "--output_dir",
                str(out),
            ]
        )
    finally:
        stream.stop()
        control.stop()
        kit.close()
    assert rc == 0
    info = json.loads((out / "eval_info.json").read_text())
    (row,) = info["per_episode"]
    assert not row["success"] and 10 <= row["steps"] < 200
    assert "camera stream stopped (cam_high" in info["timing"]["failures"]["0"]


@pytest.mark.parametrize(
    ("flags", "expected"),
    [
        (["--left_ip", "192.168.1.5"], "--left_ip '192.168.1.5' is not an IPv4 loopback"),
        (["--right_ip", "0.0.0.0"], "--right_ip '0.0.0.0' is not an IPv4 loopback"),
        (["--videos", "1"], "--backend wire runs one episode at a time"),
        (["--action_timeout", "0"], "--action_timeout must be in"),
        (["--speed_limit_fraction", "1.5"], "--speed_limit_fraction must be in (0, 1]"),
    ],
)
def test_mistakes_are_one_line_exit_2(flags, expected, tmp_path, capsys) -> None:
    rc = eval_policy.cli(
        [
            "--backend",
            "wire",
            "--policy",
            "scripted",
            "--num_episodes",
            "2",
            "--output_dir",
            str(tmp_path / "o"),
            *flags,
        ]
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and expected in err[0], err


def test_a_kit_that_is_not_there_is_one_line(tmp_path, capsys) -> None:
    rc = eval_policy.cli(
        [
            "--backend",
            "wire",
            "--connect",
            "--policy",
            "scripted",
            "--left_ip",
            "127.0.0.137",
            "--right_ip",
            "127.0.0.138",
            "--control_port",
            str(free_port()),
            "--num_episodes",
            "1",
            "--output_dir",
            str(tmp_path / "o"),
        ]
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and err[-1].startswith("error: no episode control channel on 127.0.0.1")


@pytest.fixture
def kit_here():
    """A served kit in this process (no cameras) with its control channel, for ``--connect``:
    (left address, right address, control port)."""
    from trossen_arm_mujoco.twin.episode_control import EpisodeControl
    from trossen_arm_mujoco.twin.kit_world import KitWorld
    from trossen_arm_mujoco.twin.served_kit import ServedKit

    left, right, port = "127.0.0.135", "127.0.0.136", free_port()
    world = KitWorld()
    kit = ServedKit(world, {"left": left, "right": right})
    control = EpisodeControl(world, port)
    try:
        kit.start()
        control.start()
        yield left, right, port
    finally:
        control.stop()
        kit.close()


def policy_error(argv: list[str], capsys) -> tuple[int, str, str]:
    """Run eval; (exit status, its one ``error:`` line, what follows it)."""
    rc = eval_policy.cli(argv)
    lines = capsys.readouterr().err.splitlines()
    at = [i for i, line in enumerate(lines) if line.startswith("error:")]
    assert len(at) == 1, lines
    return rc, lines[at[0]], "\n".join(lines[at[0] + 1 :])


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("raises", r"raised ValueError at episode 0 step \d+: the policy broke$"),
        (
            "text",
            "raised ValueError at episode 0 step 0: could not convert string to float: 'left'$",
        ),
        ("mapping", "raised TypeError at episode 0 step 0: float\\(\\) argument must be"),
    ],
)
def test_a_policy_that_raises_ends_the_run_as_in_the_sim(
    name, expected, tmp_path, policies, kit_here, capsys
) -> None:
    """Not an arm fault: one ``error:`` line naming the policy, episode and step, then the
    policy's traceback, exit status 1, no eval_info.json (as ``--backend sim``)."""
    import re

    left, right, port = kit_here
    spec = f"{policies.__name__}:{name}"
    common = ["--policy", spec, "--num_episodes", "2", "--episode_length", "10"]
    out = tmp_path / "wire"
    rc, line, rest = policy_error(
        [
            "--backend",
            "wire",
            "--connect",
            "--left_ip",
            left,
            "--right_ip",
            right,
            "--control_port",
            str(port),
            "--output_dir",
            str(out),
            *common,
        ],
        capsys,
    )
    assert rc == 1 and line.startswith(f"error: the policy {spec} raised "), line
    assert re.search(expected, line), line
    assert "Traceback" in rest and "arm controller error" not in rest
    assert not (out / "eval_info.json").exists()
    if name != "raises":  # the same line as the in-process eval (a step the wire may skip)
        policies.STEPS.clear()
        sim_rc, sim_line, _ = policy_error([*common, "--output_dir", str(tmp_path / "sim")], capsys)
        assert (sim_rc, sim_line) == (rc, line)


def test_a_non_finite_action_stops_both_backends_with_the_same_line(
    tmp_path, policies, kit_here, capsys
) -> None:
    """A NaN in an action is no arm fault to score: both backends stop the run at that step,
    one ``error:`` line, exit status 2, no eval_info.json (a damaged checkpoint's weights
    answer so: tests/eval/test_checkpoint_files.py)."""
    left, right, port = kit_here
    spec = f"{policies.__name__}:nan"
    common = ["--policy", spec, "--num_episodes", "2", "--episode_length", "10"]
    wire_out, sim_out = tmp_path / "wire", tmp_path / "sim"
    wire = [
        "--backend",
        "wire",
        "--connect",
        "--left_ip",
        left,
        "--right_ip",
        right,
        "--control_port",
        str(port),
    ]
    rc, line, rest = policy_error([*wire, "--output_dir", str(wire_out), *common], capsys)
    assert rc == 2 and rest == ""
    assert line == (
        f"error: the policy {spec} produced a non-finite action at episode 0 step 0: NaN in "
        "1 of 14 values; a policy must return finite numbers: check what it computes"
    )
    sim_rc, sim_line, sim_rest = policy_error([*common, "--output_dir", str(sim_out)], capsys)
    assert (sim_rc, sim_line, sim_rest) == (rc, line, "")
    assert not (wire_out / "eval_info.json").exists() and not (sim_out / "eval_info.json").exists()


#: A stand-in for eval: starts the kit as eval does (``wire_link.start_kit``), prints the
#: kit's pid, then waits to be killed. ``plain``: without the kernel's parent-death signal
#: (only serve's own watch of its parent).
PARENT = """
import sys, time
from trossen_arm_mujoco.eval import wire_link
if sys.argv[4] == "plain":
    wire_link._child_setup = lambda parent: None
link = wire_link.KitLink(sys.argv[1], sys.argv[2], control_port=int(sys.argv[3]))
kit = wire_link.start_kit(link, "sim_transfer_cube", (), (48, 64), 50.0)
print(kit.pid, flush=True)
time.sleep(600)
"""


def _gone(pid: int, timeout: float) -> bool:
    """Whether process ``pid`` ends (or is a zombie) within ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            with open(f"/proc/{pid}/stat") as f:
                if f.read().rsplit(")", 1)[1].split()[0] == "Z":
                    return True
        except FileNotFoundError:
            return True
        time.sleep(0.1)
    return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("how", ["linux", "plain"])
def test_a_killed_eval_takes_its_kit_with_it(how) -> None:
    """SIGKILL of the process that started the kit: the kit stops (on Linux the kernel's
    SIGTERM; ``plain``: serve's own watch of its parent) and frees its ports."""
    port = free_port()
    parent = subprocess.Popen(
        [sys.executable, "-c", PARENT, "127.0.0.137", "127.0.0.138", str(port), how],
        stdout=subprocess.PIPE,
        text=True,
        env={**os.environ, "MUJOCO_GL": "egl"},
    )
    child = None
    try:
        child = int(parent.stdout.readline())
        with socket.create_connection(("127.0.0.1", port), timeout=10):
            pass  # the kit serves
        parent.kill()
        parent.wait(10)
        assert _gone(child, 20), "the kit outlived the process that started it"
        with socket.socket() as s:
            s.bind(("127.0.0.1", port))  # its control port is free again
    finally:
        if parent.poll() is None:
            parent.kill()
            parent.wait()
        if child is not None and not _gone(child, 0.1):
            os.kill(child, signal.SIGKILL)


def test_the_kit_stops_at_once_with_its_report_when_sigint_is_ignored() -> None:
    """A background eval (``trap '' INT``): its kit inherits SIGINT ignored, and still stops
    at once, with its last lines (the kit's report in the timing block)."""
    from trossen_arm_mujoco.eval.wire_link import KitLink, start_kit, stop_kit

    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        kit = start_kit(
            KitLink("127.0.0.137", "127.0.0.138", control_port=free_port()),
            "sim_transfer_cube",
            (),
            (48, 64),
            50.0,
        )
    finally:
        signal.signal(signal.SIGINT, previous)
    started = time.monotonic()
    try:
        lines = stop_kit(kit)
    finally:
        if kit.poll() is None:
            kit.kill()
            kit.wait()
    assert time.monotonic() - started < 20 and kit.returncode == 0, lines
    assert any(line.startswith("stopped (SIGTERM) after ") for line in lines), lines


def test_a_joint_jump_faults_through_the_wire_as_in_process(tmp_path, policies, kit_here):
    """The same controller checks: a 1 rad jump faults the served arm within one control
    period of the step at which the in-process evaluation faults, named alike."""
    left, right, port = kit_here
    spec = f"{policies.__name__}:jump"
    common = [
        "--policy",
        spec,
        "--num_episodes",
        "1",
        "--episode_length",
        "20",
        "--cam_names",
        "none",
    ]
    wire_out, sim_out = tmp_path / "wire", tmp_path / "sim"
    rc = eval_policy.cli(
        [
            "--backend",
            "wire",
            "--connect",
            "--left_ip",
            left,
            "--right_ip",
            right,
            "--control_port",
            str(port),
            "--output_dir",
            str(wire_out),
            *common,
        ]
    )
    assert rc == 0
    rc = eval_policy.cli([*common, "--output_dir", str(sim_out)])
    assert rc == 0
    wire = json.loads((wire_out / "eval_info.json").read_text())
    sim = json.loads((sim_out / "eval_info.json").read_text())
    wf, sf = wire["per_episode"][0]["fault"], sim["per_episode"][0]["fault"]
    assert (
        (wf["joint"], wf["kind"], wf["limit"])
        == (sf["joint"], sf["kind"], sf["limit"])
        == ("left_joint_1", "speed", 3.375)
    )
    assert wf["asked"] == pytest.approx(sf["asked"], rel=0.01)
    assert sf["step"] == 5 and 0 <= wf["step"] - sf["step"] <= 1
    assert wire["controller"]["faults_by_joint"] == sim["controller"]["faults_by_joint"]
    assert wire["controller"]["peak_speed_fraction"]["left_joint_1"] > 4.9
