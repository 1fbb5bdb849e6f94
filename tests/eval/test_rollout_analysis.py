"""The rollout analysis: stage times, the release of the cube and what the left gripper did
then, and where a failed episode stopped, on the scripted policy and on broken versions of it.
"""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.eval.rollout_analysis import (
    RELEASE_OPENING,
    RolloutRecorder,
    failure_line,
    rollouts_report,
    stopped_at,
)
from trossen_arm_mujoco.eval.runner import EpisodeRunner, EvalSettings
from trossen_arm_mujoco.eval.scores import EpisodeScore
from trossen_arm_mujoco.policies.transfer_cube import RIGHT_RELEASE
from trossen_arm_mujoco.robot.layout import GRIPPER_OPEN, KIT14_LAYOUT

RIGHT_GRIPPER = KIT14_LAYOUT.gripper_index("right")
SEED = 5


class Broken:
    """The scripted policy with its right gripper commanded open from step ``open_from`` on
    (``never_close``: at every step)."""

    def __init__(self, inner, open_from: int):
        self.inner, self.open_from, self.t = inner, open_from, 0

    def reset(self, env, seed: int) -> None:
        self.inner.reset(env, seed)
        self.t = 0

    def act(self, observation):
        action = np.array(self.inner.act(observation), dtype=float)
        if self.t >= self.open_from:
            action[RIGHT_GRIPPER] = GRIPPER_OPEN
        self.t += 1
        return action

    def close(self) -> None:
        self.inner.close()


@pytest.fixture(scope="module")
def runs() -> dict[str, EpisodeScore]:
    """One transfer episode each: the scripted plan (600 steps), the right gripper opened
    early (after the lift, before the left grasps), and never closed (300 steps each)."""
    out = {}
    # checks off: the broken policies snap the gripper open, which the controller refuses
    runner = EpisodeRunner(EvalSettings(policy="scripted", seed=SEED, controller_checks=False))
    try:
        out["scripted"], _ = runner.run(0)
        scripted = runner.policy
        runner.env.episode_length = 300
        runner.policy = Broken(scripted, open_from=250)
        out["open_early"], _ = runner.run(0)
        runner.policy = Broken(scripted, open_from=0)
        out["never_close"], _ = runner.run(0)
        runner.policy = scripted
    finally:
        runner.close()
    return out


def test_scripted_transfer_succeeds_with_a_release_held_by_the_left(runs):
    score = runs["scripted"]
    a = score.analysis
    assert score.success and a["stopped"] is None
    steps = [a["stage_steps"][k] for k in ("touched", "lifted", "transferred")]
    assert None not in steps and steps == sorted(steps) and len(set(steps)) == 3
    times = list(a["stage_times_s"].values())
    assert times == pytest.approx([(k + 1) / 50.0 for k in steps])
    release = a["release"]
    assert release is not None
    assert steps[1] < release["step"] and abs(release["step"] - RIGHT_RELEASE) <= 3
    assert release["left_touching"]  # the left fingers hold the cube when the right opens
    assert release["left_gap_m"] < 0.03  # closed on the 25 mm cube (open: 0.088)
    assert release["right_gap_m"] < 0.03


def test_right_gripper_opened_early_fails_at_the_transfer(runs):
    score = runs["open_early"]
    a = score.analysis
    assert not score.success
    assert a["stopped"] == {"reached": "lifted", "missed": "transferred"}
    assert a["stage_steps"]["transferred"] is None
    release = a["release"]
    assert release is not None and abs(release["step"] - 250) <= 3
    assert not release["left_touching"]
    assert release["left_gap_m"] > 0.075  # still open (the controller opens each finger to 0.04 m)


def test_right_gripper_never_closed_fails_before_the_lift(runs):
    a = runs["never_close"].analysis
    assert not runs["never_close"].success
    assert a["stage_steps"]["lifted"] is None
    assert a["stopped"]["missed"] in ("touched", "lifted")
    assert a["release"] is None


def test_report_counts_failures_by_stage_and_compares_left_gaps(runs):
    scores = [runs["scripted"], runs["open_early"], runs["never_close"]]
    report = rollouts_report("sim_transfer_cube", scores, 50.0)
    agg = report["aggregated"]
    reached = runs["never_close"].analysis["stopped"]["reached"] or "none"
    assert agg["n_episodes"] == 3 and agg["n_failed"] == 2
    assert sum(agg["failed_by_stage_reached"].values()) == 2
    assert agg["failed_by_stage_reached"]["lifted"] == 1
    assert agg["failed_by_stage_reached"][reached] >= 1
    medians = agg["median_left_gap_at_release_m"]
    assert medians["failed"] > 0.075 > 0.03 > medians["succeeded"]
    assert [e["success"] for e in report["episodes"]] == [True, False, False]
    line = failure_line(report)
    assert line.startswith("failed: 2 (furthest stage reached: ") and "lifted 1" in line


def test_stopped_at_names_the_furthest_stage_and_the_next():
    task = "sim_transfer_cube"
    assert stopped_at(task, {"touched": None, "lifted": None, "transferred": None}) == {
        "reached": None,
        "missed": "touched",
    }
    assert stopped_at(task, {"touched": 3, "lifted": None, "transferred": None}) == {
        "reached": "touched",
        "missed": "lifted",
    }


def test_release_is_the_start_of_the_first_widening_after_the_lift():
    rec = RolloutRecorder("sim_transfer_cube", 50.0)
    right = [0.088, 0.05, 0.024, 0.024, 0.0241, 0.024, 0.024, 0.025, 0.03, 0.05, 0.08]
    rec.gaps = [(0.024, g) for g in right]
    jitter_only = [(0.024, g) for g in right[:7]]
    assert rec.release_step(2) == 6  # rises from step 6 on; the 0.1 mm at step 4 is jitter
    assert rec.release_step(None) is None
    assert rec.release_step(10) is None  # nothing widens after the last step
    rec.gaps = jitter_only
    assert rec.release_step(2) is None
    assert RELEASE_OPENING > 0.0001


def test_insertion_records_stage_times_and_the_final_gaps():
    runner = EpisodeRunner(EvalSettings(policy="scripted", task="sim_insertion", seed=SEED))
    try:
        score, _ = runner.run(0)
    finally:
        runner.close()
    a = score.analysis
    assert "release" not in a
    assert set(a["stage_steps"]) == {"grasped", "contact", "inserted"}
    reached = [v for v in a["stage_steps"].values() if v is not None]
    assert reached and reached == sorted(reached)
    assert (a["stopped"] is None) == score.success
    assert 0.0 < a["end"]["left_gap_m"] < 0.09 and 0.0 < a["end"]["right_gap_m"] < 0.09
