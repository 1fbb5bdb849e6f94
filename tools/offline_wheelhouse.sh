#!/usr/bin/env bash
# Wheels for training with LeRobot on an offline Python 3.12 machine that already has torch.
#
#   tools/offline_wheelhouse.sh [FOLDER] [--missing-only | --lean] [--with-sim]
#
# Downloads into FOLDER (default ./wheelhouse) every wheel that `lerobot[dataset,training]==0.6.1`
# training needs (with this project's [train] pins: torchcodec 0.11.1, av 15.1.0, datasets 4.8.5),
# for CPython 3.12 on manylinux x86_64, binary wheels only, EXCEPT torch, torchvision, triton,
# nvidia-* and cuda-* (the machine has torch 2.11.0 / torchvision 0.26.0 and their CUDA
# libraries) and what only those need (sympy, networkx, ...). Also setuptools and wheel, to
# install this project (and the LeRobot env plugin) from source there without its simulator.
#
#   --missing-only  only the packages a typical CUDA/torch image lacks (see TYPICAL below): the
#                   smallest set to carry; the image's own copies must then satisfy LeRobot's
#                   version ranges (printed at the end)
#   --lean          --missing-only, and also without what training never imports: cmake (a build
#                   tool LeRobot lists), wandb and what only it needs (train with
#                   --wandb.enable=false), opencv-python-headless (the image's opencv-python
#                   gives cv2); install these wheels with --no-deps (pip's resolver would ask
#                   for the left-out ones), as benchmarks/gpu_leg.py --wheels does
#   --with-sim      also this project's own dependencies (mujoco, dm_control, scipy, ...), for
#                   recording and evaluating on that machine too (large)
#
# How: a throwaway Python 3.12 venv resolves the requirements with pip's resolver
# (`pip install --dry-run --report`, constrained to torch==2.11.0 torchvision==0.26.0, so the
# versions are those a torch-2.11 machine gets), the report's dependency graph is walked from
# the requested packages without entering torch's family, and `pip download --no-deps` fetches
# the pinned wheels. Idempotent: wheels already in FOLDER are not downloaded again; wheels of
# an earlier run that are no longer wanted are listed, never deleted. Writes FOLDER/requirements.txt
# (the pins). Needs Linux x86_64 and network access to the package index (PIP_INDEX_URL or PyPI;
# this machine's pip.conf and find-links are ignored). Python: $PYTHON312, else pyenv's 3.12.1,
# else python3.12 on PATH.
set -euo pipefail

usage() { sed -n '2,4p' "$0" | sed 's/^# \{0,1\}//'; exit "${1:-0}"; }

FOLDER="./wheelhouse"
MISSING_ONLY=0
LEAN=0
WITH_SIM=0
for arg in "$@"; do
    case "$arg" in
        --missing-only) MISSING_ONLY=1 ;;
        --lean) MISSING_ONLY=1; LEAN=1 ;;
        --with-sim) WITH_SIM=1 ;;
        -h|--help) usage 0 ;;
        -*) echo "error: unknown option $arg" >&2; usage 2 >&2 ;;
        *) FOLDER="$arg" ;;
    esac
done

if [ "$(uname -s)-$(uname -m)" != "Linux-x86_64" ]; then
    echo "error: run this on Linux x86_64 (it resolves for this platform)," \
        "not $(uname -s)-$(uname -m)" >&2
    exit 2
fi
PY="${PYTHON312:-}"
if [ -z "$PY" ] && command -v pyenv >/dev/null 2>&1; then
    PYENV_PY="$(pyenv root)/versions/3.12.1/bin/python"
    if [ -x "$PYENV_PY" ]; then PY="$PYENV_PY"; fi
fi
if [ -z "$PY" ]; then PY="$(command -v python3.12 || true)"; fi
IS_312='import sys; print(sys.version_info[:2] == (3, 12))'
if [ -z "$PY" ] || [ "$("$PY" -c "$IS_312")" != "True" ]; then
    echo "error: no Python 3.12 found; set PYTHON312=/path/to/python3.12" >&2
    exit 2
fi

ROOT="$(cd "$(dirname "$0")/.." && pwd)"
mkdir -p "$FOLDER"
FOLDER="$(cd "$FOLDER" && pwd)"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
# Only the package index: not this machine's pip.conf (local mirrors, find-links, constraints).
export PIP_CONFIG_FILE=/dev/null
unset PIP_FIND_LINKS PIP_EXTRA_INDEX_URL PIP_CONSTRAINT PIP_REQUIRE_VIRTUALENV || true
export PIP_DISABLE_PIP_VERSION_CHECK=1

echo "== wheelhouse: $FOLDER (CPython 3.12, manylinux x86_64;" \
    "index: ${PIP_INDEX_URL:-https://pypi.org/simple})"
echo "== resolving in a throwaway venv ($PY)"
"$PY" -m venv "$WORK/venv"
VPY="$WORK/venv/bin/python"

printf 'torch==2.11.0\ntorchvision==0.26.0\n' >"$WORK/constraints.txt"
{
    echo "lerobot[dataset,training]==0.6.1"
    # the project's [train] extra pins these next to LeRobot (pyproject.toml)
    echo "torchcodec==0.11.1"
    echo "av==15.1.0"
    echo "datasets==4.8.5"
    # build requirements of the project and of plugins/lerobot_env_trossen (installed from source)
    echo "setuptools>=77"
    echo "wheel"
} >"$WORK/requirements.in"
if [ "$WITH_SIM" = 1 ]; then
    "$VPY" - "$ROOT/pyproject.toml" >>"$WORK/requirements.in" <<'EOF'
import sys, tomllib
with open(sys.argv[1], "rb") as f:
    print("\n".join(tomllib.load(f)["project"]["dependencies"]))
EOF
fi

"$VPY" -m pip install -q --dry-run --ignore-installed --only-binary=:all: \
    --report "$WORK/report.json" -c "$WORK/constraints.txt" -r "$WORK/requirements.in"

"$VPY" - "$WORK/report.json" "$FOLDER" "$MISSING_ONLY" "$LEAN" >"$WORK/plan.txt" <<'EOF'
"""Walk the resolved graph from the requested packages, not entering torch's family."""
import json, re, sys
from pip._vendor.packaging.requirements import Requirement

report, folder = sys.argv[1], sys.argv[2]
missing_only, lean = sys.argv[3] == "1", sys.argv[4] == "1"
norm = lambda n: re.sub(r"[-_.]+", "-", n).lower()
# torch and what comes with it: the machine has them
EXCLUDED = re.compile(r"^(torch|torchvision|torchaudio|triton|nvidia-.*|cuda-.*)$")
if lean:  # never imported by lerobot-train (wandb only with --wandb.enable=true)
    EXCLUDED = re.compile(EXCLUDED.pattern[:-2] + r"|cmake|wandb|opencv-python-headless)$")
# A typical CUDA/torch image (NGC-style): these, and what they depend on
TYPICAL = {norm(n) for n in """
torch torchvision triton accelerate h5py huggingface-hub numpy pandas pyarrow pillow safetensors
einops opencv-python matplotlib requests tqdm pyyaml
filelock typing-extensions sympy mpmath networkx jinja2 markupsafe fsspec setuptools wheel packaging
psutil python-dateutil pytz tzdata six certifi charset-normalizer idna urllib3
contourpy cycler fonttools kiwisolver pyparsing
""".split()}

items = {norm(i["metadata"]["name"]): i for i in json.load(open(report))["install"]}
graph, wanted_by = {}, {}
kept, todo = {}, []
for name, item in items.items():
    if item.get("requested"):
        todo.append((name, set(item.get("requested_extras") or ())))
while todo:
    name, extras = todo.pop()
    if EXCLUDED.match(name) or name not in items:
        continue
    old = kept.get(name)
    if old is not None and extras <= old:
        continue
    kept[name] = (old or set()) | extras
    for text in items[name]["metadata"].get("requires_dist") or ():
        req = Requirement(text)
        envs = [{"extra": e} for e in sorted(kept[name] | {""})]
        if req.marker is not None and not any(req.marker.evaluate(e) for e in envs):
            continue
        dep = norm(req.name)
        if dep in items:
            wanted_by.setdefault(dep, set()).add(f"{name} {req.specifier or '(any)'}")
            todo.append((dep, set(req.extras)))

rows = []
for name in sorted(kept):
    item = items[name]
    url = item["download_info"]["url"]
    rows.append((name, item["metadata"]["version"], url.rsplit("/", 1)[-1], name in TYPICAL))
for name, version, filename, typical in rows:
    if missing_only and typical:
        continue
    print(f"PIN {name} {version} {filename}")
for name, version, filename, typical in rows:
    print(f"{'TYPICAL' if typical else 'MISSING'} {name} {version}")
for name, version, filename, typical in rows:
    if typical:
        needs = "; ".join(sorted(wanted_by.get(name, {"requested"})))
        print(f"RANGE {name} {version} needed by: {needs}")
EOF

grep '^PIN ' "$WORK/plan.txt" | awk '{print $2 "==" $3}' >"$WORK/requirements.txt"
echo "== downloading $(wc -l <"$WORK/requirements.txt") wheels (--no-deps, binary only)"
"$VPY" -m pip download -q --no-deps --only-binary=:all: -d "$FOLDER" -r "$WORK/requirements.txt"
cp "$WORK/requirements.txt" "$FOLDER/requirements.txt.tmp"
mv "$FOLDER/requirements.txt.tmp" "$FOLDER/requirements.txt"  # atomic

# Every wanted wheel present, and each one for CPython 3.12 / abi3 / py3 on manylinux x86_64 or any
"$VPY" - "$WORK/plan.txt" "$FOLDER" <<'EOF'
import re, sys
from pathlib import Path
from pip._vendor.packaging.utils import parse_wheel_filename

plan, folder = Path(sys.argv[1]).read_text().splitlines(), Path(sys.argv[2])
norm = lambda n: re.sub(r"[-_.]+", "-", n).lower()
have = {}
for whl in folder.glob("*.whl"):
    name, version, _, tags = parse_wheel_filename(whl.name)
    have.setdefault((norm(name), str(version)), []).append(whl)
    ok = [t for t in tags
          if (t.interpreter in ("cp312", "py312", "py3", "py2") or t.abi == "abi3")
          and (t.platform == "any"
               or (t.platform.startswith("manylinux") and t.platform.endswith("_x86_64")))]
    if not ok:
        sys.exit(f"error: {whl.name} is not a CPython 3.12 manylinux x86_64 wheel")
wanted = {(p.split()[1], p.split()[2]) for p in plan if p.startswith("PIN ")}
missing = sorted(wanted - set(have))
if missing:
    sys.exit(f"error: not downloaded: {missing}")
stale = sorted(w.name for key, files in have.items() if key not in wanted for w in files)
size = lambda files: sum(f.stat().st_size for f in files)
files = [f for key in wanted for f in have[key]]
total = size(files)
print(f"== {len(files)} wheels, {total / 2**20:.1f} MiB in {folder}")
print("   largest:")
for f in sorted(files, key=lambda f: -f.stat().st_size)[:8]:
    print(f"   {f.stat().st_size / 2**20:7.1f} MiB  {f.name}")
if stale:
    print(f"   not wanted any more (from an earlier run; delete them by hand): {', '.join(stale)}")
lacks = [line.split()[1:] for line in plan if line.startswith("MISSING ")]
lack_files = [f for n, v in lacks for f in have.get((n, v), [])]
print(f"== what a typical CUDA/torch image lacks ({len(lacks)} packages, "
      f"{size(lack_files) / 2**20:.1f} MiB):")
print("   " + " ".join(f"{n}=={v}" for n, v in lacks))
print("== in a typical image, but LeRobot needs these ranges (check the image's versions):")
for line in plan:
    if line.startswith("RANGE "):
        print("   " + line[6:])
EOF

NO_DEPS="--no-deps "
if [ "$WITH_SIM" = 1 ]; then NO_DEPS=""; fi
if [ "$LEAN" = 1 ]; then
    cat <<EOF
== on the offline machine (Python 3.12 with torch 2.11.0, torchvision 0.26.0, cv2 and the
   typical packages above installed), with this folder copied there as WHEELS and this
   repository's source tree as REPO:
   pip install --no-index --no-deps WHEELS/*.whl
   pip install --no-index --no-deps --no-build-isolation -e REPO -e REPO/plugins/lerobot_env_trossen
   then train with --wandb.enable=false. (torchcodec needs FFmpeg's shared libraries, e.g.
   apt-get install ffmpeg; without them train with --dataset.video_backend=pyav.)
EOF
    exit 0
fi
cat <<EOF
== on the offline machine (Python 3.12 with torch 2.11.0 and torchvision 0.26.0 installed), with
   this folder copied there as WHEELS and this repository's source tree as REPO:
   pip install --no-index --find-links WHEELS "lerobot[dataset,training]==0.6.1" \\
       torchcodec==0.11.1 av==15.1.0 datasets==4.8.5
   pip install --no-index --find-links WHEELS ${NO_DEPS}-e REPO -e REPO/plugins/lerobot_env_trossen
   (building the project needs setuptools>=77 and wheel, in WHEELS unless --missing-only; with an
   older setuptools on the machine add --no-build-isolation. torchcodec needs FFmpeg's shared
   libraries, e.g. apt-get install ffmpeg; without them train with --dataset.video_backend=pyav:
   av bundles its own FFmpeg.)
EOF
