"""Learning curves and the benchmark table of shipped models: what ``panda-rapier curves``
and ``panda-rapier models-table`` run; the robustness table of the policies that see
(``scripts/robustness_table.py``).

Both read what ``panda-rapier train`` writes (``evaluations.jsonl``, ``run.json``, the run
record inside each model zip); the table evaluates every row as ``panda-rapier eval --policy
SPEC`` does (:func:`panda_rapier.agents.inference.resolve_policy`, the same call), so nothing in it
is typed by hand.

Over 600 lines: the three reports share the row evaluation and the run-record reading.
"""

from __future__ import annotations

import fnmatch
import json
import shlex
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from tqdm import tqdm

from .._deprecated import same_class
from ..agents.evaluation import EvaluationReport, check_reproduction, evaluate
from ..agents.inference import resolve_policy
from ..agents.lerobot_policy import is_lerobot_policy
from ..agents.model_file import model_digest, read_run_info
from ..errors import ConfigError, InvalidArgumentError
from ..learning.recipes import load_recipe, recipe_validation, recipes_train_alike
from ..pixels import RANDOMIZATION_GROUPS, randomization_of
from ..registration import TASK_NAMES, task_id, task_places, variant
from .zoo_runs import is_zoo_run, zoo_curve

__all__ = [
    "ROBUSTNESS_CONDITIONS",
    "kept_record",
    "models_table",
    "plot_curves",
    "robustness_table",
    "run_label",
]

#: Where a run record's ``recipe_file`` says the package's own recipes are (before 0.2 and now).
PACKAGE_RECIPES = ("panda_rapier/hyperparams/", "panda_rapier/learning/hyperparams/")


def _evaluations(run: Path) -> list[dict[str, Any]]:
    path = run / "evaluations.jsonl"
    try:
        lines = path.read_text().splitlines()
    except OSError as error:
        raise InvalidArgumentError(f"{run} has no evaluations.jsonl: {error}") from error
    return [json.loads(line) for line in lines if line.strip()]


def run_label(run: dict[str, Any]) -> str:
    """A short name of a run: algorithm, task variant, arm, non-default options, and what
    tells runs of one id apart: a seed other than 0, a recipe file other than the package's,
    for PPO a class other than :class:`panda_rapier.learning.ppo.PPO` (runs recorded before it
    have no ``algorithm_class``: stable-baselines3's own) and updates overlapped with the
    next rollout (``overlap_updates``)."""
    env = str(run.get("env_id", "?")).split("/")[-1]
    options = dict(run.get("env_kwargs") or {})
    arm = options.pop("arm", "dynamic")
    weights = options.pop("reward_weights", None) or {}  # shown as term=weight
    options.update({str(k): v for k, v in dict(weights).items()})
    parts = [f"{arm} arm"]
    if run.get("init_from"):
        parts.append("fine-tuned")
    parts += [f"{k}={v}" for k, v in sorted(options.items())]
    if run.get("seed"):
        parts.append(f"seed {run['seed']}")
    recipe = str(run.get("recipe_file") or "")
    if recipe and not recipe.startswith(PACKAGE_RECIPES):
        parts.append(f"recipe {Path(recipe).stem}")
    if run.get("algo") == "ppo" and run.get("backend") != "rllib":
        cls = str(run.get("algorithm_class", "stable_baselines3.ppo.ppo.PPO"))
        if not same_class(cls, "panda_rapier.learning.ppo.PPO"):
            parts.append("SB3's PPO class")
    if run.get("overlap_updates"):
        parts.append("updates overlapped")
    return f"{_trainer(run)} {env} ({', '.join(parts)})"


def _trainer(run: Mapping[str, Any]) -> str:
    """The algorithm, and RLlib where RLlib trained it (``--backend rllib``), LeRobot where
    ``lerobot-train`` did."""
    algo = str(run.get("algo", "?"))
    backend = {"rllib": "RLlib", "lerobot": "LeRobot"}.get(str(run.get("backend")))
    return f"{algo} ({backend})" if backend else algo


def plot_curves(runs: Sequence[Path], out: Path, reference: Path | None = None) -> None:
    """Success (solid, with its 95 % interval) and placed (dashed; where the task places) rate
    of each run's periodic evaluations, against env steps and against wall-clock minutes of
    training. ``reference``:
    a JSON list of ``{"label", "env_steps_per_s"}`` (another recipe's measured training
    throughput on the same machine), drawn on the steps axis at the step count it reaches in
    the longest run's wall time. A fine-tuning run (``--init-from``) is drawn after the steps
    and minutes of the model it started from, so its curve shows the whole cost."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as error:
        raise ImportError("curves need matplotlib: pip install matplotlib") from error
    figure, (by_steps, by_time) = plt.subplots(1, 2, figsize=(13, 4.8))
    longest = 0.0
    drew_placed = False
    for index, run_dir in enumerate(runs):
        folder = Path(run_dir)
        if is_zoo_run(folder):
            name, lines = zoo_curve(folder)
            run: dict[str, Any] = {}
        else:
            lines, run = _evaluations(folder), json.loads((folder / "run.json").read_text())
            name = run_label(run)
        color = f"C{index}"
        source = (run.get("init_from") or {}).get("run") or {}
        step0 = int(source.get("env_steps", 0))
        minute0 = float(source.get("wall_time_s", 0.0)) / 60
        steps = [step0 + line["env_steps"] for line in lines]
        minutes = [minute0 + line["wall_time_s"] / 60 for line in lines]
        longest = max(longest, max(minutes, default=0.0))
        success = [line["success_rate"] for line in lines]
        low = [line["success_ci95"][0] for line in lines]
        high = [line["success_ci95"][1] for line in lines]
        placed = [line["placed_rate"] for line in lines]
        for axis, x in ((by_steps, steps), (by_time, minutes)):
            axis.plot(x, success, "-o", color=color, ms=3, label=f"{name}: success")
            axis.fill_between(x, low, high, color=color, alpha=0.15)
            if any(placed):  # tasks without placing report 0 throughout
                drew_placed = True
                axis.plot(x, placed, "--", color=color, label=f"{name}: placed")
    if reference is not None and longest > 0:
        for index, item in enumerate(json.loads(Path(reference).read_text())):
            reached = float(item["env_steps_per_s"]) * longest * 60
            by_steps.axvline(reached, color=f"C{7 + index % 3}", ls=":", lw=1.5)
            by_steps.annotate(
                f"{item['label']}: {reached:,.0f} steps\nin {longest:.0f} min",
                (reached, 0.5 - 0.12 * index),
                fontsize=7,
                ha="left",
            )
    by_steps.set_xlabel("env steps (expert demonstrations and learner rollouts included)")
    by_steps.set_xscale("log")
    by_time.set_xlabel("wall-clock minutes of training on 2 cores (evaluations excluded)")
    for axis in (by_steps, by_time):
        axis.set_ylabel("rate on validation seeds")
        axis.set_ylim(-0.02, 1.02)
        axis.grid(alpha=0.3)
    by_time.legend(fontsize=7, loc="lower right")
    what = "solid: success, dashed: placed" if drew_placed else "success"
    figure.suptitle(f"panda_rapier: learning curves ({what})")
    figure.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(out, dpi=110)
    plt.close(figure)


#: Rows of the table that are not model files: the floor and the ceiling of every group.
BASELINES = ("random", "scripted")


def _evaluate_row(
    spec: str,
    env_id: str | None,
    episodes: int,
    progress: bool,
    label: str,
    visual_randomization: str = "off",
) -> EvaluationReport:
    """``panda-rapier eval --policy SPEC [--env-id ENV_ID] --episodes EPISODES
    [--visual-randomization NAME]`` as a library call (the same resolution of the policy and
    its environment): the report."""

    resolved = resolve_policy(spec, env_id)
    observation = dict(resolved.observation)
    if visual_randomization != "off":
        observation["visual_randomization"] = randomization_of(visual_randomization)
    with tqdm(total=episodes, desc=label, unit="ep", disable=not progress, leave=False) as bar:
        report = evaluate(
            resolved.policy,
            resolved.config,
            episodes,
            progress=lambda done: bar.update(done - bar.n),
            **observation,
        )
    report.policy = resolved.label
    return report


def _group_of(env_id: str) -> tuple[str, str]:
    """The task and action mode (``ee`` or ``joints``) of an id's table; a task's
    end-effector ids are its ``ee`` group whatever their actions (``ee_pose``: peg
    insertion)."""
    fixed = variant(env_id)
    mode = "joints" if fixed["control_mode"] == "joints" else "ee"
    return fixed["task"], mode


def shipped_models(folder: Path) -> list[Path]:
    """The models of a models folder: every ``*.zip`` (``panda-rapier train``'s) and every
    directory holding a LeRobot policy, sorted by name."""
    folder = Path(folder)
    return sorted(
        [*folder.glob("*.zip"), *(p for p in folder.iterdir() if is_lerobot_policy(p))],
        key=lambda path: path.name,
    )


def models_table(
    folder: Path,
    episodes: int = 1000,
    progress: bool = True,
    previous: Mapping[str, Any] | None = None,
    say: Callable[[str], None] | None = None,
    only: Sequence[str] | None = None,
) -> tuple[str, dict[str, Any]]:
    """The benchmark table of ``folder``'s README and the evaluations behind it.

    Grouped by task and action mode. Each group has a uniformly random policy, the scripted
    expert (both on the group's sparse id, default options) and every model in ``folder``
    (:func:`shipped_models`: ``*.zip`` files and LeRobot policy directories, each with its
    run record) trained on one of the group's ids. Every row is evaluated as
    ``panda-rapier eval --policy SPEC`` runs it: seeds ``0 .. episodes - 1``, which no
    training run uses.

    Returns the markdown and the evaluations: per row, the summary and each episode's success
    and placed flags as strings of 0 and 1 (and a model's ``model_sha256``,
    :func:`~panda_rapier.agents.model_file.model_digest`). A model's key is its file or
    directory name; a baseline's is ``"random panda_rapier/Reach-v0"``.

    ``previous`` (the evaluations an earlier call returned) keeps a row's earlier record
    where this evaluation reproduces it (:func:`kept_record`): where the model and the
    episodes are the same, a row's figures change only with its outcome, not with the
    machine that ran the table. ``say`` is told of every row whose record changed.

    ``only`` (shell patterns of row keys): evaluate just the rows that match one; every other
    row shows its record in ``previous`` unchanged, which must exist and be of the same model
    file and number of episodes."""
    models = shipped_models(Path(folder))
    if not models:
        raise InvalidArgumentError(f"no models (*.zip or LeRobot policy directories) in {folder}")
    runs: dict[Path, dict[str, Any]] = {}
    for model in models:
        run = read_run_info(model)
        if run is None:
            raise InvalidArgumentError(
                f"{model} has no run record (panda_rapier_run.json): was it made by train?"
            )
        runs[model] = run
    groups = [
        (task, mode)
        for task in TASK_NAMES
        for mode in ("ee", "joints")
        if any(_group_of(run["env_id"]) == (task, mode) for run in runs.values())
    ]
    records: dict[str, Any] = {}
    sections: list[str] = []
    commands: list[str] = []
    total = len(groups) * len(BASELINES) + len(models)
    with tqdm(total=total, desc="rows", unit="row", disable=not progress) as rows_bar:

        def evaluated(key: str, spec: str, env_id: str | None) -> dict[str, Any]:
            earlier = (previous or {}).get(key)
            if only is not None and not any(fnmatch.fnmatchcase(key, p) for p in only):
                records[key] = _unevaluated(key, earlier, spec, env_id, episodes)
                rows_bar.update(1)
                return records[key]
            report = _evaluate_row(spec, env_id, episodes, progress, key)
            record = _record(report.summary(), report.episodes)
            if env_id is None:
                record["model_sha256"] = model_digest(spec)
            records[key], why = kept_record(earlier, record, report)
            if say is not None and records[key] is record and earlier is not None:
                say(f"{key}: new record ({why})")
            rows_bar.update(1)
            return records[key]

        for task, mode in groups:
            base_id = task_id(task, mode)
            rows: list[tuple[str, str, str, str, str, dict[str, Any]]] = []
            for spec in BASELINES:
                summary = evaluated(f"{spec} {base_id}", spec, base_id)
                how = "uniform actions" if spec == "random" else "hand-written expert"
                rows.append((spec, how, "", "-", "-", summary))
            for model, run in runs.items():
                if _group_of(run["env_id"]) != (task, mode):
                    continue
                summary = evaluated(model.name, str(model), None)
                options = json.dumps(run.get("env_kwargs") or {}, sort_keys=True)
                # A fine-tuned model's cost includes the model it started from.
                source = (run.get("init_from") or {}).get("run") or {}
                env_steps = run["env_steps"] + int(source.get("env_steps", 0))
                wall_time = run["wall_time_s"] + float(source.get("wall_time_s", 0.0))
                how = f"{_trainer(run)} on `{run['env_id'].split('/')[-1]}`"
                rows.append(
                    (f"`{model.name}`", how, options, f"{env_steps:,}",
                     f"{wall_time / 60:.1f}", summary)
                )  # fmt: skip
                commands.append(_reproduce(model, run, source))
            places = task_places(task)
            sections.append(
                f"### {TASK_NAMES[task]}, {'joint' if mode == 'joints' else 'end-effector'} "
                f"control (`{base_id.split('/')[-1]}`)\n\n"
                "| policy | trained | options | env steps | wall time (min) "
                "| success (95 % CI) | placed |\n|---|---|---|---|---|---|---|\n"
                + "\n".join(_row(*row, places=places) for row in rows)
            )
    baseline_commands = (
        "- random and scripted rows: `panda-rapier eval --policy random --env-id ID "
        f"--episodes {episodes}` (and `--policy scripted`), ID the group's id"
    )
    text = (
        _header(folder, episodes)
        + "\n\n".join(sections)
        + "\n\n## Reproduce\n\n"
        + "\n".join([baseline_commands, *commands])
        + "\n"
    )
    return text, records


#: Record fields that say what was evaluated: a record is kept only where they are unchanged.
_SAME_EVALUATION = ("model_sha256", "episodes", "first_seed", "max_episode_steps")


def _unevaluated(
    key: str, earlier: Mapping[str, Any] | None, spec: str, env_id: str | None, episodes: int
) -> dict[str, Any]:
    """The earlier record of a row that ``models_table(only=...)`` leaves out, checked to be
    of the same model and episodes."""
    if not isinstance(earlier, Mapping):
        raise InvalidArgumentError(
            f"{key} has no record in evaluations.json to keep: name it in --only to evaluate it"
        )
    if env_id is None and earlier.get("model_sha256") != model_digest(spec):
        raise InvalidArgumentError(
            f"{key} changed since evaluations.json recorded it: name it in --only to evaluate it"
        )
    if earlier.get("episodes") != episodes:
        raise InvalidArgumentError(
            f"{key} was recorded on {earlier.get('episodes')} episodes, not {episodes}: name it "
            "in --only to evaluate it"
        )
    return dict(earlier)


def kept_record(
    earlier: Mapping[str, Any] | None, new: dict[str, Any], report: EvaluationReport
) -> tuple[dict[str, Any], str]:
    """The record a models table keeps for a row evaluated again (``new``, made from
    ``report``), and why.

    The earlier record stays where the same model file (``model_sha256``) was evaluated on
    the same episodes and the new evaluation reproduces it as :func:`~panda_rapier.
    evaluation.check_reproduction` defines it: every episode repeated where the outcome's
    environment matches (the time and the machine of the first evaluation are kept), the
    rates within the statistical test elsewhere (a float32 model on another CPU). Otherwise
    the new record replaces it: a retrained model, other episodes, or an evaluation that did
    not reproduce the earlier one."""
    if earlier is None:
        return new, "no earlier record"
    for key in _SAME_EVALUATION:
        if earlier.get(key) != new.get(key):
            return new, f"{key} changed"
    check = check_reproduction(earlier, report)
    if check.passed:
        return dict(earlier), f"reproduced ({check.kind}): {check.details}"
    return new, f"did not reproduce ({check.kind}): {check.details}"


def _record(summary: dict[str, Any], episodes: Sequence[Any]) -> dict[str, Any]:
    """An evaluation as the tables keep it: the summary and each episode's success and placed
    flags as strings of 0 and 1."""
    return {
        **summary,
        "success_by_episode": "".join("1" if e.success else "0" for e in episodes),
        "placed_by_episode": "".join("1" if e.placed else "0" for e in episodes),
    }


def _row(
    name: str,
    how: str,
    options: str,
    env_steps: str,
    minutes: str,
    summary: dict[str, Any],
    places: bool,
) -> str:
    low, high = summary["success_ci95"]
    placed = f"{summary['placed_rate']:.3f}" if places else "-"
    return (
        f"| {name} | {how} | {f'`{options}`' if options else '-'} | {env_steps} | {minutes} "
        f"| {summary['success_rate']:.3f} ({low:.3f}-{high:.3f}) | {placed} |"
    )


def _header(folder: Path, episodes: int) -> str:
    where = folder.as_posix()
    return (
        "# Benchmark: trained policies and baselines\n\n"
        f"Generated by `panda-rapier models-table {where}`. One table per task and action "
        "mode: a uniformly random policy, the scripted expert and every model shipped here, "
        f"each evaluated as `panda-rapier eval --policy random|scripted|{where}/NAME.zip` "
        "(a model needs no other flag: its environment id and options are stored in the zip; "
        "a LeRobot policy is a directory, `--policy "
        f"{where}/NAME`, and needs the `[lerobot]` extra) "
        f"on the same {episodes} episodes, seeds 0..{episodes - 1}, which no training run "
        "uses. Wall time is training on a 2-core development VM, evaluations excluded; its "
        "CPU changed between sessions (Intel Xeon, AMD EPYCs) and the same work took up to "
        "1.5x longer on one than on another (`docs/training.md`). Env steps include the "
        "expert's demonstrations and every rollout the learner drove. Success as the task "
        "defines it (95 % Wilson interval); placed: also released and at rest (tasks that "
        "place); success counts at the last step for every row, as in Gymnasium-Robotics "
        "(`lerobot-eval` counts it at any step: `success_once_rate` in `evaluations.json`). "
        "Models act through the native float64 network (the same bits on every CPU; LeRobot "
        "policies and students that see act through torch, float32): "
        "an evaluation repeats these episodes exactly wherever the package version, CPU "
        "architecture and C library recorded in `evaluations.json` match, and these rates "
        "within their interval elsewhere "
        "(`docs/reproducibility.md`).\n\n"
    )


#: Where a models folder keeps the recipes its models were trained with once the package's
#: recipe for their id has changed (``models-table`` passes the matching one as ``--conf``).
RECIPES = "recipes"


def _reproduce(model: Path, run: dict[str, Any], source: dict[str, Any]) -> str:
    if run.get("backend") == "lerobot":
        return _reproduce_lerobot(model, run)
    recipes = model.parent / RECIPES
    command, caveat = _reproducing_command(run, recipes)
    steps = [f"`{shlex.join(command)}`, then copy `{_out_of(command)}/"
             f"{_saved_as(run)}` here as `{model.name}`"]  # fmt: skip
    notes = [caveat, run.get("note", "")]
    if source:
        first, first_caveat = _reproducing_command(source, recipes)
        steps.insert(0, f"`{shlex.join(first)}` (its `{_saved_as(source)}` is "
                        f"the `--init-from` model: {source.get('env_steps', 0):,} steps, "
                        f"{float(source.get('wall_time_s', 0)) / 60:.1f} min, included in "
                        "the row)")  # fmt: skip
        notes.insert(0, first_caveat)
    notes = list(dict.fromkeys(note for note in notes if note))
    return (
        f"- `{model.name}`: " + "; then ".join(steps) + (f" ({'; '.join(notes)})" if notes else "")
    )


def _reproduce_lerobot(model: Path, run: dict[str, Any]) -> str:
    """The reproducing commands of a LeRobot policy: its run record's ``commands`` (recording
    the dataset, ``lerobot-train``), then the copy of the checkpoint it ``saved_as``."""
    commands = run.get("commands")
    if not isinstance(commands, list) or not all(isinstance(c, list) for c in commands):
        raise InvalidArgumentError(f"{model}: its run record has no list of commands")
    steps = [f"`{shlex.join(str(part) for part in command)}`" for command in commands]
    steps.append(
        f"copy `{run.get('saved_as', 'OUT/checkpoints/last/pretrained_model')}` here as "
        f"`{model.name}` with its `panda_rapier_run.json`"
    )
    note = run.get("note", "")
    return f"- `{model.name}`: " + "; then ".join(steps) + (f" ({note})" if note else "")


def _reproducing_command(run: dict[str, Any], recipes: Path) -> tuple[list[str], str]:
    """The recorded ``train`` command of ``run``, made to train as it did on today's package,
    with the first recipe that trains alike: the package's (no ``--conf``: a scratch recipe
    file that became the package's), a file in ``recipes`` (a package recipe that has
    changed since), or the ``--conf`` file the command named if it is still there; without
    one, a caveat says where the run's recipe is recorded."""

    command = _portable([str(part) for part in run["command"]])
    if "recipe" not in run:
        return command, ""

    def trains_alike(conf: Path | None) -> bool:
        try:
            return recipes_train_alike(load_recipe(run["algo"], run["env_id"], conf), run["recipe"])
        except ConfigError:
            return False

    bare, named = list(command), None
    if "--conf" in command[:-1]:
        at = command.index("--conf")
        named = Path(command[at + 1])
        del bare[at : at + 2]
    if trains_alike(None):
        return _validated_as_recorded(bare, run, None), ""
    for path in sorted(recipes.glob("*.yml")):
        if trains_alike(path):
            at = bare.index("--env-id") + 2 if "--env-id" in bare else len(bare)
            found = [*bare[:at], "--conf", path.as_posix(), *bare[at:]]
            return _validated_as_recorded(found, run, path), ""
    if named is not None and trains_alike(named):
        return _validated_as_recorded(command, run, named), ""
    return command, (
        f"the {run['algo']} recipe this run read has changed or is not in the repository; the "
        "one it used is the `recipe` entry of `panda_rapier_run.json` in the zip"
    )


#: ``panda-rapier train``'s flags for the validation settings
#: (:data:`panda_rapier.learning.recipes.VALIDATION_DEFAULTS`' keys).
_VALIDATION_FLAGS = {"every": "--eval-every", "episodes": "--eval-episodes",
                     "patience": "--patience", "final": "--final"}  # fmt: skip


def _validated_as_recorded(command: list[str], run: dict[str, Any], conf: Path | None) -> list[str]:
    """``command`` with the validation flags it needs to validate, stop and finish as the
    run did, where today's recipe file (``conf``, else the package's) would otherwise give
    other settings than those the run had (runs recorded before recipes carried them had the
    command line's or the defaults of then: 250,000 steps, 100 episodes, no patience, last)."""

    if run.get("algo") == "bc" or command[:2] != ["panda-rapier", "train"]:
        return command
    if isinstance(run.get("validation"), dict):
        used = dict(run["validation"])
    else:
        used = {"every": 250_000, "episodes": 100, "patience": None,
                "final": run.get("final") or "last"}  # fmt: skip
    try:
        recipe = recipe_validation(run["env_id"], conf, run["algo"])
    except ConfigError:
        return command
    extra: list[str] = []
    for key, flag in _VALIDATION_FLAGS.items():
        if flag in command or key not in recipe:
            continue
        if recipe[key] != used.get(key):
            value = used.get(key)
            extra += [flag, str(0 if value is None else value)]
    return [*command, *extra]


def _saved_as(run: dict[str, Any]) -> str:
    """Which file of its run directory a model is: ``best.zip`` (the best periodic
    evaluation's, whose record holds that evaluation) or ``model.zip``."""
    return "best.zip" if "evaluation" in run else "model.zip"


def _portable(command: list[str]) -> list[str]:
    """A recorded command with an absolute ``--out`` (the training machine's path) made
    ``runs/NAME``, as a reader in a clone of the repository would run it."""
    if "--out" in command[:-1]:
        at = command.index("--out") + 1
        if Path(command[at]).is_absolute():
            command[at] = f"runs/{Path(command[at]).name}"
    return command


def _out_of(command: Sequence[str]) -> str:
    """The ``--out`` directory of a recorded ``panda-rapier train`` command."""
    parts = list(command)
    if "--out" in parts[:-1]:
        return parts[parts.index("--out") + 1]
    return "OUT"


#: The conditions of :func:`robustness_table`, in its rows' order.
ROBUSTNESS_CONDITIONS = ("off", *RANDOMIZATION_GROUPS, "all")


def robustness_table(
    models: Sequence[Path], episodes: int = 500, progress: bool = True
) -> tuple[str, dict[str, Any]]:
    """How image policies hold up under visual randomisation: each model in ``models``
    evaluated on seeds ``0 .. episodes - 1`` (the benchmark table's first ones) with no
    randomisation, with each group of :data:`~panda_rapier.pixels.RANDOMIZATION_GROUPS` alone
    at its default ranges, and with all of them (``panda-rapier eval --policy MODEL
    --visual-randomization NAME``). One column per model, headed by what it sees and what it
    was trained with.

    Returns the markdown and the evaluations (per model and condition, the summary and each
    episode's success and placed flags as strings of 0 and 1)."""
    trained: list[str] = []
    for model in models:
        run = read_run_info(model)
        options = (run or {}).get("env_kwargs")
        if run is None or not isinstance(options, dict) or "obs_mode" not in options:
            raise InvalidArgumentError(f"{model} is not a model that sees: no image obs_mode")
        how = options.get("visual_randomization")
        where = "under randomisation" if how not in (None, False) else "on the plain scene"
        trained.append(f"{options['obs_mode']}, trained {where}")
    records: dict[str, Any] = {}
    cells: dict[tuple[str, str], str] = {}
    total = len(models) * len(ROBUSTNESS_CONDITIONS)
    with tqdm(total=total, desc="evaluations", unit="eval", disable=not progress) as bar:
        for model in models:
            for condition in ROBUSTNESS_CONDITIONS:
                report = _evaluate_row(
                    str(model), None, episodes, progress, f"{model.stem} {condition}", condition
                )
                summary = report.summary()
                records[f"{model.name} {condition}"] = _record(summary, report.episodes)
                low, high = summary["success_ci95"]
                cells[model.name, condition] = (
                    f"{summary['success_rate']:.3f} ({low:.3f}-{high:.3f}) / "
                    f"{summary['placed_rate']:.3f}"
                )
                bar.update(1)
    header = "| evaluated with | " + " | ".join(
        f"`{m.name}` ({how})" for m, how in zip(models, trained, strict=True)
    )
    lines = [header + " |", "|---" * (len(models) + 1) + "|"]
    for condition in ROBUSTNESS_CONDITIONS:
        name = {"off": "no randomisation", "all": "all of them"}.get(condition, condition)
        lines.append(f"| {name} | " + " | ".join(cells[m.name, condition] for m in models) + " |")
    return "\n".join(lines) + "\n", records
