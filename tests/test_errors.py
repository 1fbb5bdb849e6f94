"""One-line errors: ``report_error``, ``run_cli`` and ``unknown_name_error``."""

from __future__ import annotations

import pytest

from trossen_arm_mujoco.errors import (
    EXIT_INTERRUPTED,
    EXIT_USER_ERROR,
    UserError,
    report_error,
    run_cli,
    unknown_name_error,
)


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
    assert capsys.readouterr().err == "interrupted\n"


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
