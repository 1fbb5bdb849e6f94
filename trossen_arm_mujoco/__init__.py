"""trossen_arm_mujoco: MuJoCo simulation, scripted data collection and sim-to-real replay for
Trossen AI arms (WidowX AI "wxai", Stationary AI kit)."""

import os as _os

# Headless rendering by default (EGL); set MUJOCO_GL yourself to choose another backend.
_os.environ.setdefault("MUJOCO_GL", "egl")

from trossen_arm_mujoco.gym.registration import register_envs as _register_envs  # noqa: E402

_register_envs()  # gymnasium ids "TrossenMujoco/..."; safe to run twice
