"""The pose encoder (``train.pose_encoder``) on synthetic frames: a red square on a brown
table, its position the label. It must find the square (an encoder that ignored the image
would be as far off as the labels' spread), deterministically, and survive a save."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("torch")

from trossen_arm_mujoco.errors import UserError  # noqa: E402
from trossen_arm_mujoco.train import pose_encoder  # noqa: E402
from trossen_arm_mujoco.train.pose_encoder import (  # noqa: E402
    load_encoder,
    predict,
    save_encoder,
    train_encoder,
)


def _frames(n_eps: int = 12, per_ep: int = 20, seed: int = 0):
    """Episodes whose square stays put: frames (N, 24, 32, 3), poses (N, 7) with x, y in
    metres (1 px = 1 cm) and a unit quaternion, episode and frame index of each."""
    rng = np.random.default_rng(seed)
    images, poses, eps, idx = [], [], [], []
    for e in range(n_eps):
        r, c = rng.integers(2, 20), rng.integers(2, 28)
        for k in range(per_ep):
            img = np.empty((24, 32, 3), np.uint8)
            img[:] = (180, 140, 100)
            img[r : r + 3, c : c + 3] = (200, 20, 20)
            images.append(img)
            poses.append([c / 100, r / 100, 0.03, 1, 0, 0, 0])
            eps.append(e)
            idx.append(k)
    return np.stack(images), np.asarray(poses, np.float32), np.array(eps), np.array(idx)


@pytest.fixture(scope="module")
def trained():
    images, poses, eps, idx = _frames()
    net, report = train_encoder(
        images, poses, eps, idx, seed=3, epochs=15, threads=1, progress=lambda line: None
    )
    return net, report, images, poses, eps


def test_it_finds_the_square_on_held_out_episodes(trained, monkeypatch):
    net, report, images, poses, eps = trained
    spread_mm = poses[:, :2].std(0).mean() * 1000
    assert report.held_out_episodes == 1  # the last tenth of 12, at least one
    assert report.start_xy_mm < 0.5 * spread_mm, (report, spread_mm)
    pred = predict(net, images[eps == eps.max()])
    assert pred.shape == (20, 7) and pred.dtype == np.float32
    assert report.cpu_s > 0 and report.epochs == 15


def test_same_seed_same_encoder_and_a_save_keeps_it(trained, tmp_path):
    net, _, images, poses, eps = trained
    idx = np.tile(np.arange(20), 12)
    first, again = (
        train_encoder(
            images, poses, eps, idx, seed=5, epochs=1, threads=1, progress=lambda line: None
        )[0]
        for _ in range(2)
    )
    np.testing.assert_array_equal(predict(first, images[:5]), predict(again, images[:5]))
    save_encoder(net, tmp_path / "enc.safetensors")
    loaded = load_encoder(tmp_path / "enc.safetensors")
    np.testing.assert_allclose(predict(loaded, images[:5]), predict(net, images[:5]), atol=1e-6)


def test_early_frames_weigh_more():
    rows = pose_encoder._epoch_rows(np.arange(90), np.arange(6))
    assert len(rows) == 90 // pose_encoder.FRAME_STRIDE + 6 * pose_encoder.EARLY_REPEAT


@pytest.mark.parametrize(
    ("images", "poses", "expected"),
    [
        (np.zeros((4, 8, 8), np.uint8), np.zeros((4, 7)), "(N, H, W, 3) uint8 frames"),
        (np.zeros((4, 8, 8, 3), np.float32), np.zeros((4, 7)), "(N, H, W, 3) uint8 frames"),
        (np.zeros((4, 8, 8, 3), np.uint8), np.zeros((3, 7)), "one pose row per frame"),
        (np.zeros((4, 8, 8, 3), np.uint8), np.full((4, 7), np.nan), "NaN"),
    ],
)
def test_bad_frames_or_poses_are_one_line(images, poses, expected):
    with pytest.raises(UserError, match=expected.replace("(", r"\(").replace(")", r"\)")):
        train_encoder(images, poses, np.zeros(len(images)), np.zeros(len(images)), epochs=1)


def test_a_missing_or_foreign_file_is_one_line(tmp_path):
    with pytest.raises(UserError, match="cannot read the pose encoder"):
        load_encoder(tmp_path / "none.safetensors")
    from safetensors.numpy import save_file

    save_file({"w": np.zeros(3, np.float32)}, str(tmp_path / "foreign.safetensors"))
    with pytest.raises(UserError, match="not a pose encoder"):
        load_encoder(tmp_path / "foreign.safetensors")


def test_each_object_gets_its_own_errors():
    """Two objects (14 values): the report's errors are per object, in mm, the start ones at
    each episode's first frame only."""
    from trossen_arm_mujoco.train.pose_encoder import held_out, object_errors

    targets = np.zeros((4, 14), np.float32)
    pred = targets.copy()
    pred[:, 0] = 0.002  # object 1: 2 mm off in x at every frame
    pred[1, 8] = 0.010  # object 2: 10 mm off in y at a later frame only
    pred[3, 9] = 0.003  # and 3 mm in z there
    errors = object_errors(pred, targets, np.array([0, 1, 0, 1]))
    assert errors[0] == pytest.approx(
        {"start_xy_mm": 1.0, "start_xy_max_mm": 2.0, "mean_xyz_mm": 2 / 3}
    )
    assert errors[1] == pytest.approx(
        {"start_xy_mm": 0.0, "start_xy_max_mm": 0.0, "mean_xyz_mm": 13 / 12}
    )
    assert list(held_out(np.repeat(np.arange(20), 3))) == [18, 19]
    assert len(held_out(np.zeros(5, int))) == 0


def test_static_frames_train_with_the_early_ones_and_are_never_held_out():
    images, poses, eps, idx = _frames(n_eps=10, per_ep=4)
    extra_images, extra_poses, _, _ = _frames(n_eps=6, per_ep=1, seed=9)
    _, report = train_encoder(
        images,
        poses,
        eps,
        idx,
        seed=3,
        epochs=1,
        threads=1,
        static=(extra_images, extra_poses),
        progress=lambda line: None,
    )
    assert report.static_frames == 6 and report.held_out_episodes == 1
    assert report.train_frames == 9 * 4 + 6
    assert pose_encoder.static_repeat(36, 6) == 3 and pose_encoder.static_repeat(4, 6) == 1
    assert pose_encoder.static_repeat(36, 0) == 0
    with pytest.raises(UserError, match="one pose row per frame"):
        train_encoder(
            images,
            poses,
            eps,
            idx,
            static=(extra_images, extra_poses[:2]),
            progress=lambda line: None,
        )


def test_augment_changes_light_colour_and_place_deterministically():
    import torch

    from trossen_arm_mujoco.train.pose_encoder import AUGMENT_SHIFT, augment_batch

    images, _, _, _ = _frames(n_eps=2, per_ep=4)
    batch = torch.from_numpy(images).permute(0, 3, 1, 2).float() / 255.0
    first = augment_batch(batch, torch.Generator().manual_seed(1))
    again = augment_batch(batch, torch.Generator().manual_seed(1))
    other = augment_batch(batch, torch.Generator().manual_seed(2))
    assert first.shape == batch.shape and float(first.min()) >= 0 and float(first.max()) <= 1
    torch.testing.assert_close(first, again)
    assert not torch.allclose(first, other) and not torch.allclose(first, batch)
    # the square moves by at most AUGMENT_SHIFT pixels each way
    red = (first[:, 0] > first[:, 2] + 0.2).nonzero()
    for i in range(len(batch)):
        rows, cols = red[red[:, 0] == i, 1], red[red[:, 0] == i, 2]
        r0, c0 = (batch[i, 0] > batch[i, 2] + 0.2).nonzero().min(0).values.tolist()
        assert abs(int(rows.min()) - r0) <= AUGMENT_SHIFT
        assert abs(int(cols.min()) - c0) <= AUGMENT_SHIFT


def test_an_augmented_encoder_still_finds_the_square_and_repeats():
    images, poses, eps, idx = _frames()
    runs = [
        train_encoder(
            images,
            poses,
            eps,
            idx,
            seed=3,
            epochs=15,
            threads=1,
            augment=True,
            progress=lambda line: None,
        )
        for _ in range(2)
    ]
    (net, report), (again, _) = runs
    spread_mm = poses[:, :2].std(0).mean() * 1000
    assert report.start_xy_mm < 0.5 * spread_mm, (report, spread_mm)
    np.testing.assert_array_equal(predict(net, images[:5]), predict(again, images[:5]))
