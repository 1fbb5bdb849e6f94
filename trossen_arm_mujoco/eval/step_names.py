"""The registry names of this project's steps in a LeRobot checkpoint's saved processors
(``policy_preprocessor.json``, ``policy_postprocessor.json``): shared by the JSON side
(``eval.prepare`` and the modules it calls, no LeRobot) and the step classes
(``eval.steps``).

Docs: docs/cli/prepare.md.
"""

from __future__ import annotations

__all__ = ["IMAGE", "LIMITS", "MEASURED", "POSE"]

#: The image step: a camera's whole frame cut and scaled into the trained images.
IMAGE = "trossen_camera_image"
#: The pose encoder step: the objects' poses from a camera's image.
POSE = "trossen_camera_pose"
#: The preprocessor step that notes the measured joints.
MEASURED = "trossen_arm_measured_joints"
#: The postprocessor step that keeps actions within the arm controller's limits.
LIMITS = "trossen_arm_controller_limits"
