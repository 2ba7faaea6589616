"""mkdocs hooks of the documentation site (mkdocs.yml): the task pages, generated at build time
from what the package itself exports, so they cannot drift from the code.

For each task, ``tasks/<task>.md`` holds: the task's own description (the module
documentation of ``env-core/src/task/<task>.rs``, the text the Rust API shows, minus its
observation table), its ids, episode length and control rate, both action spaces, the
observation table and info keys of the exported schema (``_native.schema``), the dense reward's
terms and weights, the task's options with their defaults (``default_config_json``), the
scripted expert's figures (``docs/expert-figures.json``, written by
``scripts/expert_figures.py``) and a picture drawn by the CPU renderer mid-episode.
"""

from __future__ import annotations

import io
import json
import re
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]

#: Steps of the scripted expert before each task's picture is taken (a task missing here gets
#: a picture at step 40).
PICTURE_STEPS = {
    "pick_and_place": 40,
    "reach": 12,
    "lift": 40,
    "push": 30,
    "stack": 95,
    "peg_insertion": 62,
    "pick_object": 40,
    "open_drawer": 30,
}


def _tasks() -> dict[str, tuple[str, int]]:
    """Task name -> (page title, picture step), for every task of the core's registry."""
    from panda_rapier.registration import TASK_NAMES

    return {task: (stem, PICTURE_STEPS.get(task, 40)) for task, stem in TASK_NAMES.items()}


def _rust_doc(task: str) -> tuple[str, str]:
    """The summary line and the sections other than "Observation" of the task's module doc."""
    lines = []
    for line in (ROOT / "env-core" / "src" / "task" / f"{task}.rs").read_text().splitlines():
        if not line.startswith("//!"):
            break
        lines.append(line[4:] if line.startswith("//! ") else line[3:])
    text = "\n".join(lines)
    # Intra-doc links become code spans; rustdoc's headings move one level down.
    text = re.sub(r"\[(`[^`]+`)\](\([^)]*\))?", r"\1", text)
    summary, _, rest = text.partition("\n\n")
    summary = re.sub(r"^`\w+`: ", "", summary.replace("\n", " ")).strip()
    sections = re.split(r"^# ", rest, flags=re.MULTILINE)
    kept = [s for s in sections if s.strip() and not s.startswith("Observation")]
    body = "\n".join("### " + s.strip() + "\n" for s in kept)
    return summary[0].upper() + summary[1:], body


def _table(header: list[str], rows: list[list[Any]]) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(out) + "\n"


def _picture(env_id: str, steps: int) -> bytes:
    import gymnasium as gym
    from PIL import Image

    import panda_rapier

    env = gym.make(env_id, render_mode="rgb_array", width=480, height=320)
    policy = panda_rapier.ScriptedPolicy(env)
    obs, _ = env.reset(seed=0)
    for _ in range(steps):
        obs, *_ = env.step(policy(obs))
    frame = env.render()
    env.close()
    out = io.BytesIO()
    Image.fromarray(frame).save(out, format="PNG", optimize=True)
    return out.getvalue()


def _page(task: str, title: str, figures: dict[str, Any]) -> str:
    import gymnasium as gym

    from panda_rapier import _common, _native
    from panda_rapier.registration import TASKS, env_config

    ids = [f"panda_rapier/{title}{mode}-v0" for mode in ("", "Dense", "Joints", "JointsDense")]
    config = env_config(f"panda_rapier/{title}-v0")
    defaults = json.loads(_native.default_config_json())
    schema = _native.schema(_common.config_json(config))
    summary, body = _rust_doc(task)
    parts = [
        f"# {title}\n",
        f"{summary}\n",
        f"![{title}, seed 0, the scripted expert at work]({task}.png)\n",
    ]

    parts.append("## Ids\n")
    rows = []
    for env_id in ids:
        spec = gym.spec(env_id)
        rows.append(
            [
                f"`{env_id}`",
                spec.kwargs["control_mode"],
                spec.kwargs["reward_type"],
                spec.max_episode_steps,
            ]
        )
    parts.append(_table(["id", "control", "reward", "episode steps"], rows))
    steps, rate = config["max_episode_steps"], defaults["control_frequency"]
    parts.append(
        f"\nAn episode is truncated after {steps} steps at {rate:g} Hz ({steps / rate:g} s); "
        "it is never terminated on success unless `terminate_on_success` is set.\n"
    )

    parts.append("## Actions\n")
    rows = []
    for control in ("ee", "joints"):
        env = gym.make(f"panda_rapier/{title}{'' if control == 'ee' else 'Joints'}-v0")
        space = env.action_space
        env.close()
        meaning = (
            f"TCP displacement x, y, z (times `ee_step` = {defaults['ee_step']} m per step)"
            if control == "ee"
            else "joint position targets of arm joints 1-7 (times `joint_step` = "
            f"{defaults['joint_step']} rad per step)"
        ) + ", then the gripper"
        rows.append(
            [
                f"`{control}`",
                f"Box({space.low.min():g}, {space.high.max():g}, {space.shape}, {space.dtype})",
                meaning,
            ]
        )
    parts.append(_table(["control", "space", "meaning"], rows))
    parts.append("\nThe last entry opens (+1) or closes (-1) the gripper.\n")

    parts.append("## Observation\n")
    parts.append(
        f"A dict of `observation`, `achieved_goal` ({schema['goal_dim']}) and `desired_goal` "
        f"({schema['goal_dim']}); {schema['flat_dim']} numbers in all (`ee` and `joints` alike). "
        "Slices are into each dict entry:\n\n"
    )
    starts: dict[str, int] = {}
    rows = []
    for slot in schema["observation"]:
        base = starts.setdefault(slot["key"], slot["start"])
        rows.append(
            [
                f"`{slot['key']}`",
                f"{slot['start'] - base}:{slot['stop'] - base}",
                f"`{slot['name']}`",
                slot["description"],
            ]
        )
    parts.append(_table(["key", "slice", "slot", "meaning"], rows))

    parts.append("\n## Starting state, success and rewards\n")
    parts.append(body + "\n")
    terms = next(t["reward_terms"] for t in TASKS if t["name"] == task)
    parts.append(
        "The dense ids sum the weighted terms below (`reward_weights={name: weight}` sets "
        "them; a name the task's reward lacks is an error); each weighted term is also in "
        "the info, under its key:\n\n"
    )
    parts.append(
        _table(
            ["term", "default weight", "info key", "pays"],
            [
                [
                    f"`{t['name']}`",
                    f"{t['default_weight']:g}",
                    f"`{t['info_key']}`",
                    t["description"],
                ]
                for t in terms
            ],
        )
    )
    parts.append(f"\nSuccess threshold (`success_threshold`): {defaults['success_threshold']} m.\n")

    parts.append("## Info\n")
    parts.append(
        _table(
            ["key", "dtype", "meaning"],
            [[f"`{i['key']}`", i["dtype"], i["description"]] for i in schema["info"]],
        )
    )

    parts.append("\n## Options of this task\n")
    section = json.loads(next(t["defaults"] for t in TASKS if t["name"] == task))
    section.pop("name")
    parts.append(
        "The task's own section of the configuration, "
        f'`task={{"name": "{task}", ...}}` (fields left out keep their defaults; see the '
        "configuration reference of `PandaEnv`); its fields and their defaults:\n\n"
    )
    parts.append(
        _table(
            ["field", "default"],
            [[f"`{k}`", f"`{json.dumps(v)}`"] for k, v in section.items()],
        )
    )

    parts.append("\n## The scripted expert\n")
    record = figures["figures"]
    placing = next(bool(t["has_placed"]) for t in TASKS if t["name"] == task)
    rows = []
    for env_id in (f"panda_rapier/{title}-v0", f"panda_rapier/{title}Joints-v0"):
        f = record[env_id]
        placed = [f"{f['placed_rate']:.1%}"] if placing else []
        rows.append(
            [
                f"`{env_id}`",
                f"{f['success_rate']:.1%}",
                *placed,
                f"{f['mean_steps_to_success']:g}",
                f["episodes"],
            ]
        )
    header = ["id", "success", *(["placed"] if placing else []), "mean steps to success"]
    parts.append(_table([*header, "episodes"], rows))
    parts.append(
        f"\nMeasured {figures['date']} by `{figures['command']}` ({figures['what']}). "
        "`panda-rapier eval --policy scripted --env-id ID` repeats one row.\n"
    )
    return "\n".join(parts)


def _index(figures: dict[str, Any]) -> str:
    from panda_rapier.registration import TASK_EPISODE_STEPS

    rows = []
    for task, (title, _) in _tasks().items():
        summary, _ = _rust_doc(task)
        ee = figures["figures"][f"panda_rapier/{title}-v0"]
        joints = figures["figures"][f"panda_rapier/{title}Joints-v0"]
        rows.append(
            [
                f"[{title}]({task}.md)",
                summary,
                TASK_EPISODE_STEPS[task],
                f"{ee['success_rate']:.1%} / {joints['success_rate']:.1%}",
            ]
        )
    return (
        "# Tasks\n\nEvery task has four ids: `<Task>-v0` (sparse reward, `ee` control), "
        "`<Task>Dense-v0`, `<Task>Joints-v0` and `<Task>JointsDense-v0`. These pages are "
        "generated from the package's exported schema when the site is built.\n\n"
        + _table(["task", "what", "episode steps", "expert success (ee / joints)"], rows)
    )


def on_config(config: Any) -> Any:
    """The navigation's Tasks section, filled from the registry: ``mkdocs.yml`` lists only
    ``tasks/index.md`` there, and every registered task's page follows it in registry order, so
    a new task needs no line in ``mkdocs.yml``."""
    pages = [f"tasks/{task}.md" for task in _tasks()]

    def fill(items: list[Any]) -> bool:
        for item in items:
            if isinstance(item, dict):
                for title, children in item.items():
                    if title == "Tasks" and isinstance(children, list):
                        children[:] = ["tasks/index.md", *pages]
                        return True
                    if isinstance(children, list) and fill(children):
                        return True
        return False

    if not fill(config["nav"]):
        raise ValueError("mkdocs.yml: the nav has no Tasks section for the task pages")
    return config


def on_files(files: Any, config: Any) -> Any:
    from mkdocs.structure.files import File

    figures = json.loads((ROOT / "docs" / "expert-figures.json").read_text())
    files.append(File.generated(config, "tasks/index.md", content=_index(figures)))
    for task, (title, steps) in _tasks().items():
        files.append(
            File.generated(config, f"tasks/{task}.md", content=_page(task, title, figures))
        )
        files.append(
            File.generated(
                config, f"tasks/{task}.png", content=_picture(f"panda_rapier/{title}-v0", steps)
            )
        )
    return files


#: A Sphinx role as the docstrings write it (``:class:`~panda_rapier.X```), once rendered.
_ROLE = re.compile(r":(?:py:)?(?:class|func|meth|data|attr|mod|exc|obj):<code>~?([^<]*)</code>")


def on_page_content(html: str, page: Any, config: Any, files: Any) -> str:
    """The docstrings' Sphinx roles shown as plain code (``~a.b.C`` as ``C``, as Sphinx does)."""

    def plain(match: re.Match[str]) -> str:
        target = match.group(1)
        if match.group(0).split("<code>")[1].startswith("~"):
            target = target.rsplit(".", 1)[-1]
        return f"<code>{target}</code>"

    return _ROLE.sub(plain, html)
