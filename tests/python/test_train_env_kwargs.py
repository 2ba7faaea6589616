"""A recipe's training-only environment options (``train_env_kwargs``, such as Stack's start-state
curriculum): the training environments get them (merged into ``env_kwargs`` section by
section), a resumed run's too; the evaluations, the run record's ``env_kwargs`` and the saved
model's record do not; bad values are refused by name."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("stable_baselines3")
yaml = pytest.importorskip("yaml")

from panda_rapier import ConfigError  # noqa: E402
from panda_rapier.agents.model_file import read_run_info  # noqa: E402
from panda_rapier.learning import runner  # noqa: E402
from panda_rapier.learning.recipes import load_recipe, merge_options  # noqa: E402

ENV_ID = "panda_rapier/StackDense-v0"
OPTIONS = {"reward_weights": {"stage": 3.0}}
CURRICULUM = {"task": {"name": "stack", "cube1_on_goal_probability": 1.0}}


def _recipe(path: Path, **entries: Any) -> Path:
    recipe = {
        "policy": "MultiInputPolicy", "n_envs": 2, "n_steps": 16, "batch_size": 32,
        "n_epochs": 1, "policy_kwargs": "dict(net_arch=[16])", **entries,
    }  # fmt: skip
    path.write_text(yaml.safe_dump({ENV_ID: recipe}))
    return path


def test_only_the_training_environments_get_the_training_options(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    made: list[dict[str, Any]] = []
    make = runner.make_vec_env

    def spy(env_id: str, **kwargs: Any) -> Any:
        made.append(kwargs)
        return make(env_id, **kwargs)

    monkeypatch.setattr(runner, "make_vec_env", spy)
    conf = _recipe(tmp_path / "ppo.yml", env_kwargs=OPTIONS, train_env_kwargs=CURRICULUM)
    out = tmp_path / "run"
    kwargs: dict[str, Any] = {
        "conf": conf, "eval_every": 32, "eval_episodes": 2, "checkpoint_every": 32,
        "progress": False, "say": lambda _: None,
    }  # fmt: skip
    runner.train("ppo", ENV_ID, out, timesteps=32, **kwargs)
    assert [m["task"] for m in made] == [CURRICULUM["task"]]
    assert made[0]["reward_weights"] == OPTIONS["reward_weights"]
    recorded = json.loads((out / "run.json").read_text())
    assert recorded["env_kwargs"] == OPTIONS
    assert recorded["train_env_kwargs"] == CURRICULUM
    # What the evaluations and `panda-rapier eval` act in: the id's own episodes.
    assert "cube1_on_goal_probability" not in json.dumps(recorded["config"])
    assert read_run_info(out / "model.zip")["env_kwargs"] == OPTIONS  # type: ignore[index]
    assert len((out / "evaluations.jsonl").read_text().splitlines()) == 1
    # A resumed run trains with them again (its recorded recipe's).
    runner.train("ppo", ENV_ID, out, timesteps=64, resume=True, **kwargs)
    assert [m["task"] for m in made] == [CURRICULUM["task"]] * 2


def test_the_training_options_merge_into_the_runs_section_by_section(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    made: list[dict[str, Any]] = []
    make = runner.make_vec_env

    def spy(env_id: str, **kwargs: Any) -> Any:
        made.append(kwargs)
        return make(env_id, **kwargs)

    monkeypatch.setattr(runner, "make_vec_env", spy)
    options = {
        "reward_weights": {"lift": 1.0, "stage": 3.0},
        "task": {"name": "stack", "reward_distance_rate": 2.0},
    }
    training = {
        "reward_weights": {"stage": 6.0},
        "task": {"cube1_on_goal_probability": 1.0},
    }
    conf = _recipe(tmp_path / "ppo.yml", env_kwargs=options, train_env_kwargs=training)
    out = tmp_path / "run"
    runner.train(
        "ppo", ENV_ID, out, timesteps=32, conf=conf, eval_every=0, checkpoint_every=0,
        progress=False, say=lambda _: None,
    )  # fmt: skip
    # The sections keep the entries the training options do not set.
    assert made == [
        {
            **made[0],
            "reward_weights": {"lift": 1.0, "stage": 6.0},
            "task": {
                "name": "stack", "reward_distance_rate": 2.0, "cube1_on_goal_probability": 1.0,
            },
        }
    ]  # fmt: skip
    # The saved model's environment is the run's own.
    assert read_run_info(out / "model.zip")["env_kwargs"] == options  # type: ignore[index]


def test_merge_options_replaces_what_is_not_a_section_on_both_sides() -> None:
    base = {"task": {"name": "stack", "goal_region": {"low": [0, 0], "high": [1, 1]}}, "a": 1}
    extra = {"task": {"goal_region": {"low": [0.5, 0.5]}}, "a": {"b": 2}, "c": [3]}
    assert merge_options(base, extra) == {
        "task": {"name": "stack", "goal_region": {"low": [0.5, 0.5], "high": [1, 1]}},
        "a": {"b": 2},
        "c": [3],
    }
    assert base["task"]["goal_region"] == {"low": [0, 0], "high": [1, 1]}  # not changed


@pytest.mark.parametrize(
    ("algo", "value", "says"),
    [("ppo", "task=stack", "must be a mapping"), ("bc", CURRICULUM, "not bc")],
)
def test_bad_training_options_are_refused_by_name(
    tmp_path: Path, algo: str, value: Any, says: str
) -> None:
    conf = _recipe(tmp_path / "recipe.yml", train_env_kwargs=value)
    with pytest.raises(ConfigError, match=f"'train_env_kwargs'.*{says}"):
        load_recipe(algo, ENV_ID, conf)


def test_the_rllib_recipe_refuses_training_options(tmp_path: Path) -> None:
    pytest.importorskip("ray.rllib")
    from panda_rapier.scale.rllib import ppo_config

    conf = _recipe(tmp_path / "ppo.yml", train_env_kwargs=CURRICULUM)
    with pytest.raises(ConfigError, match="'train_env_kwargs' is for stable-baselines3"):
        ppo_config(ENV_ID, conf=conf)
