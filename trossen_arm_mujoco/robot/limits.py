"""Read-only copies of the limits that move groups share with their hot paths.

Docs: docs/concepts/architecture.md (the robot layer).
"""

from __future__ import annotations

import numpy as np

__all__ = ["frozen"]


def frozen(values) -> np.ndarray:
    """A read-only float copy (limits shared by the hot paths, never handed out)."""
    out = np.array(values, dtype=float)
    out.flags.writeable = False
    return out
