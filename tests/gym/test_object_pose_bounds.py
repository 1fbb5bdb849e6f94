"""Object poses given to ``reset(options={"object_poses": ...})`` (``gym.inputs``): a position
outside the task's workspace or a (near) zero quaternion is a one-line ``InvalidInput`` naming
the object and the bound, before MuJoCo sees it; the default workspace is every shipped
task's."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.gym.inputs import DEFAULT_WORKSPACE, InvalidInput, reset_options
from trossen_arm_mujoco.tasks import registry

CUBE = "TrossenMujoco/StationaryAITransferCube-v0"


@pytest.mark.parametrize(
    ("pose", "match"),
    [
        (
            [1e30, 0.0, 0.05, 1, 0, 0, 0],
            r"reset option object_poses\['box'\]: position \[1e\+30, 0.0, 0.05\] is outside the "
            r"task's workspace \[-0.8, 0.8\] x \[-0.8, 0.8\] x \[-0.1, 0.9\] m",
        ),
        ([0.0, 0.1, -3.0, 1, 0, 0, 0], r"\[0.0, 0.1, -3.0\] is outside the task's workspace"),
        (
            [0.0, 0.1, 0.05, 1e-12, 0, 0, 0],
            r"object_poses\['box'\] needs a non-zero quaternion \(norm at least 1e-06\)",
        ),
        ([0.0, 0.1, 0.05, np.inf, 0, 0, 0], "must be 7 finite numbers"),
    ],
)
def test_a_pose_out_of_bounds_is_one_line_naming_object_and_bound(make_env, pose, match):
    env = make_env(CUBE)
    with pytest.raises(InvalidInput, match=match) as err:
        env.reset(seed=0, options={"object_poses": {"box": pose}})
    assert "\n" not in str(err.value)
    env.reset(seed=0)  # the env goes on


def test_a_pose_in_the_workspace_is_placed(make_env):
    env = make_env(CUBE)
    pose = [0.05, 0.1, 0.045, 1.0, 0.0, 0.0, 0.0]
    env.reset(seed=0, options={"object_poses": {"box": pose}})
    placed = env.unwrapped.scene.objects["box"].get_pose(env.unwrapped.scene.data)
    assert np.allclose(placed, pose)


def test_a_quaternion_of_huge_values_is_normalized_not_overflowed():
    got = reset_options({"object_poses": {"box": [0, 0, 0, 1e308, 1e308, 0, 0]}}, {"box": 0})
    assert got is not None and np.allclose(got["box"][3:], [2**-0.5, 2**-0.5, 0, 0])


def test_a_given_workspace_is_the_bound():
    box = (np.array([0.0, 0.0, 0.0]), np.array([0.1, 0.1, 0.1]))
    ok = reset_options({"object_poses": {"box": [0.05] * 3 + [1, 0, 0, 0]}}, {"box": 0}, box)
    assert ok is not None and np.allclose(ok["box"][:3], 0.05)
    with pytest.raises(InvalidInput, match=r"workspace \[0, 0.1\] x \[0, 0.1\] x \[0, 0.1\] m"):
        reset_options({"object_poses": {"box": [0.2, 0, 0, 1, 0, 0, 0]}}, {"box": 0}, box)


def test_the_default_workspace_is_every_shipped_task_configs():
    for name in registry.names():
        config = registry.load(name).load_config()
        low, high = config["workspace_low"], config["workspace_high"]
        if str(config.get("scene", "")).startswith("mobile_ai/"):  # a base that drives about
            assert all(a <= b for a, b in zip(low, DEFAULT_WORKSPACE[0])), name
            assert all(a >= b for a, b in zip(high, DEFAULT_WORKSPACE[1])), name
            continue
        assert (tuple(low), tuple(high)) == DEFAULT_WORKSPACE, name
