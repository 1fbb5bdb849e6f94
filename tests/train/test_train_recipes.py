"""``trossen-mujoco train``'s parts without LeRobot: the recipes and their flags (the task's
crop and static frames, the camera checks' limits), the reports (the spread, which runs pool),
the cost, the work folder's lock and where LeRobot's Python is found."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.train import report
from trossen_arm_mujoco.train.encoding import encode_job
from trossen_arm_mujoco.train.flags import parse_args
from trossen_arm_mujoco.train.recording import static_job
from trossen_arm_mujoco.train.workspace import Workspace


@pytest.mark.parametrize(
    ("flags", "crop"),
    [
        (["--recipe", "camera_pose"], "cam_high:217,243,150,200"),
        (["--recipe", "camera_pose", "--task", "sim_insertion"], "cam_high:170,211,180,240"),
        (["--recipe", "camera", "--task", "insertion"], "cam_high:170,211,180,240"),
        (
            ["--recipe", "camera_pose", "--task", "sim_insertion", "--crop", "cam_high:0,0,48,64"],
            "cam_high:0,0,48,64",
        ),
        (["--task", "sim_insertion"], None),
    ],
)
def test_the_cropped_recipes_take_their_tasks_crop(flags, crop):
    assert parse_args(flags).crop == crop


@pytest.mark.parametrize(
    ("flags", "static"),
    [
        (["--recipe", "camera_pose", "--task", "sim_insertion"], 1000),
        (["--recipe", "camera_pose"], 0),
        (["--recipe", "camera_pose", "--task", "insertion", "--static_frames", "5"], 5),
        (["--task", "sim_insertion"], 0),
    ],
)
def test_the_pose_recipe_takes_its_tasks_static_frames(flags, static):
    assert parse_args(flags).static_frames == static


def test_the_pose_encoder_takes_images_resnet_could_not():
    args = parse_args(["--recipe", "camera_pose", "--image_size", "24x32"])
    assert args.image_size == "24x32" and args.pose_encoder


def test_each_task_crop_holds_its_objects_spawn_region():
    """The tasks' ``TaskEntry.camera_crop`` contain the projection into cam_high of each
    task's object spawn region (and, for the insertion, the lift to where they meet)."""
    import mujoco
    import numpy as np

    from trossen_arm_mujoco.assets import asset_path
    from trossen_arm_mujoco.tasks import insertion, transfer_cube
    from trossen_arm_mujoco.tasks.registry import load

    crops = {
        name: load(name).camera_crop
        for name in ("sim_transfer_cube", "transfer_cube", "sim_insertion", "insertion")
    }
    scenes = {
        "sim_transfer_cube": "trossen_ai_scene_joint.xml",
        "sim_insertion": "trossen_ai_insertion_scene_joint.xml",
    }
    corners = {
        "sim_transfer_cube": [
            (x, y, z)
            for x in transfer_cube.BOX_X_RANGE
            for y in transfer_cube.BOX_Y_RANGE
            for z in (0.02, 0.05)
        ],
        "sim_insertion": [
            (x, y, z)
            for x in insertion.PEG_X_RANGE
            for y in (
                insertion.PEG_Y_RANGE[0] - insertion.PEG_HALF[1],
                insertion.SOCKET_Y_RANGE[1] + insertion.SOCKET_HALF_LENGTH,
            )
            for z in (0.02, 0.25)
        ],
    }
    for task, points in corners.items():
        model = mujoco.MjModel.from_xml_path(str(asset_path(f"stationary_ai/{scenes[task]}")))
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        cam = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "cam_high")
        focal = 240 / np.tan(np.deg2rad(model.cam_fovy[cam]) / 2)  # pixels, 480-row frame
        top, left, height, width = (int(v) for v in crops[task].split(":")[1].split(","))
        for point in points:
            rel = data.cam_xmat[cam].reshape(3, 3).T @ (np.array(point) - data.cam_xpos[cam])
            row, col = 240 - focal * rel[1] / -rel[2], 320 + focal * rel[0] / -rel[2]
            assert top <= row <= top + height and left <= col <= left + width, (task, point)
    assert crops["transfer_cube"] == crops["sim_transfer_cube"]
    assert crops["insertion"] == crops["sim_insertion"]


def test_the_spread_over_every_run_pools_only_runs_trained_and_scored_alike(tmp_path, capsys):
    flags = {
        "work_dir": "w",
        "phase": "train",
        "train_seed": 5,
        "train_jobs": 2,
        "steps": 7000,
        "lr": 1e-4,
        "eval_episodes": 50,
        "controller_checks": "on",
    }
    made = report.recipe_flags(flags)
    assert made == {"steps": 7000, "lr": 1e-4}  # where, which seeds, how fast, how scored: out
    info = {
        "aggregated": {"pc_success": 80.0},
        "run": {
            "task": "t",
            "num_episodes": 50,
            "seed": 0,
            "episode_length": None,
            "policy": "p",
            "num_workers": 2,
        },
    }
    (tmp_path / "eval_info.json").write_text(json.dumps(info))
    scored = report.results(tmp_path / "eval_info.json")["scored_on"]
    assert scored == {"task": "t", "num_episodes": 50, "seed": 0, "episode_length": None}

    def run(pc: float, **other) -> dict:
        result = {"pc_success": pc, "pc_success_ci95": [0.0, 100.0], "n_episodes": 50, "stages": {}}
        return {"result": result, "trained_with": {**made, **other}, "scored_on": scored}

    runs = {
        "5": run(80.0),
        "6": run(90.0),
        "7": run(70.0, steps=2000),  # another recipe
        "8": {**run(60.0), "scored_on": {**scored, "seed": 1}},  # other episodes
        "10": {**run(40.0), "scored_on": {**scored, "randomize": True, "randomization": None}},
        "9": {"train": {"cpu_s": 1.0}, "trained_with": made},  # trained, not scored
        "4": {k: v for k, v in run(50.0).items() if k != "trained_with"},  # an older summary
    }
    assert set(report.alike(runs, ["6"])) == {"5", "6"}
    assert set(report.alike(runs, ["6", "9"])) == {"5", "6"}
    assert set(report.alike(runs, ["8"])) == {"8"}
    assert set(report.alike(runs, ["10"])) == {"10"}  # scored on randomized scenes
    assert report.alike(runs, ["6", "7"]) == {}  # this call's runs differ among themselves
    assert report.alike(runs, ["4"]) == {} and report.alike(runs, ["9"]) == {}
    spread = report.report(report.alike(runs, ["6"]), "every alike run", each=False)
    assert spread["runs"] == 2 and spread["mean_pc_success"] == 85.0
    assert spread["worst_pc_success"] == 80.0
    out = capsys.readouterr().out
    assert out.startswith("over 2 training runs (every alike run): mean 85.0%, worst 80.0%")
    assert "training seed" not in out


def test_the_robust_recipe_records_randomized_scenes_and_augments_the_encoder():
    args = parse_args(["--recipe", "camera_pose_robust"])
    assert args.randomize is True and args.augment and args.pose_encoder
    assert args.crop == "cam_high:217,243,150,200" and args.eval_randomize == "nominal"
    static = static_job(["trossen-mujoco"], args, Workspace(Path("w")))
    assert "--randomize" in static and static[static.index("--randomize") + 1].startswith("--")
    job = encode_job("py", Workspace(Path("w")), 2, 0, static=False, augment=True)
    assert job[-1] == "--augment"


def test_the_camera_check_lists_the_kits_cameras():
    from trossen_arm_mujoco.assets import STATIONARY_CAMERAS
    from trossen_arm_mujoco.train.recipes import camera_settings_error

    problem = camera_settings_error("cam_top", "60x80", None)
    assert problem is not None and ", ".join(STATIONARY_CAMERAS) in problem


def test_lerobot_python_is_this_one_when_it_imports_lerobot(monkeypatch):
    from trossen_arm_mujoco.train import lerobot_python as finder

    monkeypatch.setattr(finder, "_has_lerobot", lambda: True)
    assert finder.lerobot_python({"TROSSEN_LEROBOT_PYTHON": "/elsewhere"}) == sys.executable


def test_lerobot_python_then_the_variable_then_the_venv(monkeypatch, tmp_path):
    from trossen_arm_mujoco.train import lerobot_python as finder

    monkeypatch.setattr(finder, "_has_lerobot", lambda: False)
    given = tmp_path / "py312"
    given.write_text("")
    venv = tmp_path / "venv"
    (venv / "bin").mkdir(parents=True)
    (venv / "bin" / "python").write_text("")
    both = {"TROSSEN_LEROBOT_PYTHON": str(given), "TROSSEN_LEROBOT_VENV": str(venv)}
    assert finder.lerobot_python(both) == str(given)
    assert finder.lerobot_python({"TROSSEN_LEROBOT_VENV": str(venv)}) == str(
        venv / "bin" / "python"
    )
    with pytest.raises(UserError, match="is not a file; point it at a Python >= 3.12"):
        finder.lerobot_python({"TROSSEN_LEROBOT_PYTHON": str(tmp_path / "missing")})


def test_without_lerobot_anywhere_one_line_says_how_to_make_one(monkeypatch, tmp_path):
    from trossen_arm_mujoco.train import lerobot_python as finder

    monkeypatch.setattr(finder, "_has_lerobot", lambda: False)
    with pytest.raises(UserError) as exc:
        finder.lerobot_python({"TROSSEN_LEROBOT_VENV": str(tmp_path / "none")})
    line = str(exc.value)
    assert "\n" not in line and line.startswith("train needs LeRobot 0.6.1 on Python >= 3.12")
    assert f"bash tools/run_tests.sh builds one at {tmp_path / 'none'}" in line
    assert "TROSSEN_LEROBOT_PYTHON" in line


def test_the_cost_sums_each_part_of_the_loop(capsys):
    summary = {
        "record": {"wall_s": 10.0, "cpu_s": 15.0},
        "record_static": {"wall_s": 1.0, "cpu_s": 1.0},
        "export": {"wall_s": 2.0, "cpu_s": 3.0},
        "runs": {
            "5": {"train": {"wall_s": 100.0, "cpu_s": 180.0}, "eval": {"wall_s": 5, "cpu_s": 8}},
            "6": {
                "train": {"wall_s": 90.0, "cpu_s": 170.0},
                "wire_eval": {"wall_s": 7, "cpu_s": 1},
            },
            "7": {"train": {"wall_s": 1000.0, "cpu_s": 1000.0}},  # another call's run
        },
    }
    parts = report.cost(summary, ["5", "6"])
    assert parts == {
        "record": {"wall_s": 13.0, "cpu_s": 19.0},
        "train": {"wall_s": 190.0, "cpu_s": 350.0},
        "evaluate": {"wall_s": 12.0, "cpu_s": 9.0},
    }
    report.print_cost(parts)
    assert capsys.readouterr().out == (
        "cost: record 13 s wall, 19 s CPU; encode not measured here; train 190 s wall, "
        "350 s CPU; evaluate 12 s wall, 9 s CPU\n"
    )


def test_the_lock_names_the_process_holding_it(tmp_path):
    import subprocess

    ws = Workspace.open(tmp_path / "w")
    with ws.locked():
        assert ws.lock_path.read_text() == f"{os.getpid()}\n"
        other = subprocess.run(
            [
                sys.executable,
                "-c",
                "import sys; from trossen_arm_mujoco.train.workspace import Workspace\n"
                "try:\n"
                "    with Workspace.open(sys.argv[1]).locked(): print('locked')\n"
                "except Exception as e: print(e)",
                str(ws.root),
            ],
            capture_output=True,
            text=True,
            timeout=120,
        )
    assert other.stdout.strip() == (
        f"--work_dir {ws.root} is in use by process {os.getpid()} (another trossen-mujoco "
        "train); wait for it to end, or choose another --work_dir"
    )
    with ws.locked():  # released at the end of the block
        pass


def test_the_summary_is_written_whole(tmp_path):
    ws = Workspace.open(tmp_path / "w")
    ws.load_summary()
    ws.runs["5"] = {"train": {"wall_s": 1.0}}
    ws.save()
    assert json.loads(ws.summary_path.read_text()) == {"runs": {"5": {"train": {"wall_s": 1.0}}}}
    assert [p.name for p in ws.root.iterdir()] == ["summary.json"]  # no temporary left
