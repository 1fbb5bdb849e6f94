"""Public numpy calls against the shortcuts they could be replaced by, in the same run.

    MUJOCO_GL=egl python benchmarks/numpy_paths.py                  # per-call times
    MUJOCO_GL=egl python benchmarks/numpy_paths.py --step-overhead  # + effect per gym id

1. ``uniform``: ``np.random.Generator.uniform(low, high, size)`` against the same arithmetic
   written out, ``low + (high - low) * rng.random(shape)`` (how the task samplers used to
   draw), for the argument kinds the samplers pass: two floats (spawn ranges), lists of 2 and
   3 floats (cube, goal and target boxes), two floats with ``size=6`` (initial joint noise).
   Both are checked to give the same draws, bit for bit, over ``--draws`` draws per kind.
2. ``clip``: ``np.clip``, ``np.minimum(np.maximum(x, low), high)`` and numpy's clip ufunc
   called directly (``numpy._core.umath.clip``, private), each with and without ``out=``,
   for the shapes of the per-step paths: a Python float (a gripper's control), 7 and 14
   values (actions and joint targets of the arm and the kit), 22 and 58 values (the smallest
   and largest state observation vectors). Values are checked equal to ``np.clip``'s.
3. ``--step-overhead``: for every gymnasium id of ``benchmarks/step_overhead.py`` (state
   observations, default action mode), each env in its own Python process as in that
   benchmark's default mode: its ratio env time / raw ``mj_step`` time measured with the
   package's clip swapped for each variant (every module's ``clip`` name rebound, the variants
   interleaved); the clip calls of one step (counted) timed alone with each variant; and the
   shift of the ratio each variant gives against the shipped one, (its clip us - the shipped
   clip's us) / raw us per step. On a loaded machine the measured ratios swing by tenths; the
   shift, from per-call timings and the raw step of the same run, does not.

Times are the best of ``--repeats`` interleaved runs, per call (microseconds). On a busy
machine compare figures within one run only.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}


# -- timing --------------------------------------------------------------------------------------
def clip_calls(variants: dict, x, low, high, out) -> dict:
    """{name: a no-argument call of that clip variant on ``x`` (into ``out`` when given)}."""
    if out is None:
        return {name: (lambda f=f: f(x, low, high)) for name, f in variants.items()}
    return {name: (lambda f=f: f(x, low, high, out=out)) for name, f in variants.items()}


def best_per_call(
    variants: dict[str, Callable[[], object]], n: int, repeats: int, clock
) -> dict[str, float]:
    """Best time per call (us) of each variant, the variants interleaved in every repeat."""
    best = dict.fromkeys(variants, np.inf)
    for _ in range(repeats):
        for name, fn in variants.items():
            start = clock()
            for _ in range(n):
                fn()
            best[name] = min(best[name], (clock() - start) / n * 1e6)
    return best


# -- uniform -------------------------------------------------------------------------------------
def uniform_written_out(rng: np.random.Generator, low, high, size=None):
    """The arithmetic of ``Generator.uniform`` written out (the samplers' former ``uniform``)."""
    if size is None and isinstance(low, (float, int)) and isinstance(high, (float, int)):
        return low + (high - low) * rng.random()
    low = np.asarray(low, dtype=float)
    span = np.asarray(high, dtype=float) - low
    out = low + span * rng.random(span.shape if size is None else size)
    return float(out) if out.ndim == 0 else out


#: (label, low, high, size): what the samplers pass.
UNIFORM_CALLS = (
    ("two floats", -0.1, 0.2, None),
    ("lists of 2", [0.1, -0.2], [0.3, 0.2], None),
    ("lists of 3", [0.2, -0.3, 0.05], [0.5, 0.3, 0.4], None),
    ("two floats, size=6", -0.02, 0.02, 6),
)


def same_draws(low, high, size, draws: int) -> bool:
    """Whether both ways give the same values, bit for bit, over ``draws`` calls."""
    a, b = np.random.default_rng(1234), np.random.default_rng(1234)
    for _ in range(draws):
        x = np.asarray(a.uniform(low, high, size))
        y = np.asarray(uniform_written_out(b, low, high, size))
        if x.shape != y.shape or x.tobytes() != y.tobytes():
            return False
    return True


def bench_uniform(args, clock) -> None:
    print(
        f"uniform: us per call (best of {args.repeats} x {args.n} calls); same draws over "
        f"{args.draws} calls"
    )
    print(
        f"| {'arguments':<20} | {'Generator.uniform':>17} | {'written out':>11} | "
        f"{'difference':>10} | same draws |"
    )
    print(f"|{'-' * 22}|{'-' * 19}|{'-' * 13}|{'-' * 12}|------------|")
    for label, low, high, size in UNIFORM_CALLS:
        rng_a, rng_b = np.random.default_rng(0), np.random.default_rng(0)
        t = best_per_call(
            {
                "public": lambda r=rng_a, lo=low, hi=high, s=size: r.uniform(lo, hi, s),
                "written": lambda r=rng_b, lo=low, hi=high, s=size: uniform_written_out(
                    r, lo, hi, s
                ),
            },
            args.n,
            args.repeats,
            clock,
        )
        same = "yes" if same_draws(low, high, size, args.draws) else "NO"
        print(
            f"| {label:<20} | {t['public']:>17.2f} | {t['written']:>11.2f} | "
            f"{t['public'] - t['written']:>+10.2f} | {same:>10} |"
        )


# -- clip ----------------------------------------------------------------------------------------
def private_clip_ufunc() -> np.ufunc:
    """numpy's clip ufunc (``numpy._core.umath.clip``; ``numpy.core`` before numpy 2)."""
    for module in ("_core", "core"):
        found = getattr(getattr(getattr(np, module, None), "umath", None), "clip", None)
        if isinstance(found, np.ufunc):
            return found
    raise RuntimeError("this numpy has no clip ufunc under numpy._core.umath")


def two_ufuncs(x, low, high, out=None):
    """``np.minimum(np.maximum(x, low), high)``, in ``out`` when given."""
    return np.minimum(np.maximum(x, low, out=out), high, out=out)


def clip_variants() -> dict[str, Callable]:
    return {"np.clip": np.clip, "min(max())": two_ufuncs, "umath.clip": private_clip_ufunc()}


#: (label, size or None for a Python float): the shapes of the per-step paths.
CLIP_SHAPES = (("float", None), ("7", 7), ("14", 14), ("22", 22), ("58", 58))


def bench_clip(args, clock) -> None:
    variants = clip_variants()
    print(f"\nclip: us per call (best of {args.repeats} x {args.n} calls)")
    head = " | ".join(f"{name:>10}" for name in variants)
    print(f"| {'shape':<10} | {'out=':<4} | {head} |")
    print(f"|{'-' * 12}|------|" + "|".join("-" * 12 for _ in variants) + "|")
    rng = np.random.default_rng(0)
    for label, size in CLIP_SHAPES:
        if size is None:
            x, low, high = 0.05, 0.0, 0.044  # a gripper's control (m), Python floats
        else:
            x, low, high = rng.uniform(-2, 2, size), -np.ones(size), np.ones(size)
        for use_out in (False, True) if size is not None else (False,):
            buf = np.empty(size) if use_out else None
            for name, f in variants.items():
                got = f(x, low, high, out=buf) if use_out else f(x, low, high)
                assert np.array_equal(got, np.clip(x, low, high)), (name, label)
            calls = clip_calls(variants, x, low, high, buf)
            t = best_per_call(calls, args.n, args.repeats, clock)
            cells = " | ".join(f"{t[name]:>10.2f}" for name in variants)
            print(f"| {label:<10} | {'yes' if use_out else 'no':<4} | {cells} |")


# -- effect on step_overhead.py ------------------------------------------------------------------
def load_step_overhead():
    spec = importlib.util.spec_from_file_location("step_overhead", HERE / "step_overhead.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["step_overhead"] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def use_clip(fn) -> None:
    """Rebind ``clip`` in every package module that imported it (and in ``clip.py``)."""
    import trossen_arm_mujoco.clip as clip_module

    current = clip_module.clip
    for name, module in list(sys.modules.items()):
        if name.startswith("trossen_arm_mujoco") and getattr(module, "clip", None) is current:
            module.clip = fn


def gym_cases(so, args) -> list[tuple[str, Callable]]:
    """step_overhead's gym cases in its default action mode (no ``ee_delta`` rows)."""
    ns = argparse.Namespace(steps=args.steps, dm_steps=20)
    return [(name, run) for name, run in so._cases(ns) if " " not in name]


def count_clip_calls(run) -> dict[tuple[tuple[int, ...], bool], int]:
    """Calls of the package's clip in one ``run(False)``, by (shape of x, out= given)."""
    import trossen_arm_mujoco.clip as clip_module

    shipped = clip_module.clip
    counts: dict[tuple[tuple[int, ...], bool], int] = {}

    def counting(x, low, high, out=None):
        key = (np.shape(x), out is not None)
        counts[key] = counts.get(key, 0) + 1
        return shipped(x, low, high) if out is None else shipped(x, low, high, out=out)

    use_clip(counting)
    try:
        run(False)
    finally:
        use_clip(shipped)
    return counts


def clip_cost_per_step(counts, steps: int, args, clock) -> dict[str, float]:
    """Per variant, the clip calls of one env step timed alone (us): each (shape, out=)
    of ``counts`` timed per call, weighted by its calls per step."""
    variants = clip_variants()
    total = dict.fromkeys(variants, 0.0)
    rng = np.random.default_rng(0)
    for (shape, use_out), n_calls in counts.items():
        if shape == ():
            x, low, high = 0.05, 0.0, 0.044
        else:
            x, low, high = rng.uniform(-2, 2, shape), -np.ones(shape), np.ones(shape)
        buf = np.empty(shape) if use_out else None
        calls = clip_calls(variants, x, low, high, buf)
        t = best_per_call(calls, args.n, args.repeats, clock)
        for name in variants:
            total[name] += t[name] * n_calls / steps
    return total


def step_overhead_case(args, index: int) -> dict:
    """One gym case: ratios env / raw measured with each clip variant (interleaved), the
    clip calls' cost per step with each variant, and the raw physics per step (us)."""
    so = load_step_overhead()
    clock = CLOCKS[args.clock]
    so.clock = clock
    name, run = gym_cases(so, args)[index]
    _, rec = run(True)  # imports every module on the path, records the floor's inputs
    counts = count_clip_calls(run)
    variants = clip_variants()
    import trossen_arm_mujoco.clip as clip_module

    shipped = clip_module.clip
    env = dict.fromkeys(variants, np.inf)
    floor = np.inf
    for _ in range(args.so_repeats):
        for label, fn in variants.items():
            use_clip(fn)
            env[label] = min(env[label], run(False)[0])
            use_clip(shipped)
        floor = min(floor, so.floor_time(rec))
    steps = len(rec.controls)
    return {
        "name": name,
        "ratio": {label: env[label] / floor for label in variants},
        "clip_us": clip_cost_per_step(counts, steps, args, clock),
        "calls": sum(counts.values()) / steps,
        "raw_us": floor / steps * 1e6,
        "shipped": next((k for k, f in variants.items() if f is shipped), "other"),
    }


def bench_step_overhead(args) -> None:
    so = load_step_overhead()
    names = [name for name, _ in gym_cases(so, args)]
    labels = list(clip_variants())
    print(
        f"\nper gym id (default action mode, state): step_overhead.py's ratio env / raw "
        f"mj_step ({args.clock} clock, {args.steps} steps, best of {args.so_repeats}) measured "
        "with each clip; the clip calls of one step timed alone (us) with each; the shift of "
        "the ratio each variant gives against the shipped one = (its clip us - shipped's) / "
        "raw us per step (robust to load, unlike the measured ratios)"
    )
    head = " | ".join(f"{v:>10}" for v in labels)
    print(f"| {'gym id':<28} | raw us | calls | ratio {head} | clip us {head} | shift {head} |")
    passed = [
        "--steps",
        str(args.steps),
        "--so-repeats",
        str(args.so_repeats),
        "--clock",
        args.clock,
        "--n",
        str(args.n),
        "--repeats",
        str(args.repeats),
    ]
    for index, name in enumerate(names):
        done = subprocess.run(
            [sys.executable, __file__, "--case", str(index), *passed],
            capture_output=True,
            text=True,
            check=False,
        )
        rows = [x for x in done.stdout.splitlines() if x.startswith("ROW ")]
        if done.returncode != 0 or not rows:
            last = (done.stderr.strip().splitlines() or ["no output"])[-1]
            sys.exit(f"measuring {name} failed: {last}")
        row = json.loads(rows[-1][4:])
        base = row["clip_us"][row["shipped"]] if row["shipped"] in labels else 0.0
        ratio = " | ".join(f"{row['ratio'][v]:>10.3f}" for v in labels)
        cost = " | ".join(f"{row['clip_us'][v]:>10.2f}" for v in labels)
        shift = " | ".join(f"{(row['clip_us'][v] - base) / row['raw_us']:>+10.3f}" for v in labels)
        print(
            f"| {name:<28} | {row['raw_us']:>6.1f} | {row['calls']:>5.2f} | ratio {ratio} | "
            f"clip us {cost} | shift {shift} |",
            flush=True,
        )
    print(f"(shipped clip: {row['shipped']})")


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=2000, help="calls per timed run")
    p.add_argument("--repeats", type=int, default=30, help="timed runs per variant (best kept)")
    p.add_argument("--draws", type=int, default=20000, help="calls compared draw for draw")
    p.add_argument("--clock", choices=sorted(CLOCKS), default="wall", help="what to time")
    p.add_argument("--step-overhead", action="store_true", help="also the ratio per gym id")
    p.add_argument("--steps", type=int, default=1000, help="env steps per gym env (ratios)")
    p.add_argument("--so-repeats", type=int, default=3, help="timed env runs per variant")
    p.add_argument("--case", type=int, default=None, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    clock = CLOCKS[args.clock]
    if args.case is not None:
        print("ROW " + json.dumps(step_overhead_case(args, args.case)))
        return
    print(
        f"numpy {np.__version__}, Python {sys.version.split()[0]}, load average "
        f"{' '.join(f'{x:.2f}' for x in os.getloadavg())} on {os.cpu_count()} CPUs"
    )
    bench_uniform(args, clock)
    bench_clip(args, clock)
    if args.step_overhead:
        bench_step_overhead(args)
    print(f"\nload average at the end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
