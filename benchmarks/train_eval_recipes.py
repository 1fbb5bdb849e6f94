"""The recipes of ``train_eval.py`` (``--recipe``) and the checks of their camera settings.

A recipe is a set of flag defaults: ``--recipe camera`` is the camera recipe of the docs'
Train and evaluate page, and any flag given on the command line still wins over it
(``--recipe camera --steps 9000``).

- ``state``: the script's own defaults (the 14 joint values plus the object poses, 50 fps).
- ``camera``: what a real kit gives, nothing more: the 14 joint values and ``cam_high``, at
  the real kit's layout (kit14) and rate (30 fps), no object pose. The camera shows a 150x200
  crop of its 480x640 frame around the cube's spawn region, rendered straight at 60x80 (the
  25 mm cube spans about 4 pixels); ACT with ResNet-18 trained from scratch (backbone at the
  policy's rate), 200 noisy episodes, 4,500 steps of batch 16 with the rate decayed from 1e-4
  to 1e-6: 39-41 minutes of CPU per training run on the 2-core machine. Measured 2026-11-28:
  three runs scored 2 %, 18 % and 14 % (one pass over the data; the loss ended at 0.105):
  ResNet-18 learns the arms, not the cube (docs Benchmarks, "the camera recipe"). Kept as the
  end-to-end row.
- ``camera_pose``: the same observation and data; a pose encoder trained once on the
  recorded frames finds the cube in ``cam_high`` (``train_eval_pose.py``), each run trains
  the state recipe's ACT (7,000 steps) on the joints and the encoder's estimates, and each
  checkpoint carries the frozen encoder in its preprocessor. Measured 2026-11-29: three
  runs scored 100 %, 90 % and 90 % (mean 93.3 %), 24.7-26.6 min of CPU each plus 12.5 min
  for the encoder, once (docs Benchmarks, "the camera_pose recipe"). On the insertion (its
  crop and 1,000 static frames, its ``TaskEntry.pose_static_frames``) three runs scored
  80 %, 82 % and 96 % (mean 86 %).

Both camera recipes look at their task's crop of ``cam_high`` (its ``TaskEntry.camera_crop``;
``--crop`` wins): the transfer's above, the insertion's 180x240 around the peg's and the
socket's spawn regions; a task that declares none needs ``--crop``.

The camera settings are checked before anything runs (one line each): a camera the kit does
not have, an image smaller than the encoder's stride (ResNet-18 sees a 32x32-pixel cell per
feature; an image below 32 pixels in either dimension leaves the policy a single cell there,
so it cannot tell where the cube is; the pose encoder of ``camera_pose`` needs 16 pixels), a
crop outside the camera's 480x640 frame or of a camera not observed, a cropped recipe on a
task it knows no crop for. Plain Python: the train phase may run where the simulator is not
installed.
"""

from __future__ import annotations

#: The cameras of the real Stationary AI kit (Trossen's LeRobot plugin's names); the
#: simulated kit renders the same four (a test checks the package agrees).
KIT_CAMERAS = ("cam_high", "cam_low", "cam_left_wrist", "cam_right_wrist")
#: The camera's full frame, (height, width) pixels: what a crop is given in.
FRAME = (480, 640)
#: ResNet-18's output stride: one feature cell per 32x32 pixels of the input.
ENCODER_STRIDE = 32
#: The pose encoder's (``train.pose_encoder``) smallest image: its keypoint maps are at half
#: the image's size, so 16 pixels leave 8 positions each way to locate an object among.
POSE_ENCODER_MIN = 16
#: The camera recipe's backbone rate flag (ResNet-18 from scratch learns at the policy's rate).
BACKBONE_RATE = "--policy.optimizer_lr_backbone=1e-4"

RECIPES: dict[str, dict] = {
    "state": {},
    "camera": {
        "episodes": 200,
        "inject_noise": True,
        "cam_names": "cam_high",
        "image_size": "60x80",
        "no_env_state": True,
        "fps": 30,
        "steps": 4500,
        "train_arg": [BACKBONE_RATE],
    },
    # the same data; a pose encoder trained once finds the cube in cam_high, and each run
    # trains the state recipe's ACT on the joints and the encoder's estimates
    "camera_pose": {
        "episodes": 200,
        "inject_noise": True,
        "cam_names": "cam_high",
        "image_size": "60x80",
        "fps": 30,
        "pose_encoder": True,
        "steps": 7000,
    },
    # camera_pose on episodes whose scenes are randomized at the train level (lights, table,
    # colours, physics, camera poses, the arms' start) and an encoder trained on augmented
    # frames: the recipe for scenes that are not the model's
    "camera_pose_robust": {
        "episodes": 200,
        "inject_noise": True,
        "cam_names": "cam_high",
        "image_size": "60x80",
        "fps": 30,
        "pose_encoder": True,
        "randomize": True,
        "augment": True,
        "steps": 7000,
    },
}


#: The recipes that look at a crop of ``cam_high`` around the task's objects.
CROPPED = ("camera", "camera_pose", "camera_pose_robust")


def task_camera_facts(recipe: str, task: str) -> tuple[str | None, int, str | None]:
    """The task's ``camera_crop`` and ``pose_static_frames`` (its ``TaskEntry``: a user's
    task declares its own), and why a cropped recipe cannot run on it, in one line (None:
    it can). Where the project is not installed (a train-only machine) neither is needed:
    (None, 0, None)."""
    try:
        from trossen_arm_mujoco.errors import UserError
        from trossen_arm_mujoco.tasks.registry import load
    except ImportError:
        return None, 0, None
    try:
        entry = load(task)
    except UserError as exc:
        crop, static, why = None, 0, str(exc)
    else:
        crop, static = entry.camera_crop or None, entry.pose_static_frames
        why = f"its TaskEntry declares no camera_crop ({entry.package})"
    if recipe in CROPPED and crop is None:
        return (
            None,
            static,
            (
                f"--recipe {recipe} knows no crop of cam_high for task {task!r} "
                f"({why}); give --crop cam_high:TOP,LEFT,HEIGHT,WIDTH around the "
                "task's objects, or declare TaskEntry(camera_crop=...)"
            ),
        )
    return crop, static, None


def camera_settings_error(
    cam_names: str, image_size: str, crop: str | None, pose_encoder: bool = False
) -> str | None:
    """What is wrong with these camera settings, in one line (None: nothing).

    ``pose_encoder``: the images feed the pose encoder (``camera_pose``), not ResNet-18, so
    the smallest image is :data:`POSE_ENCODER_MIN`, not :data:`ENCODER_STRIDE`.

    ``cam_names``: comma-separated camera names or ``none``; ``image_size``: ``HxW`` pixels;
    ``crop``: ``CAMERA:TOP,LEFT,HEIGHT,WIDTH`` in pixels of the 480x640 frame, or None.
    """
    names = [n.strip() for n in cam_names.split(",") if n.strip()]
    if names == ["none"]:
        names = []
    unknown = [n for n in names if n not in KIT_CAMERAS]
    if unknown:
        return (
            f"--cam_names {','.join(unknown)}: the kit has no such camera; choose from "
            f"{', '.join(KIT_CAMERAS)} (or none)"
        )
    if names:
        try:
            height, width = (int(v) for v in image_size.lower().split("x"))
        except ValueError:
            return f"--image_size must be HEIGHTxWIDTH in pixels, e.g. 60x80; got '{image_size}'"
        if pose_encoder and min(height, width) < POSE_ENCODER_MIN:
            return (
                f"--image_size {image_size} is below what the pose encoder resolves: its "
                f"keypoint maps are at half the image's size, so give at least "
                f"{POSE_ENCODER_MIN} pixels each way (e.g. 60x80)"
            )
        if not pose_encoder and min(height, width) < ENCODER_STRIDE:
            return (
                f"--image_size {image_size} is below what the image encoder resolves: "
                f"ResNet-18 sees one feature per {ENCODER_STRIDE}x{ENCODER_STRIDE} pixels, "
                f"so give at least {ENCODER_STRIDE} pixels each way (e.g. 60x80)"
            )
    if crop:
        camera, _, rest = crop.partition(":")
        try:
            top, left, height, width = (int(v) for v in rest.split(","))
        except ValueError:
            return (
                f"--crop must be CAMERA:TOP,LEFT,HEIGHT,WIDTH in pixels of the 480x640 "
                f"frame, e.g. cam_high:217,243,150,200; got '{crop}'"
            )
        if camera not in names:
            return (
                f"--crop {crop}: camera {camera!r} is not observed; add it to --cam_names "
                f"({cam_names})"
            )
        if (
            min(top, left) < 0
            or min(height, width) < 1
            or top + height > FRAME[0]
            or left + width > FRAME[1]
        ):
            return (
                f"--crop {crop} is outside the camera's {FRAME[0]}x{FRAME[1]} frame "
                f"(top, left >= 0; top + height <= {FRAME[0]}; left + width <= "
                f"{FRAME[1]})"
            )
    return None
