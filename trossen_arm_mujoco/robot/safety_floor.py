"""The safety floor: a robot's arms kept above the table, in the robot layer.

A ``Robot`` holds at most one :class:`SafetyFloor` (``Robot.set_safety_floor``; the task
samplers install one) at ``floor_z = table_height + margin`` (m, world z), so every front
door that drives a robot gets it. Joint-actuated arms: every control tick, a move that would
take a point of the arm's collision geoms or tool frame below the floor, and lower than it
was, is shortened (fractions of :data:`BACKOFF`, down to holding the control); the
controller keeps its target. Cartesian targets (``ee_delta``, ``ee_pose``, mocap arms) have
their tool-frame height clipped before IK (:meth:`SafetyFloor.tool_height`). The floor holds
controls, not geometry, and gripper targets are not floored. What it changed is in
``report`` (:class:`FloorReport`; gym ``info["safety_clipped"]``, ``info["safety_links"]``).

Docs: docs/concepts/architecture.md (the robot layer); the full rule and its cost:
docs/concepts/design-notes.md.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.floor_points import ArmPoints
from trossen_arm_mujoco.robot.selection import as_slice

__all__ = ["BACKOFF", "TOLERANCE", "FloorReport", "SafetyFloor", "floor_height"]

#: Rounding (m) below which a point is not lower than it was (a turn about a vertical axis
#: leaves heights equal up to it).
TOLERANCE = 1e-9
#: Fractions of an arm's move tried when the whole move would break the floor.
BACKOFF = (0.5, 0.25, 0.125, 0.0)


def floor_height(table_height: float, margin: float = 0.0) -> float:
    """``table_height + margin`` (m, world z), checked: a one-line UserError for a height
    that is not a finite number, or a margin that is negative, NaN or infinite (a NaN floor
    would compare False: no floor at all)."""
    for name, value in (("table height", table_height), ("safety margin", margin)):
        if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
            raise UserError(f"safety floor: {name} must be a number (m), got {value!r:.40}")
    if not math.isfinite(table_height):
        raise UserError(
            f"safety floor: table height must be a finite number (m), got {table_height}"
        )
    if not (math.isfinite(margin) and margin >= 0):
        raise UserError(f"safety floor: safety margin must be a number >= 0 (m), got {margin}")
    return float(table_height) + float(margin)


class FloorReport:
    """What the safety floor changed since the robot's last command.

    Attributes:
        links: names of the links it held up (a tool frame's: the body of the site), in the
            order first met, each once.
    """

    __slots__ = ("links",)

    def __init__(self) -> None:
        self.links: list[str] = []

    @property
    def clipped(self) -> bool:
        """Whether the floor changed a control or a target."""
        return bool(self.links)

    def add(self, link: str) -> None:
        """Note that the floor held ``link`` (a body name) up this step (once)."""
        if link not in self.links:
            self.links.append(link)

    def clear(self) -> None:
        """Forget the links of the last step (a new step begins)."""
        if self.links:
            self.links.clear()


class SafetyFloor:
    """The floor of one robot's arms, and the heights of their points.

    Args:
        model: compiled model.
        arms: joint-actuated arm move groups (first joint nearest the base), every collision
            geom and the tool frame kept above the floor.
        floor_z: lowest allowed height (m, world z), e.g. ``floor_height(table_height,
            margin)``.
        tools: mocap arm groups: their commanded tool-frame pose is kept above the floor.

    Attributes:
        arms: arm name -> ``ArmPoints``.
        report: ``FloorReport`` of what the floor changed (cleared by the robot).
    """

    def __init__(self, model: mujoco.MjModel, arms: Sequence, floor_z: float, tools: Sequence = ()):
        self.model = model
        self.floor_z = float(floor_z)
        if not math.isfinite(self.floor_z):  # NaN would compare False: no floor at all
            raise UserError(
                f"safety floor height must be a finite number (m), got {floor_z!r}; "
                "check table_height and safety_margin"
            )
        self.arms = {arm.name: ArmPoints(model, arm) for arm in arms}
        # the arms' actuators (joint targets), for the ones that have them
        self._ctrl_sel = {
            arm.name: as_slice(arm.actuator_ids) for arm in arms if hasattr(arm, "actuator_ids")
        }
        self.tools = {tool.name: tool for tool in tools}
        self.report = FloorReport()
        self._data = mujoco.MjData(model)
        # views of the private data, taken once (each attribute read of MjData makes one)
        self._qpos, self._xmat, self._xpos = self._data.qpos, self._data.xmat, self._data.xpos
        # per tuple of commanded group names: (arm, its points, its actuators) of the arms
        self._checked: dict[tuple[str, ...], tuple] = {}

    # -- heights --------------------------------------------------------------------------
    def heights(self, qpos_full: np.ndarray, arm: str, q: np.ndarray | None = None) -> np.ndarray:
        """World z (m) of the lowest reach of every point of ``arm`` (its collision geoms and
        tool frame): forward kinematics on the private ``MjData``.

        Args:
            qpos_full: (nq,) the model's joint positions.
            arm: the arm's move group name.
            q: the arm's joints (rad / m) to put in place of ``qpos_full``'s; None: keep them.

        Returns:
            (N,) heights (m).
        """
        pts = self.arms[arm]
        data = self._data
        data.qpos[:] = qpos_full
        if q is not None:
            data.qpos[pts.qpos_sel] = q
        mujoco.mj_kinematics(self.model, data)
        return pts.heights(data)

    def lowest(
        self, qpos_full: np.ndarray, arm: str, q: np.ndarray | None = None
    ) -> tuple[float, int]:
        """The lowest point of ``arm``'s collision geoms and tool frame.

        Args:
            qpos_full: (nq,) the model's joint positions.
            arm: the arm's move group name.
            q: the arm's joints (rad / m) to put in place of ``qpos_full``'s; None: keep them.

        Returns:
            (world z (m), body id of that point).
        """
        z = self.heights(qpos_full, arm, q)
        i = int(z.argmin())
        return float(z[i]), int(self.arms[arm].owner[i])

    def offender(self, arm: str, z_new: np.ndarray, z_was: np.ndarray) -> int:
        """The point that breaks the floor: a point may not end below the floor unless it ends
        no lower than it was (one already below may stay or rise; ``TOLERANCE``).

        Args:
            arm: the arm's move group name.
            z_new: (N,) the points' heights after the move (m, :meth:`heights`).
            z_was: (N,) their heights before it (m).

        Returns:
            The body id of a breaking point, or -1.
        """
        bad = (z_new < self.floor_z) & (z_new < z_was - TOLERANCE)
        if not bad.any():
            return -1
        return int(self.arms[arm].owner[int(np.where(bad, z_new, np.inf).argmin())])

    def below(self, qpos_full: np.ndarray, targets: Mapping[str, np.ndarray]) -> list[str]:
        """The arms of ``targets`` (arm -> joints (rad)) with a point that can move up or
        down below the floor when every arm is at its target, at ``qpos_full`` (nq,) for
        the rest: one forward kinematics pass on the private ``MjData`` for all of them."""
        arms = self.arms
        return self._below(qpos_full, [(arm, arms[arm], q) for arm, q in targets.items()])

    def _below(self, qpos_full: np.ndarray, entries: Sequence[tuple]) -> list:
        """``below`` for ``entries`` ``(key, ArmPoints, joints (rad))``: the keys of those
        with a point below the floor."""
        qpos = self._qpos
        qpos[:] = qpos_full
        for _, pts, q in entries:
            qpos[pts.qpos_sel] = q
        mujoco.mj_kinematics(self.model, self._data)
        xmat, xpos, floor_z = self._xmat, self._xpos, self.floor_z
        out = []
        for key, pts, _ in entries:
            z = pts.moving_heights_at(xmat, xpos)
            if z[z.argmin()] < floor_z:  # z.min(), at a fraction of its cost
                out.append(key)
        return out

    def link_name(self, body: int) -> str:
        """The name of body id ``body`` (``body <id>`` when it has none)."""
        return mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_BODY, body) or f"body {body}"

    # -- the rule -------------------------------------------------------------------------
    def safe_fraction(
        self, qpos_full: np.ndarray, arm: str, q_from: np.ndarray, q_to: np.ndarray
    ) -> tuple[float, str]:
        """How much of ``arm``'s move keeps it above the floor.

        Args:
            qpos_full: (nq,) the model's joint positions (the rest of the robot).
            arm: the arm's move group name.
            q_from: the arm's joints before the move (rad / m).
            q_to: the arm's joints after the whole move.

        Returns:
            (the largest fraction, among 1 and ``BACKOFF``, that breaks the floor nowhere
            (``offender``); the name of the link that breaks it on the whole move, "" when
            none).
        """
        z_was = self.heights(qpos_full, arm, q_from)
        body = self.offender(arm, self.heights(qpos_full, arm, q_to), z_was)
        if body < 0:
            return 1.0, ""
        for fraction in BACKOFF[:-1]:
            q = q_from + fraction * (q_to - q_from)
            if self.offender(arm, self.heights(qpos_full, arm, q), z_was) < 0:
                return fraction, self.link_name(body)
        return 0.0, self.link_name(body)

    def hold(self, data: mujoco.MjData, start_ctrl: np.ndarray, names: Sequence[str]) -> list[str]:
        """Hold the floor after a control tick's controls are written: the arms whose new
        control breaks it get a shorter step toward it, written to ``data.ctrl``.

        Args:
            data: the state, its ``ctrl`` holding the tick's new controls.
            start_ctrl: (nu,) ``data.ctrl`` before the tick.
            names: the groups commanded in the tick (a tuple or list).

        Returns:
            The names of the arms held up (their links are added to ``report``).
        """
        key = names if type(names) is tuple else tuple(names)
        arms = self._checked.get(key)
        if arms is None:
            sel = self._ctrl_sel
            arms = self._checked[key] = tuple(
                (name, self.arms[name], sel[name]) for name in dict.fromkeys(key) if name in sel
            )
        if not arms:
            return []
        ctrl = data.ctrl
        below = self._below(data.qpos, [(arm, arm[1], ctrl[arm[2]]) for arm in arms])
        held = []
        for name, _, sel in below:  # the rule on each (its own kinematics passes)
            start, end = start_ctrl[sel], ctrl[sel].copy()
            fraction, link = self.safe_fraction(data.qpos, name, start, end)
            if not link:
                continue
            # within the step the controller took: its speed limits and control range hold
            ctrl[sel] = start + fraction * (end - start)
            self.report.add(link)
            held.append(name)
        return held

    def tool_height(
        self, data: mujoco.MjData, group, z_target: float, z_was: float | None = None
    ) -> float:
        """The height (m, world z) the tool frame of ``group`` may be asked to reach instead
        of ``z_target``: ``z_target`` when it is on or above the floor; else the floor, or
        ``z_was`` when that is lower (a tool frame below the floor may stay or rise). A change
        is reported with the tool frame's link.

        Args:
            data: the state.
            group: an arm move group with a tool frame.
            z_target: the height asked for (m, world z).
            z_was: where the tool frame was asked to be (a mocap arm: its control); None:
                where it is (``data``'s site pose).
        """
        floor_z = self.floor_z
        if z_target >= floor_z:
            return z_target
        site = group.frame_site_id
        if z_was is None:
            z_was = float(data.site_xpos[site, 2])
        z = max(z_target, min(floor_z, z_was))
        if z != z_target:
            self.report.add(self.link_name(int(self.model.site_bodyid[site])))
        return z
