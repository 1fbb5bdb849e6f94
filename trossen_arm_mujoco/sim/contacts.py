"""ContactPartners: which geoms touch a given set of geoms, read from ``data.contact`` in
one vector pass (rewards call it every step; a Python loop over the contacts costs about a
microsecond per contact).

Docs: docs/reference/robot-sim.md.
"""

from __future__ import annotations

from collections.abc import Iterable

import mujoco
import numpy as np

__all__ = ["ContactPartners"]


class ContactPartners:
    """The geoms in contact with any of ``geoms`` (model geom ids, looked up by the caller).

    Args:
        model: compiled model.
        geoms: the geom ids whose contact partners are asked for.
    """

    def __init__(self, model: mujoco.MjModel, geoms: Iterable[int]):
        self.mask = np.zeros(model.ngeom, dtype=bool)
        self.mask[list(geoms)] = True

    def __call__(self, data: mujoco.MjData) -> set[int]:
        """Ids of the geoms touching one of ``geoms`` now (also each other, when two of them
        touch)."""
        if not data.ncon:
            return set()
        pairs = data.contact.geom  # (ncon, 2)
        first, second = pairs[:, 0], pairs[:, 1]
        mask = self.mask
        return set(second[mask[first]].tolist()) | set(first[mask[second]].tolist())
