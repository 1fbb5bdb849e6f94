"""Shared parts of the vendor-style IK demos (``wxai_pick_place.py`` and the others): the
``--headless`` flag, the pick-and-place phases (``grasp``, ``release``) as waypoint plans
played through ``src.controller.Controller``, the placement report, and the viewer loop
(``run_demo``: headless or in the viewer, one exit status).

A plan is a list of ``Waypoint``: over ``steps`` physics steps each arm's target position
moves in a straight line from where the previous waypoint left it to ``targets[arm]``, and
its target orientation turns (slerp) from the previous waypoint's to ``quats[arm]`` (kept
when not given; ``DOWNWARD`` at the start); a gripper command is given at the waypoint's
start. The controllers compute controls, ``play`` steps physics.

Docs: docs/vendor-api.md.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import ArgumentParser, note
from trossen_arm_mujoco.quaternion import Quaternion
from trossen_arm_mujoco.src.controller import Controller, RobotType

__all__ = [
    "DOWNWARD",
    "SUCCESS_DISTANCE",
    "Waypoint",
    "demo_parser",
    "grasp",
    "has_display",
    "kit_arms",
    "play",
    "release",
    "report_placement",
    "run_demo",
    "show",
]

#: Tool frame pointing straight down (its x axis to world -z), quaternion [w, x, y, z].
DOWNWARD = np.array([np.sqrt(0.5), 0.0, np.sqrt(0.5), 0.0])
SUCCESS_DISTANCE = 0.02  # m, cube center to target in the table plane
RELEASE_HEIGHT = 0.004  # m above the resting cube's center where the gripper opens
#: Physics steps (2 ms) of ``grasp``'s moves: over, down, close, up; ``release``'s: over,
#: down, open, up.
GRASP_STEPS = (500, 350, 200, 350)
RELEASE_STEPS = (500, 350, 150, 300)
#: The same moves about 10 % faster (the kits' demos).
BRISK = {"grasp": (450, 300, 200, 300), "release": (450, 300, 150, 250)}


@dataclass
class Waypoint:
    """Targets reached at the end of ``steps`` physics steps.

    targets: arm name -> (3,) tool-frame position (m, world); arms not named hold theirs.
    quats: arm name -> (4,) orientation [w, x, y, z] reached at the segment's end (default:
        the previous segment's; DOWNWARD at the start).
    grippers: arm name -> "open" or "close", commanded at the segment's start.
    """

    steps: int
    targets: Mapping[str, Sequence[float]] = field(default_factory=dict)
    quats: Mapping[str, Sequence[float]] = field(default_factory=dict)
    grippers: Mapping[str, str] = field(default_factory=dict)


def demo_parser(description: str) -> argparse.ArgumentParser:
    """The demos' command line: ``--headless``."""
    parser = ArgumentParser(description=description)
    parser.add_argument(
        "--headless",
        action="store_true",
        help="run without the viewer and print what happened (also automatic without a display)",
    )
    return parser


def has_display() -> bool:
    """Whether a window can be opened: a DISPLAY or WAYLAND_DISPLAY on Linux, else assumed."""
    if sys.platform.startswith("linux"):
        return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    return True


def use_viewer(headless: bool) -> bool:
    """Whether to open the viewer; says so in one line when there is no display."""
    if headless:
        return False
    if not has_display():
        note("no display found: running headless (pass --headless to say so)")
        return False
    return True


def play(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    arms: Mapping[str, Controller],
    plan: Sequence[Waypoint],
    after_step: Callable[[], bool] | None = None,
    tick: Callable[[], None] | None = None,
    orientations: Mapping[str, Sequence[float]] | None = None,
) -> bool:
    """Run ``plan``: per physics step, one ``set_ee_pose`` per arm, then ``mj_step``.

    Args:
        model: compiled model.
        data: the state, stepped here.
        arms: arm name -> its ``Controller``.
        plan: the waypoints (physics steps, tool positions m, world frame).
        after_step: called after each step (the viewer's sync); returns False to stop early.
        tick: runs before each ``mj_step`` (other controllers: a mobile base's).
        orientations: the arms' target orientations at the start, quaternion wxyz (default
            ``DOWNWARD``; a plan played on from another gives that one's last).

    Returns:
        Whether the plan was played to its end.
    """
    current = {name: arm.get_ee_pose()[0] for name, arm in arms.items()}
    start_quats = orientations or {}
    quats = {name: np.asarray(start_quats.get(name, DOWNWARD), float) for name in arms}
    for wp in plan:
        for name, cmd in wp.grippers.items():
            arms[name].open_gripper() if cmd == "open" else arms[name].close_gripper()
        start = {n: p.copy() for n, p in current.items()}
        goal = {n: np.asarray(wp.targets.get(n, current[n]), float) for n in arms}
        turns = {n: (Quaternion(quats[n]), Quaternion(q)) for n, q in wp.quats.items()}
        for k in range(1, wp.steps + 1):
            a = k / wp.steps
            for name, (q0, q1) in turns.items():
                quats[name] = Quaternion.slerp(q0, q1, a).elements
            for name, arm in arms.items():
                arm.set_ee_pose(start[name] + a * (goal[name] - start[name]), quats[name])
            if tick is not None:
                tick()
            mujoco.mj_step(model, data)
            if after_step is not None and not after_step():
                return False
        current = goal
    return True


def grasp(
    arm: str,
    at: np.ndarray,
    clearance: float,
    quat: Sequence[float] | None = None,
    steps: Sequence[int] = GRASP_STEPS,
) -> list[Waypoint]:
    """Waypoints: the open gripper over ``at``, down to it, closed, lifted back.

    Args:
        arm: the arm's name.
        at: (3,) the tool frame's position at the grasp (m, world).
        clearance: the height above ``at`` the moves start and end at (m).
        quat: the tool's orientation (wxyz) from the first waypoint on; None: kept.
        steps: the physics steps of each move.
    """
    up = np.array([0.0, 0.0, clearance])
    turn = {arm: quat} if quat is not None else {}
    over, down, close, lift = steps
    return [
        Waypoint(over, {arm: at + up}, turn, grippers={arm: "open"}),
        Waypoint(down, {arm: at}),
        Waypoint(close, {arm: at}, grippers={arm: "close"}),
        Waypoint(lift, {arm: at + up}),
    ]


def release(
    arm: str,
    at: np.ndarray,
    clearance: float,
    quat: Sequence[float] | None = None,
    steps: Sequence[int] = RELEASE_STEPS,
) -> list[Waypoint]:
    """Waypoints: ``arm`` carries what it holds over ``at``, lowers it to ``RELEASE_HEIGHT``
    m above ``at``, opens and lifts away.

    Args:
        arm: the arm's name.
        at: (3,) the tool frame's position at the release (m, world).
        clearance: the height above ``at`` it arrives at and leaves to (m).
        quat: as in :func:`grasp`.
        steps: as in :func:`grasp`.
    """
    up = np.array([0.0, 0.0, clearance])
    low = np.array([0.0, 0.0, RELEASE_HEIGHT])
    turn = {arm: quat} if quat is not None else {}
    over, down, opening, lift = steps
    return [
        Waypoint(over, {arm: at + up}, turn),
        Waypoint(down, {arm: at + low}),
        Waypoint(opening, {arm: at + low}, grippers={arm: "open"}),
        Waypoint(lift, {arm: at + up}),
    ]


def kit_arms(model: mujoco.MjModel, data: mujoco.MjData, robot_type: RobotType) -> dict:
    """One ``Controller`` per arm of a kit, by side ("left", "right"), as the vendor's demos
    make them (``ik_scale`` 1.0, ``ik_damping`` 0.03).

    Args:
        model: the kit's compiled model.
        data: its state.
        robot_type: the kit's robot type.
    """
    return {
        side: Controller(
            model,
            data,
            robot_type,
            ee_site_name=f"{side}/ee_site",
            ik_scale=1.0,
            ik_damping=0.03,
        )
        for side in ("left", "right")
    }


def report_placement(cube: np.ndarray, target: np.ndarray, done: str, prefix: str = "") -> int:
    """Print how the demo ended; 0 when the cube (center ``cube``, m, world) rests within
    ``SUCCESS_DISTANCE`` of ``target`` in the table plane and within 0.01 m of its height,
    else 1.

    Args:
        cube: (3,) the cube's center (m, world).
        target: (3,) the target (m, world).
        done: the success line's start ("``done`` <miss> m from the target").
        prefix: the failure line's start, before where the cube ended.
    """
    miss = float(np.linalg.norm(cube[:2] - target[:2]))
    if miss <= SUCCESS_DISTANCE and abs(cube[2] - target[2]) < 0.01:
        print(f"{done} {miss:.3f} m from the target")
        return 0
    print(
        f"{prefix}the cube ended at {np.round(cube, 3).tolist()} m, {miss:.3f} m from the "
        f"target {np.round(target, 3).tolist()} (success: within {SUCCESS_DISTANCE} m, "
        f"resting on the table)"
    )
    return 1


def run_demo(
    headless: bool,
    model: mujoco.MjModel,
    data: mujoco.MjData,
    demo: Callable[[Callable[[], bool] | None], int | None],
    hold: Callable[[], None],
    lookat: Sequence[float] = (0.3, 0.0, 0.1),
    distance: float = 1.2,
) -> int:
    """Run ``demo(after_step)`` headless (``after_step`` None) or in the viewer.

    Args:
        headless: run without a viewer.
        model: compiled model.
        data: the state.
        demo: the demo; returns its exit status, or None when the viewer stopped it early
            (then one line says so, and the status is 0).
        hold: keeps the arms still after the demo (see :func:`show`).
        lookat: the viewer camera's target (m, world).
        distance: the viewer camera's distance (m).

    Returns:
        The exit status.
    """
    if not use_viewer(headless):
        status = demo(None)
        return 1 if status is None else status
    result: list[int | None] = []
    show(model, data, lambda after_step: result.append(demo(after_step)), hold, lookat, distance)
    if not result or result[0] is None:
        print("the viewer was closed before the demo finished")
        return 0
    return result[0]


def show(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    run: Callable[[Callable[[], bool]], None],
    hold: Callable[[], None],
    lookat: Sequence[float] = (0.3, 0.0, 0.1),
    distance: float = 1.2,
) -> None:
    """Open the passive viewer, ``run(after_step)`` in real time, then keep calling
    ``hold()`` (one control tick, then a physics step) until the window is closed.

    Args:
        model: compiled model.
        data: the state.
        run: the demo, given the viewer's sync.
        hold: one control tick and physics step with the arms still.
        lookat: the viewer camera's target (m, world).
        distance: the viewer camera's distance (m).
    """
    import mujoco.viewer

    with mujoco.viewer.launch_passive(model, data) as viewer:
        viewer.cam.lookat[:] = lookat
        viewer.cam.distance = distance
        viewer.cam.azimuth, viewer.cam.elevation = 135, -25
        dt = float(model.opt.timestep)
        clock = [time.perf_counter()]

        def after_step() -> bool:
            viewer.sync()
            clock[0] += dt
            wait = clock[0] - time.perf_counter()
            if wait > 0:
                time.sleep(wait)
            return viewer.is_running()

        run(after_step)
        while viewer.is_running():
            hold()
            mujoco.mj_step(model, data)
            after_step()
