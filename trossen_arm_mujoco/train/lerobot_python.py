"""Which Python runs LeRobot for ``trossen-mujoco train`` (Python >= 3.12 with LeRobot
0.6.1, while the project may run on 3.11).

In order: this Python when it imports ``lerobot``; ``TROSSEN_LEROBOT_PYTHON``; the venv
``tools/run_tests.sh`` builds (``$TROSSEN_LEROBOT_VENV``, by default
``~/.cache/trossen-arm-mujoco/lerobot-venv``); else one line saying how to make one.

Docs: docs/cli/train.md, docs/train-eval.md.
"""

from __future__ import annotations

import importlib.util
import os
import sys
from collections.abc import Mapping
from pathlib import Path

from trossen_arm_mujoco.errors import UserError

__all__ = ["DEFAULT_VENV", "lerobot_python"]

#: Where ``tools/run_tests.sh`` builds LeRobot's venv when ``TROSSEN_LEROBOT_VENV`` is unset.
DEFAULT_VENV = "~/.cache/trossen-arm-mujoco/lerobot-venv"


def _has_lerobot() -> bool:
    try:
        return importlib.util.find_spec("lerobot") is not None
    except (ImportError, ValueError):
        return False


def lerobot_python(environ: Mapping[str, str] | None = None) -> str:
    """The path of a Python that runs LeRobot (see the module's docstring); a UserError
    (one line, how to make one) when there is none."""
    env = os.environ if environ is None else environ
    if _has_lerobot():
        return sys.executable
    given = env.get("TROSSEN_LEROBOT_PYTHON", "")
    if given:
        path = Path(given).expanduser()
        if not path.is_file():
            raise UserError(
                f"TROSSEN_LEROBOT_PYTHON={given} is not a file; point it at a Python >= 3.12 "
                "with LeRobot 0.6.1 (bash tools/run_tests.sh builds one), or unset it"
            )
        return str(path)
    venv = Path(env.get("TROSSEN_LEROBOT_VENV") or DEFAULT_VENV).expanduser()
    python = venv / "bin" / "python"
    if python.is_file():
        return str(python)
    raise UserError(
        f"train needs LeRobot 0.6.1 on Python >= 3.12: bash tools/run_tests.sh builds one at "
        f'{venv}, or pip install ".[train]" (in the checkout) in a Python 3.12 venv and set '
        "TROSSEN_LEROBOT_PYTHON to its python"
    )
