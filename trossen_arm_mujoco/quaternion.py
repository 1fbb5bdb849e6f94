"""A small unit-quaternion type (w, x, y, z) for scripted policies and user code.

Docs: docs/vendor-api.md.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["Quaternion"]


class Quaternion:
    """Quaternion [w, x, y, z].

    Build it from 4 elements (``Quaternion([1, 0, 0, 0])``) or from an axis and an angle
    (``Quaternion(axis=[0, 1, 0], degrees=-90)`` or ``radians=...``). ``*`` composes
    rotations (``a * b`` applies b first, then a), ``.elements`` gives the numpy array.

    Args:
        elements: 4 values [w, x, y, z] (or a Quaternion to copy); None: from ``axis``, or
            the identity without one.
        axis: the rotation axis (3,), with ``degrees`` or ``radians``.
        degrees: the rotation angle about ``axis`` (degrees).
        radians: the rotation angle about ``axis`` (rad).
    """

    def __init__(
        self,
        elements: Sequence[float] | Quaternion | None = None,
        *,
        axis: Sequence[float] | None = None,
        degrees: float | None = None,
        radians: float | None = None,
    ):
        if isinstance(elements, Quaternion):
            q = elements.elements.copy()
        elif elements is not None:
            q = np.asarray(elements, dtype=float).reshape(4)
        elif axis is not None:
            angle = np.deg2rad(degrees) if degrees is not None else float(radians or 0.0)
            a = np.asarray(axis, dtype=float)
            n = np.linalg.norm(a)
            if n == 0:
                raise ValueError("rotation axis must be non-zero")
            q = np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * a / n])
        else:
            q = np.array([1.0, 0.0, 0.0, 0.0])
        self.elements = q

    def __mul__(self, other: Quaternion) -> Quaternion:
        w1, x1, y1, z1 = self.elements
        w2, x2, y2, z2 = Quaternion(other).elements
        return Quaternion(
            [
                w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
            ]
        )

    def __repr__(self) -> str:
        return f"Quaternion({np.round(self.elements, 6).tolist()})"

    @property
    def conjugate(self) -> Quaternion:
        """The conjugate [w, -x, -y, -z] (the inverse of a unit quaternion)."""
        w, x, y, z = self.elements
        return Quaternion([w, -x, -y, -z])

    @property
    def normalised(self) -> Quaternion:
        """This quaternion scaled to unit norm."""
        return Quaternion(self.elements / np.linalg.norm(self.elements))

    @property
    def inverse(self) -> Quaternion:
        """The multiplicative inverse: conjugate / squared norm."""
        return Quaternion(self.conjugate.elements / np.dot(self.elements, self.elements))

    def rotate(self, vector: Sequence[float]) -> np.ndarray:
        """Rotate a 3-vector by this (unit) quaternion."""
        v = Quaternion([0.0, *np.asarray(vector, dtype=float)])
        return (self * v * self.conjugate).elements[1:]

    @staticmethod
    def slerp(q0: Quaternion, q1: Quaternion, amount: float) -> Quaternion:
        """Spherical interpolation from q0 (amount 0) to q1 (amount 1), shortest path.

        Args:
            q0: the start rotation.
            q1: the end rotation.
            amount: the fraction of the way, 0 .. 1.
        """
        a = Quaternion(q0).normalised.elements
        b = Quaternion(q1).normalised.elements
        dot = float(np.dot(a, b))
        if dot < 0:
            b, dot = -b, -dot
        if dot > 0.9995:
            out = a + amount * (b - a)
            return Quaternion(out / np.linalg.norm(out))
        theta = np.arccos(np.clip(dot, -1.0, 1.0))
        s = np.sin(theta)
        out = (np.sin((1 - amount) * theta) * a + np.sin(amount * theta) * b) / s
        return Quaternion(out)
