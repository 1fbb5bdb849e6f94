"""Scores: the Wilson interval, stages, eval_info.json's blocks and its atomic write."""

from __future__ import annotations

import json
import math

import pytest

from trossen_arm_mujoco.eval.scores import (
    STAGES,
    EpisodeScore,
    aggregate,
    eval_info,
    stages_reached,
    wilson_interval,
    write_eval_info,
)
from trossen_arm_mujoco.tasks import registry


# -- Wilson interval --------------------------------------------------------------------------
@pytest.mark.parametrize(
    "wins,n,lo,hi",
    [
        (8, 10, 49.02, 94.33),  # the textbook example
        (5, 10, 23.66, 76.34),
        (1, 10, 1.79, 40.42),
        (50, 100, 40.38, 59.62),
        (95, 100, 88.82, 97.85),
        (1, 1, 20.65, 100.0),
    ],
)
def test_wilson_interval_known_values(wins, n, lo, hi):
    got = wilson_interval(wins, n)
    assert got == pytest.approx((lo, hi), abs=0.01)


def test_wilson_interval_edges():
    for n in (1, 2, 10, 50):
        lo, hi = wilson_interval(0, n)
        assert lo == 0.0 and 0 < hi < 100
        lo, hi = wilson_interval(n, n)
        assert hi == 100.0 and 0 < lo < 100  # exactly 100, not 99.99999
    assert wilson_interval(0, 0) == (0.0, 0.0)
    assert wilson_interval(0, 10)[1] == pytest.approx(27.75, abs=0.01)
    assert wilson_interval(10, 10)[0] == pytest.approx(72.25, abs=0.01)


def test_wilson_interval_is_symmetric_and_holds_the_rate():
    for n in (3, 10, 37):
        for wins in range(n + 1):
            lo, hi = wilson_interval(wins, n)
            mirror_lo, mirror_hi = wilson_interval(n - wins, n)
            assert lo == pytest.approx(100 - mirror_hi, abs=1e-9)
            assert hi == pytest.approx(100 - mirror_lo, abs=1e-9)
            assert 0 <= lo <= 100 * wins / n <= hi <= 100


# -- stages -----------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "best,expected",
    [
        (0.0, {"touched": False, "lifted": False, "transferred": False}),
        (0.99, {"touched": False, "lifted": False, "transferred": False}),
        (1.0, {"touched": True, "lifted": False, "transferred": False}),
        (2.0, {"touched": True, "lifted": True, "transferred": False}),
        (3.0, {"touched": True, "lifted": True, "transferred": False}),
        (4.0, {"touched": True, "lifted": True, "transferred": True}),
    ],
)
def test_transfer_stages(best, expected):
    assert stages_reached("sim_transfer_cube", best) == expected


@pytest.mark.parametrize(
    "best,expected",
    [
        (0.0, {"grasped": False, "contact": False, "inserted": False}),
        (1.0, {"grasped": False, "contact": False, "inserted": False}),
        (2.0, {"grasped": True, "contact": False, "inserted": False}),
        (3.0, {"grasped": True, "contact": True, "inserted": False}),
        (3.5, {"grasped": True, "contact": True, "inserted": False}),
        (4.0, {"grasped": True, "contact": True, "inserted": True}),
    ],
)
def test_insertion_stages(best, expected):
    assert stages_reached("sim_insertion", best) == expected


def test_a_task_without_stages_has_none():
    assert stages_reached("reach", 4.0) == {}
    assert {"sim_transfer_cube", "sim_insertion"} <= set(STAGES)  # tasks that declare stages
    assert not {"reach", "push", "pick_place"} & set(STAGES)
    assert STAGES["sim_transfer_cube"] == registry.load("sim_transfer_cube").stages


# -- aggregate and eval_info ------------------------------------------------------------------
def _episodes(task: str, rewards: list[tuple[float, float]]) -> list[EpisodeScore]:
    return [
        EpisodeScore(
            episode_ix=i,
            seed=100 + i,
            sum_reward=total,
            max_reward=best,
            success=best >= 4.0,
            steps=600,
            stages=stages_reached(task, best),
        )
        for i, (total, best) in enumerate(rewards)
    ]


def test_aggregate_numbers():
    eps = _episodes("sim_transfer_cube", [(100.0, 4.0), (50.0, 2.0), (10.0, 1.0), (0.0, 0.0)])
    agg = aggregate("sim_transfer_cube", eps, 8.0)
    assert agg["avg_sum_reward"] == 40.0
    assert agg["avg_max_reward"] == 1.75
    assert agg["pc_success"] == 25.0
    assert agg["pc_success_ci95"] == list(wilson_interval(1, 4))
    assert agg["n_episodes"] == 4
    assert agg["stages"] == {"touched": 75.0, "lifted": 50.0, "transferred": 25.0}
    assert agg["eval_s"] == 8.0 and agg["eval_ep_s"] == 2.0


def test_aggregate_of_no_episode():
    agg = aggregate("sim_insertion", [], 0.0)
    assert agg["n_episodes"] == 0 and math.isnan(agg["pc_success"])
    assert agg["pc_success_ci95"] == [0.0, 0.0]
    assert agg["stages"] == {"grasped": 0.0, "contact": 0.0, "inserted": 0.0}


def test_eval_info_blocks():
    eps = _episodes("sim_insertion", [(300.0, 4.0), (120.0, 3.0)])
    run = {"policy": "scripted", "seed": 100}
    info = eval_info("sim_insertion", eps, 3.0, ["videos/eval_episode_0.mp4"], run)
    assert set(info) == {
        "task",
        "per_episode",
        "aggregated",
        "overall",
        "video_paths",
        "run",
        "controller",
    }
    assert info["task"] == "sim_insertion" and info["run"] == run
    agg = info["aggregated"]
    for key in ("pc_success", "avg_sum_reward", "avg_max_reward", "pc_success_ci95", "stages"):
        assert key in agg, key
    assert agg["pc_success"] == 50.0 and agg["avg_sum_reward"] == 210.0
    assert agg["avg_max_reward"] == 3.5
    assert agg["stages"] == {"grasped": 100.0, "contact": 100.0, "inserted": 50.0}
    assert info["per_episode"] == [
        {
            "episode_ix": 0,
            "seed": 100,
            "sum_reward": 300.0,
            "max_reward": 4.0,
            "success": True,
            "steps": 600,
            "stages": {"grasped": True, "contact": True, "inserted": True},
            "fault": None,
        },
        {
            "episode_ix": 1,
            "seed": 101,
            "sum_reward": 120.0,
            "max_reward": 3.0,
            "success": False,
            "steps": 600,
            "stages": {"grasped": True, "contact": True, "inserted": False},
            "fault": None,
        },
    ]
    assert info["controller"] == {
        "checks": True,
        "faulted_episodes": 0,
        "faults_by_joint": {},
        "faults_by_reason": {},
        "peak_speed_fraction": {},
    }
    overall = info["overall"]  # lerobot-eval's top-level names
    for key in (
        "avg_sum_reward",
        "avg_max_reward",
        "pc_success",
        "n_episodes",
        "eval_s",
        "eval_ep_s",
    ):
        assert overall[key] == agg[key], key
    assert overall["video_paths"] == info["video_paths"] == ["videos/eval_episode_0.mp4"]
    assert "run" not in eval_info("sim_insertion", eps, 3.0)


def test_write_eval_info_is_atomic_and_round_trips(tmp_path):
    info = eval_info("sim_transfer_cube", _episodes("sim_transfer_cube", [(1.0, 4.0)]), 1.0)
    out = tmp_path / "nested" / "eval_info.json"
    assert write_eval_info(out, info) == out
    assert json.loads(out.read_text(encoding="utf-8")) == info
    assert [p.name for p in out.parent.iterdir()] == ["eval_info.json"]  # no .tmp left
    info["task"] = "replaced"
    write_eval_info(out, info)  # replaces, again through a temp file
    assert json.loads(out.read_text(encoding="utf-8"))["task"] == "replaced"
    assert [p.name for p in out.parent.iterdir()] == ["eval_info.json"]


def test_write_eval_info_failure_leaves_no_temp_and_keeps_the_old_file(tmp_path):
    out = tmp_path / "eval_info.json"
    write_eval_info(out, {"task": "old"})
    with pytest.raises(TypeError):
        write_eval_info(out, {"task": object()})  # not JSON serialisable
    assert json.loads(out.read_text(encoding="utf-8")) == {"task": "old"}
    assert [p.name for p in tmp_path.iterdir()] == ["eval_info.json"]


def test_the_rollout_analysis_stays_out_of_eval_info():
    """``EpisodeScore.analysis`` goes to rollouts.json: eval_info.json's per-episode keys are
    lerobot-eval's, and two scores differing only in it compare equal."""
    (a,) = _episodes("sim_transfer_cube", [(10.0, 4.0)])
    b = EpisodeScore(**{**a.__dict__, "analysis": {"stage_steps": {"touched": 3}}})
    assert a == b
    row = eval_info("sim_transfer_cube", [b], 1.0)["per_episode"][0]
    assert set(row) == {
        "episode_ix",
        "seed",
        "sum_reward",
        "max_reward",
        "success",
        "steps",
        "stages",
        "fault",
    }


def test_the_controller_block_counts_faults_by_joint_and_reason():
    from trossen_arm_mujoco.eval.scores import controller_summary

    eps = _episodes("sim_transfer_cube", [(10.0, 1.0), (20.0, 2.0), (30.0, 4.0)])
    speed = {"joint": "right_gripper", "kind": "speed", "asked": 0.2, "limit": 0.0875, "step": 3}
    pos = {"joint": "left_joint_1", "kind": "position", "asked": 2.0, "limit": 1.57, "step": 9}
    eps[0].fault, eps[1].fault = speed, pos
    eps[0].peak_speed_fraction = {"right_gripper": 2.29, "left_joint_1": 0.5}
    eps[2].peak_speed_fraction = {"right_gripper": 0.9, "left_joint_1": 0.7}
    block = controller_summary(eps, checks=True)
    assert block["faulted_episodes"] == 2
    assert block["faults_by_joint"] == {"left_joint_1": 1, "right_gripper": 1}
    assert block["faults_by_reason"] == {"position": 1, "speed": 1}
    assert block["peak_speed_fraction"] == {"right_gripper": 2.29, "left_joint_1": 0.7}
    assert controller_summary(eps, checks=False)["checks"] is False
