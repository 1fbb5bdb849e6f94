"""Progress: a bar on a terminal, a plain line every few seconds otherwise."""

from __future__ import annotations

import io

from trossen_arm_mujoco.collect.progress import LOG_INTERVAL_S, Progress, is_terminal


class FakeClock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_off_a_terminal_one_line_per_interval():
    out, clock = io.StringIO(), FakeClock()
    with Progress(600, "episode 3", "step", out, interval=10.0, clock=clock) as bar:
        for _ in range(600):  # 600 steps over 35 simulated seconds
            clock.now += 35.0 / 600
            bar.update()
    lines = out.getvalue().splitlines()
    assert len(lines) == 3  # at 10, 20 and 30 s
    assert "\r" not in out.getvalue()
    assert lines[0].startswith("episode 3: 172/600 step (29%), 17.") and "s left" in lines[0]


def test_short_work_prints_nothing_off_a_terminal():
    out, clock = io.StringIO(), FakeClock()
    with Progress(100, "episode 0", "step", out, clock=clock) as bar:
        for _ in range(100):
            clock.now += 0.01
            bar.update()
    assert out.getvalue() == ""


def test_a_terminal_gets_a_live_bar():
    out = Terminal()
    assert is_terminal(out) and not is_terminal(io.StringIO())
    with Progress(50, "episode 1", "step", out) as bar:
        for _ in range(50):
            bar.update()
    assert "episode 1" in out.getvalue() and "\r" in out.getvalue()  # redrawn in place


def test_default_interval_is_a_few_seconds():
    assert 5.0 <= LOG_INTERVAL_S <= 10.0
