"""Train where the GPU is: every planned ``train_eval.py --phase train`` at once, under a
deadline, then each run's last checkpoint packed for the trip back.

    python3 benchmarks/gpu_leg.py --plan plan.json --deadline_s 480 --pack_dir "$OUT"

For a GPU machine that has Python >= 3.12 and torch but neither this project's simulator nor
(maybe) LeRobot: install LeRobot there from the wheels ``tools/offline_wheelhouse.sh`` made
(``--wheels``), then run this with ``python3``. Nothing here imports the project; the
``train_eval.py`` it runs (``trossen-mujoco train``) does, which needs the ``mujoco`` wheel
there too (``tools/offline_wheelhouse.sh --with-sim``), though nothing is simulated.

The plan is a JSON list of runs, each ``{"name": ..., "args": [train_eval.py flags]}`` with
its own ``--work_dir`` holding an exported ``dataset/`` (``train_eval.py --phase
record,export``, made on the machine with the simulator). The camera recipe is a run like
``{"name": "camera", "args": ["--recipe", "camera", "--work_dir", "camera", "--train_seeds",
"3", "--train_jobs", "3", "--device", "cuda", "--num_workers", "4"]}`` (its dataset from
``train_eval.py --recipe camera --phase record,export --work_dir camera``). The
``camera_pose`` recipe's runs train on ``dataset_pose``, which the ``encode`` phase derives
from the recorded episodes (an HDF5 folder too large for the trip): make it where they are
(``train_eval.py --recipe camera_pose --phase record,export,encode --work_dir camera_pose``),
carry only ``camera_pose/dataset_pose`` (no video in it: 17 MB for the transfer's 200
episodes, and ``--stub_av`` serves), and plan ``{"name": "camera_pose", "args": ["--recipe",
"camera_pose", "--work_dir", "camera_pose", "--train_seeds", "3", "--train_jobs", "3",
"--device", "cuda"]}``. All runs start
together (several small ACT runs share one GPU); a run still going at ``--deadline_s`` is
stopped and keeps its last saved checkpoint (``--save_freq``). Each run's last checkpoint
(``train/seed_<s>/checkpoints/last/pretrained_model``) is written to ``--pack_dir`` as
``<name>_seed_<s>.tar`` (``--half``: weights stored as float16 to halve the trip; the policy
loads them back as float32; ``--split_mb``: cut into parts for a transfer with a size limit),
with ``gpu_leg.json``: per run the steps reached, wall time,
steps/s and LeRobot's own data-loading and update times per step. Unpack each tar in the
run's ``train/seed_<s>/checkpoints/last/`` and score it with ``train_eval.py --phase eval``.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import signal
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent

AV_STANDIN = '''"""Stand-in for PyAV written by gpu_leg.py --stub_av: importable, never decodes."""


class _Absent:
    def __getattr__(self, name):
        return self

    def __call__(self, *args, **kwargs):
        raise ImportError("PyAV is not installed here (gpu_leg.py --stub_av): this dataset has "
                          "videos; carry the av wheel instead")

    def __or__(self, other):  # annotations such as ``av.codec.Codec | None``
        return self

    __ror__ = __or__


def __getattr__(name):
    return _Absent()
'''
AV_METADATA = "Metadata-Version: 2.1\nName: av\nVersion: 0.0.0\n"


def _arg(args: list[str], flag: str, default: str) -> str:
    for i, a in enumerate(args):
        if a == flag and i + 1 < len(args):
            return args[i + 1]
        if a.startswith(flag + "="):
            return a.split("=", 1)[1]
    return default


def _log_stats(log: Path) -> dict:
    """Steps, and LeRobot's mean ``data_s`` / ``updt_s`` per logged step, from a train log."""
    text = log.read_text(errors="replace") if log.exists() else ""
    data = [float(x) for x in re.findall(r"data_s:([0-9.]+)", text)]
    updt = [float(x) for x in re.findall(r"updt_s:([0-9.]+)", text)]
    losses = [float(x) for x in re.findall(r"(?<![a-z0-9_])loss:([0-9.]+)", text)]
    return {
        "data_s_per_step": sum(data) / len(data) if data else None,
        "update_s_per_step": sum(updt) / len(updt) if updt else None,
        "loss_curve": losses,
    }


def _pack(src: Path, dest: Path, half: bool) -> None:
    """Tar ``src`` (a pretrained_model folder) as ``dest``, weights in float16 if ``half``."""
    tmp = dest.with_suffix(".tmp")
    with tarfile.open(tmp, "w") as tar:
        for f in sorted(src.iterdir()):
            if half and f.name == "model.safetensors":
                from safetensors.torch import load_file, save_file

                weights = {
                    k: (v.half() if v.is_floating_point() else v) for k, v in load_file(f).items()
                }
                half_file = dest.with_suffix(".model.safetensors")
                save_file(weights, str(half_file), metadata={"format": "pt"})
                tar.add(half_file, arcname=f"pretrained_model/{f.name}")
                half_file.unlink()
            else:
                tar.add(f, arcname=f"pretrained_model/{f.name}")
    tmp.replace(dest)


def _split(path: Path, mb: float) -> list[str]:
    """Cut ``path`` into ``<name>.partK`` files of at most ``mb`` MiB (none when it fits);
    ``cat <name>.part*`` joins them. The names of the files to carry back."""
    size = int(mb * 2**20)
    if mb <= 0 or path.stat().st_size <= size:
        return [path.name]
    names = []
    with open(path, "rb") as src:
        for k, chunk in enumerate(iter(lambda: src.read(size), b"")):
            part = path.with_name(f"{path.name}.part{k}")
            part.write_bytes(chunk)
            names.append(part.name)
    path.unlink()
    return names


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--plan", required=True, help="JSON list of {name, args}")
    p.add_argument("--deadline_s", type=float, default=480.0)
    p.add_argument("--pack_dir", required=True)
    p.add_argument("--half", action="store_true", help="pack weights as float16")
    p.add_argument(
        "--split_mb",
        type=float,
        default=0,
        help="cut packs larger than this many MiB into parts (0: never)",
    )
    p.add_argument(
        "--wheels",
        default="",
        help="folder of wheels to install first (offline); a *.tar.xz there is an "
        "unpacked wheel packed smaller, extracted as it is",
    )
    p.add_argument(
        "--stub_av",
        action="store_true",
        help="write an importable stand-in for PyAV (state-only datasets; see above)",
    )
    args = p.parse_args()
    env = dict(os.environ)
    if args.stub_av:
        stub = Path(tempfile.mkdtemp(prefix="gpu_leg_av_")) / "av"  # own folder per run
        stub.mkdir()
        (stub / "__init__.py").write_text(AV_STANDIN)
        # LeRobot asks importlib.metadata whether av is installed before it imports it
        meta = stub.parent / "av-0.0.0.dist-info"
        meta.mkdir(exist_ok=True)
        (meta / "METADATA").write_text(AV_METADATA)
        env["PYTHONPATH"] = str(stub.parent) + os.pathsep + env.get("PYTHONPATH", "")
    if args.wheels and Path(args.wheels).is_dir():
        site = "/tmp/gpu_leg_site"
        wheels = sorted(str(w) for w in Path(args.wheels).glob("*.whl"))
        subprocess.run(
            [
                sys.executable,
                "-m",
                "pip",
                "install",
                "-q",
                "--no-index",
                "--no-deps",
                "--no-compile",
                "--no-cache-dir",
                "--upgrade",
                "--target",
                site,
                *wheels,
            ],
            check=True,
        )
        for packed in sorted(Path(args.wheels).glob("*.tar.xz")):  # unpacked wheels, xz'd
            with tarfile.open(packed) as tar:
                tar.extractall(site, filter="data")
        env["PYTHONPATH"] = site + os.pathsep + env.get("PYTHONPATH", "")
    env.setdefault("TROSSEN_LEROBOT_PYTHON", sys.executable)
    plan = json.loads(Path(args.plan).read_text())
    pack = Path(args.pack_dir)
    pack.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    procs = []
    for run in plan:
        work = Path(_arg(run["args"], "--work_dir", "train_eval_out"))
        work.mkdir(parents=True, exist_ok=True)
        log = open(work / "gpu_leg.log", "w")
        cmd = [sys.executable, str(HERE / "train_eval.py"), "--phase", "train", *run["args"]]
        procs.append(
            (
                run,
                work,
                subprocess.Popen(
                    cmd, stdout=log, stderr=subprocess.STDOUT, env=env, start_new_session=True
                ),
            )
        )
    while any(pr.poll() is None for _, _, pr in procs):
        if time.perf_counter() - start > args.deadline_s:
            for _, _, pr in procs:
                if pr.poll() is None:
                    os.killpg(pr.pid, signal.SIGTERM)
            time.sleep(10)
            for _, _, pr in procs:
                if pr.poll() is None:
                    os.killpg(pr.pid, signal.SIGKILL)
            break
        time.sleep(2)
    wall = time.perf_counter() - start
    report = {"wall_s": round(wall, 1), "runs": []}
    for run, work, pr in procs:
        first = int(_arg(run["args"], "--train_seed", "1000"))
        for k in range(int(_arg(run["args"], "--train_seeds", "1"))):
            seed = first + k
            last = work / "train" / f"seed_{seed}" / "checkpoints" / "last"
            model = last / "pretrained_model"
            entry = {
                "name": run["name"],
                "seed": seed,
                "exit": pr.returncode,
                **_log_stats(work / f"train_seed_{seed}.log"),
            }
            if model.is_dir():
                steps = int(last.resolve().name)
                took = wall
                summary = work / "summary.json"
                if summary.exists():  # a run that finished has its own wall time there
                    done = json.loads(summary.read_text()).get("runs", {}).get(str(seed), {})
                    took = done.get("train", {}).get("wall_s", wall)
                entry.update(steps=steps, wall_s=took, steps_per_s=round(steps / took, 2))
                dest = pack / f"{run['name']}_seed_{seed}.tar"
                _pack(model, dest, args.half)
                entry["pack_mb"] = round(dest.stat().st_size / 1e6, 1)
                entry["pack"] = _split(dest, args.split_mb)
            report["runs"].append(entry)
            print(json.dumps({k: v for k, v in entry.items() if k != "loss_curve"}), flush=True)
    (pack / "gpu_leg.json").write_text(json.dumps(report, indent=2) + "\n")


if __name__ == "__main__":
    main()
