"""Where a derived pose dataset (:mod:`.pose_dataset`) keeps its encoder and the encoder's
report: plain names, read where torch and the simulator are absent (the train phase of
``trossen-mujoco train`` on a train-only machine).

Docs: docs/cli/train.md, docs/train-eval.md.
"""

from __future__ import annotations

__all__ = ["ENCODER_FILE", "REPORT_FILE"]

#: The encoder's weights, inside the derived dataset.
ENCODER_FILE = "meta/pose_encoder.safetensors"
#: What the encoder measured (held-out errors in mm, CPU and wall seconds, its camera).
REPORT_FILE = "meta/pose_encoder.json"
