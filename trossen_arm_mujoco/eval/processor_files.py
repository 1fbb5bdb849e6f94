"""A LeRobot checkpoint's saved processors (``policy_preprocessor.json``,
``policy_postprocessor.json``): read and checked before anything is edited, edited in memory,
written all or none (``trossen-mujoco prepare``, ``eval.prepare``).

Plain JSON: no LeRobot import, so a checkpoint is prepared where only the simulator runs.

Docs: docs/cli/prepare.md.
"""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from trossen_arm_mujoco.errors import UserError

__all__ = ["POSTPROCESSOR_FILE", "PREPROCESSOR_FILE", "SavedProcessors", "place_step", "read_json"]

#: The saved postprocessor and preprocessor of a LeRobot checkpoint.
POSTPROCESSOR_FILE = "policy_postprocessor.json"
PREPROCESSOR_FILE = "policy_preprocessor.json"
_MAX_BYTES = 16 * 1024 * 1024  # a processor file is a few KiB


def read_json(path: Path) -> Any:
    """The JSON in ``path`` (``OSError`` / ``ValueError`` as raised: callers word them;
    nesting too deep for the parser is a ``ValueError`` too)."""
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except RecursionError:
        raise ValueError("nested too deeply") from None


def _pipeline(path: Path) -> dict[str, Any]:
    """The saved pipeline in ``path``, checked: an object whose ``steps`` is a list of
    objects each naming its step (one-line ``UserError`` otherwise)."""
    hint = "not a LeRobot checkpoint's saved processors; train again or restore the file"
    try:
        if path.stat().st_size > _MAX_BYTES:
            raise UserError(f"{path}: larger than {_MAX_BYTES >> 20} MiB; {hint}")
        data = read_json(path)
    except FileNotFoundError:
        raise UserError(
            f"{path.parent}: no {path.name}; give a LeRobot checkpoint folder "
            "(.../checkpoints/last/pretrained_model) with its saved processors"
        ) from None
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        raise UserError(f"{path}: cannot read it as JSON ({exc}); {hint}") from None
    steps = data.get("steps") if isinstance(data, dict) else None
    if not isinstance(steps, list):
        raise UserError(f"{path}: its 'steps' is not a list; {hint}")
    for i, step in enumerate(steps):
        name = step.get("registry_name", step.get("class")) if isinstance(step, dict) else None
        if not isinstance(name, str) or not isinstance(step.get("config", {}), dict):
            raise UserError(f"{path}: step {i} is not a named step with a config object; {hint}")
    return data


@dataclass
class SavedProcessors:
    """The two saved pipelines of the checkpoint in ``folder``, loaded and checked
    (:meth:`load`); edit ``pre`` / ``post`` (their ``steps`` lists), then :meth:`save`.

    Attributes:
        folder: the checkpoint folder.
        pre, post: the preprocessor's and postprocessor's JSON.
    """

    folder: Path
    pre: dict[str, Any]
    post: dict[str, Any] | None
    _saved: dict[str, str] = field(default_factory=dict, repr=False)
    _raw: dict[str, bytes] = field(default_factory=dict, repr=False)  # the files as found

    @classmethod
    def load(cls, folder: str | Path, post: bool = True) -> SavedProcessors:
        """The files of ``folder``, checked before anything is edited (``post`` False: the
        preprocessor alone, for a step that lives there only)."""
        folder = Path(folder)
        pre_data = _pipeline(folder / PREPROCESSOR_FILE)
        post_data = _pipeline(folder / POSTPROCESSOR_FILE) if post else None
        loaded = {PREPROCESSOR_FILE: pre_data, POSTPROCESSOR_FILE: post_data}
        saved = {n: json.dumps(d, indent=2) + "\n" for n, d in loaded.items() if d is not None}
        raw = {n: (folder / n).read_bytes() for n in saved}
        return cls(folder, pre_data, post_data, saved, raw)

    def changed(self) -> bool:
        """Whether either pipeline differs from what was loaded."""
        return any(self._text(n) != t for n, t in self._saved.items())

    def _text(self, name: str) -> str:
        return json.dumps(self.pre if name == PREPROCESSOR_FILE else self.post, indent=2) + "\n"

    def save(self) -> bool:
        """Write the pipelines that changed, all or none: each to a temp file first, then
        renamed into place; a failure puts back the files already renamed. False when
        nothing changed. A folder or file that cannot be written is one ``UserError``."""
        names = [n for n, t in self._saved.items() if self._text(n) != t]
        if not names:
            return False
        temps: dict[str, str] = {}
        done: list[str] = []
        try:
            for name in names:
                fd, tmp = tempfile.mkstemp(prefix=f".{name}.", dir=self.folder)
                temps[name] = tmp
                with os.fdopen(fd, "w", encoding="utf-8") as f:
                    f.write(self._text(name))
            for name in names:
                os.replace(temps[name], self.folder / name)
                done.append(name)
        except BaseException as exc:  # an OSError, or Ctrl-C / SIGTERM between the renames
            for name in done:  # put back what was already replaced
                try:
                    (self.folder / name).write_bytes(self._raw[name])
                except OSError:
                    pass
            if not isinstance(exc, OSError):
                raise
            why = exc.strerror or type(exc).__name__
            raise UserError(
                f"{self.folder}: cannot write its processors ({why}); nothing was changed: "
                "make the folder and its files writable"
            ) from None
        finally:
            for tmp in temps.values():
                if os.path.exists(tmp):
                    os.unlink(tmp)
        self._saved.update({n: self._text(n) for n in names})
        self._raw.update({n: self._text(n).encode() for n in names})
        return True


def place_step(
    steps: list[dict[str, Any]],
    name: str,
    step: dict[str, Any],
    *,
    after: str = "",
    before: str = "",
) -> bool:
    """Put ``step`` (a saved processor step, ``registry_name`` ``name``) in ``steps``: in
    place of the step of that name when there is one, else right after the step named
    ``after``, else right before the one named ``before``, else last. True when ``steps``
    changed (False: that very step was there already).

    Args:
        steps: a saved processor's steps, edited in place.
        name: the step's ``registry_name``.
        step: the step as saved (``registry_name``, ``config``, ``state_file``).
        after: put it right after the step of this name (when there is one).
        before: else right before the step of this name.
    """
    for i, s in enumerate(steps):
        if s.get("registry_name") == name:
            if s == step:
                return False
            steps[i] = step
            return True
    names = [s.get("registry_name") for s in steps]
    at = len(steps)
    if after in names:
        at = names.index(after) + 1
    elif before in names:
        at = names.index(before)
    steps.insert(at, step)
    return True
