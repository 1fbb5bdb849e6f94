"""This project's steps in a LeRobot checkpoint's saved processors, as module-level classes.

Importing this package (it needs LeRobot and torch) registers every step with LeRobot's
``ProcessorStepRegistry``: :class:`~.camera_image.CameraImageStep` (``trossen_camera_image``),
:class:`~.camera_pose.CameraPoseStep` (``trossen_camera_pose``),
:class:`~.controller_limits.MeasuredJointsStep` (``trossen_arm_measured_joints``) and
:class:`~.controller_limits.ControllerLimitsStep` (``trossen_arm_controller_limits``).
Putting them in a checkpoint is plain JSON (``trossen-mujoco prepare``, :mod:`..prepare`).

Docs: docs/cli/prepare.md; details: docs/concepts/design-notes.md.
"""

from trossen_arm_mujoco.eval.steps.camera_image import CameraImageStep
from trossen_arm_mujoco.eval.steps.camera_pose import CameraPoseStep
from trossen_arm_mujoco.eval.steps.controller_limits import ControllerLimitsStep, MeasuredJointsStep

__all__ = ["CameraImageStep", "CameraPoseStep", "ControllerLimitsStep", "MeasuredJointsStep"]
