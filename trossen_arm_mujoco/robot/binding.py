"""State bound to one ``MjData``: what move groups and robot views share.

Docs: docs/concepts/architecture.md (the robot layer).
"""

from __future__ import annotations

import mujoco

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.checks import check_data_fits

__all__ = ["DataBound"]


class DataBound:
    """Reads and writes one ``MjData`` once bound (``bind``); ``data`` is that MjData.

    Subclasses set ``model`` and ``_data`` (None until bound), and name themselves in
    errors through ``_binding_name`` and ``_binding_hint``.
    """

    model: mujoco.MjModel
    _data: mujoco.MjData | None

    def _binding_name(self) -> str:
        raise NotImplementedError

    def _binding_hint(self) -> str:
        raise NotImplementedError

    def _bind_members(self, data: mujoco.MjData) -> None:
        """Bind what this object holds (nothing by default)."""

    def bind(self, data: mujoco.MjData) -> None:
        """Read and write ``data`` from now on (a UserError if it is of another model)."""
        check_data_fits(self.model, data, self._binding_name())
        self._bind_members(data)
        self._data = data

    @property
    def is_bound(self) -> bool:
        """Whether an ``MjData`` is bound (then calls may leave the data out)."""
        return self._data is not None

    @property
    def data(self) -> mujoco.MjData:
        """The bound ``MjData`` (a UserError when not bound)."""
        if self._data is None:
            raise UserError(
                f"{self._binding_name()} is not bound to an MjData: {self._binding_hint()}"
            )
        return self._data
