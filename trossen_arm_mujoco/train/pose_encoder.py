"""A small image encoder that finds the objects in one camera: trained once on a recorded
dataset, then frozen and reused by every policy trained on that dataset.

:class:`PoseEncoder` (about 25 k parameters; ``torch`` is imported inside the functions):
three small convolutions, a spatial soft-argmax over :data:`KEYPOINTS` feature maps and a
two-layer head giving the objects' poses (xyz m + quat wxyz per object, world, the layout
of ``observation.environment_state``) from (B, 3, H, W) float images in [0, 1]. It is trained
with the simulation's exact poses as labels, early frames weighted up (:data:`EARLY_FRAMES`,
:data:`EARLY_REPEAT`); at deployment ``eval.camera_pose_step`` runs it in the checkpoint.

Docs: docs/train-eval.md; why: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from trossen_arm_mujoco.errors import UserError

__all__ = [
    "EARLY_FRAMES",
    "EARLY_REPEAT",
    "AUGMENT_LIGHT",
    "AUGMENT_SHIFT",
    "EncoderReport",
    "augment_batch",
    "encoder_from_state",
    "held_out",
    "object_errors",
    "static_repeat",
    "KEYPOINTS",
    "load_encoder",
    "predict",
    "save_encoder",
    "train_encoder",
]

#: Feature maps whose soft-argmax the head reads.
KEYPOINTS = 16
#: Frames of an episode's start (at the dataset's rate: 1.5 s at 30 fps) in which the arms
#: have barely moved: the object's pose must come from the object there.
EARLY_FRAMES = 45
#: How many extra times each early frame is shown per epoch.
EARLY_REPEAT = 3
#: The first epochs show the early frames only (this fraction of them): there the arms are
#: at home in every episode and only the object moves, so the encoder must find it before it
#: sees the arms carry it (mixed from the start, one encoder in two learnt to read the arms'
#: approach instead, 52 mm off at episodes' starts, 2026-11-29).
EARLY_ONLY_FRACTION = 0.5
#: Every n-th of the other frames is used per epoch (neighbouring frames nearly repeat).
FRAME_STRIDE = 3
#: Training defaults: epochs, batch, peak rate of the one-cycle schedule.
EPOCHS = 8
BATCH = 64
PEAK_LR = 2e-3
#: Episodes held out (the last tenth) for the report's errors.
HOLDOUT_FRACTION = 0.1
#: ``augment``: each training image's brightness scaled by up to this fraction, each colour
#: channel by up to half of it, an offset of up to a fifth of it added (a room's light and a
#: camera's exposure and white balance), and the image shifted by up to
#: :data:`AUGMENT_SHIFT` pixels each way (a camera mounted slightly off).
AUGMENT_LIGHT = 0.3
AUGMENT_SHIFT = 2


@dataclass(frozen=True)
class EncoderReport:
    """How well the encoder finds the objects on held-out episodes (mm), and its cost."""

    start_xy_mm: float  # mean |error| of the first object's x and y at episodes' first frames
    start_xy_max_mm: float  # the largest of those errors
    mean_xyz_mm: float  # mean |error| of the first object's xyz over all held-out frames
    train_frames: int
    held_out_episodes: int
    epochs: int
    cpu_s: float
    wall_s: float
    #: The same three errors for each object (each 7 values of the poses), in order.
    objects: tuple[dict[str, float], ...] = ()
    #: Frames of the scene at its start given besides the episodes (``static``).
    static_frames: int = 0

    def as_dict(self) -> dict[str, Any]:
        """The report as plain JSON values."""
        return {**self.__dict__, "objects": [dict(o) for o in self.objects]}


def _module(out_dim: int, keypoints: int = KEYPOINTS) -> Any:
    import torch
    from torch import nn

    class PoseEncoder(nn.Module):
        """(B, 3, H, W) images in [0, 1] -> (B, out_dim) poses in the targets' units."""

        def __init__(self) -> None:
            super().__init__()
            self.conv = nn.Sequential(
                nn.Conv2d(3, 16, 5, padding=2),
                nn.ReLU(),
                nn.Conv2d(16, 32, 3, stride=2, padding=1),
                nn.ReLU(),
                nn.Conv2d(32, 32, 3, padding=1),
                nn.ReLU(),
                nn.Conv2d(32, keypoints, 1),
            )
            # a sharp soft-argmax from the start (softmax over ~1,000 cells is flat otherwise)
            self.log_temperature = nn.Parameter(torch.tensor(2.3))
            self.head = nn.Sequential(
                nn.Linear(3 * keypoints, 128), nn.ReLU(), nn.Linear(128, out_dim)
            )
            self.register_buffer("target_mean", torch.zeros(out_dim))
            self.register_buffer("target_std", torch.ones(out_dim))

        def normalized(self, images: Any) -> Any:
            f = self.conv(images)
            b, k, h, w = f.shape
            p = torch.softmax(f.flatten(2) * self.log_temperature.exp(), -1).view(b, k, h, w)
            ys = torch.linspace(-1.0, 1.0, h, device=f.device)
            xs = torch.linspace(-1.0, 1.0, w, device=f.device)
            ey = (p.sum(3) * ys).sum(2)
            ex = (p.sum(2) * xs).sum(2)
            return self.head(torch.cat([ex, ey, f.flatten(2).amax(-1)], 1))

        def forward(self, images: Any) -> Any:
            return self.normalized(images) * self.target_std + self.target_mean

    return PoseEncoder()


def _check(images: np.ndarray, targets: np.ndarray | None = None) -> None:
    if images.ndim != 4 or images.shape[-1] != 3 or images.dtype != np.uint8:
        raise UserError(
            f"the encoder takes (N, H, W, 3) uint8 frames, got {images.shape} {images.dtype}"
        )
    if targets is not None and (targets.ndim != 2 or len(targets) != len(images)):
        raise UserError(
            f"one pose row per frame is needed: {images.shape[0]} frames, targets {targets.shape}"
        )
    if targets is not None and not np.isfinite(targets).all():
        raise UserError("the object poses hold NaN or inf: re-record the episodes")


def _tensor(images: np.ndarray) -> Any:
    import torch

    return torch.from_numpy(np.ascontiguousarray(images)).permute(0, 3, 1, 2)


def predict(encoder: Any, images: np.ndarray, batch: int = 512) -> np.ndarray:
    """Poses (N, D) float32 for frames (N, H, W, 3) uint8.

    Args:
        encoder: a trained :class:`PoseEncoder`.
        images: frames (N, H, W, 3) uint8.
        batch: frames per forward pass.
    """
    import torch

    _check(images)
    x = _tensor(images)
    encoder.eval()
    out = []
    with torch.inference_mode():
        for i in range(0, len(x), batch):
            out.append(encoder(x[i : i + batch].float() / 255.0))
    return torch.cat(out).numpy().astype(np.float32)


def _epoch_rows(
    train_rows: np.ndarray, early_rows: np.ndarray, early_only: bool = False
) -> np.ndarray:
    if early_only:
        return early_rows
    return np.concatenate([train_rows[::FRAME_STRIDE]] + [early_rows] * EARLY_REPEAT)


def held_out(episode: np.ndarray) -> np.ndarray:
    """The episodes held out for the report: the last :data:`HOLDOUT_FRACTION` of them (none
    when there is one episode)."""
    episodes = np.unique(episode)
    n_hold = max(1, int(round(len(episodes) * HOLDOUT_FRACTION))) if len(episodes) > 1 else 0
    return episodes[len(episodes) - n_hold :] if n_hold else episodes[:0]


def object_errors(
    pred: np.ndarray, targets: np.ndarray, frame_index: np.ndarray
) -> list[dict[str, float]]:
    """Per object (each 7 columns of the poses (N, D), xyz first, m): the mean and the largest
    |error| of x and y at the episodes' first frames (``frame_index`` at its minimum), and
    the mean |error| of xyz over all frames; mm.

    Args:
        pred: predicted poses (N, D), 7 columns per object (xyz m, quat wxyz, world).
        targets: the exact poses (N, D).
        frame_index: each row's index in its episode, (N,).
    """
    first = frame_index == frame_index.min()
    out = []
    for k in range(0, targets.shape[1] - 2, 7):
        err = np.abs(pred[:, k : k + 3] - targets[:, k : k + 3]) * 1000.0
        start = err[first, :2]
        out.append(
            {
                "start_xy_mm": float(start.mean()),
                "start_xy_max_mm": float(start.max()),
                "mean_xyz_mm": float(err.mean()),
            }
        )
    return out


def static_repeat(early: int, static: int) -> int:
    """How many times each static frame is shown among ``early`` early frames: so that the
    static frames are about a third of them (at least once)."""
    return max(1, round(early / (2 * static))) if static else 0


def augment_batch(images: Any, generator: Any) -> Any:
    """``images`` (B, 3, H, W) float in [0, 1] with the :data:`AUGMENT_LIGHT` and
    :data:`AUGMENT_SHIFT` changes drawn from ``generator`` (a ``torch.Generator``), per image;
    the result is in [0, 1], same shape. A shift fills the uncovered border with the edge's
    pixels."""
    import torch
    import torch.nn.functional as F

    b = images.shape[0]

    def uniform(*shape: int, scale: float) -> Any:
        return (torch.rand(*shape, generator=generator) * 2 - 1) * scale

    gain = 1 + uniform(b, 1, 1, 1, scale=AUGMENT_LIGHT)
    tint = 1 + uniform(b, 3, 1, 1, scale=AUGMENT_LIGHT / 2)
    offset = uniform(b, 1, 1, 1, scale=AUGMENT_LIGHT / 5)
    out = (images * gain * tint + offset).clamp(0.0, 1.0)
    pad = AUGMENT_SHIFT
    if pad:
        h, w = out.shape[-2:]
        padded = F.pad(out, (pad, pad, pad, pad), mode="replicate")
        dy = torch.randint(0, 2 * pad + 1, (b,), generator=generator)
        dx = torch.randint(0, 2 * pad + 1, (b,), generator=generator)
        out = torch.stack([padded[i, :, dy[i] : dy[i] + h, dx[i] : dx[i] + w] for i in range(b)])
    return out


def train_encoder(
    images: np.ndarray,
    targets: np.ndarray,
    episode: np.ndarray,
    frame_index: np.ndarray,
    *,
    seed: int = 0,
    epochs: int = EPOCHS,
    threads: int | None = None,
    static: tuple[np.ndarray, np.ndarray] | None = None,
    augment: bool = False,
    progress: Any = print,
) -> tuple[Any, EncoderReport]:
    """Train an encoder on frames (N, H, W, 3) uint8 with their poses (N, D) (the first
    object's xyz in columns 0-2, m), each frame's episode and index in it; the last
    :data:`HOLDOUT_FRACTION` of the episodes are held out for the report. ``seed`` fixes the
    initial weights and the order of the frames.

    ``static``: more frames (M, H, W, 3) and their poses (M, D) of the scene at its start
    (the arms at home, the objects where the task's sampler put them): the arms say nothing
    there, so only the objects can give their poses. They train with the early frames,
    shown :func:`static_repeat` times as often, and are never held out.

    ``augment``: every training batch changed by :func:`augment_batch` (light, colour,
    a small shift), drawn from ``seed``; the held-out report reads the frames unchanged.

    Args:
        images: frames (N, H, W, 3) uint8.
        targets: their poses (N, D), 7 columns per object (xyz m, quat wxyz, world).
        episode: each frame's episode, (N,).
        frame_index: each frame's index in its episode, (N,).
        seed: the initial weights and the order of the frames.
        epochs: training epochs.
        threads: torch threads (None: torch's default).
        static: more frames (M, H, W, 3) and poses (M, D) of scenes at their start.
        augment: change every training batch by :func:`augment_batch`.
        progress: gets progress lines.
    """
    import torch
    import torch.nn.functional as F

    _check(images, targets)
    n_rows = len(images)
    if static is not None and len(static[0]):
        _check(*static)
        images = np.concatenate([images, static[0]])
        targets = np.concatenate([np.asarray(targets, np.float32), static[1]])
    if threads:
        torch.set_num_threads(int(threads))
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    draws = torch.Generator().manual_seed(seed) if augment else None
    targets = np.asarray(targets, dtype=np.float32)
    held = held_out(episode)
    n_hold = len(held)
    is_train = ~np.isin(episode, held)
    static_rows = np.arange(n_rows, len(images))
    train_rows = np.concatenate([np.nonzero(is_train)[0], static_rows])
    early_rows = np.nonzero(is_train & (frame_index < EARLY_FRAMES))[0]
    repeat = static_repeat(len(early_rows), len(static_rows))
    early_rows = np.concatenate([early_rows] + [static_rows] * repeat)
    mean, std = targets[train_rows].mean(0), targets[train_rows].std(0) + 1e-3
    net = _module(targets.shape[1])
    net.target_mean.copy_(torch.from_numpy(mean))
    net.target_std.copy_(torch.from_numpy(std))
    x_all, y_all = _tensor(images), torch.from_numpy((targets - mean) / std)
    first = int(round(epochs * EARLY_ONLY_FRACTION))
    sizes = [
        max(1, len(_epoch_rows(train_rows, early_rows, e < first)) // BATCH) for e in range(epochs)
    ]
    opt = torch.optim.AdamW(net.parameters(), lr=PEAK_LR / 25)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, PEAK_LR, total_steps=sum(sizes))
    cpu0, wall0 = time.process_time(), time.perf_counter()
    net.train()
    for epoch in range(epochs):
        per_epoch = sizes[epoch]
        rows_of_epoch = _epoch_rows(train_rows, early_rows, epoch < first)
        order = rng.permutation(rows_of_epoch)[: per_epoch * BATCH]
        total = 0.0
        for i in range(0, len(order), BATCH):
            rows = order[i : i + BATCH]
            batch = x_all[rows].float() / 255.0
            if draws is not None:
                batch = augment_batch(batch, draws)
            loss = F.mse_loss(net.normalized(batch), y_all[rows])
            opt.zero_grad()
            loss.backward()
            opt.step()
            sched.step()
            total += loss.item()
        progress(
            f"pose encoder: epoch {epoch + 1}/{epochs}, loss {total / per_epoch:.4f}, "
            f"{time.perf_counter() - wall0:.0f} s"
        )
    cpu_s, wall_s = time.process_time() - cpu0, time.perf_counter() - wall0
    held_rows = np.nonzero(~is_train)[0]
    images, targets = images[:n_rows], targets[:n_rows]
    objects = [{"start_xy_mm": 0.0, "start_xy_max_mm": 0.0, "mean_xyz_mm": 0.0}]
    if len(held_rows):
        pred = predict(net, images[held_rows])
        objects = object_errors(pred, targets[held_rows], frame_index[held_rows])
    report = EncoderReport(
        **objects[0],
        train_frames=int(len(train_rows)),
        held_out_episodes=int(n_hold),
        epochs=int(epochs),
        cpu_s=round(cpu_s, 1),
        wall_s=round(wall_s, 1),
        objects=tuple(objects),
        static_frames=int(len(static_rows)),
    )
    return net, report


def save_encoder(encoder: Any, path: str | Path) -> None:
    """Write the encoder's weights and shape to ``path`` (safetensors, atomically)."""
    from safetensors.torch import save_file

    from trossen_arm_mujoco.fileio import atomic_path

    state = {k: v.detach().contiguous() for k, v in encoder.state_dict().items()}
    meta = {"out_dim": str(int(state["target_mean"].shape[0])), "keypoints": str(KEYPOINTS)}
    with atomic_path(Path(path)) as tmp:
        save_file(state, str(tmp), metadata=meta)


def encoder_from_state(state: dict[str, Any]) -> Any:
    """An encoder holding ``state`` (what :func:`save_encoder` wrote, as tensors)."""
    try:
        out_dim = int(state["target_mean"].shape[0])
        keypoints = int(state["conv.6.weight"].shape[0])
        net = _module(out_dim, keypoints)
        net.load_state_dict(state)
    except (KeyError, RuntimeError, AttributeError) as exc:
        raise UserError(f"not a pose encoder's weights ({exc})") from None
    net.eval()
    return net


def load_encoder(path: str | Path) -> Any:
    """The encoder saved at ``path``; a one-line UserError when it is missing or foreign."""
    from safetensors.torch import load_file

    try:
        state = load_file(str(path))
    except (OSError, ValueError) as exc:
        raise UserError(
            f"{path}: cannot read the pose encoder ({exc}); run the recipe's encode phase again"
        ) from None
    return encoder_from_state(state)
