"""Where a rendered frame's CPU goes, and what each rendering change saves (docs/benchmarks.md,
"Rendering cost").

    MUJOCO_GL=egl python benchmarks/render_profile.py                    # every size, 1 and 4 cams
    MUJOCO_GL=egl python benchmarks/render_profile.py --sizes 60x80 --cams 1 --frames 100
    MUJOCO_GL=egl python benchmarks/render_profile.py --sizes 60x80 --cams 1 --crop  # recipes' view

The Stationary AI kit at its home pose (``trossen_ai_scene_joint.xml``), rendered with raw
``mujoco.Renderer`` calls, one process a row (Mesa reads its thread count once per process).
Each frame is split into the scene update (``mjv_updateScene``), the draw calls
(``mjr_render``, which queues the shadow pass and the lit passes) and the finish and read-back
(``mjr_readPixels``, which waits for the rasterizer, resolves the multisampled buffer and
copies the pixels). Rows:

- ``before``: the settings of the commit before this change (an infinite floor plane, the
  2048 shadow map scaled to the image, MuJoCo's default cuts of its built-in shapes, Mesa's
  rasterizer threads, 4x multisampling);
- one row for each change alone on top of ``before`` (a finite floor, the 1024 shadow map,
  coarser built-in shapes, no rasterizer threads);
- ``now``: what ``sim.cameras.CameraSet`` does by default, then with ``--no_antialias`` and
  with ``--no_shadows`` (``SceneLooks``).

CPU is this process's time (``time.process_time``: every thread, Mesa's included); the ratio is
against ``before`` measured in the same run, and the PSNR (dB) is against ``before``'s frames
of the same cameras (identical frames print ``same``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SCENE = "stationary_ai/trossen_ai_scene_joint.xml"
CAMERAS = ("cam_high", "cam_low", "cam_left_wrist", "cam_right_wrist")
#: MuJoCo's default cuts of its built-in shapes (numquads, numslices, numstacks).
MUJOCO_SHAPES = (4, 28, 16)
#: the camera recipes' crop of ``cam_high`` (``--crop``)
RECIPE_CROP = "cam_high:217,243,150,200"
#: row name -> (floor, model shadow map, built-in shapes, threads, antialias, shadows);
#: "model" shapes are the model's own ``<quality>``, "auto" threads are ``CameraSet``'s choice.
ROWS = {
    "before": ("infinite", 2048, MUJOCO_SHAPES, "mesa", True, True),
    "finite floor": ("finite", 2048, MUJOCO_SHAPES, "mesa", True, True),
    "shadow map 1024": ("infinite", 1024, MUJOCO_SHAPES, "mesa", True, True),
    "coarser shapes": ("infinite", 2048, "model", "mesa", True, True),
    "no raster threads": ("infinite", 2048, MUJOCO_SHAPES, "none", True, True),
    "now": ("finite", 1024, "model", "auto", True, True),
    "now --no_antialias": ("finite", 1024, "model", "auto", False, True),
    "now --no_shadows": ("finite", 1024, "model", "auto", True, False),
}


def child(
    row: str, size: tuple[int, int], ncams: int, frames: int, out: Path, crop: bool = False
) -> dict:
    """Measure one row in this process; the frames go to ``out`` (.npz)."""
    floor, map_size, shapes, threads, antialias, shadows = ROWS[row]
    import mujoco
    import numpy as np

    from trossen_arm_mujoco.constants import ASSETS_DIR
    from trossen_arm_mujoco.sim.cameras import render_threads, shadow_map_size

    chosen = {"none": "0", "mesa": None, "auto": render_threads(*size)}[threads]
    if chosen is not None:  # read when Mesa starts, at the first context below
        os.environ["LP_NUM_THREADS"] = chosen
    spec = mujoco.MjSpec.from_file(str(Path(ASSETS_DIR) / SCENE))
    if floor == "infinite":
        spec.geom("ground").size = [0, 0, 0.05]
    model = spec.compile()
    if crop:
        from trossen_arm_mujoco.sim.camera_crop import apply_crops, parse_crops

        apply_crops(model, parse_crops([RECIPE_CROP]))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    if not shadows:
        model.light_castshadow[:] = 0
    if not antialias:
        model.vis.quality.offsamples = 0
    if shapes != "model":
        q = model.vis.quality
        q.numquads, q.numslices, q.numstacks = shapes
    model.vis.quality.shadowsize = shadow_map_size(map_size, *size)
    renderer = mujoco.Renderer(model, *size)
    cams = CAMERAS[:ncams]
    opt, pert = mujoco.MjvOption(), mujoco.MjvPerturb()
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FIXED
    image = np.empty((*size, 3), np.uint8)
    con, scene, rect = renderer._mjr_context, renderer.scene, renderer._rect
    shots = {}
    parts = np.zeros(3)
    for k in range(frames + 1):  # the first frame warms up, untimed
        for name in cams:
            cam.fixedcamid = model.camera(name).id
            t0 = time.process_time()
            mujoco.mjv_updateScene(model, data, opt, pert, cam, mujoco.mjtCatBit.mjCAT_ALL, scene)
            t1 = time.process_time()
            mujoco.mjr_render(rect, scene, con)
            t2 = time.process_time()
            mujoco.mjr_readPixels(image, None, rect, con)
            t3 = time.process_time()
            if k:
                parts += (t1 - t0, t2 - t1, t3 - t2)
            else:
                shots[name] = np.flipud(image).copy()
    renderer.close()
    np.savez(out, **shots)
    per = parts / (frames * len(cams)) * 1e3
    return {"update": per[0], "draw": per[1], "read": per[2], "total": float(per.sum())}


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", default="60x80,240x320,480x640", help="HEIGHTxWIDTH list")
    p.add_argument("--cams", default="1,4", help="camera counts (cam_high first)")
    p.add_argument("--frames", type=int, default=0, help="frames a row (default by size)")
    p.add_argument("--rows", default=",".join(ROWS), help="comma list of rows")
    p.add_argument(
        "--crop", action="store_true", help=f"cam_high cropped as the recipes do ({RECIPE_CROP})"
    )
    p.add_argument("--child", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.child:
        row, size, ncams, frames, out, crop = json.loads(args.child)
        print(json.dumps(child(row, tuple(size), ncams, frames, Path(out), crop)))
        return
    import numpy as np

    from trossen_arm_mujoco.images import psnr

    rows = [r.strip() for r in args.rows.split(",")]
    unknown = [r for r in rows if r not in ROWS]
    if unknown:
        sys.exit(f"error: unknown row {unknown[0]!r}; rows: {', '.join(ROWS)}")
    if "before" not in rows:
        rows.insert(0, "before")
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    env.pop("LP_NUM_THREADS", None)
    print(
        f"{'size':>8} {'cams':>4} {'row':<22} {'update':>7} {'draw':>7} {'read':>7} "
        f"{'ms/frame':>9} {'ratio':>6} {'PSNR':>6}"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for text in args.sizes.split(","):
            size = tuple(int(v) for v in text.lower().split("x"))
            frames = args.frames or max(10, min(200, 480_000 // (size[0] * size[1]) * 2))
            for ncams in (int(c) for c in args.cams.split(",")):
                base = None
                for row in rows:
                    out = Path(tmp) / f"{row.replace(' ', '_')}_{text}_{ncams}.npz"
                    job = json.dumps([row, size, ncams, frames, str(out), args.crop])
                    done = subprocess.run(
                        [sys.executable, __file__, "--child", job],
                        env=env,
                        capture_output=True,
                        text=True,
                        check=False,
                    )
                    if done.returncode:
                        sys.exit(f"error: row {row} failed: {done.stderr.strip()[-500:]}")
                    r = json.loads(done.stdout.strip().splitlines()[-1])
                    shots = dict(np.load(out))
                    if base is None:
                        base, base_shots = r, shots
                    quality = min(psnr(shots[n], base_shots[n]) for n in shots)
                    shown = "same" if quality == float("inf") else f"{quality:.1f}"
                    print(
                        f"{text:>8} {ncams:>4} {row:<22} {r['update']:7.2f} {r['draw']:7.2f} "
                        f"{r['read']:7.2f} {r['total']:9.2f} {r['total'] / base['total']:6.2f} "
                        f"{shown:>6}",
                        flush=True,
                    )


if __name__ == "__main__":
    main()
