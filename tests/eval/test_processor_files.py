"""``eval.processor_files``: where a step goes in a saved processor, and the atomic write."""

from __future__ import annotations

from trossen_arm_mujoco.eval.processor_files import place_step, read_json, write_json


def _steps(*names):
    return [{"registry_name": n} for n in names]


def test_a_step_goes_after_before_or_last_and_replaces_its_namesake():
    steps = _steps("rename", "normalizer_processor", "device")
    assert place_step(steps, "mine", {"registry_name": "mine"}, before="normalizer_processor")
    assert [s["registry_name"] for s in steps] == ["rename", "mine", "normalizer_processor",
                                                  "device"]  # fmt: skip
    assert place_step(steps, "late", {"registry_name": "late"}, after="normalizer_processor")
    assert [s["registry_name"] for s in steps][3] == "late"
    assert place_step(steps, "end", {"registry_name": "end"}, before="absent")
    assert steps[-1]["registry_name"] == "end"
    newer = {"registry_name": "mine", "config": {"camera": "cam_low"}}
    assert place_step(steps, "mine", newer, after="device")  # replaced where it was
    assert steps[1] == newer and len(steps) == 6
    assert not place_step(steps, "mine", dict(newer))  # the same step: nothing changed


def test_write_json_leaves_no_temp_file_and_reads_back(tmp_path):
    path = tmp_path / "policy_preprocessor.json"
    write_json(path, {"steps": _steps("a")})
    assert read_json(path) == {"steps": [{"registry_name": "a"}]}
    assert [p.name for p in tmp_path.iterdir()] == [path.name]
