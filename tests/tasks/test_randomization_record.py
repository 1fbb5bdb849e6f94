"""Randomization records (``tasks.randomization_record``): re-applied exactly (model fields,
joints and images), regenerated from their seed, applied to a bare model, JSON round trip,
bad records and bad JSON as one-line errors."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.randomization import FIELDS
from trossen_arm_mujoco.tasks.randomization_record import (
    KINDS,
    apply_randomization,
    generator_from_seed,
    record_from_json,
    record_to_json,
)
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings


def _scene(name: str) -> Path:
    from trossen_arm_mujoco.assets import ASSETS_DIR

    return Path(ASSETS_DIR) / registry.load(name).load_config()["scene"]


def test_record_reapplied_reproduces_images_exactly():
    section = {k: {"enabled": True} for k in KINDS}
    a = registry.make_sampler(
        "sim_transfer_cube",
        SamplerSettings(randomize=True, camera_names=["cam_high"], height=32, width=40),
        randomization=section,
    )
    b = registry.make_sampler(
        "sim_transfer_cube", SamplerSettings(camera_names=["cam_high"], height=32, width=40)
    )
    try:
        task = a.sample_task(9)
        record = record_from_json(record_to_json(a.randomization))
        assert record == a.randomization
        poses = task.object_poses()
        images_a = [a.scene.render_images()["cam_high"] for _ in range(2)]
        b.sample_task(0, object_poses=poses, randomization=record)
        images_b = [b.scene.render_images()["cam_high"] for _ in range(2)]
        for x, y in zip(images_a, images_b, strict=True):
            np.testing.assert_array_equal(x, y)
        np.testing.assert_array_equal(a.scene.data.qpos, b.scene.data.qpos)
        for f in FIELDS:
            np.testing.assert_array_equal(getattr(a.scene.model, f), getattr(b.scene.model, f))
    finally:
        a.close()
        b.close()


def test_seed_in_the_record_regenerates_it():
    sampler = registry.make_sampler("reach", SamplerSettings(randomize=True))
    try:
        sampler.sample_task(4)
        record = sampler.randomization
        sampler.scene.reset()
        again = sampler.randomizer.sample(generator_from_seed(record["seed"]), sampler.scene.data)
        assert again == record
    finally:
        sampler.close()


def test_apply_to_a_bare_model():
    sampler = registry.make_sampler("reach", SamplerSettings(randomize=True))
    try:
        sampler.sample_task(2)
        model = mujoco.MjModel.from_xml_path(str(_scene("reach")))
        data = mujoco.MjData(model)
        apply_randomization(model, sampler.randomization, data)
        for f in FIELDS:
            np.testing.assert_array_equal(getattr(model, f), getattr(sampler.scene.model, f))
    finally:
        sampler.close()


@pytest.mark.parametrize(
    "record, match",
    [
        ({"version": 2}, "version"),
        ([], "version"),
        ({"version": 1, "weather": {}}, "unknown randomization kind"),
        ({"version": 1, "lights": {"sun": {}}}, "unknown light 'sun'"),
        ({"version": 1, "friction": {"table": "high"}}, "friction.table"),
        ({"version": 1, "camera": {"overview": {"pos": [0, 0, 1]}}}, "missing 'quat'"),
    ],
)
def test_bad_records_are_one_line_errors(record, match):
    model = mujoco.MjModel.from_xml_path(str(_scene("reach")))
    with pytest.raises(UserError, match=match) as err:
        apply_randomization(model, record)
    assert "\n" not in str(err.value)


def test_bad_json_is_a_user_error():
    with pytest.raises(UserError, match="JSON"):
        record_from_json("{not json")
