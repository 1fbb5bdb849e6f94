"""Drive the served simulated kit through Trossen's LeRobot plugin, and measure it.

Starts ``trossen-mujoco serve`` (both arms on loopback addresses), builds the plugin's
``bi_widowxai_follower_robot`` the way LeRobot's scripts do (``make_robot_from_config``),
connects, times ``get_observation`` / ``send_action``, streams a small move of five joints
and both grippers at the plugin's loop rate, reads back the error once settled,
disconnects and stops the server (SIGINT). Needs Python 3.12 with LeRobot and the plugin:

    python examples/lerobot_plugin_on_served_kit.py [--left_ip 127.0.0.2 --right_ip 127.0.0.3]
"""

from __future__ import annotations

import argparse
import importlib.util
import ipaddress
import queue
import shlex
import shutil
import signal
import subprocess
import sys
import threading
import time

import numpy as np

HINT = (
    "Trossen's LeRobot plugin is not importable here: in a Python 3.12 environment with "
    "LeRobot, pip install --no-deps <lerobot_trossen>/packages/lerobot_robot_trossen, then "
    "pip install trossen_arm trossen-slate"
)


def serve_command(given: str | None) -> list[str]:
    """How to run ``trossen-mujoco``: --serve_cmd, this interpreter's package, or PATH."""
    if given:
        return shlex.split(given)
    if importlib.util.find_spec("trossen_arm_mujoco") is not None:
        return [sys.executable, "-m", "trossen_arm_mujoco.cli"]
    found = shutil.which("trossen-mujoco")
    if found is None:
        sys.exit("error: trossen-mujoco not found; pass --serve_cmd 'COMMAND'")
    return [found]


def start_server(cmd: list[str], left: str, right: str) -> tuple[subprocess.Popen, queue.Queue]:
    """Start serve; return once it says it serves (its output lines go to the queue)."""
    proc = subprocess.Popen(
        [*cmd, "serve", "--task_name", "sim_transfer_cube", "--left_ip", left, "--right_ip", right],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),  # Ctrl-C stops it
    )
    lines: queue.Queue = queue.Queue()
    pump = threading.Thread(target=lambda: [lines.put(x.rstrip()) for x in proc.stdout])
    pump.daemon = True
    pump.start()
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        try:
            line = lines.get(timeout=0.5)
        except queue.Empty:
            continue
        print(f"[serve] {line}")
        if line.startswith("serving"):
            return proc, lines
    stop_server(proc, lines)
    sys.exit("error: the served kit did not start (see its lines above)")


def stop_server(proc: subprocess.Popen, lines: queue.Queue) -> None:
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(15)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
    time.sleep(0.2)
    while not lines.empty():
        print(f"[serve] {lines.get()}")


def stats(seconds: list[float]) -> str:
    ms = np.asarray(seconds) * 1e3
    return f"median {np.median(ms):.2f} ms, p99 {np.percentile(ms, 99):.2f} ms"


def drive(left: str, right: str) -> None:
    from lerobot.robots import RobotConfig
    from lerobot.robots.utils import make_robot_from_config
    from lerobot.utils.robot_utils import precise_sleep

    config = RobotConfig.get_choice_class("bi_widowxai_follower_robot")(
        left_arm_ip_address=left, right_arm_ip_address=right, id="served_kit"
    )
    robot = make_robot_from_config(config)
    t0 = time.perf_counter()
    robot.connect()  # each arm in turn: configure, position mode, 2 s move to the staged pose
    print(f"connect (both arms, with the plugin's staging moves): {time.perf_counter() - t0:.2f} s")
    keys = list(robot.action_features)  # left_joint_0.pos .. right_left_carriage_joint.pos

    def read() -> np.ndarray:
        obs = robot.get_observation()
        return np.array([obs[k] for k in keys])

    start, reads, sends = read(), [], []
    for _ in range(100):
        t = time.perf_counter()
        robot.get_observation()
        reads.append(time.perf_counter() - t)
        t = time.perf_counter()
        robot.send_action(dict(zip(keys, start.tolist())))
        sends.append(time.perf_counter() - t)
    print(f"get_observation: {stats(reads)}; send_action: {stats(sends)}")
    # a small move: joints 0, 1, 2, 3, 5 of each arm by 0.15 .. 0.3 rad, grippers to 20 mm open
    delta = np.tile([0.2, 0.15, -0.15, 0.2, 0.0, -0.3, 0.02], 2)
    rate, target, lag, periods = config.loop_rate, start, [], []
    ramp, hold = int(1.5 * rate), int(1.0 * rate)
    t_prev = time.perf_counter()
    for i in range(ramp + hold):
        t = time.perf_counter()
        lag.append(read() - target)  # where the arms are vs the previous command
        target = start + min(1.0, (i + 1) / ramp) * delta
        robot.send_action(dict(zip(keys, target.tolist())))
        precise_sleep(max(1.0 / rate - (time.perf_counter() - t), 0.0))
        periods.append(time.perf_counter() - t_prev)
        t_prev = time.perf_counter()
    time.sleep(0.5)
    lag, err = np.abs(np.array(lag[1:])), np.abs(read() - (start + delta))
    joints, grippers = [i for i in range(14) if i % 7 != 6], [6, 13]
    print(f"loop: {1.0 / np.mean(periods[1:]):.2f} Hz achieved at the plugin's loop_rate {rate}")
    rms, top, grip = np.sqrt(np.mean(lag[:, joints] ** 2)), lag[:, joints].max(), lag[:, grippers]
    print(
        f"while streaming (measured - last command): joints {rms:.4f} rad RMS, "
        f"{top:.4f} max; grippers {1e3 * grip.max():.2f} mm max"
    )
    print(
        f"settled 0.5 s after the last command: joints {err[joints].max():.2e} rad max, "
        f"grippers {1e3 * err[grippers].max():.3f} mm max"
    )
    t0 = time.perf_counter()
    robot.disconnect()  # staged pose, then sleep pose, then cleanup
    print(f"disconnect: {time.perf_counter() - t0:.2f} s")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--left_ip", default="127.0.0.2")
    p.add_argument("--right_ip", default="127.0.0.3")
    p.add_argument("--serve_cmd", help="command that runs trossen-mujoco (default: found)")
    args = p.parse_args()
    for ip in (args.left_ip, args.right_ip):  # the served kit, never a real arm
        try:
            loopback = ipaddress.ip_address(ip).is_loopback
        except ValueError:
            loopback = False
        if not loopback:
            print(f"error: {ip} is not a loopback address: use 127.0.0.0/8", file=sys.stderr)
            return 2
    try:
        import lerobot_robot_trossen  # noqa: F401  (registers bi_widowxai_follower_robot)
    except ImportError as exc:
        print(f"error: {HINT} ({exc})", file=sys.stderr)
        return 2
    proc, lines = start_server(serve_command(args.serve_cmd), args.left_ip, args.right_ip)
    try:
        drive(args.left_ip, args.right_ip)
    finally:
        stop_server(proc, lines)
    return 0


if __name__ == "__main__":
    sys.exit(main())
