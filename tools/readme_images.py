"""Save one 640x480 frame per camera at the hand-over of a recorded transfer (README images).

python tools/readme_images.py [--step 310] [--out docs/images]
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402

from trossen_arm_mujoco.assets import STATIONARY_CAMERAS  # noqa: E402
from trossen_arm_mujoco.collect.pipeline import EpisodeRecorder, RecordSettings, episode_seed  # noqa: E402
from trossen_arm_mujoco.images import write_png  # noqa: E402
from trossen_arm_mujoco.robot.layout import VENDOR16_LAYOUT  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--step", type=int, default=310)
    parser.add_argument("--out", default="docs/images")
    args = parser.parse_args()
    rec = EpisodeRecorder(RecordSettings(cam_names=tuple(STATIONARY_CAMERAS)))
    actions, poses = rec.scripted_rollout(np.random.default_rng(episode_seed(0, 0)))
    task = rec.joint_sampler.sample_task(0, object_poses=poses)
    for t in range(args.step):
        task.step(VENDOR16_LAYOUT.joint_commands(actions[t]))
    os.makedirs(args.out, exist_ok=True)
    for cam, img in rec.joint_scene.render_images().items():
        path = os.path.join(args.out, f"{cam}.png")
        write_png(path, img)  # atomic, as every image the package writes
        print(path)
    rec.close()


if __name__ == "__main__":
    main()
