"""Thin command lines (``trossen-mujoco <command>``): each parses its flags, checks them and
calls the package; the flags several commands share are declared once in ``common_options``.

Docs: docs/cli/index.md.
"""

__all__: list[str] = []  # submodules only: import them by name
