"""Score a policy in the sim (also ``trossen-mujoco eval``).

    trossen-mujoco eval --policy scripted --task_name sim_transfer_cube --num_episodes 10
    trossen-mujoco eval --policy outputs/train/act/checkpoints/last/pretrained_model \\
        --task_name sim_transfer_cube --num_episodes 50 --num_workers 2 --videos 2

``--policy`` is ``scripted``, a ``module:function`` or a LeRobot checkpoint folder. Episode
``i`` is ``env.reset(seed=S + i)``, as ``lerobot-eval --seed S``. Writes
``--output_dir/eval_info.json``, ``rollouts.json`` and the first ``--videos`` rollouts' mp4;
``--backend wire`` runs the same through the served kit in wall-clock time.

Docs: docs/cli/eval.md, docs/rehearsal.md; details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

__all__ = [
    "MAX_EPISODES",
    "build_parser",
    "cli",
    "controller_line",
    "deployment",
    "main",
]

if __name__ == "__main__" and not __package__:  # run as a file: import from the repo root
    import sys
    from pathlib import Path

    sys.path[0] = str(
        next(p for p in Path(__file__).resolve().parents if not (p / "__init__.py").is_file())
    )
    import trossen_arm_mujoco  # noqa: F401  (as with -m: the package sets MUJOCO_GL first)

import argparse
import sys
import traceback
from collections.abc import Sequence
from pathlib import Path

from tqdm import tqdm

from trossen_arm_mujoco.errors import (
    ArgumentParser,
    UserError,
    interrupt_note,
    note,
    report_error,
    run_cli,
)
from trossen_arm_mujoco.robot.layout import LAYOUTS
from trossen_arm_mujoco.scripts.common_options import (
    DEFAULT_TASK,
    add_cameras,
    add_crop,
    add_engine,
    add_fps,
    add_image_size,
    add_num_episodes,
    add_overwrite,
    add_randomize,
    add_seed,
    randomization_of,
)

#: Largest number of episodes one run takes.
MAX_EPISODES = 100_000


def build_parser() -> argparse.ArgumentParser:
    """Command-line flags."""
    p = ArgumentParser(
        prog="trossen-mujoco eval",
        description="Score a policy (LeRobot checkpoint, scripted, module:function) over "
        "evaluation seeds in the sim; writes eval_info.json and rollout videos.",
    )
    p.add_argument(
        "--policy",
        required=True,
        help="'scripted', module:function, or a LeRobot checkpoint folder "
        "(.../checkpoints/last/pretrained_model)",
    )
    p.add_argument(
        "--task_name",
        default=None,
        help="registered kit, Mobile AI or single-arm task (default: the checkpoint's "
        f"dataset's, else {DEFAULT_TASK})",
    )
    add_num_episodes(p, "episodes", 10)
    p.add_argument(
        "--num_workers",
        type=int,
        default=1,
        help="worker processes (default 1; at most the CPU count)",
    )
    add_seed(p, "base seed: episode i is env.reset(seed=seed + i)")
    add_cameras(p, "observed cameras", "the checkpoint's, else none")
    add_image_size(
        p, "observed image size", default=None, default_text="the checkpoint's, else 480x640"
    )
    add_crop(p)
    add_fps(p, "policy rate; 30 for data exported with --fps 30", "the task's, 50")
    p.add_argument(
        "--episode_length",
        type=int,
        default=None,
        help="steps per episode (default: the task's recording length, 12 s for the transfer)",
    )
    p.add_argument(
        "--layout",
        default=None,
        choices=sorted([*LAYOUTS, "widowxai"]),
        help="joint layout of observations and actions (default: the checkpoint's, else "
        "kit14; mobileai for a Mobile AI task, widowxai for a single arm's)",
    )
    p.add_argument(
        "--output_dir",
        default="eval_out",
        help="where eval_info.json and videos/ go (default eval_out)",
    )
    p.add_argument("--videos", type=int, default=0, help="mp4 of the first K rollouts")
    add_engine(p, "where episodes run: local worker processes, or Ray")
    p.add_argument("--device", default="cpu", help="torch device of a checkpoint (default cpu)")
    p.add_argument(
        "--backend",
        default="sim",
        choices=("sim", "wire"),
        help="sim: in-process (default); wire: through the served kit in wall-clock "
        "time (trossen_arm driver + ZMQ cameras; docs/rehearsal.md)",
    )
    p.add_argument(
        "--connect",
        action="store_true",
        help="with --backend wire: use a serve already running (with --cameras and "
        "--control_port) instead of starting one",
    )
    p.add_argument(
        "--left_ip",
        default="127.0.0.2",
        help="with --backend wire: left arm address (default 127.0.0.2)",
    )
    p.add_argument(
        "--right_ip",
        default="127.0.0.3",
        help="with --backend wire: right arm address (default 127.0.0.3)",
    )
    p.add_argument(
        "--camera_port",
        type=int,
        default=5555,
        help="with --backend wire: camera stream port (default 5555)",
    )
    p.add_argument(
        "--control_port",
        type=int,
        default=5556,
        help="with --backend wire: episode control port (default 5556)",
    )
    p.add_argument(
        "--action_timeout",
        type=float,
        default=2.0,
        help="with --backend wire: seconds without an action before the episode fails (default 2)",
    )
    p.add_argument(
        "--speed_limit_fraction",
        type=float,
        default=None,
        metavar="F",
        help="with --backend wire: shorten each goal so that no joint is asked for "
        "more than F (0-1] of the real speed limits (default: send the policy's "
        "actions as they are; a jump faults the arm, as on the real kit)",
    )
    p.add_argument(
        "--controller_checks",
        default="on",
        choices=("on", "off", "both"),
        help="on (default): every action goes to the arms as the real kit takes "
        "it (the driver's trajectory toward the goal over 3/fps s) and the arm "
        "controller's checks (joint range, speed limit, finite) apply: a fault ends "
        "the episode as failed, counted by joint and reason; off: the same motion, "
        "nothing refused (the unconstrained score); both: on, then off, the two "
        "scores side by side (twice the time). --backend wire: always on, the "
        "served kit is the controller",
    )
    add_randomize(p, "rollouts.json")
    add_overwrite(p, "replace an eval_info.json already in --output_dir")
    return p


def _settings(args: argparse.Namespace):
    from trossen_arm_mujoco.eval.policies import is_function_spec
    from trossen_arm_mujoco.eval.runner import EvalSettings
    from trossen_arm_mujoco.fileio import check_writable_dir
    from trossen_arm_mujoco.processes import available_cpus
    from trossen_arm_mujoco.sim.camera_settings import DEFAULT_SIZE, CameraSettings, camera_flags
    from trossen_arm_mujoco.tasks import registry

    if not 1 <= args.num_episodes <= MAX_EPISODES:
        raise UserError(f"--num_episodes must be in [1, {MAX_EPISODES}], got {args.num_episodes}")
    if not 0 <= args.seed <= 2**63 - 1 - args.num_episodes:
        raise UserError(f"--seed must be in [0, 2**63 - 1 - num_episodes], got {args.seed}")
    if not 0 <= args.videos <= args.num_episodes:
        raise UserError(f"--videos must be in [0, --num_episodes], got {args.videos}")
    if args.num_workers < 1:
        raise UserError(f"--num_workers must be at least 1, got {args.num_workers}")
    cpus = available_cpus()
    workers = min(args.num_workers, args.num_episodes)
    if workers > cpus:
        note(f"--num_workers {args.num_workers} > {cpus} CPUs; using {cpus}")
        workers = cpus
    flags = {
        "task": registry.canonical(args.task_name) if args.task_name else None,
        "fps": args.fps,
        "layout": args.layout,
        **camera_flags(args.cam_names, args.image_size, args.crop),  # parsed once, here
    }
    inferred: dict = {}
    if args.policy not in ("scripted",) and not is_function_spec(args.policy):
        from trossen_arm_mujoco.eval.lerobot_policy import checkpoint_dir, checkpoint_features
        from trossen_arm_mujoco.export.dataset_settings import checkpoint_settings, reconcile

        inferred = checkpoint_features(args.policy)
        carried, source = checkpoint_settings(checkpoint_dir(args.policy))
        flags = reconcile(carried, source, flags)
        if carried is not None and carried.state_extras:  # export --include_velocity/_effort
            raise UserError(
                f"the checkpoint's observation.state has per-joint {'/'.join(carried.state_extras)}"
                f" values ({source}); eval gives policies the joint positions only: train on an "
                "export without --include_velocity / --include_effort"
            )
        inferred["settings_source"] = source if carried is not None else None
    task = flags["task"] or DEFAULT_TASK
    cameras = CameraSettings(  # a flag, else the checkpoint's (settings, then config.json)
        names=flags["cam_names"]
        if flags["cam_names"] is not None
        else (inferred.get("cam_names", ())),
        size=flags["image_size"] or inferred.get("image_size", DEFAULT_SIZE),
        crops=flags["crops"] or (),
    )
    if args.videos and not _has_av():
        raise UserError("--videos needs PyAV: pip install 'trossen-arm-mujoco[video]'")
    out = Path(args.output_dir).expanduser()
    if out.exists() and not out.is_dir():
        raise UserError(f"--output_dir {out} is a file; give a folder")
    if (out / "eval_info.json").exists() and not args.overwrite:
        raise UserError(
            f"{out / 'eval_info.json'} exists; choose another --output_dir or pass --overwrite"
        )
    check_writable_dir(out, "--output_dir")  # before any episode, not after the last one
    randomize, randomization = randomization_of(args, task)
    randomize, randomization = randomization_of(args, task)
    settings = EvalSettings(
        policy=args.policy,
        task=task,
        num_episodes=args.num_episodes,
        seed=args.seed,
        cameras=cameras,
        fps=flags["fps"],
        episode_length=args.episode_length,
        layout=_layout_for(task, flags["layout"], inferred.get("layout")),
        videos=args.videos,
        output_dir=str(out),
        device=args.device,
        controller_checks=args.controller_checks != "off",
        randomize=randomize,
        randomization=randomization,
        extra={
            "settings_source": inferred.get("settings_source"),
            "sim_only": inferred.get("sim_only", False),
            "pose_camera": inferred.get("pose_camera"),
        },
    )
    return settings, workers


def _layout_for(task: str, flag: str | None, inferred: str | None) -> str:
    """The layout of the run: the flag, else the checkpoint's, else the task's default
    (``kit14`` for a kit task, ``mobileai`` for a Mobile AI one). A checkpoint of 16 action
    values reads as ``vendor16``; for a Mobile AI task it is the ``mobileai`` layout. A task
    eval does not take is a one-line UserError here, a layout it does not take one in the env."""
    from trossen_arm_mujoco.eval.env import task_layouts

    valid = task_layouts(task)
    if flag:
        return flag
    if inferred == "vendor16" and "mobileai" in valid:
        return "mobileai"
    return inferred or valid[0]


def _no_wire_for_mobile(args: argparse.Namespace, settings) -> None:
    """``--backend wire`` refuses a Mobile AI task in one line: the served kit is the
    Stationary AI (two arms on the arm controller's wire protocol; no base)."""
    from trossen_arm_mujoco.eval.mobile_base import MOBILE_LAYOUTS

    if args.backend == "wire" and settings.layout in MOBILE_LAYOUTS:
        raise UserError(
            f"--backend wire drives the served Stationary AI kit (two arms, no base); task "
            f"'{settings.task}' is a Mobile AI task: evaluate it with --backend sim"
        )


def _kit_link(args: argparse.Namespace, workers: int):
    """``--backend wire``'s kit addresses, checked (loopback only); None for ``sim``."""
    from trossen_arm_mujoco.eval.wire_link import KitLink

    if args.backend != "wire":
        defaults = build_parser().parse_args(["--policy", "x"])
        for flag in (
            "connect",
            "left_ip",
            "right_ip",
            "camera_port",
            "control_port",
            "action_timeout",
            "speed_limit_fraction",
        ):
            if getattr(args, flag) != getattr(defaults, flag):
                raise UserError(f"--{flag} needs --backend wire")
        return None
    if args.controller_checks != "on":
        raise UserError(
            f"--controller_checks {args.controller_checks} is for --backend sim: "
            "through the wire the served kit is the controller and always checks"
        )
    if workers > 1 or args.engine != "local" or args.videos:
        raise UserError(
            "--backend wire runs one episode at a time on one kit: leave out "
            "--num_workers, --engine and --videos"
        )
    if not 0.05 <= args.action_timeout <= 600:
        raise UserError(f"--action_timeout must be in [0.05, 600] s, got {args.action_timeout}")
    from trossen_arm_mujoco.eval.arm_tasks import is_arm_task

    defaults = build_parser().parse_args(["--policy", "x"])
    if args.right_ip != defaults.right_ip and is_arm_task(args.task_name or ""):
        raise UserError(
            f"--right_ip: task '{args.task_name}' is a single arm's, served on one address: "
            "give it with --left_ip"
        )
    f = args.speed_limit_fraction
    if f is not None and not 0.0 < f <= 1.0:
        raise UserError(
            f"--speed_limit_fraction must be in (0, 1], got {f} (0.9: 90 % of the "
            "real arm's limits)"
        )
    link = KitLink(
        args.left_ip,
        args.right_ip,
        camera_port=args.camera_port,
        control_port=args.control_port,
        connect=args.connect,
    )
    return link.checked()


def _has_av() -> bool:
    try:
        import av  # noqa: F401
    except ImportError:
        return False
    return True


def main(argv: Sequence[str] | None = None) -> int:
    """Evaluate; returns the exit status."""
    args = build_parser().parse_args(argv)
    from trossen_arm_mujoco.eval.policies import is_function_spec
    from trossen_arm_mujoco.eval.rollout_analysis import (
        ROLLOUTS_FILE,
        failure_line,
        rollouts_report,
    )
    from trossen_arm_mujoco.eval.runner import VIDEO_DIR, PolicyCallError, evaluate
    from trossen_arm_mujoco.eval.scores import write_results

    settings, workers = _settings(args)
    _no_wire_for_mobile(args, settings)
    link = _kit_link(args, workers)  # --backend wire's addresses, checked before any episode
    env = settings.make_env()  # fail fast on a bad task, camera, size or checkpoint
    try:
        if settings.policy == "scripted":  # a task without one: one line before any episode
            from trossen_arm_mujoco.tasks import registry

            registry.load(settings.task).policy_class()
        if settings.policy != "scripted" and not is_function_spec(settings.policy):
            from trossen_arm_mujoco.eval.lerobot_policy import (
                check_checkpoint,
                check_loadable,
                import_lerobot,
            )

            check_checkpoint(settings.policy, env)
            import_lerobot()
            check_loadable(settings.policy)  # its files whole: before any episode, any kit
    finally:
        env.close()
    bar = tqdm(total=settings.num_episodes, desc="eval", unit="episode", file=sys.stderr)
    wins = [0]
    scores = []

    def tick(score) -> None:
        scores.append(score)
        wins[0] += score.success
        bar.update(1)
        bar.set_postfix(success=f"{wins[0]}/{bar.n}")

    def kept() -> str:  # Ctrl-C or SIGTERM: what the one line of run_cli says
        videos = ""
        if settings.videos and bar.n:
            folder = Path(settings.output_dir) / VIDEO_DIR
            videos = f"; the finished rollout videos stay in {folder}"
        return (
            f"{bar.n} of {settings.num_episodes} episode(s) finished; no eval_info.json "
            f"written{videos}"
        )

    try:
        with interrupt_note(kept):
            if args.backend == "wire":
                from trossen_arm_mujoco.eval.wire_backend import evaluate_wire

                info = evaluate_wire(
                    settings,
                    link,
                    args.action_timeout,
                    on_episode=tick,
                    speed_fraction=args.speed_limit_fraction,
                )
            else:
                info = evaluate(settings, workers, args.engine, on_episode=tick)
    except PolicyCallError as exc:  # the user's code raised: say where, then its traceback
        bar.close()
        report_error(exc, 1)
        cause = exc.__cause__ if exc.__cause__ is not None else exc
        traceback.print_exception(type(cause), cause, cause.__traceback__, file=sys.stderr)
        return 1
    finally:
        bar.close()
    if args.controller_checks == "both":
        info["unconstrained"] = _unconstrained(settings, workers, args.engine)
    info["deployment"] = deployment(settings, args.backend)
    report = rollouts_report(settings.task, scores, env.fps)
    path, rollouts = write_results(
        {  # both or neither (a full disk: one line, nothing)
            Path(settings.output_dir) / "eval_info.json": info,
            Path(settings.output_dir) / ROLLOUTS_FILE: report,
        }
    )
    agg = info["aggregated"]
    lo, hi = agg["pc_success_ci95"]
    stages = ", ".join(f"{k} {v:.0f}%" for k, v in agg["stages"].items())
    print(
        f"{settings.task}: {wins[0]}/{agg['n_episodes']} succeeded, {agg['pc_success']:.1f}% "
        f"(95% CI {lo:.1f}-{hi:.1f}); stages: {stages or 'none'}; avg max reward "
        f"{agg['avg_max_reward']:.2f}; {agg['eval_s']:.1f} s"
    )
    print(controller_line(info["controller"]))
    if info["deployment"]["sim_only"]:
        print(f"sim-only: {info['deployment']['why']}")
    if "unconstrained" in info:
        free = info["unconstrained"]["aggregated"]
        flo, fhi = free["pc_success_ci95"]
        print(
            f"without the controller's checks: {free['pc_success']:.1f}% (95% CI "
            f"{flo:.1f}-{fhi:.1f}) on the same seeds"
        )
    print(
        f"wrote {path}"
        + (f" and {len(info['video_paths'])} video(s)" if info["video_paths"] else "")
    )
    print(f"{failure_line(report)}; wrote {rollouts}")
    return 0


def deployment(settings, backend: str) -> dict:
    """The ``deployment`` block of ``eval_info.json``: whether the policy can run on a real
    kit (``sim_only``: it observes what only the simulation has; None: cannot tell) and
    why; where its
    settings came from (``settings_source``). Through the wire, a sim-only policy's run is
    not a deployment rehearsal, and the block says so."""
    from trossen_arm_mujoco.eval.policies import is_function_spec

    if settings.policy == "scripted":
        sim_only, why = (
            True,
            ("the scripted policy plans from the objects' exact poses, which no real kit gives"),
        )
    elif is_function_spec(settings.policy):
        sim_only, why = (
            False,
            (
                "a module:function policy: this tool cannot tell whether it reads "
                "environment_state (the objects' exact poses); it deploys only if it does not"
            ),
        )
    elif settings.extra.get("sim_only"):
        sim_only, why = (
            True,
            (
                "the checkpoint observes observation.environment_state (the objects' exact "
                "poses), which no real kit gives: it cannot run on hardware; train on joints and "
                "cameras (train_eval --no_env_state) for a policy that deploys"
            ),
        )
    elif settings.extra.get("pose_camera"):
        sim_only, why = (
            False,
            (
                "the checkpoint observes only what the real kit gives: the object poses it "
                f"was trained on come from its pose encoder reading {settings.extra['pose_camera']}"
            ),
        )
    else:
        sim_only, why = False, "the checkpoint observes only what the real kit gives"
    if sim_only and backend == "wire":
        why += "; so this run through the wire is not a deployment rehearsal"
    return {
        "sim_only": sim_only,
        "why": why,
        "settings_source": settings.extra.get("settings_source"),
    }


def _unconstrained(settings, workers: int, engine: str) -> dict:
    """The same evaluation with the controller's checks off: its aggregated and controller
    blocks (``--controller_checks both``)."""
    import dataclasses

    from trossen_arm_mujoco.eval.runner import evaluate

    free_settings = dataclasses.replace(settings, controller_checks=False, videos=0)
    bar = tqdm(
        total=settings.num_episodes, desc="eval, checks off", unit="episode", file=sys.stderr
    )
    try:
        free = evaluate(free_settings, workers, engine, on_episode=lambda _: bar.update(1))
    finally:
        bar.close()
    return {"aggregated": free["aggregated"], "controller": free["controller"]}


def controller_line(block: dict) -> str:
    """One line of an ``eval_info.json`` controller block: checks, faults by joint and
    reason, the largest asked speed as a fraction of its limit."""
    peak = block.get("peak_speed_fraction") or {}
    top = max(peak.items(), key=lambda kv: kv[1]) if peak else None
    fastest = f"; fastest asked: {top[0]} at {top[1]:.2f} of its limit" if top else ""
    if not block.get("checks", True):
        return f"arm controller checks: off (nothing refused){fastest}"
    n = block.get("faulted_episodes", 0)
    if not n:
        return f"arm controller checks: on, 0 faults{fastest}"
    joints = ", ".join(f"{k} {v}" for k, v in block["faults_by_joint"].items())
    reasons = ", ".join(f"{k} {v}" for k, v in block["faults_by_reason"].items())
    return (
        f"arm controller checks: on, {n} episode(s) faulted (by joint: {joints}; by "
        f"reason: {reasons}){fastest}"
    )


def cli(argv: Sequence[str] | None = None) -> int:
    """Entry point: like :func:`main`, with user errors as one line and exit status 2."""
    return run_cli(main, argv)


if __name__ == "__main__":
    sys.exit(cli())
