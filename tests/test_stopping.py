"""Stop signals (``stopping``): raised, recorded as requests or only noted, by mode; the
handlers replaced are put back. Signals are raised in this process, handlers installed."""

from __future__ import annotations

import os
import signal

import pytest

from trossen_arm_mujoco.stopping import (
    NOTE,
    RAISE,
    REQUEST,
    StopSignals,
    Terminated,
    interrupt_signal,
    stops_handling,
)

HANDLED = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGQUIT)


@pytest.fixture
def stops():
    before = {s: signal.getsignal(s) for s in HANDLED}
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
    assert stops_handling(signal.SIGTERM) is stops
    for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.raise_signal(sig)  # returns: nothing is raised
    assert stops.requested and stops.reason == "SIGTERM" and stops.exit_code == 143
    expected = ["SIGINT", "SIGTERM"] + ([] if hup_ignored else ["SIGHUP"])
    assert stops.new_repeats() == expected and stops.new_repeats() == []
    assert stops.wait(5.0)  # returns at once
    stops.restore()
    assert signal.getsignal(signal.SIGTERM) == before and stops_handling(signal.SIGTERM) is None


def test_interruptible_raises_once(stops: StopSignals) -> None:
    stops.install()
    with pytest.raises(Terminated):
        with stops.interruptible():
            signal.raise_signal(signal.SIGTERM)
            pytest.fail("not interrupted")
    signal.raise_signal(signal.SIGINT)  # after the block: recorded only
    assert stops.received == [signal.SIGTERM, signal.SIGINT] and stops.mode == REQUEST
    with pytest.raises(Terminated):  # a stop already requested ends the wait at once
        with stops.interruptible():
            pytest.fail("entered")


def test_ignore_keeps_late_signals_from_ending_the_process(stops: StopSignals) -> None:
    stops.install()
    stops.ignore()
    assert signal.getsignal(signal.SIGTERM) == signal.SIG_IGN
    signal.raise_signal(signal.SIGTERM)
    assert not stops.requested


def test_the_modes_raise_then_request_then_note() -> None:
    """replay-real's sequence: raise before any arm may move, a request while streaming
    (the first stop, a signal or an error, gives the reason), only a note after."""
    stops = StopSignals(RAISE)
    with stops.handling():
        with pytest.raises(Terminated) as exc:
            signal.raise_signal(signal.SIGTERM)
        assert exc.value.signum == 143 - 128 and interrupt_signal(exc.value, stops) == 15
        assert isinstance(exc.value, KeyboardInterrupt) and stops.requested
        with pytest.raises(KeyboardInterrupt) as exc:
            signal.raise_signal(signal.SIGINT)
        assert interrupt_signal(exc.value) == signal.SIGINT

    stops = StopSignals(REQUEST)
    with stops.handling():
        signal.raise_signal(signal.SIGINT)
        stops.request("a driver error", 1)  # after the signal: the signal stays the reason
        signal.raise_signal(signal.SIGTERM)
        assert stops.reason == "SIGINT" and stops.exit_code == 130 and stops.by_signal
        stops.mode = NOTE
        signal.raise_signal(signal.SIGHUP)
        assert stops.late == [signal.SIGHUP] and stops.received == [2, 15]

    errored = StopSignals()
    errored.request("a driver error", 1)
    assert errored.requested and errored.reason == "a driver error"
    assert errored.exit_code == 1 and not errored.by_signal


def test_an_inner_block_leaves_the_outer_handlers_alone() -> None:
    before = signal.getsignal(signal.SIGTERM)
    stops = StopSignals(RAISE)
    with stops.handling():
        with stops.handling():  # replay() inside replay-real's main
            pass
        assert stops_handling(signal.SIGTERM) is stops
    assert signal.getsignal(signal.SIGTERM) == before


def test_another_handler_stays_unless_asked() -> None:
    """run_cli's way: Python's default handlers are replaced, another one only where
    ``over`` names its signal."""

    def own(signum, frame):
        pass

    previous = signal.signal(signal.SIGUSR1, own)
    try:
        stops = StopSignals(RAISE, (signal.SIGUSR1,))
        with stops.handling(over=()):
            assert signal.getsignal(signal.SIGUSR1) is own
        with stops.handling(over=(signal.SIGUSR1,)):
            assert stops_handling(signal.SIGUSR1) is stops
        assert signal.getsignal(signal.SIGUSR1) is own
    finally:
        signal.signal(signal.SIGUSR1, previous)


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_a_forked_child_gets_the_default_handlers(stops: StopSignals) -> None:
    stops.install()
    pid = os.fork()
    if pid == 0:  # the child: not the command; SIGTERM ends it, as for any worker
        ok = signal.getsignal(signal.SIGTERM) == signal.SIG_DFL
        ok = ok and signal.getsignal(signal.SIGINT) is signal.default_int_handler
        os._exit(0 if ok else 1)
    assert os.waitpid(pid, 0)[1] == 0
