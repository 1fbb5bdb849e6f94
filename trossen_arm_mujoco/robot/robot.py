"""Robot: a robot view with one controller per move group, and its kinematics.

Docs: docs/reference/robot-sim.md, docs/concepts/architecture.md.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import mujoco
import numpy as np

from trossen_arm_mujoco.clip import clip
from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.robot.arm_groups import MocapArmGroup
from trossen_arm_mujoco.robot.base_group import CarriedRobotBaseGroup, ImmobileRobotBaseGroup
from trossen_arm_mujoco.robot.checks import model_and_data
from trossen_arm_mujoco.robot.configs import RobotConfig
from trossen_arm_mujoco.robot.controllers import Controller, make_controller
from trossen_arm_mujoco.robot.frames import as_transform, invert
from trossen_arm_mujoco.robot.joint_target_batch import (
    JointTargetBatch,
    JointTargets,
    batchable,
    split_batchable,
)
from trossen_arm_mujoco.robot.mjcf_frame import MJCFFrameMixin
from trossen_arm_mujoco.robot.parallel_kinematics import ParallelKinematics
from trossen_arm_mujoco.robot.robot_kinematics import RobotKinematics
from trossen_arm_mujoco.robot.robot_view import RobotView
from trossen_arm_mujoco.robot.safety_floor import FloorReport, SafetyFloor, floor_height

__all__ = ["Robot"]


class Robot:
    """Commands in, controls out.

    ``update_control`` stores the latest command per move group; ``compute_control`` turns
    the stored commands into controls and writes them to ``data.ctrl`` (or the mocap bodies).
    Groups without a command hold the control set at ``reset``. Physics is never stepped here.

    Joint-actuated groups are rate-limited (``MoveGroupSpec.velocity_limits``): each call
    of ``compute_control`` moves their control by at most ``velocity_limits * ctrl_dt``.
    A relative command (``joint_rel_position``, ``ee_delta``) is taken against the joints
    once, when first applied; its joint target is then approached over as many ticks as
    the limits need, unless a newer command replaces it.

    Safety floor (``set_safety_floor``; off on a bare robot, on for every robot a task
    sampler builds): each tick the arms' controls are held above the table
    (``robot.safety_floor``), the controllers' targets kept; ``floor_report`` says what it
    changed since the last command.

    Bound to an ``MjData`` (built from one, ``data=``, or ``bind``), ``compute_control()``,
    ``reset()``, ``hold()`` and ``set_world_pose`` work on it; every call also takes an
    explicit ``data`` (the earlier form), which wins.

    Args:
        model: compiled model, or the ``MjData`` to bind to.
        config: move groups, initial joints, command modes, velocity limits.
        ctrl_dt: control period (s), the time between two ``compute_control`` calls;
            default the model timestep. Controllers put into ``controllers`` later without
            a ``ctrl_dt`` of their own take this one.
        data: the ``MjData`` to bind to (with a model as first argument).

    Attributes:
        robot_view: the move groups (``view`` is the same object).
        controllers: move group id -> controller.
        kinematics: ``RobotKinematics`` (FK of every group, IK), on a private ``MjData``
            whose reference state is the bound data.
        parallel_kinematics: ``ParallelKinematics`` of the first arm (batched FK / IK).
    """

    def __init__(
        self,
        model: mujoco.MjModel | mujoco.MjData,
        config: RobotConfig,
        ctrl_dt: float | None = None,
        data: mujoco.MjData | None = None,
    ):
        model, bound = model_and_data(model)
        self.model = model
        self.config = config
        self.ctrl_dt = float(model.opt.timestep) if ctrl_dt is None else float(ctrl_dt)
        if not (np.isfinite(self.ctrl_dt) and self.ctrl_dt > 0):
            raise UserError(f"ctrl_dt must be a positive number of seconds, got {ctrl_dt}")
        self.view: RobotView = config.build_view(model)
        self.controllers: dict[str, Controller] = {
            g: make_controller(mode, self.view.get_move_group(g), model, self.ctrl_dt)
            for g, mode in config.command_mode.items()
        }
        self._commands: dict[str, np.ndarray] = {}
        # resolved relative commands not yet reached: (target, target within ctrl limits)
        self._targets: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        # plain joint_position commands batched, and the other commanded ids (see _make_batch)
        self._batch: tuple[JointTargetBatch | None, list[str]] | None = None
        self._splits: dict[tuple[str, ...], tuple[tuple[str, ...], list[str]]] = {}
        self._batches: dict[tuple[str, ...], JointTargetBatch] = {}
        self._kinematics: RobotKinematics | None = None
        self._parallel: dict[tuple[str, tuple[str, ...]], ParallelKinematics] = {}
        self._floor: SafetyFloor | None = None
        if bound is not None or data is not None:
            self.bind(bound if data is None else data)

    # -- the documented surface ----------------------------------------------------------
    def bind(self, data: mujoco.MjData) -> None:
        """Work on ``data`` from now on (its move groups read and write it)."""
        self.view.bind(data)

    @property
    def robot_view(self) -> RobotView:
        """The robot's ``RobotView`` (the same as ``robot.view``)."""
        return self.view

    @property
    def kinematics(self) -> RobotKinematics:
        """FK of every move group and IK (built on first use)."""
        if self._kinematics is None:
            self._kinematics = RobotKinematics(self.model, self.config, reference=self.view)
        return self._kinematics

    @property
    def parallel_kinematics(self) -> ParallelKinematics:
        """Batched FK and IK of the first arm (the first group with a tool frame)."""
        arms = [n for n, g in self.view.move_groups.items() if isinstance(g, MJCFFrameMixin)]
        if not arms:
            raise UserError(f"robot '{self.config.name}' has no arm with a tool frame for IK")
        return self.get_parallel_kinematics(arms[0])

    def get_parallel_kinematics(
        self, move_group_id: str, unlocked_move_group_ids: Sequence[str] | None = None
    ) -> ParallelKinematics:
        """Batched kinematics with IK of ``move_group_id`` over the unlocked groups' joints
        (default the group itself); built once per combination."""
        key = (move_group_id, tuple(unlocked_move_group_ids or (move_group_id,)))
        if key not in self._parallel:
            self._parallel[key] = ParallelKinematics(self.kinematics, key[0], key[1])
        return self._parallel[key]

    def _data(self, data: mujoco.MjData | None) -> mujoco.MjData:
        return self.view.data if data is None else data

    def get_world_pose(self, data: mujoco.MjData | None = None) -> np.ndarray:
        """World pose of the robot (its primary base group), 4x4."""
        return self.view.base.get_transform(self._data(data))

    def set_world_pose(self, pose, data: mujoco.MjData | None = None) -> None:
        """Teleport the robot: put its primary base at ``pose`` (4x4, or 7 values
        [x, y, z, qw, qx, qy, qz], world frame, m); other bases move rigidly with it.

        A mocap base moves its mocap body, a free-joint base writes its qpos (a carried
        base, an arm's mount on a mobile base, follows its carrier); an immobile
        base (fixed in the MJCF) raises a UserError. Kinematics is updated
        (``mj_kinematics``); velocities are left as they are.
        """
        data = self._data(data)
        target = as_transform("world pose", pose)
        bases = [self.view.get_move_group(n) for n in self.view.base_group_ids()]
        if not bases:
            raise UserError(f"robot '{self.config.name}' has no base group to move")
        bases = [b for b in bases if not isinstance(b, CarriedRobotBaseGroup)]
        if not bases:
            raise UserError(f"robot '{self.config.name}': its bases are carried; move the carrier")
        for base in bases:
            if isinstance(base, ImmobileRobotBaseGroup):
                base.set_transform(data, target)  # raises the immobile-base error
        move = target @ invert(bases[0].get_transform(data))
        new = [move @ base.get_transform(data) for base in bases]
        for base, pose_b in zip(bases, new):
            base.set_transform(data, pose_b)
        mujoco.mj_kinematics(self.model, data)

    # -- the safety floor -----------------------------------------------------------------
    def set_safety_floor(
        self, table_height: float | None, margin: float = 0.0
    ) -> SafetyFloor | None:
        """Keep the arms above ``table_height + margin`` (m, world z) from now on
        (``robot.safety_floor``); ``table_height=None`` removes the floor. Returns the floor.

        Every arm with a tool frame is kept above it: a joint-actuated arm with all its
        collision geoms, tick by tick; a mocap arm by its commanded tool-frame height. A
        table height that is not a finite number, or a margin that is negative, NaN or
        infinite, is a one-line UserError.
        """
        if table_height is None:
            floor = None
        else:
            floor_z = floor_height(table_height, margin)
            framed = [g for g in self.view.move_groups.values() if isinstance(g, MJCFFrameMixin)]
            floor = SafetyFloor(
                self.model,
                [g for g in framed if not isinstance(g, MocapArmGroup)],
                floor_z,
                tools=[g for g in framed if isinstance(g, MocapArmGroup)],
            )
        self._floor = floor
        for controller in self.controllers.values():
            controller.floor = floor
        return floor

    @property
    def safety_floor(self) -> SafetyFloor | None:
        """The ``SafetyFloor`` the arms are kept above (None: none)."""
        return self._floor

    @property
    def floor_report(self) -> FloorReport:
        """What the safety floor changed since the last command: ``clipped`` (bool) and
        ``links`` (the links it held up); empty without a floor."""
        return self._floor.report if self._floor is not None else FloorReport()

    def update_control(self, commands: Mapping[str, np.ndarray]) -> None:
        """Store commands (the action command dict), group id -> vector of that group's
        ``command_dim`` values; ``compute_control`` applies them. The safety floor's report
        starts afresh (``floor_report``).

        ``JointTargets`` (``joint_target_batch(names).commands(vector)``) are checked
        already: their vector becomes the batch's target as is."""
        if self._floor is not None:
            self._floor.report.clear()
        if type(commands) is JointTargets and self._take_targets(commands):
            return
        for name, cmd in commands.items():
            if name not in self.controllers:
                raise unknown_name_error("controlled move group", name, self.controllers)
            self._commands[name] = self.controllers[name]._check(cmd)
        self._batch = None  # rebuilt from the new commands by the next compute_control

    def compute_control(self, data: mujoco.MjData | None = None) -> dict[str, np.ndarray]:
        """Compute and apply the controls of the commanded groups (in ``data``, default the
        bound data); returns them by group.

        Plain ``joint_position`` groups are rate-limited together, as one vector
        (``JointTargetBatch``, built once per new set of commands); the others one by one.
        """
        out: dict[str, np.ndarray] = {}
        self._control(self.view.data if data is None else data, out)
        return out

    def apply_control(self, data: mujoco.MjData | None = None) -> None:
        """``compute_control`` without gathering the controls it wrote into a dict (the
        stepping loop's call, once per control tick)."""
        self._control(self.view.data if data is None else data, None)

    def _control(self, data: mujoco.MjData, out: dict[str, np.ndarray] | None) -> None:
        """One control tick: write the commanded groups' controls to ``data``, the arms held
        above the safety floor; and, when ``out`` is a dict, put them there by group."""
        controllers = self.controllers
        floor = self._floor
        # with a floor over joint arms: the controls the tick starts from, the groups it moves
        start = data.ctrl.copy() if floor is not None and floor.arms else None
        moved: tuple[str, ...] | list[str] = ()  # the groups whose controls the tick moved
        targets: list[tuple[str, np.ndarray, np.ndarray]] = []
        if self._commands:
            batch = self._batch
            if batch is None:
                batch = self._batch = self._make_batch()
            if batch[0] is not None:
                u = batch[0].apply(data)
                if out is not None:
                    out.update(batch[0].by_group(u))
                moved = batch[0].names
            if batch[1]:
                moved = list(moved)
            for name in batch[1]:
                controller = controllers[name]
                target = controller._target(data, self._commands[name])  # checked already
                if controller.relative:  # applied once: its target holds until reached
                    group = controller.group
                    reached = clip(target, group._ctrl_low, group._ctrl_high)
                    self._targets[name] = (target, reached)
                    del self._commands[name]
                    self._batch = None
                else:
                    ctrl = controller.limit(data, target)
                    controller.group._write_ctrl(data, ctrl)
                    if out is not None:
                        out[name] = ctrl
                    moved.append(name)
        if self._targets:
            moved = list(moved)
            for name, (target, reached) in list(self._targets.items()):
                controller = controllers[name]
                ctrl = controller.limit(data, target)
                controller.group._write_ctrl(data, ctrl)
                if out is not None:
                    out[name] = ctrl
                targets.append((name, ctrl, reached))
                moved.append(name)
        held = floor.hold(data, start, moved) if moved and start is not None else ()
        for name in held:
            if out is not None:
                out[name] = controllers[name].group.get_ctrl(data)
        for name, ctrl, reached in targets:
            if name not in held and (ctrl == reached).all():
                del self._targets[name]  # reached: the control now holds it

    def joint_target_batch(self, names: Sequence[str]) -> JointTargetBatch | None:
        """The ``JointTargetBatch`` rate-limiting the groups ``names`` as one vector, or None
        when one of their controllers is not a plain joint_position one (``batchable``).
        Built once per set of ids and kept while its controllers and limits stay the same;
        ``commands(vector)`` of it is the fastest way to command those groups."""
        names = tuple(names)
        batch = self._batches.get(names)
        if batch is not None and batch.fits(self.controllers):
            return batch
        for name in names:
            if name not in self.controllers:
                raise unknown_name_error("controlled move group", name, self.controllers)
        self._give_ctrl_dt(names)
        if not all(batchable(self.controllers[n]) for n in names):
            return None
        batch = self._batches[names] = JointTargetBatch(self.controllers, names)
        return batch

    def kept_batch(self, names: tuple[str, ...]) -> JointTargetBatch | None:
        """The batch ``joint_target_batch(names)`` last built for the tuple ``names``, or
        None: no check (a caller holding a batch compares it with this one to see whether
        the robot has built another; ``update_control`` still checks what it is given)."""
        return self._batches.get(names)

    def _give_ctrl_dt(self, names: Sequence[str]) -> None:
        """The robot's ``ctrl_dt`` to the controllers of ``names`` that have none yet (put
        into ``controllers`` without one), and its safety floor to those without it."""
        for name in names:
            controller = self.controllers[name]
            if controller.ctrl_dt is None:
                controller.ctrl_dt = self.ctrl_dt
            if controller.floor is not self._floor:  # put into ``controllers`` later
                controller.floor = self._floor

    def _take_targets(self, commands: JointTargets) -> bool:
        """Store ``JointTargets`` as the batch's target, when the batch is still this robot's
        for those groups and no other group has a command pending; else False (the caller
        takes them one by one)."""
        batch = commands.batch
        if (
            commands.vector is None
            or self._batches.get(batch.names) is not batch
            or not batch.fits(self.controllers)
            or not self._commands.keys() <= commands.keys()
        ):
            return False
        self._commands.update(commands)
        batch.set_vector(commands.vector)
        self._batch = (batch, [])
        return True

    def _make_batch(self) -> tuple[JointTargetBatch | None, list[str]]:
        """(batch of the plain joint_position commands or None, ids of the other commands).
        The batch's structure is kept per set of ids and reused while its controllers and
        limits stay the same; only the target is new."""
        names = tuple(self._commands)
        self._give_ctrl_dt(names)
        split = self._splits.get(names)
        if split is None:
            split = self._splits[names] = split_batchable(self.controllers, names)
        plain, other = split
        if not plain:
            return None, other
        batch = self.joint_target_batch(plain)
        if batch is None:
            self._splits.clear()  # a controller was replaced: split again
            return self._make_batch()
        batch.set_target(self._commands)
        return batch, other

    def reset(self, data: mujoco.MjData | None = None, hold: bool = True) -> None:
        """Put the joints at ``config.init_qpos`` at rest, and every control at a no-op
        (in ``data``, default the bound data).

        Mocap arms get their mocap pose set to the tool-frame pose of the initial joints,
        so the weld holds the arm where it is. ``hold=False`` sets the joints only (no
        kinematics, controls untouched), for a caller that moves things further and then
        calls ``hold`` itself.
        """
        data = self._data(data)
        self.view.set_qpos_dict(data, self.config.init_qpos)
        for name in self.config.init_qpos:
            data.qvel[self.view.get_move_group(name).dof_idx] = 0.0
        self._commands.clear()
        self._targets.clear()
        self._batch = None
        if self._floor is not None:
            self._floor.report.clear()
        if hold:
            mujoco.mj_kinematics(self.model, data)
            self.hold(data)

    def hold(self, data: mujoco.MjData | None = None) -> None:
        """Set every control to hold the current state (kinematics must be up to date)."""
        data = self._data(data)
        self._commands.clear()
        self._targets.clear()
        self._batch = None
        if self._floor is not None:
            self._floor.report.clear()
        for group in self.view.move_groups.values():
            if isinstance(group, MocapArmGroup):
                group.set_ctrl(data, group.get_frame_pose(data))
            elif group.ctrl_dim:
                group.set_ctrl(data, group.get_noop_ctrl(data))
