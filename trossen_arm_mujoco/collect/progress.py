"""Progress of a recording run: a live bar on a terminal, sparse plain lines otherwise.

On a terminal, :class:`Progress` is a tqdm bar that redraws in place. When the stream is a
file or a pipe (a log, CI, ``nohup``), a redrawn bar would leave one fragment per update;
there it prints one plain line at most every ``interval`` seconds instead, e.g.
``episode 3: 120/600 step (20%), 4.8 step/s, 100 s left``.

Docs: docs/cli/record.md.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import Any, TextIO

from tqdm import tqdm

__all__ = ["LOG_INTERVAL_S", "Progress", "is_terminal"]

#: Seconds between two plain progress lines when the output is not a terminal.
LOG_INTERVAL_S: float = 10.0


def is_terminal(stream: Any) -> bool:
    """True when ``stream`` is an interactive terminal."""
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # no isatty, or closed
        return False


class Progress:
    """Count ``total`` units of work, reporting to ``stream`` (default stderr).

    Args:
        total: units expected (steps of an episode, episodes of a run).
        desc: label, e.g. ``"episode 3"``.
        unit: unit name, e.g. ``"step"``.
        stream: where to report; a terminal gets a tqdm bar, anything else plain lines.
        interval: seconds between plain lines (not on a terminal).
        leave: keep the finished bar on the terminal.
        clock: monotonic time source in seconds (tests pass a fake one).

    Use as a context manager, calling :meth:`update` per unit done.
    """

    def __init__(
        self,
        total: int,
        desc: str,
        unit: str,
        stream: TextIO | None = None,
        interval: float = LOG_INTERVAL_S,
        leave: bool = False,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.total, self.desc, self.unit = int(total), desc, unit
        self.stream = sys.stderr if stream is None else stream
        self.interval = float(interval)
        self.clock = clock
        self.done = 0
        self._bar: tqdm | None = None
        if is_terminal(self.stream):
            self._bar = tqdm(total=self.total, desc=desc, unit=unit, leave=leave, file=self.stream)
        self._start = self._last = clock()

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def update(self, n: int = 1) -> None:
        """Record ``n`` more units done."""
        self.done += n
        if self._bar is not None:
            self._bar.update(n)
            return
        now = self.clock()
        if now - self._last >= self.interval:
            self._last = now
            print(self.line(now), file=self.stream, flush=True)

    def line(self, now: float) -> str:
        """The plain progress line at time ``now``."""
        elapsed = max(now - self._start, 1e-9)
        rate = self.done / elapsed
        text = f"{self.desc}: {self.done}/{self.total} {self.unit}"
        if self.total:
            text += f" ({100 * self.done / self.total:.0f}%)"
        text += f", {rate:.3g} {self.unit}/s"
        if rate > 0 and self.done < self.total:
            text += f", {(self.total - self.done) / rate:.0f} s left"
        return text

    def close(self) -> None:
        """Finish the bar (plain mode prints nothing more)."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None
