"""``eval.processor_files``: where a step goes in a saved processor, and the all-or-none
write."""

from __future__ import annotations

import json

from trossen_arm_mujoco.eval.processor_files import (
    POSTPROCESSOR_FILE,
    PREPROCESSOR_FILE,
    SavedProcessors,
    place_step,
    read_json,
)


def _steps(*names):
    return [{"registry_name": n} for n in names]


def test_a_step_goes_after_before_or_last_and_replaces_its_namesake():
    steps = _steps("rename", "normalizer_processor", "device")
    assert place_step(steps, "mine", {"registry_name": "mine"}, before="normalizer_processor")
    assert [s["registry_name"] for s in steps] == [
        "rename",
        "mine",
        "normalizer_processor",
        "device",
    ]
    assert place_step(steps, "late", {"registry_name": "late"}, after="normalizer_processor")
    assert [s["registry_name"] for s in steps][3] == "late"
    assert place_step(steps, "end", {"registry_name": "end"}, before="absent")
    assert steps[-1]["registry_name"] == "end"
    newer = {"registry_name": "mine", "config": {"camera": "cam_low"}}
    assert place_step(steps, "mine", newer, after="device")  # replaced where it was
    assert steps[1] == newer and len(steps) == 6
    assert not place_step(steps, "mine", dict(newer))  # the same step: nothing changed


def test_save_writes_what_changed_and_leaves_no_temp_file(tmp_path):
    for name in (PREPROCESSOR_FILE, POSTPROCESSOR_FILE):
        (tmp_path / name).write_text(json.dumps({"steps": _steps("a")}))
    procs = SavedProcessors.load(tmp_path)
    assert not procs.changed() and procs.save() is False
    procs.pre["steps"].append({"registry_name": "b"})
    assert procs.changed() and procs.save() is True
    assert read_json(tmp_path / PREPROCESSOR_FILE)["steps"][-1] == {"registry_name": "b"}
    assert sorted(p.name for p in tmp_path.iterdir()) == [POSTPROCESSOR_FILE, PREPROCESSOR_FILE]
    assert procs.save() is False  # saved: nothing new
