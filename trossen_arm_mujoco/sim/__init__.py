"""What the world is: physics, robots, cameras and objects.

Docs: docs/concepts/architecture.md, docs/reference/robot-sim.md.
"""

from trossen_arm_mujoco.sim.cameras import CameraSet
from trossen_arm_mujoco.sim.objects import FreeJointObject
from trossen_arm_mujoco.sim.scene import Scene

__all__ = ["CameraSet", "FreeJointObject", "Scene"]
