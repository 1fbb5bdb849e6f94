"""No GL until an image is asked for (ARCHITECTURE principle 10), checked in fresh processes.

A GL context, or even an initialized EGL display, loads the GL driver (Mesa: swrast_dri and
its libLLVM), after which loading triton's LLVM (torch.compile, SB3's optimizer) segfaults.
So importing the package, making and stepping state-only envs, ``Scene`` without
renders, and the real replay must load no driver and import nothing that does.

What "GL-free" means here, in each scenario's own process:

- no ``dm_control.mujoco`` / ``dm_control._render`` in ``sys.modules``;
- no ``mujoco.Renderer`` created and no EGL display initialized (``mujoco.egl.EGL_DISPLAY``);
- no GL driver in ``/proc/self/maps`` (``*_dri.so``, libLLVM, libgallium, NVIDIA GL cores);
- no GL library beyond those a bare ``import mujoco`` maps for the same ``MUJOCO_GL``:
  with ``MUJOCO_GL=egl`` mujoco's own ``__init__`` imports PyOpenGL's EGL bindings, which map
  the libEGL/libOpenGL dispatch stubs without initializing anything.
"""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
TIMEOUT = 120

#: Prepended to every scenario: GL probes that print nothing.
PROBE = r"""
import json, os, sys

GL_LIBS = ("libEGL", "libGL", "libOpenGL", "libgbm")
DRIVERS = ("_dri.so", "libLLVM", "libgallium", "libnvidia-glcore", "libnvidia-eglcore")

def mapped(keys):
    out = set()
    with open("/proc/self/maps") as f:
        for line in f:
            name = line.split()[-1].rsplit("/", 1)[-1]
            if any(k in name for k in keys):
                out.add(name)
    return sorted(out)

renderers = []
def count_renderers():
    import mujoco
    init = mujoco.Renderer.__init__
    def counting(self, *a, **k):
        renderers.append(1)
        return init(self, *a, **k)
    mujoco.Renderer.__init__ = counting

def gl_problems(allowed, dm_control_ok=False):
    problems = []
    modules = ("mujoco.viewer",) if dm_control_ok else (
        "dm_control.mujoco", "dm_control._render", "mujoco.viewer")
    for mod in modules:
        if mod in sys.modules:
            problems.append(f"imported {mod}")
    egl = sys.modules.get("mujoco.egl")
    if egl is not None and egl.EGL_DISPLAY is not None:
        problems.append("initialized an EGL display")
    if renderers:
        problems.append(f"created {len(renderers)} mujoco.Renderer")
    drivers = mapped(DRIVERS)
    if drivers:
        problems.append(f"loaded GL drivers {drivers}")
    extra = sorted(set(mapped(GL_LIBS)) - set(allowed))
    if extra:
        problems.append(f"loaded GL libraries {extra} beyond a bare `import mujoco`")
    return problems

def report(**kw):
    print("RESULT " + json.dumps(kw), flush=True)
"""


def run_script(body: str, *args: str, timeout: float = TIMEOUT, **env_extra) -> dict:
    """Run ``PROBE + body`` in a fresh interpreter (repo root, MUJOCO_GL=egl); the dict it
    reported with ``report(...)``."""
    env = {**os.environ, "MUJOCO_GL": "egl", "PYTHONPATH": str(ROOT), **env_extra}
    env.pop("PYOPENGL_PLATFORM", None)
    code = PROBE + textwrap.dedent(body)
    proc = subprocess.run(
        [sys.executable, "-c", code, *args],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")]
    assert proc.returncode == 0 and lines, (
        f"exit {proc.returncode}\nstdout:\n{proc.stdout[-3000:]}\nstderr:\n{proc.stderr[-3000:]}"
    )
    return json.loads(lines[-1][len("RESULT ") :])


@pytest.fixture(scope="module")
def baseline() -> list[str]:
    """GL libraries a bare ``import mujoco`` maps with MUJOCO_GL=egl."""
    out = run_script(
        """
        import mujoco
        report(libs=mapped(GL_LIBS), problems=gl_problems(mapped(GL_LIBS)))
        """
    )
    assert out["problems"] == []  # the probe itself sees nothing wrong with bare mujoco
    return out["libs"]


def test_import_and_state_envs_open_no_gl(baseline):
    out = run_script(
        """
        import trossen_arm_mujoco
        import gymnasium as gym
        allowed = json.loads(sys.argv[1])
        after_import = gl_problems(allowed)
        count_renderers()
        from trossen_arm_mujoco.gym.registration import ENV_IDS
        import numpy as np

        stepped = []
        for env_id in ENV_IDS:
            modes = ["joint_position", "ee_delta"] if "Goal" not in env_id else [None]
            for mode in modes:
                kw = {} if mode is None else {"action_mode": mode}
                env = gym.make(env_id, **kw)
                env.reset(seed=0)
                for _ in range(3):
                    env.step(env.action_space.sample())
                env.close()
                stepped.append(env_id)

        from trossen_arm_mujoco.assets import ASSETS_DIR
        from trossen_arm_mujoco.robot.configs import wxai_config
        from trossen_arm_mujoco.sim.scene import Scene
        scene = Scene(os.path.join(ASSETS_DIR, "wxai/scene_reach.xml"),
                      robots={"wxai": wxai_config()}, ctrl_dt=0.02,
                      camera_names=["overview"])  # cameras, but no image asked for
        scene.reset()
        scene.step(5)
        scene.close()
        report(after_import=after_import, after_envs=gl_problems(allowed),
               stepped=len(stepped), physics=scene.physics is None)
        """,
        json.dumps(baseline),
    )
    assert out["after_import"] == []
    assert out["after_envs"] == []
    assert out["stepped"] >= 7
    assert out["physics"]  # a plain MjModel/MjData, no dm_control Physics


def test_real_replay_modules_open_no_gl(baseline):
    out = run_script(
        """
        import trossen_arm_mujoco.real.replay
        import trossen_arm_mujoco.real.sim_driver
        report(problems=gl_problems(json.loads(sys.argv[1])))
        """,
        json.dumps(baseline),
    )
    assert out["problems"] == []


def test_state_only_dm_control_envs_open_no_gl_until_an_image(baseline):
    """The dm_control front doors without cameras (state-only recording) load no GL driver:
    dm_control opens its display at its first rendering context, not at import; images still
    work afterwards, through the package's cameras and through ``physics.render``."""
    out = run_script(
        """
        import numpy as np
        import trossen_arm_mujoco
        from trossen_arm_mujoco.ee_sim_env import TransferCubeEETask
        from trossen_arm_mujoco.sim_env import TransferCubeTask
        from trossen_arm_mujoco.utils import make_sim_env

        allowed = json.loads(sys.argv[1])
        count_renderers()
        ee = make_sim_env(TransferCubeEETask, cam_list=[])
        ts = ee.reset()
        for _ in range(5):
            obs = ts.observation
            ts = ee.step(np.concatenate([obs["mocap_pose_left"], [0.04],
                                         obs["mocap_pose_right"], [0.04]]))
        joint = make_sim_env(TransferCubeTask, cam_list=[])
        ts = joint.reset()
        for _ in range(5):
            ts = joint.step(ts.observation["qpos"])
        state_only = gl_problems(allowed, dm_control_ok=True)
        frame = joint.physics.render(height=24, width=32, camera_id="cam_high")
        cams = make_sim_env(TransferCubeTask, cam_list=["cam_high"], image_size=(24, 32))
        image = cams.reset().observation["images"]["cam_high"]
        report(state_only=state_only, frame=list(frame.shape), image=list(image.shape),
               drawn=bool(frame.std() > 0 and image.std() > 0))
        """,
        json.dumps(baseline),
    )
    assert out["state_only"] == []
    assert out["frame"] == [24, 32, 3] and out["image"] == [24, 32, 3] and out["drawn"]


@pytest.mark.skipif(
    importlib.util.find_spec("stable_baselines3") is None, reason="needs the rl extra"
)
def test_sb3_ppo_after_import_needs_no_import_order_workaround(baseline):
    """The documented RL path, in the plain order: package, env, then SB3 (torch, and
    torch._dynamo/triton when PPO builds its optimizer). It used to segfault here."""
    out = run_script(
        """
        import trossen_arm_mujoco
        import gymnasium as gym
        env = gym.make("TrossenMujoco/WXAIReach-v0")
        goal_env = gym.make("TrossenMujoco/WXAIReachGoal-v0", action_mode="ee_delta")
        problems = gl_problems(json.loads(sys.argv[1]))
        from stable_baselines3 import PPO
        PPO("MlpPolicy", env, n_steps=64, batch_size=32, seed=0).learn(64)
        PPO("MultiInputPolicy", goal_env, n_steps=64, batch_size=32, seed=0).learn(64)
        import torch._dynamo  # what used to crash (triton's LLVM after Mesa's)
        report(problems=problems)
        """,
        json.dumps(baseline),
    )
    assert out["problems"] == []


#: A process that renders, then runs a vector env of state envs.
VECTOR_AFTER_RENDER = """
import functools
import gymnasium as gym
import numpy as np
import trossen_arm_mujoco

REACH = "trossen_arm_mujoco:TrossenMujoco/WXAIReach-v0"

def main(context):
    viewer = gym.make(REACH, render_mode="rgb_array", width=32, height=24)
    viewer.reset(seed=0)
    frame = viewer.render()
    venv = gym.vector.AsyncVectorEnv([functools.partial(gym.make, REACH)] * 2, context=context)
    obs, _ = venv.reset(seed=0)
    for _ in range(3):
        obs, *_ = venv.step(venv.action_space.sample())
    venv.close()
    viewer.close()
    report(frame=list(frame.shape), obs=list(obs.shape), finite=bool(np.isfinite(obs).all()))

if __name__ == "__main__":
    main(sys.argv[1])
"""


def test_async_vector_env_after_rendering_with_spawn():
    """The recommended start method: fresh children, whatever the parent has rendered."""
    out = run_script(VECTOR_AFTER_RENDER, "spawn")
    assert out == {"frame": [24, 32, 3], "obs": [2, 22], "finite": True}


def test_forked_child_of_a_rendering_process_fails_fast_instead_of_hanging():
    """Rendering in a forked child of a process with a GL context would hang: making an
    image env there fails at once with a one-line error naming the fix; state envs work."""
    out = run_script(
        """
        import multiprocessing as mp
        import gymnasium as gym
        import trossen_arm_mujoco

        REACH = "TrossenMujoco/WXAIReach-v0"

        def child(queue):
            try:
                env = gym.make(REACH)  # state only: fine
                env.reset(seed=0)
                env.step(env.action_space.sample())
                env.close()
                gym.make(REACH, obs_type="pixels", width=32, height=24)
                queue.put("no error")
            except Exception as exc:
                queue.put(f"{type(exc).__name__}: {exc}")

        if __name__ == "__main__":
            viewer = gym.make(REACH, render_mode="rgb_array", width=32, height=24)
            viewer.reset(seed=0)
            viewer.render()
            ctx = mp.get_context("fork")
            queue = ctx.Queue()
            proc = ctx.Process(target=child, args=(queue,))
            proc.start()
            message = queue.get(timeout=60)
            proc.join(timeout=30)
            viewer.close()
            report(message=message, exitcode=proc.exitcode)
        """
    )
    assert out["exitcode"] == 0
    assert out["message"].startswith("UserError: cannot render in a process forked")
    assert 'context="spawn"' in out["message"] and "\n" not in out["message"]
