#!/usr/bin/env bash
# The test command: installs what the tests need on a fresh Debian/Ubuntu machine (system
# packages with apt-get, the [dev] extra with a CPU torch, a Python 3.12 venv with LeRobot
# 0.6.1, the project, the LeRobot env plugin and the example task package), then runs the suite
# on this Python (spread over the cores, the served-kit tests alone after it) and the tests
# marked py312 again on 3.12 next to LeRobot, then the tests marked long (left out of a plain
# pytest run). CI (.ci/run) runs exactly this command. Already set up? MUJOCO_GL=egl python -m pytest -q
# runs leg 1 (pytest's defaults spread it over the cores; docs/testing.md: the legs, the markers
# and their timings).
set -euo pipefail
cd "$(dirname "$0")/.."
for arg in "$@"; do
    echo "error: unknown argument $arg: bash tools/run_tests.sh takes none" >&2
    exit 2
done

export DEBIAN_FRONTEND=noninteractive
SUDO=""
if [ "$(id -u)" != "0" ]; then SUDO="sudo"; fi
# Software EGL (Mesa) for headless rendering; Xvfb + screenshot tools for the live-viewer tests;
# FFmpeg's shared libraries, which torchcodec (LeRobot's video decoder) loads.
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends \
    libegl1 libegl-mesa0 libgl1 libgl1-mesa-dri \
    xvfb x11-apps imagemagick ffmpeg >/dev/null
# Headless Chromium: tests/docs screenshots the built documentation site.
$SUDO apt-get install -y -qq --no-install-recommends chromium fonts-dejavu-core >/dev/null

# setuptools >= 70.1 builds wheels itself: tests/tasks/test_task_packages.py pip-installs a
# throwaway package without build isolation (Python 3.11 ships setuptools 65, without it)
python -m pip install -q --upgrade pip "setuptools>=70.1"
# torch (for stable-baselines3) as the CPU build: without a torch already installed, [dev]
# would pull the multi-GB CUDA build. TORCH_SPEC overrides it (e.g. a CUDA machine's pin).
python -m pip install -q "${TORCH_SPEC:-torch==2.13.0}" || python -m pip install -q torch
python -m pip install -q -e ".[dev,cameras,docs]"
python -m pip install -q -e examples/my_trossen_task  # the example task package (tests/test_examples.py)

# The documentation site, strictly (a warning or a broken link fails), into site/ (git-ignored);
# tests/docs checks it (TROSSEN_DOCS_REQUIRED turns their "site not built" skip into a failure).
NO_MKDOCS_2_WARNING=1 python -m mkdocs build --strict --quiet
export TROSSEN_DOCS_REQUIRED=1

# LeRobot (the real dataset loader, lerobot-train and lerobot-eval the export and the env plugin
# are tested against) needs Python >= 3.12: a second venv, reused while it holds the pinned
# version. The project itself (with [dev,train]), the env plugin and the example task package
# (lerobot-eval --env.task=lift_puck) are installed into it on every run (editable, from this
# clone). Tests run LeRobot's tools through TROSSEN_LEROBOT_PYTHON.
LEROBOT_PINS="lerobot[dataset,training]==0.6.1 torch==2.11.0 torchvision==0.26.0 torchcodec==0.11.1 av==15.1.0 datasets==4.8.5"
LEROBOT_VENV="${TROSSEN_LEROBOT_VENV:-$HOME/.cache/trossen-arm-mujoco/lerobot-venv}"
PY312=""
PYENV_312=""
if command -v pyenv >/dev/null 2>&1; then PYENV_312="$(pyenv root)/versions/3.12.1/bin/python"; fi
for candidate in "$PYENV_312" python3.12; do  # a pyenv shim may exist yet not run: try it
    if [ -n "$candidate" ] && "$candidate" -c "import sys; assert sys.version_info[:2] == (3, 12)" 2>/dev/null; then
        PY312="$candidate"
        break
    fi
done
if [ -z "$PY312" ]; then
    echo "error: no Python 3.12 found for the LeRobot venv (pyenv install 3.12.1)" >&2
    exit 1
fi
if ! "$LEROBOT_VENV/bin/python" -c "import lerobot, accelerate, sys; sys.exit(lerobot.__version__ != '0.6.1')" 2>/dev/null; then
    rm -rf "$LEROBOT_VENV"
    "$PY312" -m venv "$LEROBOT_VENV"
    start=$(date +%s)
    for attempt in 1 2 3; do
        # shellcheck disable=SC2086
        "$LEROBOT_VENV/bin/python" -m pip install -q $LEROBOT_PINS && break
        if [ "$attempt" = 3 ]; then echo "error: installing LeRobot failed" >&2; exit 1; fi
        sleep 10
    done
    echo "LeRobot venv installed in $(( $(date +%s) - start )) s: $LEROBOT_VENV"
fi
"$LEROBOT_VENV/bin/python" -m pip install -q "setuptools>=70.1" -e ".[dev,train,cameras]" \
    -e plugins/lerobot_env_trossen -e examples/my_trossen_task
export TROSSEN_LEROBOT_PYTHON="$LEROBOT_VENV/bin/python"
# a test skipped for want of LeRobot fails instead (tests/conftest.py): none may skip silently
export TROSSEN_LEROBOT_REQUIRED=1

# The legs (docs/testing.md has their timings). Each runs even when an earlier one failed;
# the exit status is non-zero if any did.
# 0. Lint: `ruff check` and `ruff format --check` (the formatter owns the layout; the
#    version is pinned in pyproject.toml's dev extra, so every machine formats alike).
# 1. This Python (3.11 in CI), every test but those marked serial, spread over the cores by
#    pytest-xdist (PYTEST_WORKERS=N to choose; a test file stays on one worker, so its module
#    fixtures are built once and the served kits' loopback addresses, one block a module, never
#    clash). Here run, once: the documentation tests and the tests marked `once`, whose result
#    does not depend on the interpreter running pytest (LeRobot itself always runs in the 3.12
#    venv, through TROSSEN_LEROBOT_PYTHON).
# 2. This Python, the tests marked serial, alone (-n 0: on an xdist worker they skip): they measure wall-clock motion or timing of a
#    served kit (beside a busy neighbouring worker a homing test missed its tolerance).
# 3. Python 3.12 next to LeRobot 0.6.1, the tests marked py312 (tests/conftest.py lists their
#    modules: LeRobot or torch in-process, the env plugin, task entry points, every public
#    module imported, the export's video with the venv's PyAV), less the `once` ones; none
#    of them serves a kit, so they too are spread over the cores.
# 4. The tests marked long (on this Python), left out of the other legs and of a plain pytest run.
WORKERS="${PYTEST_WORKERS:-auto}"
FAILED=""
leg() {  # leg NAME COMMAND...: runs it, prints its wall-clock time, notes a failure
    local name="$1" start
    shift
    start=$(date +%s)
    echo "== $name"
    if ! MUJOCO_GL=egl "$@"; then FAILED="${FAILED:+$FAILED, }$name"; fi
    echo "== $name: $(( $(date +%s) - start )) s"
}
leg "leg 0 (lint)" bash -c 'ruff check --quiet . && ruff format --check --quiet .'
leg "leg 1 (this Python, parallel)" python -m pytest -q -n "$WORKERS" --dist loadfile -m "not serial"
leg "leg 2 (this Python, serial)" python -m pytest -q -p no:cacheprovider -n 0 -m serial
leg "leg 3 (Python 3.12, LeRobot)" "$LEROBOT_VENV/bin/python" -m pytest -q -p no:cacheprovider \
    -n "$WORKERS" --dist loadfile --ignore=tests/docs -m "py312 and not once"
leg "leg 4 (this Python, long)" python -m pytest -q -p no:cacheprovider -n 0 --long -m long
if [ -n "$FAILED" ]; then
    echo "error: failed: $FAILED" >&2
    exit 1
fi
