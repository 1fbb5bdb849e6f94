"""``clip(x, low, high, out=None)``: ``x`` clipped into [low, high], elementwise.

The per-step paths (action normalization, the joint targets' rate limit, observation
bounds: about 4 calls per gym step) clip short vectors, where ``np.clip``'s argument handling
costs more than the clipping. ``np.minimum(np.maximum(x, low), high)`` gives the same values
(NaN propagates; for ``low <= high``) at half the cost: measured in one run with
``benchmarks/numpy_paths.py`` (numpy 2.4, 7 to 58 values, a loaded 2-CPU machine), 1.1-1.2 us
per call against 2.3-2.5 us for ``np.clip``. numpy's clip ufunc called directly (private
``numpy._core.umath.clip``, 0.55-0.6 us) would save another 2.4 us per gym step, 0.01-0.03 of
``benchmarks/step_overhead.py``'s ratio on the single arm and under 0.01 on the kit; this
public path keeps every gym id within its goal, so the private one is not used.
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
