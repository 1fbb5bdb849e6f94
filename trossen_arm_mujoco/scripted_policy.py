"""Scripted policies of the documented public surface.

``PickAndTransferPolicy(inject_noise=False, rng=None)`` (the cube transfer) lives in
``policies/transfer_cube.py``; every registered task's policy is reached through
``tasks.registry.load(name).policy_class()``.

Docs: docs/vendor-api.md.
"""

from __future__ import annotations

from trossen_arm_mujoco.policies.transfer_cube import PickAndTransferPolicy

__all__ = ["PickAndTransferPolicy"]
