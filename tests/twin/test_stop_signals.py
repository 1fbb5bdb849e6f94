"""Stop signals recorded as requests, never raised (except to end a blocking wait); the
handlers replaced are put back. Signals are raised in this process, handlers installed."""

from __future__ import annotations

import signal

import pytest

from trossen_arm_mujoco.errors import Terminated
from trossen_arm_mujoco.twin.stop_signals import StopSignals


@pytest.fixture
def stops():
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    made = StopSignals()
    yield made
    made.restore()
    for sig, handler in before.items():
        signal.signal(sig, handler)


def test_signals_are_recorded_and_never_raise(stops: StopSignals) -> None:
    before = signal.getsignal(signal.SIGTERM)
    # a signal ignored when serve starts (SIGHUP under nohup) stays ignored, as it should
    hup_ignored = signal.getsignal(signal.SIGHUP) == signal.SIG_IGN
    stops.install()
    for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.raise_signal(sig)  # returns: nothing is raised
    assert stops.requested and stops.reason == "SIGTERM"
    expected = ["SIGINT", "SIGTERM"] + ([] if hup_ignored else ["SIGHUP"])
    assert stops.new_repeats() == expected and stops.new_repeats() == []
    assert stops.wait(5.0)  # returns at once
    stops.restore()
    assert signal.getsignal(signal.SIGTERM) == before


def test_interruptible_raises_once(stops: StopSignals) -> None:
    stops.install()
    with pytest.raises(Terminated):
        with stops.interruptible():
            signal.raise_signal(signal.SIGTERM)
            pytest.fail("not interrupted")
    signal.raise_signal(signal.SIGINT)  # after the block: recorded only
    assert stops.received == [signal.SIGTERM, signal.SIGINT]
    with pytest.raises(Terminated):  # a stop already requested ends the wait at once
        with stops.interruptible():
            pytest.fail("entered")


def test_ignore_keeps_late_signals_from_ending_the_process(stops: StopSignals) -> None:
    stops.install()
    stops.ignore()
    assert signal.getsignal(signal.SIGTERM) == signal.SIG_IGN
    signal.raise_signal(signal.SIGTERM)
    assert not stops.requested
