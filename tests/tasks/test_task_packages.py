"""Tasks from installed packages (entry-point group ``trossen_arm_mujoco.tasks``).

A throwaway package built in a temp folder (a kit task with a scene object of its own, a
scripted policy, a gym id and an entry point) is pip-installed into this Python, recorded,
evaluated and ``gym.make``d by name, then uninstalled. Packages that cannot be used (an entry
point that fails to import, two packages giving one name, a task missing a required fact)
are left out, and using them by name is one line naming the package; they are put on the
path as bare distributions (a ``.dist-info`` folder with ``entry_points.txt``: what an
installed package is to ``importlib.metadata``), which costs no pip run.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from trossen_arm_mujoco.tasks import registry

PACKAGE = "tmp-trossen-task"
MODULE = "tmp_trossen_task"

TASK_MODULE = '''
"""A throwaway kit task: keep a yellow ball on the table (reward 1 while it touches it)."""
import numpy as np

from trossen_arm_mujoco.names import lookup_id
from trossen_arm_mujoco.policies.scripted import BimanualWaypointPolicy, waypoint
from trossen_arm_mujoco.sim.contacts import ContactPartners
from trossen_arm_mujoco.tasks.bimanual import BimanualSampler, BimanualTask
from trossen_arm_mujoco.tasks.task_entry import TaskEntry, record_defaults

BALL = """<body name="ball" pos="0 -0.1 0.04"><freejoint name="ball_joint"/>
<geom name="ball" type="sphere" size="0.02" mass="0.02" rgba="0.9 0.8 0.1 1"/></body>"""


class TouchBall(BimanualTask):
    name = "tmp_touch_ball"
    objects = ("ball",)
    max_reward = 1.0

    def __init__(self, scene, config):
        super().__init__(scene, config)
        self.partners = ContactPartners(scene.model, [lookup_id(scene.model, "geom", "ball")])
        self.table = lookup_id(scene.model, "geom", "table")

    def get_reward(self):
        return int(self.table in self.partners(self.data))

    def get_task_description(self):
        return "keep the yellow ball on the table"


class TouchBallSampler(BimanualSampler):
    task_cls = TouchBall
    scene_objects = (BALL,)
    removed_objects = ("box",)

    def objects(self):
        return {"ball": ("ball_joint", "ball")}

    def _sample_task(self, scene):
        pose = np.array([self.rng.uniform(-0.05, 0.05), -0.1, 0.04, 1.0, 0.0, 0.0, 0.0])
        scene.objects["ball"].set_pose(scene.data, pose)
        return self.task_cls(scene, self.config)


class HoldPolicy(BimanualWaypointPolicy):
    def plan(self, obs):
        l, r = obs["mocap_pose_left"], obs["mocap_pose_right"]
        return ([waypoint(0, l[:3], l[3:], 0.044), waypoint(1000, l[:3], l[3:], 0.044)],
                [waypoint(0, r[:3], r[3:], 0.044), waypoint(1000, r[:3], r[3:], 0.044)])


CONFIG = {
    "scene": "stationary_ai/trossen_ai_scene_joint.xml",
    "ee_scene": "stationary_ai/trossen_ai_scene.xml",
    "policy_dt": 0.02, "ctrl_dt": 0.02, "sim_dt": 0.002, "max_episode_steps": 20,
    "ee_delta_limit": 0.03, "joint_rel_limit": 0.1, "table_height": 0.02,
    "safety_margin": 0.01, "workspace_low": [-0.8, -0.8, -0.1],
    "workspace_high": [0.8, 0.8, 0.9], "max_joint_velocity": 20.0,
    "max_object_velocity": 5.0,
}

TASK = TaskEntry("tmp_touch_ball", TouchBall, TouchBallSampler, CONFIG,
                 "keep a ball on the table", policy=HoldPolicy, record=record_defaults(20),
                 stages={"resting": 1.0}, gym_ids={"TmpTrossen/TouchBall-v0": "env"})
'''


def _run(*args: str, cwd: Path, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, *args], capture_output=True, text=True, timeout=300, cwd=cwd, env=env
    )


def _pip(*args: str, cwd: Path) -> None:
    proc = _run("-m", "pip", "-q", "--disable-pip-version-check", *args, cwd=cwd)
    assert proc.returncode == 0, proc.stdout + proc.stderr


@pytest.fixture
def installed_package(tmp_path_factory):
    """The throwaway package, pip-installed (editable, no dependencies) for one test."""
    root = tmp_path_factory.mktemp("pkg")
    (root / MODULE).mkdir()
    (root / MODULE / "__init__.py").write_text(TASK_MODULE)
    (root / "pyproject.toml").write_text(
        textwrap.dedent(f"""\
        [build-system]
        requires = ["setuptools>=64"]
        build-backend = "setuptools.build_meta"

        [project]
        name = "{PACKAGE}"
        version = "0.0.1"

        [project.entry-points."trossen_arm_mujoco.tasks"]
        tmp_touch_ball = "{MODULE}:TASK"
        """)
    )
    _pip("install", "--no-deps", "--no-build-isolation", "-e", str(root), cwd=root)
    try:
        yield root
    finally:
        _pip("uninstall", "-y", PACKAGE, cwd=root)


@pytest.mark.once
def test_an_installed_package_task_records_evaluates_and_makes_its_gym_env(
    installed_package, tmp_path
):
    cli = ("-m", "trossen_arm_mujoco.cli")
    proc = _run(
        *cli,
        "record",
        "--task_name",
        "tmp_touch_ball",
        "--data_dir",
        "eps",
        "--root_dir",
        str(tmp_path),
        "--num_episodes",
        "2",
        "--cam_names",
        "none",
        cwd=tmp_path,
    )
    assert proc.returncode == 0 and "Success: 2 / 2" in proc.stdout, proc.stdout + proc.stderr
    assert sorted(p.name for p in (tmp_path / "eps").glob("*.hdf5")) == [
        "episode_0.hdf5",
        "episode_1.hdf5",
    ]
    proc = _run(
        *cli,
        "eval",
        "--policy",
        "scripted",
        "--task_name",
        "tmp_touch_ball",
        "--num_episodes",
        "2",
        "--cam_names",
        "none",
        "--output_dir",
        str(tmp_path / "ev"),
        cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    info = json.loads((tmp_path / "ev" / "eval_info.json").read_text())
    assert info["aggregated"]["n_episodes"] == 2
    assert info["aggregated"]["stages"] == {"resting": 100.0}  # the package's own stages
    code = (
        "import gymnasium as gym, numpy as np, trossen_arm_mujoco\n"
        "env = gym.make('TmpTrossen/TouchBall-v0')\n"
        "obs, _ = env.reset(seed=0)\n"
        "obs, reward, *_ = env.step(env.action_space.sample())\n"
        "assert np.all(np.isfinite(obs)) and env.spec.max_episode_steps == 20\n"
        "print('gym ok', obs.shape)\n"
    )
    proc = _run("-c", code, cwd=tmp_path)
    assert proc.returncode == 0 and "gym ok" in proc.stdout, proc.stdout + proc.stderr
    # an unknown name lists the installed tasks, the package's among them
    proc = _run(
        *cli,
        "record",
        "--task_name",
        "no_such_task",
        "--data_dir",
        "x",
        "--root_dir",
        str(tmp_path),
        cwd=tmp_path,
    )
    assert proc.returncode != 0 and "Traceback" not in proc.stderr
    assert proc.stderr.count("\n") == 1 and "tmp_touch_ball" in proc.stderr, proc.stderr


# -- packages that cannot be used ----------------------------------------------------------
def _bare_package(root: Path, dist: str, module: str, source: str, entry: str) -> None:
    """A distribution ``dist`` on the path at ``root``: ``module.py`` and a ``.dist-info``
    whose ``entry_points.txt`` registers ``entry`` (``name = module:attr``)."""
    info = root / f"{dist.replace('-', '_')}-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[{registry.ENTRY_POINT_GROUP}]\n{entry}\n")
    (root / f"{module}.py").write_text(source)


GOOD = (
    "from trossen_arm_mujoco.tasks.task_entry import TaskEntry\n"
    "TASK = TaskEntry('{name}', 'trossen_arm_mujoco.tasks.reach:ReachTask',\n"
    "                 'trossen_arm_mujoco.tasks.reach:ReachSampler', 'reach')\n"
)


def test_packages_that_cannot_be_used_are_left_out_each_with_one_line(tmp_path, monkeypatch):
    _bare_package(
        tmp_path,
        "bad-import-pkg",
        "bad_import_mod",
        "import no_such_module_here\n",
        "bad_task = bad_import_mod:TASK",
    )
    _bare_package(
        tmp_path,
        "dup-one-pkg",
        "dup_one_mod",
        GOOD.format(name="dup_task"),
        "dup_task = dup_one_mod:TASK",
    )
    _bare_package(
        tmp_path,
        "dup-two-pkg",
        "dup_two_mod",
        GOOD.format(name="dup_task"),
        "dup_task = dup_two_mod:TASK",
    )
    _bare_package(
        tmp_path,
        "no-sampler-pkg",
        "no_sampler_mod",
        "from trossen_arm_mujoco.tasks.task_entry import TaskEntry\n"
        "TASK = TaskEntry('half_task', 'trossen_arm_mujoco.tasks.reach:ReachTask',"
        " None, 'reach')\n",
        "half_task = no_sampler_mod:TASK",
    )
    _bare_package(
        tmp_path, "shadow-pkg", "shadow_mod", GOOD.format(name="reach"), "reach = shadow_mod:TASK"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    entries, problems = registry._gather()
    names = {e.name for e in entries}
    assert not {"bad_task", "dup_task", "half_task", "reach"} & names
    assert {"sim_transfer_cube", "push"} <= names  # the rest still works
    expected = {
        "bad_task": ("bad-import-pkg", "fails to import", "ModuleNotFoundError"),
        "dup_task": ("dup-one-pkg", "dup-two-pkg", "registered by 2"),
        "half_task": ("no-sampler-pkg", "no sampler"),
        "reach": ("shadow-pkg", "trossen_arm_mujoco", "pip uninstall shadow-pkg"),
    }
    for name, parts in expected.items():
        line = problems[name]
        assert "\n" not in line and all(p in line for p in parts), line


def test_using_a_broken_package_task_by_name_is_one_line_naming_it(tmp_path):
    _bare_package(
        tmp_path,
        "bad-import-pkg",
        "bad_import_mod",
        "raise RuntimeError('boom')\n",
        "bad_task = bad_import_mod:TASK",
    )
    env = {**__import__("os").environ, "PYTHONPATH": str(tmp_path)}
    proc = _run(
        "-m",
        "trossen_arm_mujoco.cli",
        "record",
        "--task_name",
        "bad_task",
        "--data_dir",
        "x",
        "--root_dir",
        str(tmp_path),
        cwd=tmp_path,
        env=env,
    )
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr and proc.stderr.count("\n") == 1, proc.stderr
    assert "bad-import-pkg" in proc.stderr and "RuntimeError: boom" in proc.stderr
    # the shipped tasks are still there
    proc = _run(
        "-c",
        "from trossen_arm_mujoco.tasks import registry; print(registry.names())",
        cwd=tmp_path,
        env=env,
    )
    assert proc.returncode == 0 and "sim_transfer_cube" in proc.stdout, proc.stderr


def test_the_camera_facts_of_a_declaration_are_checked():
    from trossen_arm_mujoco.tasks.task_entry import TaskEntry

    def entry(**facts):
        reach = "trossen_arm_mujoco.tasks.reach"
        return TaskEntry(
            "crop_task", f"{reach}:ReachTask", f"{reach}:ReachSampler", "reach", **facts
        )

    assert entry(camera_crop="cam_high:170,211,180,240", pose_static_frames=10).problems() == []
    (bad_crop,) = entry(camera_crop="cam_high:1,2").problems()
    assert bad_crop.startswith("camera_crop: --crop must look like")
    (bad_frames,) = entry(pose_static_frames=-1).problems()
    assert "pose_static_frames must be an int >= 0" in bad_frames
