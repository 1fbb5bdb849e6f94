"""ObservationBuilder: spaces per observation type, state vectors, goals, pixel layout.

Built directly over registered tasks (no gymnasium env), with hand-made images, so no GL
context is needed.
"""

from __future__ import annotations

import numpy as np
import pytest
from gymnasium import spaces

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.gym.spaces import OBS_TYPES, ObservationBuilder
from trossen_arm_mujoco.tasks import registry

H, W = 6, 8


@pytest.fixture(scope="module")
def reach():
    sampler = registry.make_sampler("reach")
    yield sampler.sample_task(0)
    sampler.close()


@pytest.fixture(scope="module")
def cube():
    sampler = registry.make_sampler("sim_transfer_cube")
    yield sampler.sample_task(0)
    sampler.close()


def _images(n: int) -> dict[str, np.ndarray]:
    return {f"cam{i}": np.full((H, W, 3), 10 * (i + 1), np.uint8) for i in range(n)}


def _state_size(task) -> int:
    return sum(int(np.size(low)) for low, _ in task.observation_bounds().values())


def test_unknown_obs_type_lists_the_valid_ones(reach):
    with pytest.raises(UserError, match="valid observation types: pixels, pixels_state, state"):
        ObservationBuilder(reach, "rgb", False, 1, H, W)


def test_state_space_of_a_plain_task(cube):
    b = ObservationBuilder(cube, "state", False, 0, H, W)
    assert not b.with_goal and not b.needs_images
    assert b.keys == list(cube.observation_bounds())
    assert isinstance(b.space, spaces.Box) and b.space.dtype == np.float32
    assert b.space.shape == (_state_size(cube),)
    assert np.all(np.isfinite(b.space.low)) and np.all(np.isfinite(b.space.high))
    obs = b.build(cube, None)
    assert obs.dtype == np.float32 and b.space.contains(obs)
    expected = np.concatenate([np.ravel(v) for v in cube.get_observation().values()])
    np.testing.assert_allclose(obs, expected.astype(np.float32))


def test_goal_conditioned_state_appends_goal_and_delta(reach):
    b = ObservationBuilder(reach, "state", False, 0, H, W)
    assert b.with_goal and b.keys[-2:] == ["goal", "goal_delta"]
    assert b.space.shape == (_state_size(reach) + 6,)
    obs = b.build(reach, None)
    desired, achieved = reach.desired_goal(), reach.achieved_goal()
    np.testing.assert_allclose(obs[-6:-3], desired, atol=1e-6)
    np.testing.assert_allclose(obs[-3:], desired - achieved, atol=1e-6)
    low, high = reach.goal_bounds()
    np.testing.assert_allclose(b.space.low[-3:], low - high)
    assert b.space.contains(obs)


def test_state_is_clipped_into_the_bounds(reach):
    b = ObservationBuilder(reach, "state", False, 0, H, W)
    arm = reach.arm
    saved = reach.data.qvel.copy()
    try:
        reach.data.qvel[arm.dof_idx] = 1e6  # far beyond max_joint_velocity
        obs = b.state(reach)
    finally:
        reach.data.qvel[:] = saved
    sizes = {k: int(np.size(low)) for k, (low, _) in reach.observation_bounds().items()}
    start = sum(sizes[k] for k in b.keys[: b.keys.index("arm_qvel")])
    qvel = obs[start : start + 6]
    np.testing.assert_array_equal(qvel, np.float32(reach.max_qvel))
    assert b.space.contains(obs)


def test_pixels_are_the_cameras_side_by_side(reach):
    b = ObservationBuilder(reach, "pixels", False, 3, H, W)
    assert b.needs_images
    assert b.space == spaces.Box(0, 255, (H, 3 * W, 3), dtype=np.uint8)
    obs = b.build(reach, _images(3))
    assert obs.shape == (H, 3 * W, 3) and b.space.contains(obs)
    assert [obs[0, i * W, 0] for i in range(3)] == [10, 20, 30]  # camera order kept


def test_pixels_state_is_a_dict(reach):
    b = ObservationBuilder(reach, "pixels_state", False, 2, H, W)
    assert isinstance(b.space, spaces.Dict) and list(b.space) == ["pixels", "state"]
    obs = b.build(reach, _images(2))
    assert b.space.contains(obs)
    np.testing.assert_array_equal(obs["state"], b.state(reach))


@pytest.mark.parametrize("obs_type", OBS_TYPES)
def test_goal_env_dict(reach, obs_type):
    b = ObservationBuilder(reach, obs_type, True, 1, H, W)
    assert not b.with_goal  # goals are separate keys, not part of the state vector
    keys = ["observation", "achieved_goal", "desired_goal"]
    if obs_type == "pixels_state":
        keys.insert(1, "pixels")
    assert sorted(b.space) == sorted(keys)  # gymnasium sorts the keys of a Dict space
    obs = b.build(reach, _images(1))
    assert b.space.contains(obs), obs_type
    np.testing.assert_allclose(obs["desired_goal"], reach.desired_goal(), atol=1e-6)
    np.testing.assert_allclose(obs["achieved_goal"], reach.achieved_goal(), atol=1e-6)
    main = obs["observation"]
    assert main.shape == ((H, W, 3) if obs_type == "pixels" else (_state_size(reach),))


def test_goals_are_clipped_to_the_workspace(reach):
    b = ObservationBuilder(reach, "state", True, 0, H, W)
    goal = reach.goal.copy()
    try:
        reach.goal[:] = [100.0, -100.0, 0.1]
        obs = b.build(reach, None)
    finally:
        reach.goal[:] = goal
    far = obs["desired_goal"]
    assert far.dtype == np.float32
    np.testing.assert_allclose(far, [reach.ws_high[0], reach.ws_low[1], 0.1], rtol=1e-6)
    assert b.space.contains(obs)
