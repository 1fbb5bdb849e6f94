"""``trossen-mujoco``: usage, subcommand dispatch and the one-line error for a bad name."""

from __future__ import annotations

import importlib

import pytest

from trossen_arm_mujoco import cli
from trossen_arm_mujoco.errors import Terminated


@pytest.mark.parametrize("argv", [[], ["-h"], ["--help"]])
def test_usage_lists_every_subcommand(argv, capsys):
    assert cli.main(argv) == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: trossen-mujoco")
    for name in cli.SUBCOMMANDS:
        assert f"  {name} " in out


def test_unknown_subcommand_is_one_error_line(capsys):
    assert cli.main(["recrod", "--data_dir", "x"]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err == (
        "error: unknown subcommand 'recrod'; valid subcommands: eval, export, prepare, record, "
        "replay-real, serve, teleop, train, visualize (see 'trossen-mujoco --help')\n"
    )


@pytest.mark.parametrize("name", sorted(cli.SUBCOMMANDS))
def test_every_subcommand_module_has_a_cli(name):
    module = importlib.import_module(cli.SUBCOMMANDS[name])
    assert callable(module.cli)


def test_dispatch_passes_the_remaining_arguments(monkeypatch):
    seen = []
    module = importlib.import_module(cli.SUBCOMMANDS["visualize"])
    monkeypatch.setattr(module, "cli", lambda argv: seen.append(argv) or 7)
    assert cli.main(["visualize", "--data_dir", "d", "--fps", "10"]) == 7
    assert seen == [["--data_dir", "d", "--fps", "10"]]


@pytest.mark.parametrize("name", sorted(cli.SUBCOMMANDS))
def test_subcommand_help_names_the_command(name, capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main([name, "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith(f"usage: trossen-mujoco {name} "), out.splitlines()[0]


@pytest.mark.parametrize(
    ("error", "status", "line"),
    [
        (KeyboardInterrupt, 130, "interrupted (Ctrl-C)\n"),
        (Terminated, 143, "interrupted (SIGTERM)\n"),
    ],
)
def test_interrupt_while_importing_the_subcommand_is_one_line(
    error, status, line, monkeypatch, capsys
):
    def slow_import(name):
        raise error

    monkeypatch.setattr(cli.importlib, "import_module", slow_import)
    assert cli.main(["export", "--help"]) == status
    assert capsys.readouterr() == ("", line)
