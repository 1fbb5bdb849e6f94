"""Shared parts of the vendor-style IK demos (``wxai_pick_place.py`` and the others): the
``--headless`` flag, waypoint plans played through ``src.controller.Controller``, and the
viewer loop.

A plan is a list of ``Waypoint``: over ``steps`` physics steps each arm's target position
moves in a straight line from where the previous waypoint left it to ``targets[arm]``
(orientation: the waypoint's, held); a gripper command is given at the waypoint's start.
The controllers compute controls, ``play`` steps physics.
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
from trossen_arm_mujoco.src.controller import Controller

__all__ = ["DOWNWARD", "Waypoint", "demo_parser", "has_display", "play", "show"]

#: Tool frame pointing straight down (its x axis to world -z), quaternion [w, x, y, z].
DOWNWARD = np.array([np.sqrt(0.5), 0.0, np.sqrt(0.5), 0.0])


@dataclass
class Waypoint:
    """Targets reached at the end of ``steps`` physics steps.

    targets: arm name -> (3,) tool-frame position (m, world); arms not named hold theirs.
    quats: arm name -> (4,) orientation [w, x, y, z] for the whole segment (default DOWNWARD).
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
) -> bool:
    """Run ``plan``: per physics step, one ``set_ee_pose`` per arm, then ``mj_step``.

    ``tick`` runs before each ``mj_step`` (other controllers: a mobile base's); ``after_step``
    (the viewer's sync) returns False to stop early. Returns whether the plan was played to
    its end.
    """
    current = {name: arm.get_ee_pose()[0] for name, arm in arms.items()}
    quats = {name: DOWNWARD for name in arms}
    for wp in plan:
        for name, cmd in wp.grippers.items():
            arms[name].open_gripper() if cmd == "open" else arms[name].close_gripper()
        start = {n: p.copy() for n, p in current.items()}
        goal = {n: np.asarray(wp.targets.get(n, current[n]), float) for n in arms}
        quats.update({n: np.asarray(q, float) for n, q in wp.quats.items()})
        for k in range(1, wp.steps + 1):
            a = k / wp.steps
            for name, arm in arms.items():
                arm.set_ee_pose(start[name] + a * (goal[name] - start[name]), quats[name])
            if tick is not None:
                tick()
            mujoco.mj_step(model, data)
            if after_step is not None and not after_step():
                return False
        current = goal
    return True


def show(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    run: Callable[[Callable[[], bool]], None],
    hold: Callable[[], None],
    lookat: Sequence[float] = (0.3, 0.0, 0.1),
    distance: float = 1.2,
) -> None:
    """Open the passive viewer, ``run(after_step)`` in real time, then keep calling
    ``hold()`` (one control tick, then a physics step) until the window is closed."""
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
