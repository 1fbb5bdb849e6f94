"""Observation parts: what a task observes, said once.

A task declares its observation as an ordered list of named ``Part`` s
(``Task.observation_parts``); everything else derives from it: the dict observation
(``Task.get_observation``: float64 copies), its bounds, the gym env's flat float32 vector and
Box, and for goal-conditioned tasks the achieved and desired goals and the goal distance. A
part's value is a live view (a numpy array sharing memory with ``MjData`` or the task, read
as is) or a callable returning the current value. ``indexed`` and ``joined`` make one live
view where memory allows. Views handed out are read-only: nothing that reads an observation
can write the simulation through it.

Docs: docs/writing-a-task.md.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence

import numpy as np

from trossen_arm_mujoco.errors import UserError

__all__ = ["ObservationParts", "Part", "PartValue", "check_part", "indexed", "joined"]

#: A part's value: a live view (read as is) or a callable returning the current value.
PartValue = np.ndarray | Callable[[], np.ndarray]


def _readonly(view: np.ndarray) -> np.ndarray:
    """``view`` as a new read-only view of the same memory (the original stays writable)."""
    out = view.view()
    out.flags.writeable = False
    return out


def _bound(bound) -> np.ndarray | float:
    """A bound as a 1-D float64 copy, or a float for a scalar (filled in later)."""
    if isinstance(bound, (float, int)):
        return float(bound)
    out = np.array(bound, dtype=float)
    return float(out) if out.ndim == 0 else out.reshape(-1)


def _kept(bound):
    """A bound as given, copied where the caller could change it later (arrays, lists)."""
    if isinstance(bound, np.ndarray):
        return bound.copy()
    return list(bound) if isinstance(bound, list) else bound


def _filled(value: float, size: int) -> np.ndarray:
    out = np.empty(size)
    out.fill(value)
    return out


class Part:
    """One named entry of a task's observation.

    Args:
        name: the entry's key in the dict observation (unique within a task).
        value: a live view (an ndarray that follows the simulation; kept as a read-only
            view of the same memory) or a callable returning the current value; either way
            ``size`` values (any shape with that many elements; 1-D is usual).
        low, high: bounds of the value, in its units: ``size`` values each, or scalars
            (broadcast to the size of a live view, or of the other bound; a computed part
            with both bounds scalar has one value). Turned into 1-D float64 arrays (copies)
            and checked when first used (``low``, ``high``, ``size``): the gym env builds its
            spaces from them at construction, while a task made for an episode, whose
            observation only is read, never pays for them.
    """

    __slots__ = ("name", "value", "live", "_bounds", "_low", "_high")

    def __init__(self, name: str, value: PartValue, low, high):
        self.name = str(name)
        self.live = isinstance(value, np.ndarray)
        if not self.live and not callable(value):
            raise UserError(
                f"observation part '{name}': the value must be an array (a live view) or a "
                f"callable returning one, got {type(value).__name__}"
            )
        self.value: PartValue = _readonly(value) if self.live else value
        self._bounds = (_kept(low), _kept(high))
        self._low: np.ndarray | None = None
        self._high: np.ndarray | None = None

    def _materialize(self) -> None:
        low, high = (_bound(b) for b in self._bounds)  # copies; floats stay floats
        if self.live:
            size = self.value.size
        elif isinstance(low, float):
            size = 1 if isinstance(high, float) else high.size
        else:
            size = low.size
        low = _filled(low, size) if isinstance(low, float) else low
        high = _filled(high, size) if isinstance(high, float) else high
        if low.size != size or high.size != size:
            raise UserError(
                f"observation part '{self.name}': bounds of {low.size} and {high.size} "
                f"values for {size} values"
            )
        self._low, self._high = low, high

    @property
    def low(self) -> np.ndarray:
        """Lower bound (size,), float64."""
        if self._low is None:
            self._materialize()
        return self._low

    @property
    def high(self) -> np.ndarray:
        """Upper bound (size,), float64."""
        if self._high is None:
            self._materialize()
        return self._high

    @property
    def size(self) -> int:
        """Number of values (that of the bounds)."""
        return self.value.size if self.live else self.low.size

    def read(self) -> np.ndarray:
        """The current value: the view itself (no copy) or the callable's result."""
        return self.value if self.live else self.value()

    def __repr__(self) -> str:
        kind = "view" if self.live else "computed"
        return f"Part({self.name!r}, {kind})"


class ObservationParts:
    """A task's observation parts, in order: the dict, the bounds and the values of the flat
    vector, all from the one list.

    Args:
        parts: the task's parts (``Task.observation_parts()``).

    Raises:
        UserError: a duplicated name (here), or, when the bounds are first used
            (``bounds``, ``low_high``, ``size``), bounds that are not finite or not ordered
            (one line naming the part).
    """

    def __init__(self, parts: Iterable[Part]):
        self.parts: tuple[Part, ...] = tuple(parts)
        for part in self.parts:
            if not isinstance(part, Part):
                raise UserError(
                    f"observation parts must be Part objects, got {type(part).__name__}"
                )
        names = [p.name for p in self.parts]
        if len(set(names)) != len(names):
            twice = sorted({n for n in names if names.count(n) > 1})
            raise UserError(f"observation part '{twice[0]}' is declared twice")
        self.names: tuple[str, ...] = tuple(names)
        self._by_name = dict(zip(names, self.parts))
        #: values as they are read: live views in place, None where a callable fills in
        self._values: list[np.ndarray | None] = [p.value if p.live else None for p in self.parts]
        self._calls = tuple((i, p.value) for i, p in enumerate(self.parts) if not p.live)
        self._low_high: tuple[np.ndarray, np.ndarray] | None = None

    def __getitem__(self, name: str) -> Part:
        part = self._by_name.get(name)
        if part is None:
            raise UserError(f"no observation part '{name}'; the parts are: {', '.join(self.names)}")
        return part

    def __contains__(self, name: object) -> bool:
        return name in self._by_name

    def __iter__(self):
        return iter(self.parts)

    def __len__(self) -> int:
        return len(self.parts)

    def read(self, name: str) -> np.ndarray:
        """The current value of part ``name`` (a live view is returned as is: no copy)."""
        return self[name].read()

    def values(self) -> list[np.ndarray]:
        """The current values in order: live views as they are, callables called once each
        (the pieces of the flat vector; use them before the next step)."""
        values = self._values.copy()
        for i, call in self._calls:
            values[i] = call()
        return values

    def as_dict(self) -> dict[str, np.ndarray]:
        """name -> current value, as a float64 copy (1-D, ``size`` values)."""
        return {
            p.name: np.array(v, dtype=float).reshape(-1) for p, v in zip(self.parts, self.values())
        }

    def bounds(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """name -> (low, high), copies (1-D float64), checked."""
        self.low_high()
        return {p.name: (p.low.copy(), p.high.copy()) for p in self.parts}

    def low_high(self) -> tuple[np.ndarray, np.ndarray]:
        """The bounds of the flat vector (the parts' bounds concatenated in order), checked
        once: finite with low <= high, or a UserError naming the part."""
        if self._low_high is None:
            if not self.parts:
                self._low_high = np.zeros(0), np.zeros(0)
            else:
                low = np.concatenate([p.low for p in self.parts])
                high = np.concatenate([p.high for p in self.parts])
                if not (np.isfinite(low).all() and np.isfinite(high).all() and (low <= high).all()):
                    for part in self.parts:  # name the failing part
                        check_part(part)
                self._low_high = low, high
        low, high = self._low_high
        return low.copy(), high.copy()

    @property
    def size(self) -> int:
        """Number of values of the flat vector."""
        return sum(p.size for p in self.parts)


def check_part(part: Part) -> None:
    """UserError (one line naming the part) unless its bounds are finite with low <= high."""
    low, high = part.low, part.high
    if not (np.isfinite(low).all() and np.isfinite(high).all()) or (low > high).any():
        raise UserError(
            f"observation entry '{part.name}': bounds must be finite with low <= high, got "
            f"low {np.round(low, 4).tolist()}, high {np.round(high, 4).tolist()}; check the "
            "task config (workspace_low/high, max_joint_velocity, max_object_velocity)"
        )


def indexed(array: np.ndarray, index: Sequence[int] | np.ndarray) -> PartValue:
    """``array[index]`` (1-D ``array``) as a live view when the indices are evenly spaced and
    increasing (a slice), else as a callable returning the copy ``array[index]``."""
    idx = np.asarray(index, dtype=int).reshape(-1)
    if idx.size == 0:
        return array[0:0]
    step = int(idx[1] - idx[0]) if idx.size > 1 else 1
    if step > 0 and np.array_equal(idx, idx[0] + step * np.arange(idx.size)):
        return array[int(idx[0]) : int(idx[-1]) + 1 : step]
    return lambda: array[idx]


def joined(views: Sequence[np.ndarray]) -> PartValue:
    """Several 1-D views as one: a single live view when they lie end to end in the same
    memory (e.g. the poses of free joints that follow each other in ``qpos``), else a
    callable returning their concatenation."""
    views = list(views)
    if not views:
        return np.zeros(0)
    if len(views) == 1:
        return views[0]
    first = views[0]
    item = first.itemsize
    ok = all(
        v.ndim == 1
        and v.dtype == first.dtype
        and (v.size <= 1 or v.strides == (item,))
        and v.base is not None
        and v.base is first.base
        for v in views
    )
    if ok:
        end = _address(first) + first.size * item
        for v in views[1:]:
            if _address(v) != end:
                ok = False
                break
            end += v.size * item
    if ok:
        total = sum(v.size for v in views)
        return np.lib.stride_tricks.as_strided(
            first, shape=(total,), strides=(item,), writeable=False
        )
    return lambda: np.concatenate(views)


def _address(view: np.ndarray) -> int:
    return int(view.__array_interface__["data"][0])
