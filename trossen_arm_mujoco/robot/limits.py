"""Limits of move groups: the (n, 2) ``Limits`` array and frozen (read-only) copies."""

from __future__ import annotations

import numpy as np


def frozen(values) -> np.ndarray:
    """A read-only float copy (limits shared by the hot paths, never handed out)."""
    out = np.array(values, dtype=float)
    out.flags.writeable = False
    return out


class Limits(np.ndarray):
    """An (n, 2) array of [low, high] rows (``limits[:, 0]`` the lower bounds).

    Calling it, ``group.ctrl_limits()``, gives the pair ``(low, high)`` of (n,) copies: the
    form of the earlier ``ctrl_limits()`` method, kept for its callers. Indexing and
    arithmetic give plain arrays.
    """

    @staticmethod
    def of(low: np.ndarray, high: np.ndarray) -> Limits:
        return np.stack([np.asarray(low, float), np.asarray(high, float)], axis=-1).view(Limits)

    def __call__(self) -> tuple[np.ndarray, np.ndarray]:
        arr = np.asarray(self)
        return arr[:, 0].copy(), arr[:, 1].copy()

    def __getitem__(self, key):
        return np.asarray(self)[key]

    def __array_ufunc__(self, ufunc, method, *inputs, **kwargs):
        inputs = tuple(np.asarray(x) if isinstance(x, Limits) else x for x in inputs)
        if "out" in kwargs:
            kwargs["out"] = tuple(
                np.asarray(o) if isinstance(o, Limits) else o for o in kwargs["out"]
            )
        return getattr(ufunc, method)(*inputs, **kwargs)
