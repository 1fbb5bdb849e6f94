"""Recorded HDF5 episodes -> datasets of other frameworks.

:mod:`.lerobot` writes a LeRobot v3.0 dataset (parquet frames, one mp4 stream per camera,
``meta/`` with info, stats, tasks and episodes) with pyarrow and PyAV: the ``lerobot`` extra,
``pip install ".[lerobot]"`` (in the checkout). LeRobot itself is not needed to write one.

Docs: docs/cli/export.md, docs/datasets.md.
"""

from trossen_arm_mujoco.export.lerobot import ExportSummary, export_lerobot
from trossen_arm_mujoco.export.lerobot_video import VideoSettings

__all__ = ["ExportSummary", "VideoSettings", "export_lerobot"]
