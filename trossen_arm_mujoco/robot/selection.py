"""Index selections into ``MjData`` arrays: consecutive indices become a slice, which numpy
reads and writes through faster than an index array (and reads as a view).

Docs: docs/concepts/architecture.md (the robot layer).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["as_slice"]


def as_slice(indices: Sequence[int] | np.ndarray) -> slice | np.ndarray:
    """``slice(first, first + n)`` when ``indices`` are n consecutive ints, else them as an
    int array."""
    idx = np.asarray(indices, dtype=int).reshape(-1)
    if len(idx) and np.array_equal(idx, np.arange(idx[0], idx[0] + len(idx))):
        return slice(int(idx[0]), int(idx[0]) + len(idx))
    return idx
