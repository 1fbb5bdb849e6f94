"""``trossen-mujoco eval --policy module:function`` finds a module in the current folder (the
console script, unlike ``python -m``, does not put it on ``sys.path``)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path


def test_the_console_script_imports_a_policy_from_the_current_folder(tmp_path: Path) -> None:
    script = Path(sys.executable).with_name("trossen-mujoco")
    assert script.is_file(), f"the console script is not installed next to {sys.executable}"
    (tmp_path / "my_hold_policy.py").write_text(
        "import numpy as np\n\ndef hold(obs):\n    return np.asarray(obs['agent_pos'])\n"
    )
    env = {**os.environ, "MUJOCO_GL": "egl"}
    env.pop("PYTHONPATH", None)
    done = subprocess.run(
        [
            str(script),
            "eval",
            "--policy",
            "my_hold_policy:hold",
            "--num_episodes",
            "1",
            "--episode_length",
            "5",
            "--output_dir",
            "out",
        ],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    info = json.loads((tmp_path / "out" / "eval_info.json").read_text())
    assert info["aggregated"]["n_episodes"] == 1
