"""This project's steps in a LeRobot checkpoint's saved processors, as module-level classes.

Importing this package (it needs LeRobot and torch) registers every step with LeRobot's
``ProcessorStepRegistry``, so any LeRobot runner that imported it loads a checkpoint that
holds them: the env plugin ``lerobot_env_trossen`` imports it (LeRobot imports every
``lerobot_env_*`` package at start), and so do ``trossen-mujoco eval`` and ``train_eval``.

- :class:`~.camera_image.CameraImageStep` (``trossen_camera_image``): a camera's whole frame
  to the crop and size the policy was trained on;
- :class:`~.camera_pose.CameraPoseStep` (``trossen_camera_pose``): the objects' poses from
  that image, by the frozen pose encoder;
- :class:`~.controller_limits.MeasuredJointsStep` (``trossen_arm_measured_joints``) and
  :class:`~.controller_limits.ControllerLimitsStep` (``trossen_arm_controller_limits``): the
  actions kept within what the arm controller accepts.

Putting them in a checkpoint is plain JSON (``trossen-mujoco prepare``, :mod:`..prepare`).
"""

from trossen_arm_mujoco.eval.steps.camera_image import CameraImageStep
from trossen_arm_mujoco.eval.steps.camera_pose import CameraPoseStep
from trossen_arm_mujoco.eval.steps.controller_limits import ControllerLimitsStep, MeasuredJointsStep

__all__ = ["CameraImageStep", "CameraPoseStep", "ControllerLimitsStep", "MeasuredJointsStep"]
