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


def section(text: str, start: str, end: str) -> str:
    """The text from ``start`` up to ``end`` (both must be there), without the docs tests'
    needs marks (HTML comments) and with the README's ``docs/`` link prefix dropped."""
    assert start in text and end in text[text.index(start) :], (start, end)
    part = text[text.index(start) :]
    part = part[: part.index(end)]
    part = re.sub(r"^ *<!-- needs: .*-->\n", "", part, flags=re.MULTILINE)
    return part.replace("](docs/", "](")


def test_home_page_opens_as_the_readme():
    """The docs home page starts with the README's two commands and describes the test
    command in the README's words (tools/run_tests.sh: what it installs, the site it builds,
    the legs it runs)."""
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    home = (REPO / "docs" / "index.md").read_text(encoding="utf-8")
    first = 'pip install ".[video]" && trossen-mujoco record'
    assert section(home, "```bash\n", "```\n\n") == section(readme, "```bash\n", "```\n\n")
    assert first in section(home, "```bash\n", "```\n\n")
    tests_part = section(readme, "**Run the tests**", "```bash")
    assert tests_part == section(home, "**Run the tests**", "```")
    assert "(testing.md)" in tests_part
    # the Testing page describes the command in full: what it installs, the site it builds,
    # the legs it runs
    testing = (REPO / "docs" / "testing.md").read_text(encoding="utf-8")
    script = (REPO / "tools" / "run_tests.sh").read_text(encoding="utf-8")
    described = " ".join(testing.split())  # however the paragraphs are wrapped
    assert (
        "mkdocs build --strict" in script and "builds the documentation site strictly" in described
    )
    assert "chromium" in script and "Chromium" in described
    assert '-e ".[dev,cameras,docs]"' in script and "`[dev,cameras,docs]`" in described
    assert "--ignore=tests/docs" in script and "less the documentation tests" in described
    assert "ruff format --check" in script and "ruff format --check" in described
    # "python -m pytest -q ... spread over the cores": pytest's own defaults say so
    pyproject = (REPO / "pyproject.toml").read_text(encoding="utf-8")
    addopts = next(line for line in pyproject.splitlines() if line.startswith("addopts"))
    assert "-n auto" in addopts and "`MUJOCO_GL=egl python -m pytest -q` reruns" in described
    assert "spread over the cores" in described and "-n 0 -m serial" in described


def test_readme_first_screen_says_what_it_is_before_the_commands():
    """What the project is, how it relates to Trossen's package of the same name, and the
    cameras come before the first command; the test runner's legs are not on it."""
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    first_command = readme.index("```bash")
    assert readme.index("not Trossen's package of the same name") < first_command
    assert readme.index("| cam_high | cam_low |") < first_command
    assert "leg 1" not in readme and "Python 3.12 next to LeRobot" not in readme


def test_why_this_project_quotes_the_measured_figures():
    """README and home page carry the same side-by-side with Trossen's package and gym-aloha,
    and every figure in it is one the Benchmarks or Rehearsal page reports."""
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    home = (REPO / "docs" / "index.md").read_text(encoding="utf-8")
    why = section(readme, "## Why this project", "\n## ")
    assert why == section(home, "## Why this project", "\n## ")
    assert readme.index("## Why this project") > readme.index("bash tools/run_tests.sh")
    for other in (
        "github.com/TrossenRobotics/trossen_arm_mujoco",
        "github.com/huggingface/gym-aloha",
    ):
        assert other in why
    measured = "\n".join(
        (REPO / "docs" / page).read_text(encoding="utf-8")
        for page in ("benchmarks.md", "rehearsal.md")
    )
    figures = re.findall(r"\d+(?:\.\d+)? (?:min \d+ s\b|s\b|MB\b|%)|\d+\.\d+", why)
    assert len(figures) >= 8, figures
    missing = [f for f in figures if f not in measured]
    assert not missing, f"figures not on the Benchmarks or Rehearsal page: {missing}"


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
