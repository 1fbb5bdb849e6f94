#!/usr/bin/env bash
# In-process vs through-the-wire success of one policy on the same seeds (docs/rehearsal.md,
# "Measured"): `trossen-mujoco eval` in-process, then `eval --backend wire` (a served kit on
# loopback, the trossen_arm driver, wall-clock pacing), as sent and with the goals shortened
# to 90 % of the real speed limits. Prints each run's success line; the eval_info.json
# (with the wire runs' timing block) and rollouts.json of each run stay in OUT.
#
#   bash benchmarks/wire_rehearsal.sh POLICY [EPISODES] [FPS] [OUT]
#   bash benchmarks/wire_rehearsal.sh scripted 10 30
#   bash benchmarks/wire_rehearsal.sh .../checkpoints/last/pretrained_model 20 50
#
# POLICY: scripted, module:function or a LeRobot checkpoint (run with LeRobot's Python:
# PYTHON=~/.cache/trossen-arm-mujoco/lerobot-venv/bin/python). FPS: the policy's rate (a
# checkpoint's is its dataset's). Loopback only (127.0.0.61/62, ports 5655/5656).
set -euo pipefail
POLICY=${1:?usage: wire_rehearsal.sh POLICY [EPISODES] [FPS] [OUT]}
EPISODES=${2:-20}
FPS=${3:-50}
OUT=${4:-wire_rehearsal}
PY=${PYTHON:-python}
export MUJOCO_GL=egl
KIT=(--left_ip 127.0.0.61 --right_ip 127.0.0.62 --camera_port 5655 --control_port 5656)
run() {  # NAME FLAGS...
    local name=$1
    shift
    "$PY" -m trossen_arm_mujoco.cli eval --policy "$POLICY" --task_name sim_transfer_cube \
        --num_episodes "$EPISODES" --seed 0 --fps "$FPS" --output_dir "$OUT/$name" \
        --overwrite "$@" 2>&1 | grep -E "succeeded|^error" | sed "s/^/$name: /"
}
run in_process
run wire "--backend" wire "${KIT[@]}"
run wire_speed_0.9 --backend wire "${KIT[@]}" --speed_limit_fraction 0.9
