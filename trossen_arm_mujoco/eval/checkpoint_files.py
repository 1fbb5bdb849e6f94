"""A LeRobot checkpoint's files, checked before any episode runs (no LeRobot, no torch).

The weights (``model.safetensors``), the saved processors and the state files their steps
name: each file that is missing, empty, truncated or not what it should be is a one-line
``UserError`` naming the file, instead of a traceback from deep inside LeRobot. A
safetensors file is checked from its header and size, without reading its tensors.

Docs: docs/cli/eval.md; details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import json
import math
import struct
from pathlib import Path
from typing import Any

from trossen_arm_mujoco.errors import UserError, describe_os_error
from trossen_arm_mujoco.eval.processor_files import (
    POSTPROCESSOR_FILE,
    PREPROCESSOR_FILE,
    SavedProcessors,
)

__all__ = [
    "WEIGHTS_FILE",
    "check_checkpoint_files",
    "safetensors_problem",
    "saved_steps",
]

#: The weights LeRobot's ``PreTrainedPolicy.from_pretrained`` loads from a checkpoint folder.
WEIGHTS_FILE = "model.safetensors"
#: The largest JSON header a safetensors file may have (bytes), as the safetensors package.
MAX_HEADER = 100_000_000
#: Bytes per element of the safetensors dtypes.
DTYPE_BYTES = {
    "BOOL": 1,
    "U8": 1,
    "I8": 1,
    "F8_E5M2": 1,
    "F8_E4M3": 1,
    "I16": 2,
    "U16": 2,
    "F16": 2,
    "BF16": 2,
    "I32": 4,
    "U32": 4,
    "F32": 4,
    "I64": 8,
    "U64": 8,
    "F64": 8,
}
_FIX = "copy the checkpoint again (all of its files) or train again"


def safetensors_problem(path: Path) -> str | None:
    """What is wrong with the safetensors file ``path`` in a few words (None: whole and
    readable): missing, empty, its header unreadable, or its size other than the header says."""
    try:
        size = path.stat().st_size
        if not path.is_file():
            return "is not a file"
        with path.open("rb") as f:
            head = f.read(8)
            if size == 0:
                return "is empty (0 bytes)"
            if len(head) < 8:
                return f"is truncated ({size} bytes: not even its 8-byte header length)"
            (length,) = struct.unpack("<Q", head)
            raw = f.read(min(length, MAX_HEADER))
    except FileNotFoundError:
        return "is missing"
    except OSError as exc:
        return f"cannot be read ({describe_os_error(exc)})"
    if length > MAX_HEADER or not raw.lstrip().startswith(b"{"):
        return "is not a safetensors file (no JSON header after its 8-byte header length)"
    if 8 + length > size:
        return (
            f"is truncated ({size} bytes; its header alone needs {8 + length}: the file was "
            "cut short)"
        )
    try:
        header = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError):
        return "is not a safetensors file (its header is not JSON)"
    if not isinstance(header, dict):
        return "is not a safetensors file (its header is not a JSON object)"
    end = 0
    for name, info in header.items():
        if name == "__metadata__":
            continue
        problem = _tensor_problem(name, info)
        if problem is not None:
            return f"has a damaged header ({problem})"
        end = max(end, int(info["data_offsets"][1]))
    data = size - 8 - length
    if data < end:
        return (
            f"is truncated ({size} bytes; its header describes {8 + length + end}: the file "
            "was cut short)"
        )
    if data > end:
        return f"is not a whole safetensors file ({data - end} bytes after its last tensor)"
    return None


def _tensor_problem(name: str, info: Any) -> str | None:
    """What is wrong with one tensor's header entry (None: a dtype, a shape and a byte range
    that fits them)."""
    if not isinstance(info, dict):
        return f"tensor {name!r} is not described"
    offsets, shape, dtype = info.get("data_offsets"), info.get("shape"), info.get("dtype")
    ints = (
        isinstance(offsets, list)
        and len(offsets) == 2
        and isinstance(shape, list)
        and all(isinstance(v, int) and not isinstance(v, bool) and v >= 0 for v in offsets + shape)
    )
    if not ints or offsets[1] < offsets[0]:
        return f"tensor {name!r}: no valid shape and byte range"
    width = DTYPE_BYTES.get(dtype) if isinstance(dtype, str) else None
    if width is not None and offsets[1] - offsets[0] != math.prod(shape) * width:
        return f"tensor {name!r}: its byte range does not fit its {dtype} shape {shape}"
    return None


def saved_steps(folder: Path) -> list[tuple[str, int, dict[str, Any]]]:
    """Each step of the checkpoint's two saved processors: (file name, index, step), after
    both files were checked (``processor_files``: one ``UserError`` naming the file)."""
    saved = SavedProcessors.load(folder)
    steps = []
    for name, pipeline in ((PREPROCESSOR_FILE, saved.pre), (POSTPROCESSOR_FILE, saved.post)):
        for i, step in enumerate((pipeline or {}).get("steps", [])):
            steps.append((name, i, step))
    return steps


def check_checkpoint_files(folder: str | Path, policy: str | Path | None = None) -> None:
    """Refuse, in one line naming the file, a checkpoint folder whose weights, saved
    processors or processor state files are missing or damaged (``policy``: what
    ``--policy`` said, for the message; default the folder)."""
    folder = Path(folder)
    flag = f"--policy {policy if policy is not None else folder}"
    weights = folder / WEIGHTS_FILE
    problem = safetensors_problem(weights)
    if problem == "is missing":
        raise UserError(
            f"{flag}: no {WEIGHTS_FILE} in {folder} (the policy's weights); give the "
            "pretrained_model folder lerobot-train saved, with all of its files"
        )
    if problem is not None:
        raise UserError(f"{flag}: {weights} {problem}; {_FIX}")
    try:
        steps = saved_steps(folder)
    except UserError as exc:
        raise UserError(f"{flag}: {exc}") from None
    for name, i, step in steps:
        state = step.get("state_file")
        if state is None:
            continue
        what = f"step {i} ({_step_name(step)}) of {name}"
        if not isinstance(state, str) or not state or Path(state).name != state:
            raise UserError(f"{flag}: {what} names no valid state file ({state!r}); {_FIX}")
        problem = safetensors_problem(folder / state)
        if problem is not None:
            raise UserError(f"{flag}: {folder / state}, the state of {what}, {problem}; {_FIX}")


def _step_name(step: dict[str, Any]) -> str:
    """A saved step's registry name, or its class path."""
    return str(step.get("registry_name", step.get("class", "?")))
