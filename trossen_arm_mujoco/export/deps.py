"""Optional dependencies of the exporters, imported only when an export runs.

Docs: docs/cli/export.md.
"""

from __future__ import annotations

import importlib
from types import ModuleType

from trossen_arm_mujoco.errors import UserError

__all__ = ["LEROBOT_INSTALL_HINT", "require"]

#: How to install what the LeRobot export needs.
LEROBOT_INSTALL_HINT = 'pip install ".[lerobot]" in the trossen_arm_mujoco checkout'


def require(module: str, package: str | None = None) -> ModuleType:
    """Import ``module``; a missing package is a one-line UserError naming the extra.

    Args:
        module: module to import, e.g. ``"pyarrow.parquet"``.
        package: distribution name in the message (default: the top-level module name).
    """
    try:
        return importlib.import_module(module)
    except ImportError:
        name = package or module.split(".")[0]
        raise UserError(
            f"the LeRobot export needs the '{name}' package; install it with: "
            f"{LEROBOT_INSTALL_HINT}"
        ) from None
