"""The README is the front door (short, the two commands first, links that resolve), and
the numbers behind the Benchmarks page's plots are the page's own."""

from __future__ import annotations

import json
import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def test_readme_is_a_short_front_door():
    text = (REPO / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 250
    blocks = re.findall(r"```(\w+)\n(.*?)```", text, re.DOTALL)
    assert blocks[0][1].startswith('pip install ".[video]" && trossen-mujoco record')
    assert blocks[1][1].strip() == "bash tools/run_tests.sh"
    for heading in ("## Record", "## Export, train, evaluate", "## Gymnasium", "mkdocs serve"):
        assert heading in text
    links = re.findall(r"\]\(((?:docs)/[^)#]+)(?:#[^)]*)?\)", text)
    assert len(links) >= 15
    missing = [link for link in links if not (REPO / link).exists()]
    assert not missing, missing


def test_plotted_runs_are_the_benchmark_tables_runs():
    curves = json.loads((REPO / "docs" / "data" / "benchmark_curves.json").read_text())
    page = (REPO / "docs" / "benchmarks.md").read_text(encoding="utf-8")
    for run in curves["training_success"]["runs"]:
        low, high = run["ci"]
        quoted = f"{run['seed']}: {run['success']} % ({low}-{high})"
        quoted_bold = f"{run['seed']}: **{run['success']} %** ({low}-{high})"
        assert quoted in page or quoted_bold in page, quoted
    for key in ("camera_run_loss", "crop_run_loss"):
        loss = curves[key]
        assert loss["label"] and loss["measured"], key
        for step, value in zip(loss["steps"], loss["loss"], strict=True):
            label = f"{step // 1000}k" if step >= 1000 else f"step {step}"
            assert f"{value:.3f} ({label})" in page, (key, step, value)


def test_plotted_recording_cost_is_the_benchmark_table():
    cost = json.loads((REPO / "docs" / "data" / "benchmark_curves.json").read_text())
    page = (REPO / "docs" / "benchmarks.md").read_text(encoding="utf-8")
    cost = cost["recording_cost"]
    assert cost["source"].startswith("benchmarks/record_episode.py --sweep")
    assert re.match(r"20\d\d-\d\d-\d\d, ", cost["measured"]), "when and where"
    assert (REPO / "docs" / "images" / "benchmarks" / "recording_cost.png").is_file()
    assert "images/benchmarks/recording_cost.png" in page
    for setting in cost["settings"]:
        assert len(setting["points"]) >= 3, setting["label"]
        for p in setting["points"]:
            row = (
                f"| {setting['label']} | {p['steps']} | {p['wall_s']:.2f} | {p['cpu_s']:.2f} "
                f"| {p['bytes'] / 1e6:.2f} |"
            )
            assert row in page, row
