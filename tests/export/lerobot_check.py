"""Load exported datasets with the real ``LeRobotDataset`` and compare them with the source.

Run by tests/export/test_lerobot_load.py with the Python that has LeRobot installed
(``TROSSEN_LEROBOT_PYTHON``, Python >= 3.12), never imported by the test suite itself::

    python lerobot_check.py SPEC.json

SPEC lists datasets ``{"root", "repo_id", "expected"}`` (``expected``: an .npz with, per
episode ``i``, ``state_i``, ``velocity_i``, ``action_i``, ``env_state_i`` float32,
``reward_i`` float32, ``success_i`` bool, ``images_<camera>_i`` uint8 (T, H, W, 3): frame
``t`` of the export, and ``tasks``; the features a dataset lacks, such as the simulation's
in a default export, are skipped) and the video backends to try. Prints one line
``RESULT <json>`` with what was measured; the test asserts.
"""

from __future__ import annotations

import json
import os
import sys

os.environ.setdefault("HF_HUB_OFFLINE", "1")  # a local root needs no network

import numpy as np  # noqa: E402


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = float(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2))
    return 100.0 if mse == 0 else 10.0 * np.log10(255.0**2 / mse)


#: Vector features compared with the expected values: key -> name in the .npz and result.
VECTORS = {
    "observation.state": "state",
    "observation.velocity": "velocity",
    "action": "action",
    "observation.environment_state": "env_state",
}


def check(root: str, repo_id: str, expected_path: str, backend: str) -> dict:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    exp = np.load(expected_path)
    ds = LeRobotDataset(repo_id, root=root, video_backend=backend)
    cams = [key.split(".", 2)[2] for key in ds.meta.video_keys]
    vectors = {key: name for key, name in VECTORS.items() if key in ds.meta.features}
    scalars = [("next.reward", "reward")] if "next.reward" in ds.meta.features else []
    out = {
        "features": list(ds.meta.features),
        "robot_type": ds.meta.info["robot_type"],
        "num_frames": len(ds),
        "num_episodes": ds.num_episodes,
        "fps": ds.fps,
        "cameras": cams,
        "names": {name: ds.meta.features[key]["names"] for key, name in vectors.items()},
        "shapes": {},
        "tasks": sorted(ds.meta.tasks.index.tolist()),
        "stats_keys": sorted(ds.meta.stats),
        "max_abs": {name: 0.0 for name in (*vectors.values(), *(n for _, n in scalars))},
        "dtypes": {},
        "success_equal": True,
        "task_equal": True,
        "min_psnr": {cam: 100.0 for cam in cams},
        "misaligned": [],
        "order": [],
    }
    for idx in range(len(ds)):
        item = ds[idx]
        ep, t = int(item["episode_index"]), int(item["frame_index"])
        out["order"].append([ep, t])
        for key, name in (*vectors.items(), *scalars):
            got = item[key].numpy()
            out["dtypes"][name] = str(got.dtype)
            out["shapes"][name] = list(got.shape)
            diff = np.abs(got.astype(np.float64) - exp[f"{name}_{ep}"][t].astype(np.float64))
            out["max_abs"][name] = max(out["max_abs"][name], float(np.max(diff)))
        if scalars:
            out["success_equal"] &= bool(item["next.success"]) == bool(exp[f"success_{ep}"][t])
        out["task_equal"] &= item["task"] == str(exp["tasks"][ep])
        for cam in cams:
            img = item[f"observation.images.{cam}"].numpy()  # float (3, H, W) in [0, 1]
            img = np.clip(np.round(img.transpose(1, 2, 0) * 255.0), 0, 255).astype(np.uint8)
            frames = exp[f"images_{cam}_{ep}"]
            out["min_psnr"][cam] = min(out["min_psnr"][cam], psnr(img, frames[t]))
            # another frame of the episode matching clearly better (by about 1 dB) means
            # the wrong frame came back; near-equal frames (arm at rest) pass
            errors = np.mean((frames.astype(float) - img.astype(float)) ** 2, axis=(1, 2, 3))
            best = int(np.argmin(errors))
            if best != t and errors[best] < 0.8 * errors[t]:
                out["misaligned"].append([cam, ep, t, best])
    return out


def main() -> None:
    spec = json.load(open(sys.argv[1]))
    import lerobot

    result = {"lerobot": lerobot.__version__, "python": sys.version.split()[0], "runs": {}}
    for backend in spec["backends"]:
        if backend == "torchcodec":
            try:
                from torchcodec.decoders import VideoDecoder  # noqa: F401
            except Exception as exc:  # FFmpeg libraries missing, most often
                result["runs"][backend] = {"unavailable": " ".join(str(exc).split())[:300]}
                continue
        result["runs"][backend] = {
            ds["name"]: check(ds["root"], ds["repo_id"], ds["expected"], backend)
            for ds in spec["datasets"]
        }
    print("RESULT " + json.dumps(result))


if __name__ == "__main__":
    main()
