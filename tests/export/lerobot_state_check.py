"""Load a state-only export with the real ``LeRobotDataset`` and print its state feature.

Run by tests/export/test_lerobot_state.py with the Python that has LeRobot installed
(``TROSSEN_LEROBOT_PYTHON``), never imported by the test suite itself::

    python lerobot_state_check.py ROOT REPO_ID

Prints one line ``RESULT <json>``: the ``observation.state`` names and shape LeRobot reads
from the dataset, and every frame's state and action as LeRobot returns them.
"""

from __future__ import annotations

import json
import os
import sys

os.environ.setdefault("HF_HUB_OFFLINE", "1")  # a local root needs no network


def main(root: str, repo_id: str) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset(repo_id, root=root)
    feature = ds.meta.features["observation.state"]
    frames = [ds[i] for i in range(len(ds))]
    print(
        "RESULT "
        + json.dumps(
            {
                "names": feature["names"],
                "shape": list(feature["shape"]),
                "action_names": ds.meta.features["action"]["names"],
                "state": [f["observation.state"].tolist() for f in frames],
                "episode_index": [int(f["episode_index"]) for f in frames],
            }
        )
    )


if __name__ == "__main__":
    main(*sys.argv[1:3])
