"""The ``panda-rapier`` command line.

Over 600 lines: one parser per subcommand with its help texts, and each subcommand's thin
runner; the work itself lives in the modules the runners call.

The only module of the environment layer that uses the wings (:mod:`panda_rapier.agents`,
:mod:`~panda_rapier.learning`, :mod:`~panda_rapier.scale`, :mod:`~panda_rapier.tools`): it
imports them inside the functions that need them (the parser takes two torch-free constants,
each runner its subcommand's modules), so ``panda-rapier --help`` loads no torch and no Ray.

::

    panda-rapier eval --policy scripted --episodes 1000 --num-envs 32 --seed 0
    panda-rapier eval --policy runs/tqc_her/model.zip --episodes 100 --json eval.json
    panda-rapier eval --policy scripted --episodes 2 --video scripted.mp4
    panda-rapier bench --num-envs 1 16 64 256 --json bench.json
    panda-rapier bench-train --env-id panda_rapier/PickAndPlaceDense-v0 --variant now \
        --variant one-thread update_threads=1
    panda-rapier train --algo bc --env-id panda_rapier/PickAndPlace-v0 --out runs/bc
    panda-rapier train --algo ppo --env-id panda_rapier/PickAndPlaceDense-v0 --out runs/ppo
    panda-rapier train --algo ppo --backend rllib --out runs/rllib_ppo --num-env-runners 2
    panda-rapier curves runs/bc runs/ppo --out curves.png
    panda-rapier models-table models/ --out models/README.md
"""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from . import __version__
from .errors import InvalidArgumentError, PandaRapierError
from .pixels import DEFAULT_IMAGE_SIZE, RANDOMIZATION_GROUPS, randomization_of
from .registration import DEFAULT_ENV_ID, ENV_IDS, task_places, variant


def _positive(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def _non_negative(text: str) -> int:
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {value}")
    return value


def _rate(text: str) -> float:
    value = float(text)
    if not 0.0 < value <= 1.0:  # also refuses nan
        raise argparse.ArgumentTypeError(f"must be a rate in (0, 1], got {text}")
    return value


def _size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"must be WIDTHxHEIGHT, e.g. 720x480, got {text!r}"
        ) from None
    if width < 1 or height < 1:
        raise argparse.ArgumentTypeError(f"sizes must be >= 1, got {text!r}")
    return width, height


def _parser() -> argparse.ArgumentParser:
    # The wings' constants the parser offers as choices; torch-free modules (see above).
    from .agents.inference import INFERENCE_CHOICES

    parser = argparse.ArgumentParser(
        prog="panda-rapier",
        description="panda_rapier: Franka Panda manipulation tasks on rapier3d.",
    )
    parser.add_argument("--version", action="version", version=f"panda-rapier {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    evaluation = commands.add_parser(
        "eval",
        help="evaluate the scripted baseline or a saved stable-baselines3 model",
        description="Runs seeded episodes (episode k is seeded with SEED + k) on the native "
        "vector environment and reports the success rate with a 95 %% Wilson interval, the "
        "mean return and length, the steps to success and the throughput.",
    )
    evaluation.add_argument(
        "--policy",
        default="scripted",
        help="'scripted' (the task's expert), 'random' (uniform actions, seeded by episode), "
        "the path of a stable-baselines3 model .zip, or a LeRobot policy's directory "
        "(lerobot-train's checkpoints/*/pretrained_model; needs the lerobot extra) "
        "(default: scripted)",
    )
    evaluation.add_argument(
        "--env-id",
        "--env",
        choices=ENV_IDS,
        default=None,
        help=f"environment (default: run.json beside the model, else {DEFAULT_ENV_ID}; for a "
        "LeRobot policy the id its training dataset was recorded on)",
    )
    evaluation.add_argument(
        "--control",
        choices=("ee", "joints"),
        default=None,
        help="action mode, overriding the id's (default: the id's; for a model, the one its "
        "action space fits)",
    )
    evaluation.add_argument(
        "--arm",
        choices=("dynamic", "kinematic"),
        default=None,
        help="fidelity level of the arm (default: the id's, dynamic)",
    )
    evaluation.add_argument("--episodes", type=_positive, default=1000)
    evaluation.add_argument("--num-envs", type=_positive, default=32)
    evaluation.add_argument("--seed", type=_non_negative, default=0, help="first episode's seed")
    evaluation.add_argument(
        "--threads", type=_positive, default=None, help="worker threads (default: all cores)"
    )
    evaluation.add_argument(
        "--max-episode-steps", type=_positive, default=None, help="time limit (default: the id's)"
    )
    evaluation.add_argument(
        "--algo", default=None, help="algorithm of the model file (default: read from the file)"
    )
    evaluation.add_argument(
        "--inference",
        choices=INFERENCE_CHOICES,
        default="auto",
        help="how a model's actions are computed: native (float64, the same on every CPU), "
        "torch (the model's own float32 predict) or auto (native where the model allows, the "
        "default)",
    )
    evaluation.add_argument(
        "--trust-model-file",
        action="store_true",
        help="allow loading the model with stable-baselines3, which unpickles (and may run) "
        "code from the file: needed for models the native network cannot act out (image "
        "policies, other architectures) and for --inference torch",
    )
    evaluation.add_argument(
        "--visual-randomization",
        choices=("off", "all", *RANDOMIZATION_GROUPS),
        default=None,
        help="evaluate an image policy under visual randomisation: all of it, or only the "
        "camera, light, colors or noise (their ranges: panda_rapier.pixels.VISUAL_RANDOMIZATION);"
        " default off, whatever the model was trained with",
    )
    evaluation.add_argument("--json", type=Path, default=None, help="write the report here")
    evaluation.add_argument(
        "--video",
        type=Path,
        default=None,
        help="record the episodes environment 0 runs (episodes 0, NUM_ENVS, ...; all of them "
        "with --num-envs 1) to this video file, e.g. out.mp4 (needs the render extra)",
    )
    evaluation.add_argument(
        "--video-size", type=_size, default=(720, 480), help="WIDTHxHEIGHT (default 720x480)"
    )
    evaluation.add_argument("--quiet", action="store_true", help="no progress bar")
    evaluation.set_defaults(run=_run_eval)

    bench = commands.add_parser(
        "bench",
        help="throughput: env-steps/s and simulated seconds per second, next to the peers",
        description="Measures the gym.make single env, the native vector env and the "
        "stable-baselines3 VecEnv at each N, with random actions and the scripted policy, and "
        "the installed peers (panda-gym, Gymnasium-Robotics, envpool) in the same run, "
        "interleaved round by round; prints medians, ratios against the peers and the accuracy "
        "side (grasp slip, tracking error, scripted placed rate).",
    )
    bench.add_argument("--env-id", "--env", choices=ENV_IDS, default=DEFAULT_ENV_ID)
    bench.add_argument(
        "--arm",
        choices=("dynamic", "kinematic"),
        default="dynamic",
        help="fidelity level of the arm (default: dynamic, the full multibody)",
    )
    bench.add_argument(
        "--num-envs", type=_positive, nargs="+", default=[1, 16, 64, 256], metavar="N"
    )
    bench.add_argument(
        "--targets",
        nargs="+",
        choices=("gym.make", "vector", "sb3"),
        default=["gym.make", "vector", "sb3"],
    )
    bench.add_argument(
        "--policies", nargs="+", choices=("random", "scripted"), default=["random", "scripted"]
    )
    bench.add_argument(
        "--threads", type=_positive, default=None, help="worker threads (default: all cores)"
    )
    bench.add_argument("--rounds", type=_positive, default=3, help="repeats (median reported)")
    bench.add_argument(
        "--env-steps", type=_positive, default=4000, help="environment steps per measurement"
    )
    bench.add_argument(
        "--image-sizes",
        type=_positive,
        nargs="*",
        default=[],
        metavar="PX",
        help="also measure gym.make and vector with image observations of these sizes "
        "(obs_mode=state+rgb, one camera; e.g. 64 84 128)",
    )
    bench.add_argument(
        "--image-modes",
        nargs="+",
        default=["rgb"],
        metavar="MODE",
        help="what the --image-sizes cases observe, each after state+ (default rgb; e.g. rgb "
        "depth segmentation points rgbd)",
    )
    bench.add_argument("--no-peers", action="store_true", help="skip the peer environments")
    bench.add_argument("--json", type=Path, default=None, help="write the report here")
    bench.add_argument("--quiet", action="store_true", help="no progress bar")
    bench.set_defaults(run=_run_bench)

    bench_train = commands.add_parser(
        "bench-train",
        help="training throughput: end-to-end env-steps/s of recipe variants, and where the "
        "wall time goes",
        description="Trains each VARIANT of the recipe (the package's, or --conf) for --steps "
        "env steps, round after round in a fixed interleaved order, and prints per variant the "
        "median env-steps/s (updates included, evaluations excluded), its ratio to the first "
        "variant's and the median seconds of env stepping, the policy in rollouts, other "
        "rollout work and updates. Speed only: compare learning with full runs.",
    )
    bench_train.add_argument("--algo", choices=("ppo", "sac", "tqc"), default="ppo")
    bench_train.add_argument("--env-id", "--env", choices=ENV_IDS, default=DEFAULT_ENV_ID)
    bench_train.add_argument("--conf", type=Path, default=None, help="recipe file (rl-zoo3 YAML)")
    bench_train.add_argument(
        "--variant",
        nargs="+",
        action="append",
        metavar="NAME [KEY=VALUE ...]",
        help="a variant: a name, then recipe overrides, update_threads (torch's threads "
        "during updates), overlap=true (ppo: updates in a second process while the next rollout "
        "is collected) and backend=sb3-stock (ppo: stable-baselines3's PPO class itself "
        "instead of panda_rapier.learning.ppo.PPO) or backend=rllib (ppo: the same recipe "
        "trained by RLlib); repeat for each (default: one, the recipe as it is)",
    )
    bench_train.add_argument(
        "--steps", type=_positive, default=81_920, help="env steps per run (default 81,920)"
    )
    bench_train.add_argument("--rounds", type=_positive, default=3, help="interleaved rounds")
    bench_train.add_argument("--json", type=Path, default=None, help="write the report here")
    bench_train.add_argument("--quiet", action="store_true", help="no progress bar")
    bench_train.set_defaults(run=_run_bench_train)

    from .learning.recipes import ALGORITHMS, FINAL_CHOICES

    train = commands.add_parser(
        "train",
        help="train a policy (PPO, SAC, TQC with stable-baselines3, or bc: behaviour cloning "
        "and DAgger from the scripted expert)",
        description="Trains ALGO on an environment id with the recipe's hyperparameters "
        "(rl-zoo3's YAML format; default: the package's hyperparams/ALGO.yml) on the native "
        "stable-baselines3 VecEnv, with a progress bar, TensorBoard logs, periodic seeded "
        "evaluation on validation seeds (success rate with its 95 %% interval), checkpoints "
        "and --resume. Writes model.zip, best.zip, run.json and evaluations.jsonl to OUT.",
    )
    train.add_argument("--algo", choices=ALGORITHMS, required=True)
    train.add_argument("--env-id", choices=ENV_IDS, default=DEFAULT_ENV_ID)
    train.add_argument("--out", type=Path, required=True, help="run directory")
    train.add_argument("--conf", type=Path, default=None, help="recipe file (rl-zoo3 YAML)")
    train.add_argument("--seed", type=_non_negative, default=0)
    train.add_argument(
        "--timesteps", type=_positive, default=None, help="env steps (default: the recipe's)"
    )
    train.add_argument("--n-envs", type=_positive, default=None, help="default: the recipe's")
    train.add_argument(
        "--env-kwargs",
        nargs="*",
        default=[],
        metavar="KEY=JSON",
        help="environment options added to the recipe's, e.g. arm='\"kinematic\"' or "
        "max_episode_steps=80 (values are JSON; bare words are taken as strings)",
    )
    train.add_argument(
        "--eval-every",
        type=_non_negative,
        default=None,
        help="env steps between evaluations on the validation seeds (0: none; default: the "
        "recipe file's validation entry, else 250,000; bc evaluates after each round)",
    )
    train.add_argument(
        "--eval-episodes",
        type=_positive,
        default=None,
        help="episodes per evaluation (default: the recipe's validation entry, else 100)",
    )
    train.add_argument(
        "--checkpoint-every", type=_non_negative, default=500_000, help="env steps (0: none)"
    )
    train.add_argument("--resume", action="store_true", help="continue the run in OUT")
    train.add_argument(
        "--init-from",
        type=Path,
        default=None,
        metavar="MODEL.zip",
        help="start from this model's weights (and observation normaliser) instead of a "
        "fresh network: fine-tuning, e.g. on another arm model or from a cloned policy",
    )
    train.add_argument(
        "--trust-model-file",
        action="store_true",
        help="with --resume: load a replay buffer this user's runs did not write (it is "
        "unpickled, which may run code from it); checkpoints are otherwise read by data",
    )
    train.add_argument(
        "--threads", type=_positive, default=None, help="environment threads (default: all)"
    )
    train.add_argument(
        "--torch-threads",
        type=_positive,
        default=1,
        help="torch threads while environments step (default 1: more fight the "
        "environment's threads for the cores)",
    )
    train.add_argument(
        "--update-threads",
        type=_positive,
        default=None,
        help="torch threads while nothing else runs: PPO's updates, behaviour cloning's fits "
        "(default: every core)",
    )
    train.add_argument(
        "--overlap-updates",
        action="store_true",
        help="ppo: run each update in a second process while the next rollout is collected "
        "(by the policy from before that update; docs/guide/throughput.md)",
    )
    train.add_argument(
        "--patience",
        type=_non_negative,
        default=None,
        metavar="N",
        help="stop after N evaluations in a row that do not beat the best one (ranked as "
        "best.zip is: placed rate, then success rate); 0: never (default: the recipe's "
        "validation entry, else never)",
    )
    train.add_argument(
        "--stop-at",
        type=_rate,
        default=None,
        metavar="SUCCESS",
        help="stop once a validation evaluation's success rate (and placed rate, on tasks "
        "that place) reaches SUCCESS (0-1]",
    )
    train.add_argument(
        "--final",
        choices=FINAL_CHOICES,
        default=None,
        help="what model.zip holds: the weights training ended with or the best "
        "evaluation's, so a run never ends on a policy that fell back after its best "
        "(default: the recipe's validation entry, else last)",
    )
    train.add_argument(
        "--backend",
        choices=("sb3", "rllib"),
        default="sb3",
        help="who trains: stable-baselines3 on the native VecEnv (default), or RLlib (ppo "
        "only; the same recipe, EnvRunners on a local Ray or a cluster: docs/guide/ray.md)",
    )
    train.add_argument(
        "--num-env-runners", type=_positive, default=2, help="rllib: EnvRunners (Ray actors)"
    )
    train.add_argument(
        "--num-envs-per-env-runner",
        type=_positive,
        default=None,
        help="rllib: environments per EnvRunner (default: the recipe's n_envs shared out)",
    )
    train.add_argument(
        "--address", default=None, help="rllib: a running Ray cluster (auto); default: local"
    )
    train.add_argument("--quiet", action="store_true", help="no progress bar")
    train.set_defaults(run=_run_train)

    curves = commands.add_parser(
        "curves",
        help="plot success rate against env steps and wall time from training runs",
        description="Reads each run's evaluations.jsonl (and its run.json for the label) "
        "and draws success and placed rates, with 95 %% intervals, against env steps and "
        "against wall-clock minutes. A run directory may also be rl-zoo3's (python -m "
        "rl_zoo3.train ... --eval-freq N: its evaluations.npz, args.yml and Monitor files), "
        "e.g. a panda-gym run to compare with. Needs matplotlib.",
    )
    curves.add_argument(
        "runs", type=Path, nargs="+", help="run directories (panda-rapier train's or rl-zoo3's)"
    )
    curves.add_argument("--out", type=Path, required=True, help="PNG file")
    curves.add_argument(
        "--reference",
        type=Path,
        default=None,
        help="JSON of other recipes' measured throughput to draw as reference lines",
    )
    curves.set_defaults(run=_run_curves)

    table = commands.add_parser(
        "models-table",
        help="evaluate every model in a folder and write its README table (and "
        "evaluations.json, every episode's outcome)",
        description="Evaluates each model in FOLDER (MODEL.zip files and LeRobot policy "
        "directories) with `panda-rapier eval`'s defaults "
        "(1000 episodes, seeds 0..999, the environment recorded in the model) and writes a "
        "markdown table of algorithm, env id and options, env steps, wall time, success rate "
        "with its 95 %% interval, placed rate and the command that reproduces each. A row "
        "keeps its record in evaluations.json where the same model file, evaluated again, "
        "repeats every episode, or (float32 models on another CPU) lands within the "
        "recorded intervals; rows whose record changed are listed on stderr.",
    )
    table.add_argument("folder", type=Path)
    table.add_argument(
        "--out",
        type=Path,
        default=None,
        help="default: FOLDER/README.md; the records are evaluations.json beside it (read, "
        "for --only and for records kept, and written)",
    )
    table.add_argument("--episodes", type=_positive, default=1000)
    table.add_argument(
        "--only",
        action="append",
        default=None,
        metavar="PATTERN",
        help="evaluate only the rows whose key (a model's file or directory name, or 'random "
        "ID' / 'scripted ID') matches this shell pattern (repeatable); the others keep their "
        "record in evaluations.json, which must be of the same model file and episodes",
    )
    table.add_argument("--quiet", action="store_true", help="no progress bar")
    table.set_defaults(run=_run_models_table)

    demos = commands.add_parser(
        "demos",
        help="record the scripted expert's episodes as a Minari or LeRobot dataset",
        description="Runs the scripted expert for EPISODES seeded episodes (episode k with "
        "seed FIRST_SEED + k) and writes them, with every step info, the environment's spec "
        "and reference scores, as a Minari dataset under Minari's data path "
        "(MINARI_DATASETS_PATH; needs the demos extra, minari); or with --format lerobot as a "
        "LeRobot dataset (format v3.0) in the new directory --root, recorded on --num-envs "
        "environments in parallel, with an image stream per --camera (needs the lerobot "
        "extra, Python >= 3.12).",
    )
    demos.add_argument("--env", choices=ENV_IDS, default=DEFAULT_ENV_ID)
    demos.add_argument("--episodes", type=_positive, default=1000)
    demos.add_argument(
        "--dataset-id",
        default=None,
        help="default: panda_rapier/<variant>/expert-v0 (medium-v0 with --noise)",
    )
    demos.add_argument(
        "--noise",
        type=float,
        default=0.0,
        help="standard deviation of Gaussian noise added to the expert's actions (0: none)",
    )
    demos.add_argument("--first-seed", type=_non_negative, default=None)
    demos.add_argument(
        "--env-kwargs", nargs="*", default=[], metavar="KEY=JSON", help="environment options"
    )
    demos.add_argument("--format", choices=("minari", "lerobot"), default="minari")
    demos.add_argument(
        "--root", type=Path, default=None, help="lerobot: the new directory to write into"
    )
    demos.add_argument(
        "--camera",
        action="append",
        default=[],
        metavar="KEY",
        help="lerobot: an image stream from the observation camera "
        "(panda_rapier.pixels.DEFAULT_CAMERA) under observation.images.KEY; repeatable",
    )
    demos.add_argument("--image-size", type=_positive, default=DEFAULT_IMAGE_SIZE)
    demos.add_argument(
        "--no-videos", action="store_true", help="lerobot: PNG images instead of videos"
    )
    demos.add_argument("--num-envs", type=_positive, default=8, help="lerobot: environments")
    demos.add_argument(
        "--environment-state",
        action="store_true",
        help="lerobot: the objects' state as observation.environment_state, the goals and the "
        "robot's as observation.state (for ACT or Diffusion Policy without images)",
    )
    demos.add_argument("--quiet", action="store_true", help="no progress bar")
    demos.set_defaults(run=_run_demos)
    return parser


def _run_demos(args: argparse.Namespace) -> int:
    if args.format == "lerobot":
        return _run_lerobot_demos(args)
    lerobot_only = [
        flag
        for flag, given in (
            ("--root", args.root is not None),
            ("--camera", bool(args.camera)),
            ("--no-videos", args.no_videos),
            ("--environment-state", args.environment_state),
        )
        if given
    ]
    if lerobot_only:
        raise ValueError(f"{', '.join(lerobot_only)} go with --format lerobot")
    from tqdm import tqdm

    from .learning.demos import DEFAULT_FIRST_SEED, record

    with tqdm(desc="demos", unit="episode", disable=args.quiet, file=sys.stderr) as bar:

        def progress(done: int, total: int) -> None:
            bar.total = total
            bar.update(done - bar.n)

        summary = record(
            args.env,
            args.episodes,
            dataset_id=args.dataset_id,
            noise=args.noise,
            first_seed=DEFAULT_FIRST_SEED if args.first_seed is None else args.first_seed,
            env_kwargs=_env_kwargs(args.env_kwargs),
            progress=progress,
        )
    print(
        f"recorded {summary.episodes} episodes ({summary.steps} steps) of the scripted expert "
        f"on {args.env} as the Minari dataset {summary.dataset_id} in {summary.wall_time_s:.1f} s"
    )
    print(
        f"  success {summary.success_rate:.3f}, placed {summary.placed_rate:.3f}, mean return "
        f"{summary.mean_return:.2f} (reference scores: random {summary.ref_min_score:.2f}, "
        f"expert {summary.ref_max_score:.2f})"
    )
    print(f"  stored in {summary.path}; load it with minari.load_dataset({summary.dataset_id!r})")
    return 0


def _run_lerobot_demos(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from .learning.lerobot_dataset import record_lerobot
    from .pixels import DEFAULT_CAMERA
    from .seeds import DEMOS_FIRST_SEED

    if args.root is None:
        raise ValueError("--format lerobot needs --root DIR (a new directory)")
    if args.noise:
        raise ValueError(
            "--noise is for --format minari; LeRobot datasets hold the expert's actions"
        )
    with tqdm(
        desc="demos", unit="episode", total=args.episodes, disable=args.quiet, file=sys.stderr
    ) as bar:
        summary = record_lerobot(
            args.env,
            args.episodes,
            args.root,
            repo_id=args.dataset_id,
            cameras={key: dict(DEFAULT_CAMERA) for key in args.camera} or None,
            image_size=args.image_size,
            use_videos=not args.no_videos,
            num_envs=args.num_envs,
            first_seed=DEMOS_FIRST_SEED if args.first_seed is None else args.first_seed,
            env_kwargs=_env_kwargs(args.env_kwargs),
            environment_state=args.environment_state,
            progress=lambda done: bar.update(done - bar.n),
        )
    print(
        f"recorded {summary.episodes} episodes ({summary.frames} frames) of the scripted expert "
        f"on {args.env} as the LeRobot dataset {summary.repo_id} in {summary.wall_time_s:.1f} s; "
        f"success {summary.success_rate:.3f}"
    )
    print(
        f"  stored in {summary.root}; load it with LeRobotDataset({summary.repo_id!r}, "
        f"root={summary.root!r})"
    )
    return 0


def _env_kwargs(items: Sequence[str]) -> dict[str, Any]:
    options: dict[str, Any] = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep or not key:
            raise ValueError(f"--env-kwargs takes KEY=VALUE, got {item!r}")
        try:
            options[key] = json.loads(text)
        except ValueError:
            options[key] = text
    return options


#: ``panda-rapier train`` options that only the stable-baselines3 backend reads, with their
#: defaults.
_SB3_ONLY = {
    "n_envs": None,
    "init_from": None,
    "trust_model_file": False,
    "threads": None,
    "update_threads": None,
    "overlap_updates": False,
}


def _run_train_rllib(args: argparse.Namespace) -> dict[str, Any]:
    if args.algo != "ppo":
        raise InvalidArgumentError(f"--backend rllib trains ppo only, not {args.algo}")
    given = [k for k, default in _SB3_ONLY.items() if getattr(args, k) != default]
    if given or args.torch_threads != 1:
        names = [f"--{k.replace('_', '-')}" for k in given]
        names += ["--torch-threads"] if args.torch_threads != 1 else []
        raise InvalidArgumentError(f"--backend rllib does not take {', '.join(names)}")
    from .scale.rllib_training import train

    return train(
        args.env_id,
        args.out,
        **_train_options(args),
        num_env_runners=args.num_env_runners,
        num_envs_per_env_runner=args.num_envs_per_env_runner,
        address=args.address,
    )


def _train_options(args: argparse.Namespace) -> dict[str, Any]:
    """The ``train`` options both backends take."""
    return {
        "conf": args.conf,
        "seed": args.seed,
        "timesteps": args.timesteps,
        "env_kwargs": _env_kwargs(args.env_kwargs),
        "eval_every": args.eval_every,
        "eval_episodes": args.eval_episodes,
        "checkpoint_every": args.checkpoint_every,
        "resume": args.resume,
        "patience": args.patience,
        "stop_at": args.stop_at,
        "final": args.final,
        "progress": not args.quiet,
        "command": ["panda-rapier", *args.argv],
    }


def _run_train(args: argparse.Namespace) -> int:
    from .learning.runner import train

    if args.backend == "rllib":
        run = _run_train_rllib(args)
    else:
        if (args.num_env_runners, args.num_envs_per_env_runner, args.address) != (2, None, None):
            raise InvalidArgumentError(
                "--num-env-runners, --num-envs-per-env-runner and --address are for --backend rllib"
            )
        run = train(
            args.algo,
            args.env_id,
            args.out,
            **_train_options(args),
            n_envs=args.n_envs,
            num_threads=args.threads,
            init_from=args.init_from,
            trust=args.trust_model_file,
            torch_threads=args.torch_threads,
            update_threads=args.update_threads,
            default_eval_every=250_000,
            overlap_updates=True if args.overlap_updates else None,
        )
    return _report_run(args, run)


def _report_run(args: argparse.Namespace, run: Mapping[str, Any]) -> int:
    minutes = run["wall_time_s"] / 60
    print(
        f"trained {args.algo} on {args.env_id}: {run['env_steps']:,} env steps in "
        f"{minutes:.1f} min; model written to {args.out / 'model.zip'}"
    )
    last = run.get("last_evaluation")
    if last is not None:
        low, high = last["success_ci95"]
        placed = (
            f", placed {last['placed_rate']:.3f}"
            if task_places(variant(str(run["env_id"]))["task"])
            else ""
        )
        print(
            f"last validation: success {last['success_rate']:.3f} ({low:.3f}-{high:.3f})"
            f"{placed} over {last['episodes']} episodes"
        )
    weights = run.get("final_weights")
    if run.get("final") == "best" and weights is not None:
        print(f"model.zip holds the best evaluation's weights ({weights['env_steps']:,} steps)")
    return 0


def _run_curves(args: argparse.Namespace) -> int:
    from .tools.reporting import plot_curves

    plot_curves(args.runs, args.out, reference=args.reference)
    print(f"curves written to {args.out}")
    return 0


def _run_models_table(args: argparse.Namespace) -> int:
    from .tools.reporting import models_table

    out = args.out or args.folder / "README.md"
    evaluations = out.parent / "evaluations.json"
    previous = None
    if evaluations.exists():
        try:
            previous = json.loads(evaluations.read_text())
        except (OSError, ValueError) as error:
            raise InvalidArgumentError(f"cannot read {evaluations}: {error}") from error
        if not isinstance(previous, dict):
            raise InvalidArgumentError(f"{evaluations} is not a JSON object of records")
    text, records = models_table(
        args.folder, episodes=args.episodes, progress=not args.quiet, previous=previous,
        say=lambda line: print(line, file=sys.stderr), only=args.only,
    )  # fmt: skip
    out.write_text(text)
    evaluations.write_text(json.dumps(records, indent=1, sort_keys=True) + "\n")
    print(text)
    print(f"table written to {out}, every episode's outcome to {evaluations}")
    return 0


@contextlib.contextmanager
def _run_bar(desc: str, quiet: bool) -> Any:
    """A progress bar of runs on stderr, yielding the ``progress(done, total, label)``
    callback the benchmarks call."""
    from tqdm import tqdm

    with tqdm(desc=desc, unit="run", disable=quiet, file=sys.stderr) as bar:

        def progress(done: int, total: int, label: str) -> None:
            bar.total = total
            bar.set_postfix_str(label)
            bar.update(done - bar.n)

        yield progress


def _write_report(path: Path | None, text: str) -> None:
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
        print(f"report written to {path}")


def _run_bench(args: argparse.Namespace) -> int:
    from .tools.bench import format_report, run_benchmark, to_json

    with _run_bar("bench", args.quiet) as progress:
        report = run_benchmark(
            env_id=args.env_id,
            num_envs=args.num_envs,
            targets=args.targets,
            policies=args.policies,
            threads=args.threads,
            rounds=args.rounds,
            env_steps=args.env_steps,
            peers=not args.no_peers,
            progress=progress,
            image_sizes=args.image_sizes,
            image_modes=args.image_modes,
            arm=args.arm,
        )
    print(format_report(report))
    _write_report(args.json, to_json(report))
    return 0


def _run_bench_train(args: argparse.Namespace) -> int:
    from .tools.train_bench import benchmark_training, format_training_report, parse_variant

    variants = [parse_variant(tokens) for tokens in (args.variant or [["recipe"]])]
    with _run_bar("bench-train", args.quiet) as progress:
        report = benchmark_training(
            args.algo, args.env_id, variants, steps=args.steps, rounds=args.rounds,
            conf=args.conf, progress=progress,
        )  # fmt: skip
    print(format_training_report(report))
    _write_report(args.json, json.dumps(report, indent=1) + "\n")
    return 0


def _run_eval(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from .agents.evaluation import evaluate
    from .agents.inference import resolve_policy

    overrides: dict[str, Any] = {}
    if args.control is not None:
        overrides["control_mode"] = args.control
    if args.max_episode_steps is not None:
        overrides["max_episode_steps"] = args.max_episode_steps
    if args.arm is not None:
        overrides["arm"] = args.arm
    # A --policy that is neither a baseline nor a file: InvalidArgumentError, exit 2.
    resolved = resolve_policy(
        args.policy, args.env_id, overrides, args.algo, args.inference, args.trust_model_file
    )
    if resolved.fallback is not None:
        print(f"inference: torch float32 (not the native network: {resolved.fallback})")
    policy, config, observation, label = (
        resolved.policy, resolved.config, resolved.observation, resolved.label
    )  # fmt: skip
    if args.visual_randomization not in (None, "off"):
        if not observation.get("obs_mode", "state").endswith("rgb"):
            raise InvalidArgumentError(
                f"--visual-randomization needs a policy that sees images; {label} acts on "
                f"obs_mode={observation.get('obs_mode', 'state')!r}"
            )
        observation = {
            **observation,
            "visual_randomization": randomization_of(args.visual_randomization),
        }

    recorder = None
    if args.video is not None:
        from .video import VideoRecorder

        width, height = args.video_size
        fps = float(config.get("control_frequency", 25.0))
        recorder = VideoRecorder(args.video, fps, width=width, height=height)
    with (
        tqdm(
            total=args.episodes, desc="episodes", unit="ep", disable=args.quiet, file=sys.stderr
        ) as bar,
        recorder if recorder is not None else contextlib.nullcontext(),
    ):
        report = evaluate(
            policy,
            config,
            args.episodes,
            num_envs=args.num_envs,
            first_seed=args.seed,
            num_threads=args.threads,
            progress=lambda done: bar.update(done - bar.n),
            recorder=recorder,
            **observation,
        )
    report.policy = label
    summary = report.summary()
    low, high = summary["success_ci95"]
    steps = summary["mean_steps_to_success"]
    print(
        f"policy {label} on {summary['episodes']} episodes "
        f"({summary['arm']} arm, {summary['control_mode']} control, "
        f"{summary['reward_type']} reward, "
        f"{summary['max_episode_steps']} steps, seeds {args.seed}..{args.seed + args.episodes - 1})"
    )
    if args.visual_randomization not in (None, "off"):
        print(f"  visual randomisation {args.visual_randomization} (seed 0)")
    print(
        f"  success rate        {summary['success_rate']:.3f} "
        f"(95 % CI {low:.3f}-{high:.3f})"
        + (
            f"; placed in {summary['placed_rate']:.3f}"
            if task_places(report.config["task"]["name"])
            else ""
        )
    )
    once_low, once_high = summary["success_once_ci95"]
    print(
        f"  success at any step {summary['success_once_rate']:.3f} "
        f"(95 % CI {once_low:.3f}-{once_high:.3f}; lerobot-eval counts this)"
    )
    print(f"  mean return         {summary['mean_return']:.3f} +- {summary['std_return']:.3f}")
    print(f"  inference           {report.inference}")
    print(f"  mean episode length {summary['mean_length']:.1f} steps")
    print(
        "  steps to success    "
        + (
            f"mean {steps:.1f}, median {summary['median_steps_to_success']:.1f}"
            if steps is not None
            else "never succeeded"
        )
    )
    print(
        f"  throughput          {summary['env_steps_per_s']:.0f} env-steps/s "
        f"({summary['env_steps']} steps, {summary['num_envs']} envs, "
        f"{summary['num_threads']} threads, {summary['wall_time_s']:.1f} s)"
    )
    if recorder is not None:
        print(f"  video               {recorder.frames} frames written to {args.video}")
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(report.to_json())
        print(f"  report written to {args.json}")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``panda-rapier`` console script."""
    args = _parser().parse_args(argv)
    args.argv = list(argv) if argv is not None else sys.argv[1:]
    try:
        return int(args.run(args))
    except (PandaRapierError, ImportError, ValueError, OSError) as error:
        print(f"panda-rapier {args.command}: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
