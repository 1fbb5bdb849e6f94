"""Make LeRobot checkpoints deployable by any runner (also ``trossen-mujoco prepare``).

    trossen-mujoco prepare outputs/train/act/checkpoints/last/pretrained_model

Adds to each checkpoint's saved processors the steps ``trossen_arm_mujoco.eval.prepare``
describes (the images cut and scaled as trained, the pose encoder where the checkpoint has
one, the arm controller's limits); a prepared checkpoint is left as it is.

Docs: docs/cli/prepare.md.
"""

from __future__ import annotations

__all__ = ["build_parser", "cli", "main"]

if __name__ == "__main__" and not __package__:  # run as a file: import from the repo root
    import sys
    from pathlib import Path

    sys.path[0] = str(
        next(p for p in Path(__file__).resolve().parents if not (p / "__init__.py").is_file())
    )
    import trossen_arm_mujoco  # noqa: F401  (as with -m: the package sets MUJOCO_GL first)

import argparse
import sys
from collections.abc import Sequence

from trossen_arm_mujoco.errors import ArgumentParser, run_cli


def build_parser() -> argparse.ArgumentParser:
    """Command-line flags."""
    p = ArgumentParser(
        prog="trossen-mujoco prepare",
        description="Add to LeRobot checkpoints the steps any runner needs: images cut and "
        "scaled as trained, the pose encoder, the arm controller's limits.",
    )
    p.add_argument(
        "checkpoints",
        nargs="+",
        metavar="CHECKPOINT",
        help="checkpoint folder (.../checkpoints/last/pretrained_model)",
    )
    p.add_argument(
        "--encoder",
        default=None,
        help="pose encoder to put in (default: the training dataset's "
        "meta/pose_encoder.safetensors, if it has one)",
    )
    p.add_argument(
        "--camera", default=None, help="camera the pose encoder reads (default: the checkpoint's)"
    )
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Prepare each checkpoint; returns the exit status."""
    args = build_parser().parse_args(argv)
    from trossen_arm_mujoco.eval.prepare import prepare_checkpoint

    for folder in args.checkpoints:
        changed = prepare_checkpoint(folder, args.encoder, args.camera)
        print(f"{folder}: {'added ' + ', '.join(changed) if changed else 'prepared already'}")
    return 0


def cli(argv: Sequence[str] | None = None) -> int:
    """Entry point: like :func:`main`, with user errors as one line and exit status 2."""
    return run_cli(main, argv)


if __name__ == "__main__":
    sys.exit(cli())
