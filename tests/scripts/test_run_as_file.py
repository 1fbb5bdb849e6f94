"""Running a module as a file (``python trossen_arm_mujoco/scripts/x.py``): one bootstrap,
the same lines in every module that has one, working from any folder."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
PACKAGE = REPO / "trossen_arm_mujoco"
GUARD = 'if __name__ == "__main__" and not __package__:'
MAIN = 'if __name__ == "__main__":'
#: The command-line scripts: modules of scripts/ that run as a program. The others there
#: (``record_args.py``, ``record_report.py``) are parts the scripts import.
SCRIPTS = sorted(
    p
    for p in (PACKAGE / "scripts").glob("*.py")
    if p.name != "__init__.py" and MAIN in p.read_text().splitlines()
)


def bootstrap(path: Path) -> str | None:
    """The guard line and its indented body (blank lines inside included), or None."""
    lines = path.read_text().splitlines()
    starts = [i for i, line in enumerate(lines) if line.startswith(GUARD)]
    if not starts:
        return None
    assert len(starts) == 1, f"{path}: {len(starts)} bootstraps"
    block = [lines[starts[0]]]
    for line in lines[starts[0] + 1 :]:
        if line and not line.startswith(" "):
            break
        block.append(line)
    return "\n".join(block).rstrip()


def _modules_with_bootstrap() -> dict[str, str]:
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        block = bootstrap(path)
        if block is not None:
            found[str(path.relative_to(REPO))] = block
    return found


def test_every_script_has_the_bootstrap():
    for path in SCRIPTS:
        assert bootstrap(path) is not None, f"{path.name} cannot run as a file"


def test_every_subcommand_is_a_script():
    from trossen_arm_mujoco.cli import SUBCOMMANDS

    names = {f"trossen_arm_mujoco.scripts.{p.stem}" for p in SCRIPTS}
    assert set(SUBCOMMANDS.values()) <= names


def test_one_identical_bootstrap_everywhere():
    found = _modules_with_bootstrap()
    reference = found["trossen_arm_mujoco/scripts/record_sim_episodes.py"]
    different = [name for name, block in found.items() if block != reference]
    assert different == [], f"bootstrap differs from record_sim_episodes.py in {different}"


def test_no_other_bootstrap_variant():
    offenders = []
    for path in sorted(PACKAGE.rglob("*.py")):
        text = path.read_text()
        if "__package__ in (None" in text or "sys.path.insert" in text:
            offenders.append(str(path.relative_to(REPO)))
    assert offenders == []


def _run_file(script: Path, *args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    return subprocess.run(
        [sys.executable, str(script), *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_help_as_a_file_from_another_folder(script, tmp_path):
    proc = _run_file(script, "--help", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("usage: ") and "-h, --help" in proc.stdout


@pytest.mark.parametrize(
    ("name", "extra"),
    [("visualize_eps.py", []), ("replay_episode_real.py", ["--dry_run"])],
)
def test_user_error_as_a_file_is_one_line(name, extra, tmp_path):
    proc = _run_file(
        PACKAGE / "scripts" / name,
        *("--root_dir", str(tmp_path), "--data_dir", "missing", *extra),
        cwd=REPO,
    )
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), proc.stderr
    assert "missing" in lines[0]
