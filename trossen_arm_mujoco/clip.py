"""``clip(x, low, high, out=None)``: ``x`` clipped into [low, high], elementwise.

The same values as ``np.clip`` (NaN propagates; for ``low <= high``), computed as
``np.minimum(np.maximum(x, low), high)``: half the cost on the short vectors the per-step
paths clip (action normalization, the joint targets' rate limit, observation bounds; about 4
calls per gym step), where ``np.clip``'s argument handling costs more than the clipping.

Docs: docs/benchmarks.md (the per-call cost); why not numpy's private clip ufunc:
docs/concepts/design-notes.md.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["clip"]


def clip(x: Any, low: Any, high: Any, out: np.ndarray | None = None) -> Any:
    """``x`` clipped into [``low``, ``high``] (broadcasting), into ``out`` when given.

    Args:
        x: array (any shape) or scalar.
        low, high: bounds broadcastable against ``x``, ``low <= high``.
        out: array of ``x``'s broadcast shape to write into (it may be ``x`` itself).

    Returns:
        ``out``, or a new array (a numpy scalar for scalar inputs).
    """
    return np.minimum(np.maximum(x, low, out=out), high, out=out)
