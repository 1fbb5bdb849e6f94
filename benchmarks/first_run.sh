#!/usr/bin/env bash
# The README's first command from scratch, timed: a fresh virtual environment, a fresh HOME,
# pip's cache off, then exactly
#     pip install ".[video]" && trossen-mujoco record --data_dir demo --num_episodes 1 \
#         && trossen-mujoco visualize --data_dir demo
# Prints wall and CPU seconds (user + sys of every process and thread it started) of each
# part and of the whole, the episode's size and the machine's load. Needs network access to
# PyPI and about 5 minutes on a 2-core CPU with software rendering (run it on an idle machine:
# the figure on the Getting started page was taken so).
#
#     bash benchmarks/first_run.sh [python]      # python: the interpreter to make the venv with
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON="${1:-python3}"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
export HOME="$WORK/home" PIP_NO_CACHE_DIR=1 MUJOCO_GL=egl
mkdir -p "$HOME"
echo "first run: $(date -u +%Y-%m-%dT%H:%MZ), $(nproc) CPUs, load average $(cut -d' ' -f1 /proc/loadavg)"
"$PYTHON" -m venv "$WORK/venv"
# shellcheck disable=SC1091
source "$WORK/venv/bin/activate"

TIMEFORMAT="%R s wall, %U s user + %S s sys"
echo "install:";   time pip install -q ".[video]"
echo "record:";    time trossen-mujoco record --data_dir demo --num_episodes 1
echo "visualize:"; time trossen-mujoco visualize --data_dir demo
echo "episode: $(du -h "$HOME/.trossen/mujoco/data/demo/episode_0.hdf5" | cut -f1); load average now $(cut -d' ' -f1 /proc/loadavg)"
# The whole is the sum of the three parts (the README chains them with &&).
