"""The whole loop, measured over several training runs: record -> export -> lerobot-train (ACT)
-> trossen-mujoco eval.

    TROSSEN_LEROBOT_PYTHON=~/.cache/trossen-arm-mujoco/lerobot-venv/bin/python \\
        python benchmarks/train_eval.py --inject_noise --train_seeds 3 --train_jobs 3

1. ``record``: ``trossen-mujoco record`` of ``--episodes`` scripted episodes of ``--task``
   (``--seed``), no camera by default (``--cam_names cam_high --image_size 96x128
   --no_env_state`` for the image recipe, with ``--crop cam_high:217,243,150,200`` to see
   the cube's spawn region instead of the whole frame);
2. ``export``: ``trossen-mujoco export --sim_features`` in the real kit's 14-value layout
   (state, action, and the sim's features: velocity, environment_state = the object poses,
   reward, success);
3. ``encode`` (only with ``--pose_encoder``, the ``camera_pose`` recipe): a pose encoder
   trained once on the episodes' camera frames, and ``dataset_pose``, the dataset with its
   estimates as the object poses and no video (``train_eval_pose.py``);
4. ``train``: LeRobot's own ``lerobot-train`` with ACT (the settings below), once per training
   seed (``--train_seeds K``: seeds ``--train_seed``, ``--train_seed`` + 1, ...; same data),
   ``--train_jobs`` of them at a time (CPU unless ``--device``); with ``--pose_encoder`` on
   ``dataset_pose`` (derived first if missing);
5. ``eval``: ``trossen-mujoco eval`` of each run's last checkpoint over ``--eval_episodes``
   evaluation seeds (a stream of its own: never a training episode), with the arm
   controller's checks on and, beside it, off (``--controller_checks both``): each run's
   faults and the largest speed it asked of each joint, as a fraction of its limit;
6. ``wire`` (only when asked: ``--phase wire``): the same checkpoints and seeds through the
   served kit (``trossen-mujoco eval --backend wire``), in wall-clock time; run it on an
   otherwise idle machine.

The checkpoints carry what they need: ACT's temporal ensembling (``--temporal_ensemble_coeff``,
0.01 by default, one action per inference) is in their LeRobot config, and the dataset's
settings (rate, layout, cameras, image size, crops) are written beside their weights
(``trossen_settings.json``), so ``eval`` (both backends) and ``lerobot-eval`` take them with no
flag.

``--phase`` runs any subset (``record,export,encode`` here, ``train`` on a GPU machine, ``eval``
back here): each phase reads what the earlier ones left in ``--work_dir``. A phase whose output is
already complete is skipped with a line. Prints one line per phase and run with its wall and
CPU time, then each run's success with its 95 % Wilson interval, the mean and the worst run;
merges everything into ``summary.json`` in ``--work_dir``. LeRobot runs in
``TROSSEN_LEROBOT_PYTHON`` (Python >= 3.12; ``bash .ci/run`` builds one); the train phase needs
nothing else, so it runs on a machine with LeRobot and torch but without this project's
simulator (see ``tools/offline_wheelhouse.sh``).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # its report module, run as a file
from train_eval_command import train_args  # noqa: E402
from train_eval_jobs import Job, cores, fail, run_jobs  # noqa: E402
from train_eval_pose import (  # noqa: E402
    POSE_DATASET,
    derived_ready,
    encode_job,
    encoder_of,
    encoder_report,
    pose_dataset,  # noqa: E402
    static_folder,
    static_job,
)
from train_eval_recipes import (  # noqa: E402
    CROPPED,
    RECIPES,
    camera_settings_error,
    task_camera_facts,
)
from train_eval_report import alike, losses, recipe_flags, report, results  # noqa: E402

PHASES = ("record", "export", "encode", "train", "eval", "wire")
#: Phases run when ``--phase`` is not given (``wire`` needs an idle machine: asked for;
#: ``encode`` does nothing without ``--pose_encoder``).
DEFAULT_PHASES = ("record", "export", "encode", "train", "eval")
#: ``export.dataset_settings``' ``INFO_KEY`` and ``CHECKPOINT_FILE`` (tests check they agree).
SETTINGS_KEY, SETTINGS_FILE = "trossen_arm_mujoco", "trossen_settings.json"
#: Thread-pool sizes a training run is given (torch reads OMP_NUM_THREADS at start).
THREAD_VARS = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")


def _carry_settings(dataset: Path, train: Path) -> None:
    """Write the dataset's settings beside the weights of every checkpoint of one training
    run: ``trossen_arm_mujoco.export.dataset_settings``' ``INFO_KEY`` of its info.json as
    ``CHECKPOINT_FILE`` (plain JSON here: the train phase may run where the simulator is not
    installed, see ``gpu_leg.py``)."""
    info = json.loads((dataset / "meta" / "info.json").read_text())
    settings = info.get(SETTINGS_KEY)
    if not isinstance(settings, dict):
        return
    for model in sorted((train / "checkpoints").glob("*/pretrained_model")):
        tmp = model / (SETTINGS_FILE + ".tmp")
        tmp.write_text(json.dumps(settings, indent=2) + "\n")
        tmp.replace(model / SETTINGS_FILE)


def _prepare(ckpt: Path, dataset: Path, pose: bool = False) -> None:
    """Before a checkpoint is scored (here, where the simulator is installed): the dataset's
    settings beside its weights, then ``trossen-mujoco prepare``'s steps (its images cut and
    scaled as trained, with ``pose`` the dataset's pose encoder, the arm controller's
    limits: ``eval.prepare``)."""
    from trossen_arm_mujoco.eval.prepare import prepare_checkpoint

    if not (ckpt / SETTINGS_FILE).exists() and (dataset / "meta" / "info.json").exists():
        _carry_settings(dataset, ckpt.parent.parent.parent)
    encoder, camera = encoder_of(dataset) if pose else (None, None)
    changed = prepare_checkpoint(ckpt, encoder, camera)  # after the settings: they say how
    if changed:
        print(f"{ckpt}: prepared ({', '.join(changed)})")


def _scored(info_path: Path, ckpt: Path, args: argparse.Namespace, both: bool) -> bool:
    """Whether ``info_path`` already scores ``ckpt`` as this phase would (the same episodes
    and seed, newer than the checkpoint's weights and postprocessor, with the unconstrained
    score when ``both``): then the phase keeps it instead of evaluating again."""
    try:
        info = json.loads(info_path.read_text())
        run = info["run"]
        made = max(
            (ckpt / name).stat().st_mtime
            for name in ("model.safetensors", "policy_postprocessor.json")
        )
        newer = info_path.stat().st_mtime > made
    except (OSError, ValueError, KeyError, TypeError):
        return False
    return (
        newer
        and Path(run.get("policy", "")).resolve() == ckpt.resolve()
        and run.get("num_episodes") == args.eval_episodes
        and run.get("seed") == args.eval_seed
        # the same evaluation level: nominal, train (the task's section) or hard (widened)
        and bool(run.get("randomize")) == (args.eval_randomize != "nominal")
        and (run.get("randomization") is None) == (args.eval_randomize != "hard")
        and (not both or "unconstrained" in info)
    )


def _checkpoint(train: Path) -> Path:
    return train / "checkpoints" / "last" / "pretrained_model"


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--work_dir", default="train_eval_out")
    p.add_argument(
        "--recipe",
        choices=tuple(RECIPES),
        default="state",
        help="flag defaults: state (the joints and the object poses, 50 fps), "
        "camera_pose (the joints and cam_high only, as a real kit gives, 30 fps, a "
        "pose encoder reading the camera) or camera (the same, end to end; see "
        "train_eval_recipes.py); flags given still win (default: state)",
    )
    p.add_argument(
        "--phase",
        default=",".join(DEFAULT_PHASES),
        help="comma list of phases to run, any subset of record,export,encode,"
        "train,eval,wire (default: record,export,encode,train,eval)",
    )
    p.add_argument("--task", default="sim_transfer_cube")
    p.add_argument(
        "--episodes",
        type=int,
        default=200,
        help="scripted episodes to record (200: the amount whose runs met the goal; "
        "docs Benchmarks, 'The whole loop')",
    )
    p.add_argument("--seed", type=int, default=0, help="recording seed")
    p.add_argument(
        "--inject_noise", action="store_true", help="record with the scripted plan's waypoint noise"
    )
    p.add_argument(
        "--randomize",
        action="store_true",
        help="record (and record the static frames) with each episode's scene randomized by "
        "the task's randomization section (record --randomize: lights, table, colours, "
        "friction, masses, damping, camera poses, the arms' start)",
    )
    p.add_argument("--cam_names", default="none")
    p.add_argument("--image_size", default="96x128")
    p.add_argument(
        "--crop",
        default=None,
        metavar="CAMERA:TOP,LEFT,HEIGHT,WIDTH",
        help="record and evaluate this rectangle of the camera's 480x640 frame "
        "(trossen-mujoco record --crop; e.g. cam_high:217,243,150,200, the "
        "transfer cube's spawn region; default: whole frames)",
    )
    p.add_argument("--fps", type=int, default=50, help="export (and eval) rate")
    p.add_argument(
        "--train_seeds",
        type=int,
        default=1,
        help="training runs on the same data, seeds --train_seed, +1, ...",
    )
    p.add_argument("--train_seed", type=int, default=1000, help="first training seed")
    p.add_argument(
        "--train_jobs", type=int, default=1, help="training runs at a time (several fit one GPU)"
    )
    p.add_argument(
        "--train_threads",
        type=int,
        default=0,
        help="CPU threads of each training run (default: the cores shared among the runs "
        "at a time; torch's own default oversubscribes the cores when runs share them)",
    )
    p.add_argument("--steps", type=int, default=7000)
    p.add_argument("--batch_size", type=int, default=16)
    p.add_argument("--num_workers", type=int, default=0, help="lerobot-train's data loaders")
    p.add_argument(
        "--video_backend",
        default="",
        help="lerobot-train's --dataset.video_backend (pyav where torchcodec "
        "has no FFmpeg; default: LeRobot's)",
    )
    p.add_argument("--save_freq", type=int, default=1000, help="checkpoint every N steps")
    p.add_argument("--lr", type=float, default=1e-4)
    p.add_argument(
        "--lr_schedule",
        choices=["constant", "cosine"],
        default="cosine",
        help="cosine (default): decayed from --lr to --lr_final over --steps; "
        "constant: ACT's preset, whose rate never decays, so the last checkpoint "
        "lands wherever the noise of the updates left it (one run's score moved "
        "between 52 %% and 92 %% from one saved checkpoint to the next)",
    )
    p.add_argument(
        "--lr_final",
        type=float,
        default=1e-6,
        help="the rate at the last step with --lr_schedule cosine",
    )
    p.add_argument("--dim_model", type=int, default=256)
    p.add_argument("--dim_feedforward", type=int, default=1024)
    p.add_argument("--n_encoder_layers", type=int, default=4)
    p.add_argument("--n_decoder_layers", type=int, default=1)
    p.add_argument("--chunk_size", type=int, default=50)
    p.add_argument(
        "--n_action_steps",
        type=int,
        default=0,
        help="actions executed per chunk (default: --chunk_size)",
    )
    p.add_argument(
        "--temporal_ensemble_coeff",
        type=float,
        default=0.01,
        help="ACT's temporal ensembling, in the checkpoint's config (one action per inference: "
        "the averaged actions stay within the arms' speed limits; 0: off, --n_action_steps "
        "actions per chunk; default 0.01)",
    )
    p.add_argument("--use_vae", default="false")
    p.add_argument(
        "--normalize_env",
        default="MEAN_STD",
        help="normalization of observation.environment_state (ACT's default mapping leaves "
        "ENV features raw, in metres, and the policy then learns to ignore the cube: "
        "MEAN_STD fixes that; IDENTITY is LeRobot's default)",
    )
    p.add_argument(
        "--no_env_state",
        action="store_true",
        help="train on the state and the cameras only: the policy does not see "
        "observation.environment_state (the object poses), so it must find the cube in the "
        "images (the image recipe)",
    )
    p.add_argument(
        "--pose_encoder",
        action="store_true",
        help="train a small encoder once to find the cube in the camera and train every run "
        "on its estimates (the camera_pose recipe; train_eval_pose.py)",
    )
    p.add_argument(
        "--static_frames",
        type=int,
        default=None,
        help="with --pose_encoder: record this many 3-step episodes (the scene at "
        "its start, objects sampled) whose first frames the encoder also trains on "
        "(default: the task's TaskEntry.pose_static_frames: 1000 for the "
        "insertion, 0 for the transfer)",
    )
    p.add_argument(
        "--augment",
        action="store_true",
        help="with --pose_encoder: train the encoder on frames with the light, the camera's "
        "exposure and white balance changed and the image shifted by up to 2 pixels",
    )
    p.add_argument(
        "--train_arg",
        action="append",
        default=[],
        help="one more lerobot-train flag, e.g. --train_arg=--policy.dropout=0.1 (repeatable)",
    )
    p.add_argument("--device", default="cpu")
    p.add_argument("--eval_episodes", type=int, default=50)
    p.add_argument("--eval_workers", type=int, default=2)
    p.add_argument("--eval_seed", type=int, default=0)
    p.add_argument(
        "--eval_randomize",
        default="nominal",
        choices=("nominal", "train", "hard"),
        help="the evaluation level (eval --randomize LEVEL; default nominal: the model's "
        "scene); benchmarks/robustness.py scores a checkpoint at every level",
    )
    p.add_argument(
        "--controller_checks",
        choices=("both", "on", "off"),
        default="both",
        help="eval's --controller_checks: both (default: the score with the arm "
        "controller's checks and, beside it, without), on, or off",
    )
    p.add_argument(
        "--eval_episode_length",
        type=int,
        default=0,
        help="eval episode length in steps (default: the task's)",
    )
    return p


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The flags, over the defaults of ``--recipe``; camera settings checked (one line)."""
    parser = build_parser()
    recipe = parser.parse_known_args(argv)[0].recipe
    parser.set_defaults(**RECIPES[recipe])
    args = parser.parse_args(argv)
    if recipe in CROPPED or args.pose_encoder:  # the task's own settings (its TaskEntry)
        crop, static, problem = task_camera_facts(recipe, args.task)
        if args.crop is None and recipe in CROPPED:
            if problem:
                fail(problem)
            args.crop = crop
        if args.static_frames is None and args.pose_encoder:
            args.static_frames = static
    if args.static_frames is not None and args.static_frames < 0:
        fail(f"--static_frames {args.static_frames}: give a count >= 0 (0: none)")
    if args.static_frames and not args.pose_encoder:
        fail(
            "--static_frames trains the pose encoder: use it with --recipe camera_pose (or "
            "--pose_encoder), or leave it out"
        )
    args.static_frames = args.static_frames or 0
    if args.augment and not args.pose_encoder:
        fail(
            "--augment changes the pose encoder's training frames: use it with --recipe "
            "camera_pose (or --pose_encoder), or leave it out"
        )
    problem = camera_settings_error(args.cam_names, args.image_size, args.crop, args.pose_encoder)
    if problem:
        fail(problem)
    return args


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    phases = [x.strip() for x in args.phase.split(",") if x.strip()]
    unknown = sorted(set(phases) - set(PHASES))
    if unknown or not phases:
        fail(f"--phase {args.phase!r}: unknown {unknown}; choose from {','.join(PHASES)}")
    if args.train_seeds < 1 or args.train_jobs < 1:
        fail("--train_seeds and --train_jobs must be at least 1")
    python = os.environ.get("TROSSEN_LEROBOT_PYTHON", "")
    if not python:
        fail("set TROSSEN_LEROBOT_PYTHON to a Python >= 3.12 with LeRobot (bash .ci/run)")
    work = Path(args.work_dir).expanduser().resolve()
    if work.exists() and not work.is_dir():
        fail(f"--work_dir {work} is a file; give a folder (it is created when missing)")
    try:
        work.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        fail(f"--work_dir {work}: cannot create it ({exc.strerror or exc})")
    env = {**os.environ, "MUJOCO_GL": "egl", "HF_HUB_OFFLINE": "1", "WANDB_MODE": "disabled"}
    cli = [python, "-m", "trossen_arm_mujoco.cli"]
    summary_path = work / "summary.json"
    summary: dict = {}
    if summary_path.exists():  # what earlier phases measured: merged into, never replaced
        try:
            summary = json.loads(summary_path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:  # truncated, not UTF-8, unreadable
            why = exc.strerror if isinstance(exc, OSError) else " ".join(str(exc).split())
            fail(
                f"{summary_path} cannot be read as JSON ({why}); repair it, or move it away "
                "to start a new summary"
            )
        ok = isinstance(summary, dict)
        kept = (summary.get("settings", {}), summary.get("runs", {})) if ok else ({}, {})
        ok = ok and all(isinstance(part, dict) for part in kept)
        if not ok or not all(isinstance(run, dict) for run in kept[1].values()):
            fail(
                f"{summary_path} is not a summary of this benchmark (a JSON object whose "
                "'settings' and 'runs' are objects); move it away to start anew"
            )
    summary.setdefault("settings", {})[",".join(phases)] = vars(args)
    runs: dict[str, dict] = summary.setdefault("runs", {})
    data, dataset = work / "episodes", work / "dataset"
    seeds = [args.train_seed + k for k in range(args.train_seeds)]
    crop = ["--crop", args.crop] if args.crop else []

    def save() -> None:
        tmp = summary_path.with_suffix(".json.tmp")
        tmp.write_text(json.dumps(summary, indent=2) + "\n")
        tmp.replace(summary_path)

    if "record" in phases:
        if (data / f"episode_{args.episodes - 1}.hdf5").exists():
            print(f"record: {data} already holds {args.episodes} episodes")
        else:
            summary["record"] = run_jobs(
                [
                    (
                        "record",
                        cli
                        + [
                            "record",
                            "--task_name",
                            args.task,
                            "--data_dir",
                            str(data),
                            "--num_episodes",
                            str(args.episodes),
                            "--seed",
                            str(args.seed),
                            "--cam_names",
                            args.cam_names,
                            "--image_size",
                            args.image_size,
                            "--num_workers",
                            "2",
                            "--skip_failed",
                        ]
                        + (["--inject_noise"] if args.inject_noise else [])
                        + (["--randomize"] if args.randomize else [])
                        + crop,
                        work / "record.log",
                    )
                ],
                env,
                1,
            )[0]
        static = static_folder(work)
        if args.static_frames and not (static / f"episode_{args.static_frames - 1}.hdf5").exists():
            job = Job(
                "record static frames",
                static_job(cli, args, static),
                work / "static.log",
                env,
                ok=(0, 1),
            )
            summary["record_static"] = job.wait()  # exit 1: its episodes end before success
            if not (static / f"episode_{args.static_frames - 1}.hdf5").exists():
                fail(
                    f"record static frames wrote fewer than {args.static_frames} episodes "
                    f"in {static}; see {work / 'static.log'}"
                )
    if "export" in phases:
        if (dataset / "meta/info.json").exists():
            print(f"export: {dataset} already exported")
        else:
            summary["export"] = run_jobs(
                [
                    (
                        "export",
                        cli
                        + [
                            "export",
                            "--data_dir",
                            str(data),
                            "--output",
                            str(dataset),
                            "--repo_id",
                            "local/sim_dataset",
                            "--fps",
                            str(args.fps),
                            "--sim_features",  # the state recipe observes the object poses
                            "--vcodec",
                            "h264",
                        ],
                        work / "export.log",
                    )
                ],
                env,
                1,
            )[0]
    save()
    if args.pose_encoder:  # every run trains on (and every score uses) the derived dataset
        derived = pose_dataset(work)
        if derived_ready(derived):
            if "encode" in phases:
                print(f"encode: {derived} already derived")
        elif "encode" in phases or "train" in phases:
            if not (dataset / "meta/info.json").exists() or not data.is_dir():
                fail(
                    f"no {POSE_DATASET} in {work}, and no {dataset.name}/ and "
                    f"{data.name}/ to derive it from: run --phase record,export,encode where "
                    f"the episodes are (and carry {POSE_DATASET}/ to a train-only machine)"
                )
            static = static_folder(work) if args.static_frames else None
            summary["encode"] = run_jobs(
                [
                    (
                        "pose encoder",
                        encode_job(
                            python,
                            dataset,
                            data,
                            derived,
                            cores(),
                            args.seed,
                            static,
                            augment=args.augment,
                        ),
                        work / "encode.log",
                    )
                ],
                env,
                1,
            )[0]
            summary["encode"]["report"] = encoder_report(derived)
            save()
        dataset = derived
    if "train" in phases:
        if not (dataset / "meta/info.json").exists():
            fail(f"no dataset in {dataset}: run --phase record,export first")
        jobs = []
        for seed in seeds:
            out = work / "train" / f"seed_{seed}"
            if _checkpoint(out).is_dir():
                print(f"train seed {seed}: {out} already holds a checkpoint")
                continue
            if out.exists():
                fail(f"{out} holds an unfinished run: remove it to train seed {seed} again")
            out.parent.mkdir(parents=True, exist_ok=True)
            log = work / f"train_seed_{seed}.log"
            jobs.append(
                (
                    seed,
                    (
                        f"lerobot-train seed {seed}",
                        train_args(args, python, dataset, out, seed),
                        log,
                    ),
                )
            )
        at_once = min(args.train_jobs, max(1, len(jobs)))
        threads = args.train_threads or max(1, cores() // at_once)
        train_env = {**env, **{k: str(threads) for k in THREAD_VARS}}
        print(f"train: {len(jobs)} run(s), {at_once} at a time, {threads} CPU thread(s) each")
        timings = run_jobs([job for _, job in jobs], train_env, at_once)
        for (seed, (_, _, log)), took in zip(jobs, timings):
            rate = round(args.steps / took["wall_s"], 2) if took["wall_s"] > 0 else None
            runs[str(seed)] = {
                "train": {
                    **took,
                    "steps": args.steps,
                    "steps_per_s": rate,
                    "device": args.device,
                    "jobs_at_once": at_once,
                    "threads": threads,
                },
                "loss_curve": losses(log),
                "trained_with": recipe_flags(vars(args)),
            }
            save()
        for seed in seeds:  # the dataset's settings travel with each checkpoint
            _carry_settings(dataset, work / "train" / f"seed_{seed}")
    if "eval" in phases:
        for seed in seeds:
            ckpt = _checkpoint(work / "train" / f"seed_{seed}")
            if not ckpt.is_dir():
                fail(f"no checkpoint at {ckpt}: run --phase train first")
            _prepare(ckpt, dataset, args.pose_encoder)
            out = work / "eval" / f"seed_{seed}"
            length = ["--episode_length", str(args.eval_episode_length)]
            if _scored(out / "eval_info.json", ckpt, args, both=args.controller_checks == "both"):
                print(f"eval seed {seed}: {out} already holds its scores")
                runs.setdefault(str(seed), {}).update(results(out / "eval_info.json"))
                continue
            took = run_jobs(
                [
                    (
                        f"eval seed {seed}",
                        cli
                        + [
                            "eval",
                            "--policy",
                            str(ckpt),
                            "--task_name",
                            args.task,
                            "--num_episodes",
                            str(args.eval_episodes),
                            "--num_workers",
                            str(args.eval_workers),
                            "--seed",
                            str(args.eval_seed),
                            "--output_dir",
                            str(out),
                            "--overwrite",
                            "--controller_checks",
                            args.controller_checks,
                            "--randomize",
                            args.eval_randomize,
                        ]
                        + (length if args.eval_episode_length else []),
                        work / f"eval_seed_{seed}.log",
                    )
                ],
                env,
                1,
            )[0]
            run = runs.setdefault(str(seed), {})
            run["eval"] = took
            run.update(results(out / "eval_info.json"))
            save()
        mine = [str(seed) for seed in seeds]
        summary["spread"] = report({s: runs[s] for s in mine if s in runs})
        every = alike(runs, mine)  # runs added by earlier calls, trained and scored alike
        summary.pop("spread_all", None)
        if set(every) - set(mine):
            summary["spread_all"] = report(every, f"every alike run in {work}", each=False)
        save()
    if "wire" in phases:
        for seed in seeds:
            ckpt = _checkpoint(work / "train" / f"seed_{seed}")
            if not ckpt.is_dir():
                fail(f"no checkpoint at {ckpt}: run --phase train first")
            _prepare(ckpt, dataset, args.pose_encoder)
            out = work / "wire" / f"seed_{seed}"
            length = ["--episode_length", str(args.eval_episode_length)]
            if _scored(out / "eval_info.json", ckpt, args, both=False):
                print(f"wire seed {seed}: {out} already holds its scores")
                runs.setdefault(str(seed), {})["wire"] = results(out / "eval_info.json")
                continue
            took = run_jobs(
                [
                    (
                        f"wire seed {seed}",
                        cli
                        + [
                            "eval",
                            "--backend",
                            "wire",
                            "--policy",
                            str(ckpt),
                            "--task_name",
                            args.task,
                            "--num_episodes",
                            str(args.eval_episodes),
                            "--seed",
                            str(args.eval_seed),
                            "--output_dir",
                            str(out),
                            "--overwrite",
                        ]
                        + (length if args.eval_episode_length else []),
                        work / f"wire_seed_{seed}.log",
                    )
                ],
                env,
                1,
            )[0]
            run = runs.setdefault(str(seed), {})
            run["wire_eval"] = took
            run["wire"] = results(out / "eval_info.json")
            save()
        summary["spread_wire"] = report(
            {s: runs[s]["wire"] for s in map(str, seeds) if "wire" in runs.get(s, {})}, "wire"
        )
        save()
    print(f"summary: {summary_path}")


if __name__ == "__main__":
    main()
