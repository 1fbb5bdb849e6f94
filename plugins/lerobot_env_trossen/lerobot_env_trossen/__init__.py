"""LeRobot env plugin for trossen_arm_mujoco: ``--env.type=trossen``.

Installed next to LeRobot (``pip install -e plugins/lerobot_env_trossen``), it is imported by
LeRobot's own scripts (``lerobot-eval``, ``lerobot-train``) and registers ``TrossenEnvConfig``::

    lerobot-eval --policy.path=outputs/train/act/checkpoints/last/pretrained_model \\
        --env.type=trossen --env.task=sim_transfer_cube --env.cam_names=none \\
        --eval.n_episodes=50 --eval.batch_size=2 --seed=1000

Options: ``--env.task`` (a Stationary AI kit task, ``tasks.registry.kit_names()``: the shipped
``sim_transfer_cube``, ``sim_insertion`` and those of installed task packages; or a single
WidowX AI arm's, ``push``, ``pick_place``, ``reach``: below),
``--env.cam_names`` (comma list or ``none``; default the four kit cameras), ``--env.image_size``
(``HxW``, like ``record``), ``--env.fps`` (policy rate; 30 for a dataset exported with
``--fps 30``), ``--env.episode_length`` (steps; default the task's recording length at that
rate), ``--env.layout`` (``kit14``, the real kit's 14 values, or ``vendor16``), ``--env.crop``
(``CAMERA:TOP,LEFT,HEIGHT,WIDTH``, ``;`` between cameras: the rectangle of the 480x640 frame a
dataset recorded with ``record --crop`` shows; default none), ``--env.controller_checks``
(default true: every action reaches the arms as on the real kit, the driver's trajectory over
3/fps s, and the arm controller's checks apply: a fault ends the episode as failed; false:
the unconstrained score), ``--env.randomize`` (``nominal``, the default; ``train`` or
``true``: each episode's scene randomized as the task's ``randomization`` section says, from
the episode's seed; ``hard``: every range widened past training's,
``tasks.randomization_levels``), ``--env.randomization`` (a YAML file of kinds and ranges
replacing the task's).

Importing the plugin also registers this project's processor steps
(``trossen_arm_mujoco.eval.steps``: the image step, the pose encoder, the arm controller's
limits; ``trossen-mujoco prepare`` puts them in a checkpoint), so a prepared checkpoint
loads in every LeRobot tool (``lerobot-rollout`` on the real kit too).

With ``--policy.path`` a local checkpoint, every option above but ``episode_length`` and
``controller_checks`` defaults to what the checkpoint was trained with (the settings its
dataset carries, ``trossen_arm_mujoco.export.dataset_settings``); an option that contradicts
them is refused, one that repeats them is accepted.

Observations and actions carry exactly the feature names and shapes ``trossen-mujoco export``
writes (``observation.state``, ``observation.images.<cam>``, ``action``, and with
``--sim_features`` ``observation.velocity`` and ``observation.environment_state``; datasets
exported before that flag always had them), so a policy trained on an export runs with no
``--rename_map``. The env itself is ``trossen_arm_mujoco.eval.env.KitPolicyEnv``; vector envs
are built from it directly (picklable, so ``--eval.use_async_envs=true`` works with any start
method).

A single arm's task (``--env.task=pick_place``, ``push``, ``reach``) steps the single WidowX AI
arm (``trossen_arm_mujoco.eval.arm_env.ArmPolicyEnv``) in its 7-value layout ``widowxai``
(``observation.state`` and ``action``: ``joint_0`` .. ``joint_5`` rad, then the gripper's
``left_carriage_joint`` travel m; ``observation.environment_state`` the cube's pose), through
the same arm controller model and checks; its cameras are ``overview`` and ``cam`` (the
default ``--env.cam_names`` and ``--env.layout`` become ``overview,cam`` and ``widowxai`` for
it; another layout is refused).

    lerobot-eval --policy.path=... --env.type=trossen --env.task=pick_place --env.cam_names=cam
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path

import gymnasium as gym
from lerobot.configs import FeatureType, PolicyFeature
from lerobot.envs.configs import EnvConfig

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.eval.arm_env import ArmPolicyEnv
from trossen_arm_mujoco.eval.arm_tasks import ARM_LAYOUT_NAME, arm_names, is_arm_task
from trossen_arm_mujoco.eval.camera_pose_step import register as register_camera_pose
from trossen_arm_mujoco.eval.controller_limits_step import register as register_controller_limits
from trossen_arm_mujoco.eval.env import KitPolicyEnv, feature_spec
from trossen_arm_mujoco.sim.camera_settings import CameraSettings
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.config import read_randomization
from trossen_arm_mujoco.tasks.randomization_levels import level_section

__all__ = ["TrossenEnvConfig"]

# the arm controller's limits as a postprocessor step (a checkpoint prepared with
# trossen_arm_mujoco.eval.controller_limits_step holds it): registered for every LeRobot tool
# that imports this plugin (lerobot-eval, lerobot-rollout, lerobot-record)
register_controller_limits()
# and a checkpoint's pose encoder (trossen_arm_mujoco.eval.camera_pose_step), a preprocessor step
register_camera_pose()

#: The kit's cameras, in the order ``record`` renders them.
KIT_CAMERAS = "cam_high,cam_low,cam_left_wrist,cam_right_wrist"
#: A single arm's cameras (``tasks.single_arm.SingleArmSampler.cameras``).
ARM_CAMERAS = "overview,cam"


@EnvConfig.register_subclass("trossen")
@dataclass
class TrossenEnvConfig(EnvConfig):
    """``--env.type=trossen`` (see the module docstring)."""

    task: str | None = registry.DEFAULT_TASK
    fps: int = 50
    episode_length: int | None = None
    cam_names: str = KIT_CAMERAS
    image_size: str = "480x640"
    layout: str = "kit14"
    crop: str = ""
    controller_checks: bool = True
    randomize: str = "nominal"
    randomization: str = ""
    features: dict[str, PolicyFeature] = field(default_factory=dict)
    features_map: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        # the --env.cam_names / image_size / crop texts, parsed once here (a bad one fails
        # here, with its format); the object goes on to every env
        name = registry.canonical(self.task or "")
        self.single_arm = is_arm_task(name)
        if self.single_arm:  # the kit's defaults become the single arm's
            if self.cam_names == KIT_CAMERAS:
                self.cam_names = ARM_CAMERAS
            if self.layout == "kit14":
                self.layout = ARM_LAYOUT_NAME
        self.cameras = self._adopt_checkpoint_settings()
        name = registry.canonical(self.task or "")
        self.single_arm = is_arm_task(name)
        if name not in registry.kit_names() and not self.single_arm:
            raise ValueError(
                f"--env.task={self.task} is neither a Stationary AI kit task nor a single "
                f"arm's; valid: {', '.join(registry.kit_names() + arm_names())}"
            )
        if self.single_arm and self.layout != ARM_LAYOUT_NAME:
            raise ValueError(
                f"--env.task={name} is a single arm's task: it takes --env.layout="
                f"{ARM_LAYOUT_NAME} (one arm's 7 values), not {self.layout}"
            )
        self.task = name
        # --env.randomize=LEVEL (true: train) and --env.randomization=FILE, read and checked
        # once here (one line on a bad level or file)
        level = {"true": "train", "false": "nominal", "": None}.get(
            str(self.randomize).lower(), str(self.randomize)
        )
        replacement = (
            read_randomization(Path(self.randomization).expanduser())
            if self.randomization
            else None
        )
        self._randomize, self._randomization = level_section(level, name, replacement)
        cams = self.cameras
        self.features, self.features_map = {}, {}
        spec = feature_spec(name, cams.names, cams.size, self.layout)
        for env_key, (key, kind, shape) in spec.items():
            self.features[env_key] = PolicyFeature(type=FeatureType[kind], shape=tuple(shape))
            self.features_map[env_key] = key

    def _adopt_checkpoint_settings(self) -> CameraSettings:
        """The cameras of the ``--env.*`` flags; with an evaluated checkpoint
        (``--policy.path``; ``trossen_arm_mujoco.export.dataset_settings``), the task, rate,
        layout, cameras, image size and crops are taken from it: a ``--env.*`` flag not given
        takes the checkpoint's value, one that contradicts it is refused, one that repeats it
        is accepted. The text fields are set to what runs (what LeRobot records)."""
        from lerobot.configs import parser

        own = CameraSettings.from_cli(self.cam_names, self.image_size, self.crop)
        path = parser.get_path_arg("policy")
        if not path:
            return own
        from trossen_arm_mujoco.eval.lerobot_policy import checkpoint_dir
        from trossen_arm_mujoco.export.dataset_settings import checkpoint_settings, reconcile

        try:
            folder = checkpoint_dir(path)
        except UserError:
            return own  # not a local checkpoint (a hub id): LeRobot reports on it
        carried, source = checkpoint_settings(folder)
        if carried is None:
            return own

        def given(flag: str):
            return parser.parse_arg(f"env.{flag}") is not None

        flags = {
            "task": registry.canonical(self.task) if given("task") else None,
            "fps": self.fps if given("fps") else None,
            "layout": self.layout if given("layout") else None,
            "cam_names": own.names if given("cam_names") else None,
            "image_size": own.size if given("image_size") else None,
            "crops": own.crops if given("crop") else None,
        }
        merged = reconcile(carried, source, flags)
        self.task = merged["task"] or self.task
        self.fps = int(merged["fps"] or self.fps)
        self.layout = merged["layout"] or self.layout
        cameras = CameraSettings(
            names=own.names if merged["cam_names"] is None else merged["cam_names"],
            size=merged["image_size"] or own.size,
            crops=merged["crops"] or (),
        )
        self.cam_names = ",".join(cameras.names) or "none"
        self.image_size = "x".join(str(v) for v in cameras.size)
        self.crop = ";".join(cameras.crop_texts())
        return cameras

    @property
    def package_name(self) -> str:
        return "lerobot_env_trossen"

    @property
    def gym_kwargs(self) -> dict:
        return {
            "task_name": self.task,
            "cameras": self.cameras,
            "fps": self.fps,
            "episode_length": self.episode_length,
            "layout": self.layout,
            "render_mode": "rgb_array",
            "controller_checks": bool(self.controller_checks),
            "randomize": self._randomize,
            "randomization": self._randomization,
        }

    def create_envs(
        self, n_envs: int, use_async_envs: bool = False
    ) -> dict[str, dict[int, gym.vector.VectorEnv]]:
        """``{"trossen": {0: VectorEnv of n_envs KitPolicyEnv}}`` (a single arm's task:
        ``ArmPolicyEnv``); async envs start their workers with ``spawn`` (each builds its own
        world; nothing is inherited)."""
        env_cls = ArmPolicyEnv if self.single_arm else KitPolicyEnv
        make = functools.partial(env_cls, **self.gym_kwargs)
        if use_async_envs and n_envs > 1:
            vec = gym.vector.AsyncVectorEnv(
                [make] * n_envs,
                context="spawn",
                autoreset_mode=gym.vector.AutoresetMode.SAME_STEP,
            )
        else:
            vec = gym.vector.SyncVectorEnv(
                [make] * n_envs, autoreset_mode=gym.vector.AutoresetMode.SAME_STEP
            )
        return {self.type: {0: vec}}
