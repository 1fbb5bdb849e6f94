"""``trossen-mujoco train`` end to end on tiny runs: the phases one at a time (record,export
here, then train, then eval, as on two machines), two training seeds at once, the spread, the
recipes' runs, the README's command as written, and its one-line refusals (flags, summary,
work folder, lock) and interruptions.

Needs LeRobot (``TROSSEN_LEROBOT_PYTHON``, set by ``tools/run_tests.sh``).
"""

from __future__ import annotations

import json
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import tarfile
import time
from pathlib import Path

import pytest

from trossen_arm_mujoco.export.dataset_settings import CHECKPOINT_FILE as SETTINGS_FILE
from trossen_arm_mujoco.export.dataset_settings import INFO_KEY as SETTINGS_KEY

pytestmark = pytest.mark.once  # LeRobot runs in TROSSEN_LEROBOT_PYTHON whatever runs pytest

REPO = Path(__file__).resolve().parents[2]
COMMAND = [sys.executable, "-m", "trossen_arm_mujoco.cli", "train"]
GPU_LEG = REPO / "benchmarks" / "gpu_leg.py"
TINY = [
    "--steps",
    "2",
    "--save_freq",
    "2",
    "--batch_size",
    "2",
    "--dim_model",
    "32",
    "--dim_feedforward",
    "64",
    "--n_encoder_layers",
    "1",
    "--chunk_size",
    "5",
]


def _python() -> str:
    python = os.environ.get("TROSSEN_LEROBOT_PYTHON", "")
    if not python or not Path(python).is_file():
        pytest.skip(
            "TROSSEN_LEROBOT_PYTHON is not set to a Python with LeRobot (run_tests.sh sets it)"
        )
    return python


def _bench(work: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [*COMMAND, "--work_dir", str(work), *args],
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "TROSSEN_LEROBOT_PYTHON": _python()},
    )


def test_phases_run_apart_and_the_spread_covers_every_training_seed(tmp_path):
    work = tmp_path / "loop"
    made = _bench(work, "--phase", "record,export", "--episodes", "2")
    assert made.returncode == 0, made.stdout + made.stderr
    assert (work / "dataset" / "meta" / "info.json").is_file()
    assert not (work / "train").exists()  # only the phases asked for ran

    seeds = ["--train_seeds", "2", "--train_seed", "5"]
    trained = _bench(
        work,
        "--phase",
        "train",
        *seeds,
        "--train_jobs",
        "2",
        *TINY,
        "--lr_schedule",
        "cosine",
        "--lr_final",
        "3e-7",
    )
    assert trained.returncode == 0, trained.stdout + trained.stderr
    for seed in (5, 6):
        assert (
            work
            / "train"
            / f"seed_{seed}"
            / "checkpoints"
            / "last"
            / "pretrained_model"
            / "model.safetensors"
        ).is_file()
        config = json.loads(
            (
                work
                / "train"
                / f"seed_{seed}"
                / "checkpoints"
                / "last"
                / "pretrained_model"
                / "train_config.json"
            ).read_text()
        )
        assert config["seed"] == seed
        # LeRobot took the decayed schedule with ACT's own optimizer settings
        assert config["scheduler"]["type"] == "cosine_decay_with_warmup"
        assert config["scheduler"]["num_decay_steps"] == 2
        assert config["scheduler"]["decay_lr"] == pytest.approx(3e-7)
        assert config["optimizer"]["lr"] == pytest.approx(1e-4)
        assert config["optimizer"]["weight_decay"] == pytest.approx(1e-4)
    again = _bench(work, "--phase", "train", *seeds, *TINY)
    assert again.returncode == 0 and "already holds a checkpoint" in again.stdout

    scored = _bench(
        work,
        "--phase",
        "eval",
        *seeds,
        "--eval_episodes",
        "2",
        "--eval_episode_length",
        "10",
        "--eval_workers",
        "1",
    )
    assert scored.returncode == 0, scored.stdout + scored.stderr
    summary = json.loads((work / "summary.json").read_text())
    assert set(summary["runs"]) == {"5", "6"}
    for run in summary["runs"].values():
        assert run["train"]["cpu_s"] > 0 and run["train"]["steps"] == 2
        assert run["result"]["n_episodes"] == 2
    spread = summary["spread"]
    rates = [r["result"]["pc_success"] for r in summary["runs"].values()]
    assert spread["runs"] == 2
    assert spread["worst_pc_success"] == min(rates)
    assert spread["mean_pc_success"] == pytest.approx(sum(rates) / 2)
    assert "over 2 training runs (in-process): mean" in scored.stdout
    assert re.search(
        r"cost: record \d+ s wall, \d+ s CPU; encode not measured here; train \d+ s "
        r"wall, \d+ s CPU; evaluate \d+ s wall, \d+ s CPU",
        scored.stdout,
    ), scored.stdout
    for seed in (5, 6):
        ckpt = (
            work.resolve() / "train" / f"seed_{seed}" / "checkpoints" / "last" / "pretrained_model"
        )
        assert f"checkpoint seed {seed}: {ckpt}\n" in scored.stdout
    for run in summary["runs"].values():  # checks on, and off beside it; what it asked for
        assert run["controller"]["checks"] is True and run["unconstrained"]["n_episodes"] == 2
        assert set(run["controller"]["peak_speed_fraction"]) >= {"left_joint_0", "right_gripper"}
        assert run["deployment"]["sim_only"] is True  # the default export: the cube's pose
        assert run["deployment"]["settings_source"].endswith(SETTINGS_FILE)
    from trossen_arm_mujoco.export.dataset_settings import checkpoint_settings

    carried, source = checkpoint_settings(
        work / "train" / "seed_5" / "checkpoints" / "last" / "pretrained_model"
    )
    assert carried is not None and carried.fps == 50 and carried.layout == "kit14"
    assert "record" in summary and "export" in summary  # earlier phases kept in the summary
    assert "spread_all" not in summary  # no run beyond this call's

    more = _bench(
        work,
        "--phase",
        "train,eval",
        "--train_seed",
        "7",
        *TINY,
        "--lr_schedule",
        "cosine",
        "--lr_final",
        "3e-7",
        "--eval_episodes",
        "2",
        "--eval_episode_length",
        "10",
        "--eval_workers",
        "1",
    )
    assert more.returncode == 0, more.stdout + more.stderr
    summary = json.loads((work / "summary.json").read_text())
    assert summary["spread"]["runs"] == 1  # this call's run
    assert summary["spread_all"]["runs"] == 3  # with the two trained and scored alike before
    rates = [r["result"]["pc_success"] for r in summary["runs"].values()]
    assert summary["spread_all"]["mean_pc_success"] == pytest.approx(sum(rates) / 3)
    assert f"over 3 training runs (every alike run in {work}): mean" in more.stdout


def test_bad_phases_and_missing_inputs_are_one_line(tmp_path):
    bad = _bench(tmp_path / "w", "--phase", "record,fly")
    assert bad.returncode != 0 and "error: --phase" in bad.stderr
    assert "Traceback" not in bad.stderr
    early = _bench(tmp_path / "w", "--phase", "train")
    assert early.returncode != 0 and "run --phase record,export first" in early.stderr
    noeval = _bench(tmp_path / "w", "--phase", "eval")
    assert noeval.returncode != 0 and "run --phase train first" in noeval.stderr


def _bench_without_lerobot(work: Path, *args: str) -> subprocess.CompletedProcess:
    """The command up to its first phase: TROSSEN_LEROBOT_PYTHON only has to be set."""
    return subprocess.run(
        [*COMMAND, "--work_dir", str(work), "--phase", "train", *args],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "TROSSEN_LEROBOT_PYTHON": sys.executable},
    )


@pytest.mark.parametrize(
    ("summary", "expected"),
    [
        (b'{"settings": {}, "runs": {"5": {"train": ', "summary.json cannot be read as JSON ("),
        (b"", "summary.json cannot be read as JSON (Expecting value"),
        (b"\xff\xfe{}", "summary.json cannot be read as JSON ("),
        (b"[1, 2]", "summary.json is not a summary of trossen-mujoco train"),
        (b'{"runs": []}', "summary.json is not a summary of trossen-mujoco train"),
        (b'{"runs": {"5": 3}}', "summary.json is not a summary of trossen-mujoco train"),
    ],
)
def test_a_broken_summary_is_one_line_and_left_as_it_is(tmp_path, summary, expected):
    work = tmp_path / "w"
    work.mkdir()
    (work / "summary.json").write_bytes(summary)
    run = _bench_without_lerobot(work)
    assert run.returncode != 0 and "Traceback" not in run.stderr, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and expected in lines[0], lines
    assert (work / "summary.json").read_bytes() == summary  # never overwritten


def test_a_file_as_work_dir_is_one_line(tmp_path):
    given = tmp_path / "notes.txt"
    given.write_text("mine\n")
    for work, expected in (
        (given, f"error: cannot write to --work_dir {given}: it is a file; give a folder"),
        (
            given / "sub",
            f"error: cannot write to --work_dir {given / 'sub'}: a file is in the way ({given})",
        ),
    ):
        run = _bench_without_lerobot(work)
        assert run.returncode != 0 and "Traceback" not in run.stderr, run.stderr
        lines = run.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(expected), lines
    assert given.read_text() == "mine\n"


def test_gpu_leg_trains_the_plan_and_packs_each_checkpoint_for_the_trip(tmp_path):
    """``benchmarks/gpu_leg.py`` (run with LeRobot's Python, as on a GPU machine): the plan's
    runs train at once; each last checkpoint comes back as a tar (float16 weights, cut into
    parts under a size limit) that joins and unpacks into a checkpoint folder."""
    python = _python()
    work = tmp_path / "w"
    assert _bench(work, "--phase", "record,export", "--episodes", "2").returncode == 0
    plan = tmp_path / "plan.json"
    args = ["--work_dir", str(work), "--train_seeds", "2", "--train_jobs", "2", *TINY]
    plan.write_text(json.dumps([{"name": "tiny", "args": args}]))
    pack = tmp_path / "pack"
    leg = subprocess.run(
        [
            python,
            str(GPU_LEG),
            "--plan",
            str(plan),
            "--deadline_s",
            "300",
            "--pack_dir",
            str(pack),
            "--half",
            "--split_mb",
            "0.05",
        ],
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "TROSSEN_LEROBOT_PYTHON": python},
    )
    assert leg.returncode == 0, leg.stdout + leg.stderr
    report = json.loads((pack / "gpu_leg.json").read_text())
    assert [(r["seed"], r["steps"]) for r in report["runs"]] == [(1000, 2), (1001, 2)]
    import tarfile

    for run in report["runs"]:
        assert len(run["pack"]) > 1  # cut into parts of 0.05 MiB
        whole = tmp_path / f"{run['seed']}.tar"
        whole.write_bytes(b"".join((pack / name).read_bytes() for name in run["pack"]))
        dest = tmp_path / f"ckpt_{run['seed']}"
        with tarfile.open(whole) as tar:
            tar.extractall(dest, filter="data")
        model = dest / "pretrained_model"
        assert (model / "config.json").is_file()
        check = subprocess.run(
            [
                python,
                "-c",
                "import sys; from safetensors import safe_open; "
                "f = safe_open(sys.argv[1], 'pt'); "
                "print({str(f.get_tensor(k).dtype) for k in f.keys()})",
                str(model / "model.safetensors"),
            ],
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert check.returncode == 0 and "torch.float16" in check.stdout, check.stderr


def test_gpu_leg_stand_in_for_pyav_lets_lerobot_train_import_and_refuses_to_decode(tmp_path):
    """``gpu_leg.py --stub_av`` (a GPU machine without PyAV, state-only datasets): with the
    stand-in first on the path, LeRobot's dataset and training modules import, and any use of
    PyAV raises ImportError naming the fix instead of decoding nothing."""
    python = _python()
    sys.path.insert(0, str(GPU_LEG.parent))
    try:
        import gpu_leg
    finally:
        sys.path.pop(0)
    (tmp_path / "av").mkdir()
    (tmp_path / "av" / "__init__.py").write_text(gpu_leg.AV_STANDIN)
    (tmp_path / "av-0.0.0.dist-info").mkdir()
    (tmp_path / "av-0.0.0.dist-info" / "METADATA").write_text(gpu_leg.AV_METADATA)
    probe = (
        "import av, lerobot.datasets.lerobot_dataset, lerobot.scripts.lerobot_train\n"
        "from lerobot.utils.import_utils import require_package\n"
        "import importlib.metadata as m; print('version', m.version('av'))\n"
        "require_package('av', 'dataset')\n"
        "print(av.__file__)\n"
        "try:\n    av.open('x.mp4')\nexcept ImportError as e:\n    print('refused:', e)\n"
    )
    run = subprocess.run(
        [python, "-c", probe],
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "PYTHONPATH": str(tmp_path)},
    )
    assert run.returncode == 0, run.stderr
    assert str(tmp_path / "av" / "__init__.py") in run.stdout
    assert "refused: PyAV is not installed here" in run.stdout
    assert "carry the av wheel" in run.stdout
    assert "version 0.0.0" in run.stdout  # LeRobot's own check sees the stand-in


def test_the_camera_recipe_runs_small_and_reports_its_cost(tmp_path):
    """``--recipe camera`` end to end on 2 episodes and 2 steps: what the kit gives (the
    joints and cam_high's crop at 60x80, 30 fps, no object pose), each run's success,
    interval, CPU seconds and steps/s in summary.json."""
    work = tmp_path / "cam"
    run = _bench(
        work,
        "--recipe",
        "camera",
        "--episodes",
        "2",
        *TINY,
        "--eval_episodes",
        "1",
        "--eval_episode_length",
        "15",
        "--eval_workers",
        "1",
        "--controller_checks",
        "on",
    )
    assert run.returncode == 0, run.stdout + run.stderr
    info = json.loads((work / "dataset" / "meta" / "info.json").read_text())
    assert info["fps"] == 30
    assert info["features"]["observation.images.cam_high"]["shape"][:2] == [60, 80]
    ckpt = work / "train" / "seed_1000" / "checkpoints" / "last" / "pretrained_model"
    config = json.loads((ckpt / "config.json").read_text())
    assert set(config["input_features"]) == {"observation.state", "observation.images.cam_high"}
    assert config["optimizer_lr_backbone"] == pytest.approx(1e-4)
    carried = json.loads((ckpt / SETTINGS_FILE).read_text())
    assert carried["fps"] == 30 and "cam_high:217,243,150,200" in json.dumps(carried)
    summary = json.loads((work / "summary.json").read_text())
    got = summary["runs"]["1000"]
    assert got["train"]["cpu_s"] > 0 and got["train"]["steps_per_s"] > 0
    assert got["result"]["n_episodes"] == 1 and len(got["result"]["pc_success_ci95"]) == 2
    assert got["deployment"]["sim_only"] is False  # nothing the kit lacks
    assert "s CPU (" in run.stdout and "steps/s" in run.stdout


def test_the_camera_pose_recipe_runs_small_through_the_gpu_route_and_deploys(tmp_path):
    """``--recipe camera_pose`` end to end on 2 episodes and 2 steps, split as on two machines:
    ``record,export,encode`` here (the encoder derived once, its report in summary.json, the
    copy without video); ``gpu_leg.py`` trains in a folder holding only ``dataset_pose`` with
    PyAV stood in (nothing decodes a video), on the joints and the estimates (no image); the
    packed checkpoint is scored back here with the encoder in its preprocessor, reading
    cam_high: it observes what the kit gives."""
    python = _python()
    work = tmp_path / "pose"
    pose = ["--recipe", "camera_pose", *TINY]
    made = _bench(
        work, *pose, "--episodes", "2", "--static_frames", "2", "--phase", "record,export,encode"
    )
    assert made.returncode == 0, made.stdout + made.stderr
    assert len(list((work / "static").glob("episode_*.hdf5"))) == 2  # 3 steps each
    derived = work / "dataset_pose"
    report = json.loads((derived / "meta" / "pose_encoder.json").read_text())
    assert report["camera"] == "cam_high" and report["image_size"] == [60, 80]
    assert report["static_frames"] == 2 and len(report["objects"]) == 1
    info = json.loads((derived / "meta" / "info.json").read_text())
    assert "observation.images.cam_high" not in info["features"]
    assert not (derived / "videos").exists()
    assert info[SETTINGS_KEY]["cam_names"] == ["cam_high"]  # what a checkpoint observes
    summary = json.loads((work / "summary.json").read_text())
    assert summary["encode"]["cpu_s"] > 0 and "start_xy_mm" in summary["encode"]["report"]

    gpu = tmp_path / "gpu" / "pose"  # the train-only machine: the derived copy, nothing else
    shutil.copytree(derived, gpu / "dataset_pose")
    plan = tmp_path / "plan.json"
    plan.write_text(json.dumps([{"name": "pose", "args": [*pose, "--work_dir", str(gpu)]}]))
    pack = tmp_path / "pack"
    leg = subprocess.run(
        [
            python,
            str(GPU_LEG),
            "--plan",
            str(plan),
            "--deadline_s",
            "300",
            "--pack_dir",
            str(pack),
            "--stub_av",
        ],
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "TROSSEN_LEROBOT_PYTHON": python},
    )
    assert leg.returncode == 0, leg.stdout + leg.stderr + (gpu / "gpu_leg.log").read_text()
    (entry,) = json.loads((pack / "gpu_leg.json").read_text())["runs"]
    assert entry["steps"] == 2 and entry["exit"] == 0
    last = work / "train" / "seed_1000" / "checkpoints" / "last"
    with tarfile.open(pack / entry["pack"][0]) as tar:
        tar.extractall(last, filter="data")
    ckpt = last / "pretrained_model"
    config = json.loads((ckpt / "config.json").read_text())
    assert set(config["input_features"]) == {"observation.state", "observation.environment_state"}

    scored = _bench(
        work,
        *pose,
        "--phase",
        "eval",
        "--eval_episodes",
        "1",
        "--eval_episode_length",
        "15",
        "--eval_workers",
        "1",
        "--controller_checks",
        "on",
    )
    assert scored.returncode == 0, scored.stdout + scored.stderr
    steps = json.loads((ckpt / "policy_preprocessor.json").read_text())["steps"]
    names = [step["registry_name"] for step in steps]
    assert names.index("trossen_camera_pose") < names.index("normalizer_processor")
    assert (ckpt / steps[names.index("trossen_camera_pose")]["state_file"]).is_file()
    got = json.loads((work / "summary.json").read_text())["runs"]["1000"]
    assert got["result"]["n_episodes"] == 1
    assert got["deployment"]["sim_only"] is False  # the cube's pose comes from the camera
    assert "pose encoder reading cam_high" in got["deployment"]["why"]


def test_a_train_only_machine_without_the_derived_copy_is_told_what_to_carry(tmp_path):
    run = _bench_without_lerobot(tmp_path / "w", "--recipe", "camera_pose")
    assert run.returncode != 0 and "Traceback" not in run.stderr, run.stderr
    lines = run.stderr.strip().splitlines()
    assert (
        len(lines) == 1
        and "run --phase record,export,encode where the episodes are" in lines[0]
        and "carry dataset_pose/" in lines[0]
    ), lines


def test_a_cropped_recipe_on_a_task_it_knows_no_crop_for_is_one_line(tmp_path):
    run = _bench_without_lerobot(tmp_path / "w", "--recipe", "camera_pose", "--task", "my_task")
    assert run.returncode != 0 and "Traceback" not in run.stderr, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "knows no crop of cam_high for task 'my_task'" in lines[0], lines
    assert "give --crop cam_high:TOP,LEFT,HEIGHT,WIDTH" in lines[0]


@pytest.mark.parametrize(
    ("flags", "expected"),
    [
        (
            ["--cam_names", "cam_top"],
            "--cam_names cam_top: the task's scene has no such camera; choose from cam_high",
        ),
        (  # a single arm's scene has its own two
            ["--task", "pick_place", "--cam_names", "cam_high"],
            "--cam_names cam_high: the task's scene has no such camera; choose from overview, cam",
        ),
        (
            ["--recipe", "camera", "--image_size", "24x32"],
            "--image_size 24x32 is below what the image encoder resolves",
        ),
        (
            ["--recipe", "camera_pose", "--image_size", "12x16"],
            "--image_size 12x16 is below what the pose encoder resolves",
        ),
        (
            ["--recipe", "camera", "--crop", "cam_high:400,0,100,100"],
            "--crop cam_high:400,0,100,100 is outside the camera's 480x640 frame",
        ),
        (["--recipe", "camera", "--crop", "cam_low:0,0,10,10"], "camera 'cam_low' is not observed"),
        (
            ["--recipe", "camera_pose", "--static_frames", "-5"],
            "--static_frames -5: give a count >= 0",
        ),
        (
            ["--recipe", "camera", "--static_frames", "5"],
            "--static_frames trains the pose encoder: use it with --recipe camera_pose",
        ),
    ],
)
def test_camera_settings_are_checked_before_anything_runs(tmp_path, flags, expected):
    run = _bench_without_lerobot(tmp_path / "w", *flags)
    assert run.returncode != 0 and "Traceback" not in run.stderr, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and expected in lines[0], lines
    assert not (tmp_path / "w").exists()  # refused before the work folder was made


def test_augment_without_the_pose_encoder_is_one_line(tmp_path):
    run = _bench_without_lerobot(tmp_path / "w", "--augment")
    assert run.returncode != 0 and "Traceback" not in run.stderr, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "--augment changes the pose encoder's" in lines[0], lines


def test_the_former_script_runs_the_same_command(tmp_path):
    """``benchmarks/train_eval.py`` (named by gpu_leg.py and the benchmarks) is the command."""
    run = subprocess.run(
        [sys.executable, str(REPO / "benchmarks" / "train_eval.py"), "--phase", "record,fly"],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=tmp_path,
    )
    assert run.returncode == 2 and run.stderr.startswith("error: --phase 'record,fly'"), run.stderr
    assert len(run.stderr.strip().splitlines()) == 1


def test_a_second_run_in_the_same_folder_is_one_line_naming_the_first(tmp_path):
    from trossen_arm_mujoco.train.workspace import Workspace

    ws = Workspace.open(tmp_path / "w")
    with ws.locked():
        run = _bench_without_lerobot(ws.root)
    assert run.returncode == 2 and "Traceback" not in run.stderr, run.stderr
    assert run.stderr == (
        f"error: --work_dir {ws.root} is in use by process {os.getpid()} (another "
        "trossen-mujoco train); wait for it to end, or choose another --work_dir\n"
    )
    after = _bench_without_lerobot(ws.root)  # released: it goes on to its first phase
    assert "run --phase record,export first" in after.stderr, after.stderr


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes in a read-only folder")
def test_a_read_only_work_folder_is_one_line(tmp_path):
    work = tmp_path / "w"
    work.mkdir()
    work.chmod(0o555)
    try:
        run = _bench_without_lerobot(work)
    finally:
        work.chmod(0o755)
    assert run.returncode == 2 and "Traceback" not in run.stderr, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: cannot write to --work_dir {work}")


def test_a_write_refused_midway_is_one_line(tmp_path, monkeypatch, capsys):
    """The folder turns read-only (or the disk fills up) while the command runs."""
    import errno

    from trossen_arm_mujoco.train import command
    from trossen_arm_mujoco.train.workspace import Workspace

    def refuse(self):
        raise OSError(errno.EROFS, "Read-only file system", str(self.summary_path))

    monkeypatch.setattr(Workspace, "save", refuse)
    monkeypatch.setenv("TROSSEN_LEROBOT_PYTHON", sys.executable)
    work = tmp_path / "w"
    assert command.cli(["--work_dir", str(work), "--phase", "train"]) == 2
    err = capsys.readouterr().err
    assert err == (
        f"error: cannot write {work / 'summary.json'}: Read-only file system (EROFS); the file "
        "system is read-only; choose another --work_dir\n"
    )


def _alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie waiting for its parent does not)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


@pytest.mark.parametrize(
    ("signum", "status", "name"),
    [(signal.SIGINT, 130, "Ctrl-C"), (signal.SIGTERM, 143, "SIGTERM")],
)
def test_a_signal_stops_the_run_and_its_children_in_one_line(tmp_path, signum, status, name):
    """A child (here a stand-in for LeRobot's Python that starts a worker and waits) and its
    worker end with the command, which says so in one line and how to resume."""
    pids = tmp_path / "pids"
    fake = tmp_path / "python"
    fake.write_text(f'#!/bin/sh\necho $$ >> "{pids}"\nsleep 300 &\necho $! >> "{pids}"\nwait\n')
    fake.chmod(0o755)
    work = tmp_path / "w"
    proc = subprocess.Popen(
        [*COMMAND, "--work_dir", str(work), "--phase", "record", "--episodes", "2"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "TROSSEN_LEROBOT_PYTHON": str(fake)},
    )
    deadline = time.monotonic() + 120
    while not (pids.exists() and len(pids.read_text().split()) == 2):
        assert time.monotonic() < deadline and proc.poll() is None, proc.communicate()
        time.sleep(0.1)
    proc.send_signal(signum)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == status, err
    assert err == (
        f"interrupted ({name}): stopped; rerun the same command to resume in {work.resolve()}\n"
    )
    for pid in map(int, pids.read_text().split()):
        deadline = time.monotonic() + 10
        while _alive(pid) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not _alive(pid), f"process {pid} outlived the command"


def _readme_train_commands() -> list[list[str]]:
    """The flags of each ``trossen-mujoco train`` command in the README's bash blocks."""
    text = (REPO / "README.md").read_text(encoding="utf-8")
    found = []
    for block in re.findall(r"```bash\n(.*?)```", text, re.S):
        for line in block.replace("\\\n", " ").splitlines():
            if line.startswith("trossen-mujoco train "):
                found.append(shlex.split(line, comments=True)[2:])
    return found


def test_the_readme_training_commands_run_as_written_and_reach_training(tmp_path):
    """Each README training command, as written, with a tiny episode count and run (and no
    TROSSEN_LEROBOT_PYTHON: it finds the venv tools/run_tests.sh builds), trains a
    checkpoint."""
    python = Path(_python())
    commands = _readme_train_commands()
    assert commands, "the README shows no trossen-mujoco train command"
    env = {k: v for k, v in os.environ.items() if k != "TROSSEN_LEROBOT_PYTHON"}
    if python.parent.name == "bin":
        env["TROSSEN_LEROBOT_VENV"] = str(python.parent.parent)
    else:
        env["TROSSEN_LEROBOT_PYTHON"] = str(python)
    entry = shutil.which("trossen-mujoco")
    for k, flags in enumerate(commands):
        where = tmp_path / f"readme_{k}"
        where.mkdir()
        run = subprocess.run(
            [*([entry, "train"] if entry else COMMAND), *flags]
            + ["--episodes", "2", "--train_seeds", "1", "--phase", "record,export,encode,train"]
            + TINY,
            capture_output=True,
            text=True,
            timeout=900,
            cwd=where,
            env=env,
        )
        assert run.returncode == 0, (flags, run.stdout + run.stderr)
        work = next(where.iterdir())  # the command's --work_dir, relative to where it ran
        assert (work / "train" / "seed_1000" / "checkpoints" / "last" / "pretrained_model").is_dir()
        assert "lerobot-train seed 1000:" in run.stdout and "cost: record" in run.stdout
