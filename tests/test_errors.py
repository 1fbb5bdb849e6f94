"""One-line errors: ``report_error``, ``run_cli`` (user errors, Ctrl-C, SIGTERM) and the
helpers for I/O errors and interrupt notes."""

from __future__ import annotations

import errno
import os
import signal
import threading
import time

import pytest

from trossen_arm_mujoco.errors import (
    EXIT_INTERRUPTED,
    EXIT_TERMINATED,
    EXIT_USER_ERROR,
    Terminated,
    UserError,
    describe_os_error,
    interrupt_note,
    os_error_hint,
    report_error,
    run_cli,
    unknown_name_error,
)
from trossen_arm_mujoco.stopping import RAISE, StopSignals, stops_handling


def raises_here(sig: int) -> bool:
    """Whether ``sig`` is handled now by stop signals that raise (``run_cli``'s)."""
    stops = stops_handling(sig)
    return stops is not None and stops.mode == RAISE


def test_report_error_prints_one_line_and_returns_the_status(capsys):
    assert report_error("no episodes in /x") == EXIT_USER_ERROR == 2
    assert report_error(UserError("bad flag"), 1) == 1
    out, err = capsys.readouterr()
    assert out == ""
    assert err == "error: no episodes in /x\nerror: bad flag\n"


def test_report_error_joins_a_multi_line_message(capsys):
    report_error("first\n  second\n\nthird  ")
    assert capsys.readouterr().err == "error: first; second; third\n"


def test_run_cli_maps_user_errors_to_status_2(capsys):
    def main(argv):
        raise UserError(f"unknown flag {argv[0]}")

    assert run_cli(main, ["--x"]) == 2
    assert capsys.readouterr().err == "error: unknown flag --x\n"


def test_run_cli_maps_interrupts_to_130(capsys):
    def main(argv):
        raise KeyboardInterrupt

    assert run_cli(main, []) == EXIT_INTERRUPTED == 130
    assert capsys.readouterr().err == "interrupted (Ctrl-C)\n"


def test_run_cli_maps_terminated_to_143(capsys):
    def main(argv):
        raise Terminated

    assert run_cli(main, []) == EXIT_TERMINATED == 143
    assert capsys.readouterr().err == "interrupted (SIGTERM)\n"


def test_sigterm_unwinds_main_like_ctrl_c(capsys):
    """A real SIGTERM: the cleanup written for Ctrl-C runs, the note says what was kept,
    and the previous handler is back afterwards."""
    before = signal.getsignal(signal.SIGTERM)
    cleaned = []

    def main(argv):
        assert raises_here(signal.SIGTERM)
        with interrupt_note(lambda: "kept 2 file(s) in /x"):
            try:
                os.kill(os.getpid(), signal.SIGTERM)
                for _ in range(1000):  # the handler runs at the next bytecode
                    pass
                raise AssertionError("SIGTERM did not interrupt main")
            except KeyboardInterrupt:
                cleaned.append(True)
                raise

    assert run_cli(main, []) == 143
    assert cleaned == [True]
    assert capsys.readouterr().err == "interrupted (SIGTERM): kept 2 file(s) in /x\n"
    assert signal.getsignal(signal.SIGTERM) == before


def test_sigterm_reraised_as_a_plain_keyboard_interrupt_still_exits_143(capsys):
    def main(argv):
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            for _ in range(1000):
                pass
        except KeyboardInterrupt:
            raise KeyboardInterrupt from None  # the subclass is lost; the signal is not

    assert run_cli(main, []) == 143
    assert capsys.readouterr().err == "interrupted (SIGTERM)\n"


def test_interrupt_note_innermost_wins_and_a_failing_note_is_dropped(capsys):
    def main(argv):
        with interrupt_note(lambda: "outer"):
            with interrupt_note(lambda: "inner;\nsecond line"):
                raise KeyboardInterrupt

    assert run_cli(main, []) == 130
    assert capsys.readouterr().err == "interrupted (Ctrl-C): inner;; second line\n"

    def broken(argv):
        with interrupt_note(lambda: 1 / 0):
            raise KeyboardInterrupt

    assert run_cli(broken, []) == 130
    assert capsys.readouterr().err == "interrupted (Ctrl-C)\n"


def test_a_handler_main_installs_itself_wins_and_is_undone(capsys):
    """Commands that handle SIGTERM themselves (record, replay-real) keep doing so: run_cli
    installs its handler before main, main's replaces it, the previous one comes back."""
    before = signal.getsignal(signal.SIGTERM)
    seen = []

    def own(signum, frame):
        seen.append(signum)

    def main(argv):
        signal.signal(signal.SIGTERM, own)
        os.kill(os.getpid(), signal.SIGTERM)
        for _ in range(1000):
            pass
        return 5

    assert run_cli(main, []) == 5
    assert seen == [signal.SIGTERM]
    assert capsys.readouterr().err == ""
    assert signal.getsignal(signal.SIGTERM) == before


def test_an_ignored_sigterm_stays_ignored(monkeypatch):
    monkeypatch.setattr(signal, "getsignal", lambda sig: signal.SIG_IGN)
    installed = []
    monkeypatch.setattr(signal, "signal", lambda sig, handler: installed.append(handler))
    assert run_cli(lambda argv: 0, []) == 0
    assert installed == []


def test_run_cli_outside_the_main_thread_installs_nothing():
    before = signal.getsignal(signal.SIGTERM)
    result = []
    thread = threading.Thread(target=lambda: result.append(run_cli(lambda argv: 4, [])))
    thread.start()
    thread.join()
    assert result == [4]
    assert signal.getsignal(signal.SIGTERM) == before


def test_the_handler_is_restored_after_user_errors_and_bugs(capsys):
    before = signal.getsignal(signal.SIGTERM)

    def bad(argv):
        raise UserError("bad")

    assert run_cli(bad, []) == 2
    assert signal.getsignal(signal.SIGTERM) == before

    def bug(argv):
        raise ValueError("bug")

    with pytest.raises(ValueError):
        run_cli(bug, [])
    assert signal.getsignal(signal.SIGTERM) == before
    capsys.readouterr()


@pytest.mark.parametrize(
    ("number", "cause", "hint"),
    [
        (errno.ENOSPC, "No space left on device (ENOSPC)", "free some disk space"),
        (errno.EROFS, "Read-only file system (EROFS)", "the file system is read-only"),
        (errno.EPERM, "Operation not permitted (EPERM)", "immutable attribute"),
        (errno.EACCES, "Permission denied (EACCES)", "permissions"),
        (errno.ENOTDIR, "Not a directory (ENOTDIR)", "a file is in the way"),
        (errno.EBUSY, "Device or resource busy (EBUSY)", "mount point"),
    ],
)
def test_os_error_cause_and_hint(number, cause, hint):
    exc = OSError(number, os.strerror(number), "/some/file")
    assert describe_os_error(exc) == cause
    assert hint in os_error_hint(exc, "--output") and "--output" in os_error_hint(exc, "--output")


def test_os_error_without_errno():
    assert describe_os_error(OSError("Error writing\n bytes")) == "Error writing bytes"
    assert describe_os_error(OSError()) == "OSError"
    assert os_error_hint(OSError("x"), "--output_dir").endswith("choose another --output_dir")


@pytest.mark.parametrize(("returned", "status"), [(None, 0), (0, 0), (3, 3)])
def test_run_cli_passes_the_status_through(returned, status, capsys):
    assert run_cli(lambda argv: returned, None) == status
    assert capsys.readouterr().err == ""


def test_run_cli_lets_bugs_raise():
    def main(argv):
        raise ValueError("a bug, not a user mistake")

    with pytest.raises(ValueError, match="a bug"):
        run_cli(main, [])


def test_unknown_name_error_lists_sorted_names_and_hint():
    exc = unknown_name_error("camera", "top", ["zeta", "alpha"], "or 'none'")
    assert isinstance(exc, UserError)
    assert str(exc) == "unknown camera 'top'; valid cameras: alpha, zeta (or 'none')"
    assert str(unknown_name_error("task", "x", ["b", "a"])) == "unknown task 'x'; valid tasks: a, b"


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_a_forked_child_gets_the_default_sigterm():
    seen = []

    def main(argv):
        pid = os.fork()
        if pid == 0:  # the child: SIGTERM ends it, as for any worker
            ok = signal.getsignal(signal.SIGTERM) == signal.SIG_DFL
            os._exit(0 if ok else 1)
        seen.append(os.waitpid(pid, 0)[1])
        return 0

    assert run_cli(main, []) == 0
    assert seen == [0]


def test_sighup_is_handled_like_sigterm_and_a_handler_in_place_is_kept(capsys):
    """Closing the terminal (SIGHUP) unwinds like Ctrl-C (exit 129); a handler that was
    installed before for another such signal (SIGUSR1 here) is left alone."""
    seen = []
    previous_usr1 = signal.signal(signal.SIGUSR1, lambda signum, frame: seen.append(signum))
    before_hup = signal.getsignal(signal.SIGHUP)
    try:

        def main(argv):
            assert raises_here(signal.SIGHUP)
            os.kill(os.getpid(), signal.SIGUSR1)  # the handler in place runs, no interrupt
            for _ in range(1000):
                pass
            with interrupt_note(lambda: "nothing partial left"):
                os.kill(os.getpid(), signal.SIGHUP)
                for _ in range(1000):
                    pass
            return 0

        if before_hup != signal.SIG_DFL:
            pytest.skip("SIGHUP has a handler in this process")
        assert run_cli(main, []) == 128 + signal.SIGHUP == 129
        assert seen == [signal.SIGUSR1]
        assert capsys.readouterr().err == "interrupted (SIGHUP): nothing partial left\n"
        assert signal.getsignal(signal.SIGHUP) == before_hup
    finally:
        signal.signal(signal.SIGUSR1, previous_usr1)


def test_signal_in_a_finalizer_is_delivered_after_it(monkeypatch):
    """SIGTERM arriving while a ``__del__`` runs is not lost as "Exception ignored in": it
    is raised once the finalizer has returned."""
    seen = []

    class Finalized:
        def __del__(self):
            signal.raise_signal(signal.SIGTERM)  # the handler runs inside __del__
            seen.append("finalizer done")

    stops = StopSignals(RAISE, (signal.SIGTERM,))
    with stops.handling(), pytest.raises(Terminated):
        Finalized()  # collected at once: __del__ runs here
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline:  # the signal comes again a moment later
            time.sleep(0.001)
    assert seen and seen[0] == "finalizer done" and stops.received == [signal.SIGTERM]


def test_ctrl_c_in_a_finalizer_is_delivered_after_it():
    """Commands run by ``run_cli`` get a SIGINT handler that does the same for Ctrl-C
    (Python's own raised inside the finalizer: "Exception ignored", and the run went on)."""
    seen, handlers = [], []

    class Finalized:
        def __del__(self):
            signal.raise_signal(signal.SIGINT)
            seen.append("finalizer done")

    def command(argv=None) -> int:
        handlers.append(raises_here(signal.SIGINT))
        Finalized()
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline:
            time.sleep(0.001)
        return 0

    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        assert run_cli(command) == 130
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # put back
    finally:
        signal.signal(signal.SIGINT, before)
    assert handlers == [True] and seen == ["finalizer done"]
