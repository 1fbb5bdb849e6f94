"""The one check every policy action passes before it reaches the arms, on both backends of
``trossen-mujoco eval`` (``eval.runner``, ``eval.wire_backend``): it must be finite.

A checkpoint whose weights are damaged (overwritten with NaN, or trained into NaN) answers
with NaN at every step. In the sim the arm controller's checks would refuse each such setpoint
as a fault and the run would score it as a policy that fails, exit status 0; through the wire
the driver refuses it. Both now stop the evaluation with the same one line, exit status 2.

Docs: docs/cli/eval.md.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from trossen_arm_mujoco.errors import UserError

__all__ = ["check_action"]


def check_action(policy: str, action: Any, index: int, when: str) -> None:
    """A one-line ``UserError`` when the ``action`` ``policy`` returned at episode ``index``
    ``when`` (``"step 3"``) holds NaN or inf, naming both and how many of its values; an action
    that is not numbers is left to the env (the policy's own error).

    Args:
        policy: the ``--policy`` text, named in the error.
        action: what the policy returned: the env's layout, (n_values,) (rad; gripper m).
        index: the episode index.
        when: where in the episode, for the error (e.g. ``"step 3"``).

    Raises:
        UserError: the action holds NaN or inf.
    """
    try:
        values = np.asarray(action, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        return
    bad = ~np.isfinite(values)
    if not bad.any():
        return
    from trossen_arm_mujoco.eval.policies import is_function_spec

    kinds = " and ".join(k for k, m in (("NaN", np.isnan), ("inf", np.isinf)) if m(values).any())
    if policy == "scripted" or is_function_spec(policy):
        hint = "a policy must return finite numbers: check what it computes"
    else:
        hint = (
            "the checkpoint's weights may be damaged (overwritten, or trained into NaN): "
            "evaluate another checkpoint or train again"
        )
    raise UserError(
        f"the policy {policy} produced a non-finite action at episode {index} {when}: "
        f"{kinds} in {int(bad.sum())} of {values.size} values; {hint}"
    )
