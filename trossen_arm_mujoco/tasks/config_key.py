"""One value of a task config checked against what its key accepts.

``Key``: a key's kind (number, whole number, true/false, string, one of a few names, a list of
numbers of given lengths) and range (NaN and inf are never valid); ``Key.check`` converts a
value or raises a one-line ``UserError`` saying what is valid. ``Source``: where values come
from (a file, or a task's keyword arguments), for those messages. The keys themselves are in
``config_schema`` (``KEYS``) and ``randomization_schema``.

Docs: docs/writing-a-task.md, docs/reference/tasks.md.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from numbers import Integral, Real
from typing import Any

import numpy as np

from trossen_arm_mujoco.errors import UserError

__all__ = [
    "INF",
    "Key",
    "Source",
    "fmt_number",
    "is_real",
    "number",
    "positive",
    "region",
    "show",
    "vector",
]

INF = math.inf


# -- where values come from --------------------------------------------------------------------
@dataclass(frozen=True)
class Source:
    """Where config values come from, for error messages.

    Attributes:
        origin: ``config file <path>`` or ``task config '<name>'``.
        label: what a key is called there: ``key`` or ``keyword argument``.
    """

    origin: str
    label: str = "key"

    @classmethod
    def file(cls, path: Any) -> Source:
        """The source of keys read from the YAML file at ``path``."""
        return cls(f"config file {path}", "key")

    @classmethod
    def overrides(cls, name: str) -> Source:
        """The source of keyword overrides of task config ``name``."""
        return cls(f"task config '{name}'", "keyword argument")

    def where(self, key: str) -> str:
        """Where ``key`` comes from, for an error message (``config file x.yaml, key k``)."""
        return f"{self.origin}, {self.label} {key}"


def show(value: Any) -> str:
    """``repr(value)``, cut to 60 characters (for messages)."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def is_real(value: Any) -> bool:
    """A real number (Python or numpy), not a bool."""
    return isinstance(value, Real) and not isinstance(value, (bool, np.bool_))


def fmt_number(x: float) -> str:
    """``x`` short: ``0.5``, ``1e-05``, ``10000000`` (whole numbers in full)."""
    return str(int(x)) if float(x).is_integer() and abs(x) < 1e15 else f"{x:g}"


# -- one key ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Key:
    """What one config key accepts.

    Attributes:
        kind: ``number`` | ``int`` (a whole number) | ``bool`` | ``str`` (non-empty) |
            ``choice`` (one of ``choices``) | ``vector`` (a list of numbers, ``lengths``).
        low, high: bounds of a number (or of every entry of a vector); NaN and inf never pass.
        open_low: ``low`` itself excluded (``> low``).
        lengths: the lengths a vector may have.
        choices: the names a ``choice`` may be.
        unit: shown after the range (m, rad, s, ...).
    """

    kind: str
    low: float = -INF
    high: float = INF
    open_low: bool = False
    lengths: tuple[int, ...] = ()
    choices: tuple[str, ...] = ()
    unit: str = ""

    def _interval(self) -> str:
        """``in (0, 1] m``, ``>= 0``, ... ("" when unbounded)."""
        unit = f" {self.unit}" if self.unit else ""
        if self.low == -INF and self.high == INF:
            return ""
        if self.high == INF:
            return f"{'>' if self.open_low else '>='} {fmt_number(self.low)}{unit}"
        if self.low == -INF:
            return f"<= {fmt_number(self.high)}{unit}"
        low, high = fmt_number(self.low), fmt_number(self.high)
        return f"in {'(' if self.open_low else '['}{low}, {high}]{unit}"

    def describe(self) -> str:
        """What is valid, in words: ``a number in (0, 1] m``."""
        if self.kind == "bool":
            return "true/false"
        if self.kind == "str":
            return "a non-empty string"
        if self.kind == "choice":
            return "one of " + ", ".join(self.choices)
        interval = self._interval()
        if self.kind in ("int", "number"):
            noun = "a whole number" if self.kind == "int" else "a number"
            return f"{noun} {interval}" if interval else f"a finite {noun[2:]}"
        sizes = " or ".join(str(n) for n in self.lengths) or "some"
        return f"a list of {sizes} numbers, each {interval or 'finite'}"

    def in_range(self, value: Any) -> bool:
        """Whether ``value`` is a finite number within ``low``/``high`` (the kind unchecked)."""
        try:
            x = float(value)
        except (OverflowError, TypeError, ValueError):
            return False
        if not math.isfinite(x):
            return False
        above = x > self.low if self.open_low else x >= self.low
        return above and x <= self.high

    def check(self, where: str, value: Any, length: int | None = None) -> Any:
        """``value`` converted (int, float, bool, str, list of floats).

        Args:
            where: what the value is, starting the error.
            value: the value given.
            length: the one length a vector must have (an override of a file's vector).

        Raises:
            UserError: ``<where>: expected <what is valid>, got <value>``.
        """
        bad = UserError(f"{where}: expected {self.describe()}, got {show(value)}")
        if self.kind == "bool":
            if isinstance(value, (bool, np.bool_)):
                return bool(value)
            raise bad
        if self.kind in ("str", "choice"):
            if not isinstance(value, str) or not value.strip():
                raise bad
            if self.kind == "choice" and value not in self.choices:
                raise bad
            return value
        if self.kind in ("number", "int"):
            if not is_real(value) or not self.in_range(value):
                raise bad
            x = float(value)
            if self.kind == "int":
                if not isinstance(value, Integral) and x != int(x):
                    raise bad
                return int(x)
            return x
        # vector
        if isinstance(value, (str, bytes, Mapping)) or not hasattr(value, "__len__"):
            raise bad
        seq = list(value) if getattr(value, "ndim", 1) == 1 else None
        lengths = (length,) if length is not None else self.lengths
        if seq is None or (lengths and len(seq) not in lengths):
            if length is not None and seq is not None:
                raise UserError(
                    f"{where}: expected a list of {length} numbers (as in the task's file), "
                    f"got {show(value)}"
                )
            raise bad
        if not all(is_real(v) and self.in_range(v) for v in seq):
            raise bad
        return [float(v) for v in seq]


# -- the usual keys --------------------------------------------------------------------------
def number(low: float = -INF, high: float = INF, unit: str = "", open_low: bool = False) -> Key:
    """A number in ``[low, high]`` (``(low, high]`` with ``open_low``).

    Args:
        low: the smallest value.
        high: the largest value.
        unit: the unit, for messages and docs.
        open_low: ``low`` itself is not valid.
    """
    return Key("number", low, high, open_low, unit=unit)


def positive(high: float = INF, unit: str = "") -> Key:
    """A number in ``(0, high]``."""
    return Key("number", 0.0, high, True, unit=unit)


def vector(*lengths: int, low: float = -10.0, high: float = 10.0, unit: str = "m") -> Key:
    """A list of numbers of one of ``lengths``, each in ``[low, high]``.

    Args:
        *lengths: the valid lengths.
        low: the smallest value of each number.
        high: the largest value of each number.
        unit: the unit, for messages and docs.
    """
    return Key("vector", low, high, lengths=lengths, unit=unit)


def region(
    name: str, *lengths: int, low: float = -10.0, high: float = 10.0, unit: str = "m"
) -> dict[str, Key]:
    """``{name}_low`` and ``{name}_high``: the corners of a box (checked low <= high on every
    axis, ``config_schema.check_ranges``).

    Args:
        name: the keys' stem.
        *lengths: the valid lengths of each corner.
        low: the smallest value of each number.
        high: the largest value of each number.
        unit: the unit, for messages and docs.
    """
    key = vector(*lengths, low=low, high=high, unit=unit)
    return {f"{name}_low": key, f"{name}_high": key}
