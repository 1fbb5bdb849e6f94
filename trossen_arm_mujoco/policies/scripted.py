"""Waypoint trajectories for scripted policies: (t, xyz, quat, gripper), interpolation, noise.

A waypoint is a dict ``{"t": step, "xyz": (3,) m, "quat": (4,) wxyz, "gripper": m}``, with
poses of the arm's tool frame (``ee_site``) in the world frame and the gripper as finger
travel (0 closed .. 0.044 open). Between waypoints, positions and gripper interpolate
linearly and orientations by slerp.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.quaternion import Quaternion

Waypoint = dict


def waypoint(t: float, xyz, quat, gripper: float) -> Waypoint:
    """Build a waypoint dict with float arrays."""
    return {
        "t": float(t),
        "xyz": np.asarray(xyz, dtype=float).copy(),
        "quat": np.asarray(quat, dtype=float).copy(),
        "gripper": float(gripper),
    }


def check_waypoints(waypoints: Sequence[Waypoint], name: str) -> None:
    """Times must start at 0 and increase strictly; every value finite."""
    if not waypoints:
        raise UserError(f"{name}: no waypoints")
    times = [w["t"] for w in waypoints]
    if times[0] != 0 or any(b <= a for a, b in zip(times, times[1:])):
        raise UserError(f"{name}: waypoint times must start at 0 and increase, got {times}")
    for w in waypoints:
        values = np.concatenate([w["xyz"], w["quat"], [w["gripper"]]])
        if not np.all(np.isfinite(values)):
            raise UserError(f"{name}: waypoint at t={w['t']} has NaN or inf")


def interpolate(waypoints: Sequence[Waypoint], t: float) -> np.ndarray:
    """Pose and gripper at time ``t``: [x, y, z, qw, qx, qy, qz, gripper] (8,).

    Before the first / after the last waypoint the end values are held.
    """
    if t <= waypoints[0]["t"]:
        w = waypoints[0]
        return np.concatenate([w["xyz"], Quaternion(w["quat"]).normalised.elements, [w["gripper"]]])
    for prev, nxt in zip(waypoints, waypoints[1:]):
        if prev["t"] <= t <= nxt["t"]:
            frac = (t - prev["t"]) / (nxt["t"] - prev["t"])
            xyz = prev["xyz"] + frac * (nxt["xyz"] - prev["xyz"])
            quat = Quaternion.slerp(Quaternion(prev["quat"]), Quaternion(nxt["quat"]), frac)
            grip = prev["gripper"] + frac * (nxt["gripper"] - prev["gripper"])
            return np.concatenate([xyz, quat.elements, [grip]])
    w = waypoints[-1]
    return np.concatenate([w["xyz"], Quaternion(w["quat"]).normalised.elements, [w["gripper"]]])


def add_position_noise(
    waypoints: Sequence[Waypoint], rng: np.random.Generator, scale: float, skip_first: bool = True
) -> list[Waypoint]:
    """Copies of the waypoints with xyz += U(-scale, scale) per axis (m)."""
    out = []
    for i, w in enumerate(waypoints):
        w = dict(w)
        if not (skip_first and i == 0):
            w["xyz"] = w["xyz"] + rng.uniform(-scale, scale, size=3)
        out.append(w)
    return out
