"""Agents learn: behaviour cloning from the scripted expert and a short PPO run, each measured
against a baseline on fixed seeds, within a CI-sized budget; and ``panda-rapier train``'s run
directory, resume, recipes, curves and models table.

Over 600 lines: every learning path (cloning, PPO, fine-tuning a cloned policy) with the run
directory it writes; each test trains on a tiny budget, so they share the helpers here."""

from __future__ import annotations

import base64
import hashlib
import json
import pickle
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
yaml = pytest.importorskip("yaml")

import torch as th  # noqa: E402
from conftest import hostile_payload, poisoned  # noqa: E402
from stable_baselines3 import PPO  # noqa: E402

from panda_rapier import ConfigError, InvalidArgumentError, RandomPolicy  # noqa: E402
from panda_rapier.agents.evaluation import evaluate  # noqa: E402
from panda_rapier.agents.model_file import RUN_MEMBER, read_run_info  # noqa: E402
from panda_rapier.cli import main  # noqa: E402
from panda_rapier.learning.imitation import Demonstrations, behaviour_cloning, collect  # noqa: E402
from panda_rapier.learning.normalization import NormalizedFlatten, fit_normalizers  # noqa: E402
from panda_rapier.learning.phases import PHASES, describe_split  # noqa: E402
from panda_rapier.learning.recipes import load_recipe, recipe_validation  # noqa: E402
from panda_rapier.learning.runner import train  # noqa: E402
from panda_rapier.registration import env_config  # noqa: E402
from panda_rapier.sb3 import make_vec_env  # noqa: E402

th.set_num_threads(1)

TEST_SEED = 0  # test episodes: seeds 0, 1, ...; the training below starts at 10**6


def _ppo(env, pi=(256, 256), **kwargs):
    return PPO(
        "MultiInputPolicy",
        env,
        policy_kwargs={
            "features_extractor_class": NormalizedFlatten,
            "net_arch": {"pi": list(pi), "vf": [64, 64]},
            "activation_fn": th.nn.ReLU,
        },
        seed=0,
        device="cpu",
        **kwargs,
    )


def test_behaviour_cloning_from_200_expert_episodes_places_the_cube() -> None:
    """Cloned from 200 scripted episodes (14,000 states; about 45 s on 2 cores), the policy
    succeeds in at least 40 % of 100 unseen episodes, where random actions do not (measured
    when written: 0.59 success, 0.80 placed; random 0.00. DAgger rounds take it past 0.95:
    see models/README.md)."""
    config = env_config("panda_rapier/PickAndPlace-v0")
    demos, expert = collect(config, 200, first_seed=10**6)
    assert len(demos) == 200 * 70 and demos.num_episodes == 200
    assert expert.placed_rate >= 0.95  # the expert it learns from
    model = _ppo(make_vec_env("panda_rapier/PickAndPlace-v0"), pi=(256, 256, 256))
    fit_normalizers(model.policy, demos.observations)
    losses = behaviour_cloning(model, demos, epochs=30, seed=0)
    assert losses[-1] < 0.5 * losses[0]
    cloned = evaluate(model, config, 100, first_seed=TEST_SEED)
    random = evaluate(RandomPolicy(config), config, 100, first_seed=TEST_SEED)
    assert random.success_rate <= 0.05, random.summary()
    assert cloned.success_rate >= 0.4, cloned.summary()
    assert cloned.placed_rate >= 0.4, cloned.summary()


@pytest.mark.parametrize("env_id", ["panda_rapier/Stack-v0", "panda_rapier/ReachJoints-v0"])
def test_behaviour_cloning_reads_each_tasks_layout(env_id: str) -> None:
    """Demonstrations are split into the goal dict by their own task's layout (Stack's goals
    are 6-D, Reach has no cube), so cloning fits on every task."""
    config = env_config(env_id)
    demos, _ = collect(config, 2, first_seed=3, num_envs=2)
    model = _ppo(make_vec_env(env_id, n_envs=2), pi=(32,))
    fit_normalizers(model.policy, demos.observations)
    losses = behaviour_cloning(model, demos, epochs=3, seed=0)
    assert len(losses) == 3 and losses[-1] < losses[0]


def test_short_ppo_run_improves_the_dense_return() -> None:
    """60,000 steps of PPO on the dense reward (kinematic arm, 32 environments) raise the
    deterministic policy's mean return on 64 fixed test seeds by at least 25 over the
    untrained policy's (measured when written: 5.0 -> 48.9, in about 55 s on 2 cores; the
    reach term alone is worth up to 70 per episode)."""
    env_id = "panda_rapier/PickAndPlaceDense-v0"
    config = env_config(env_id, arm="kinematic")
    env = make_vec_env(env_id, n_envs=32, seed=10**6, arm="kinematic")
    model = _ppo(env, n_steps=64, batch_size=512, n_epochs=10, gamma=0.98, learning_rate=3e-4)
    demos, _ = collect(config, 32, first_seed=2 * 10**6)
    fit_normalizers(model.policy, demos.observations)
    before = evaluate(model, config, 64, first_seed=TEST_SEED).mean_return
    model.learn(60_000)
    after = evaluate(model, config, 64, first_seed=TEST_SEED).mean_return
    assert after >= before + 25.0, f"mean return {before:.1f} -> {after:.1f}"


def test_ppo_learns_reach_from_scratch() -> None:
    """No expert in the loop (the expert's states only fit the observation scaler): 51,200
    steps of PPO on ReachDense-v0 take the deterministic policy's success on 100 test seeds
    from the random policy's to at least 0.5 (measured when written: random 0.00, PPO 0.78
    after 19 s on 2 shared cores; 0.93 after 61,440 steps)."""
    env_id = "panda_rapier/ReachDense-v0"
    config = env_config(env_id)
    env = make_vec_env(env_id, n_envs=32, seed=10**6)
    model = _ppo(env, pi=(64, 64), n_steps=32, batch_size=256, n_epochs=10, gamma=0.95,
                 learning_rate=1e-3)  # fmt: skip
    demos, _ = collect(config, 16, first_seed=2 * 10**6)
    fit_normalizers(model.policy, demos.observations)
    floor = evaluate(RandomPolicy(config), config, 100, first_seed=TEST_SEED).success_rate
    model.learn(51_200)
    learned = evaluate(model, config, 100, first_seed=TEST_SEED).success_rate
    assert floor <= 0.05 and learned >= 0.5, f"success: random {floor:.2f}, PPO {learned:.2f}"


def test_demonstrations_round_trip_and_relabel_any_driver(tmp_path: Path) -> None:
    config = env_config("panda_rapier/PickAndPlaceJoints-v0")
    demos, stats = collect(config, 3, first_seed=5, num_envs=2)
    assert demos.actions.shape == (3 * 70, 8) and demos.observations.shape == (3 * 70, 47)
    assert demos.episode_seeds == [5, 6, 7] and stats.env_steps == 3 * 70
    assert np.bincount(demos.episode_index).tolist() == [70, 70, 70]
    demos.save(tmp_path / "demos.npz")
    back = Demonstrations.load(tmp_path / "demos.npz")
    np.testing.assert_array_equal(back.observations, demos.observations)
    assert back.config == demos.config and back.episode_placed == demos.episode_placed
    # Driven by random actions, the labels are still the expert's: the same as asking it.
    from panda_rapier import ScriptedPolicy

    driven, _ = collect(config, 2, first_seed=5, actor=lambda o: np.ones((len(o), 8), np.float32))
    expected, _ = ScriptedPolicy(config).predict(
        {k: v for k, v in zip(("achieved_goal", "desired_goal", "observation"),
                              np.split(driven.observations, [3, 6], axis=1), strict=True)}
    )  # fmt: skip
    np.testing.assert_array_equal(driven.actions, expected)
    with pytest.raises(InvalidArgumentError):
        collect(config, 0, first_seed=0)


def test_normaliser_is_saved_with_the_model(tmp_path: Path) -> None:
    model = _ppo(make_vec_env("panda_rapier/PickAndPlace-v0"))
    rows = np.random.default_rng(0).normal(3.0, 2.0, (100, 47)).astype(np.float32)
    assert fit_normalizers(model.policy, rows) == 1
    model.save(tmp_path / "m.zip")
    loaded = PPO.load(tmp_path / "m.zip", device="cpu")
    extractor = loaded.policy.features_extractor
    assert isinstance(extractor, NormalizedFlatten)
    np.testing.assert_allclose(extractor.mean.numpy(), rows.mean(axis=0), rtol=1e-5)
    obs = {"achieved_goal": th.zeros(1, 3), "desired_goal": th.zeros(1, 3),
           "observation": th.full((1, 41), 1e6)}  # fmt: skip
    assert float(extractor(obs).abs().max()) <= 10.0


def _write_recipe(path: Path, algo: str, recipe: dict) -> Path:
    path.write_text(yaml.safe_dump({"panda_rapier/PickAndPlace-v0": recipe,
                                    "panda_rapier/PickAndPlaceDense-v0": recipe}))  # fmt: skip
    return path


def test_train_bc_writes_a_run_that_eval_reads_without_flags(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    conf = _write_recipe(tmp_path / "bc.yml", "bc", {
        "demo_episodes": 8, "dagger_rounds": 1, "dagger_episodes": 8, "epochs": 2,
        "dagger_epochs": 1, "n_envs": 4,
        "policy_kwargs": "dict(features_extractor_class=NormalizedFlatten, net_arch=[32])",
    })  # fmt: skip
    out = tmp_path / "run"
    argv = ["train", "--algo", "bc", "--out", str(out), "--conf", str(conf), "--quiet",
            "--eval-episodes", "4", "--env-kwargs", "arm=kinematic",
            "max_episode_steps=60"]  # fmt: skip
    assert main(argv) == 0
    assert "demonstrations" not in capsys.readouterr().err  # --quiet: no progress bars
    run = json.loads((out / "run.json").read_text())
    assert run["env_kwargs"] == {"arm": "kinematic", "max_episode_steps": 60}
    assert run["env_steps"] == 16 * 60 and run["saved_algo"] == "ppo"
    assert {"panda_rapier", "torch", "stable_baselines3"} <= set(run["versions"])
    assert run["command"][:3] == ["panda-rapier", "train", "--algo"]
    # Which CPU the wall time was measured on.
    assert run["machine"]["cpus"] >= 1 and run["machine"]["cpu"] and "cpu_flags" in run["machine"]
    lines = [json.loads(x) for x in (out / "evaluations.jsonl").read_text().splitlines()]
    assert [x["env_steps"] for x in lines] == [8 * 60, 16 * 60, 16 * 60]  # and the final fit
    assert all(0 <= x["success_ci95"][0] <= x["success_rate"] <= x["success_ci95"][1]
               for x in lines)  # fmt: skip
    assert list((out / "tensorboard").rglob("events.out.tfevents.*"))
    with zipfile.ZipFile(out / "model.zip") as archive:
        assert RUN_MEMBER in archive.namelist()
    assert read_run_info(out / "model.zip")["env_kwargs"]["arm"] == "kinematic"
    # Evaluation needs no flag: the environment comes from the zip; and is reproducible.
    capsys.readouterr()
    reports = []
    for i in range(2):
        assert main(["eval", "--policy", str(out / "model.zip"), "--episodes", "6",
                     "--quiet", "--json", str(tmp_path / f"e{i}.json")]) == 0  # fmt: skip
        reports.append(json.loads((tmp_path / f"e{i}.json").read_text()))
    assert "kinematic arm" in capsys.readouterr().out
    assert reports[0]["config"]["max_episode_steps"] == 60
    assert reports[0]["episode_records"] == reports[1]["episode_records"]
    # An existing run is not overwritten.
    assert main(argv) == 2


def test_train_ppo_checkpoints_and_resumes(tmp_path: Path) -> None:
    conf = _write_recipe(tmp_path / "ppo.yml", "ppo", {
        "n_envs": 4, "n_steps": 32, "batch_size": 64, "n_epochs": 1,
        "learning_rate": "lin_3e-4",
        "policy_kwargs": "dict(features_extractor_class=NormalizedFlatten, net_arch=[32])",
        "callback": "panda_rapier.learning.normalization.FitNormalizerCallback",
    })  # fmt: skip
    out = tmp_path / "run"
    common = ["train", "--algo", "ppo", "--env-id", "panda_rapier/PickAndPlaceDense-v0",
              "--out", str(out), "--conf", str(conf), "--quiet", "--eval-every", "256",
              "--eval-episodes", "2", "--checkpoint-every", "256"]  # fmt: skip
    assert main([*common, "--timesteps", "512"]) == 0
    state = json.loads((out / "checkpoints" / "state.json").read_text())
    assert state["num_timesteps"] == 512
    first = PPO.load(out / "model.zip", device="cpu")
    scale = first.policy.features_extractor.scale.numpy()
    assert (scale != 1).any()  # fitted to the expert's states at the start
    # Where the wall time went: every phase timed, evaluations and checkpoints left out.
    run = json.loads((out / "run.json").read_text())
    split = run["wall_time_split"]
    assert list(split) == list(PHASES) and all(split[p] > 0 for p in PHASES), split
    assert sum(split.values()) <= run["wall_time_s"], (split, run["wall_time_s"])
    assert "env stepping" in describe_split(split) and " %" in describe_split(split)
    assert main([*common, "--timesteps", "1024", "--resume"]) == 0
    resumed_split = json.loads((out / "run.json").read_text())["wall_time_split"]
    assert all(resumed_split[p] > split[p] for p in PHASES), (split, resumed_split)
    resumed = PPO.load(out / "model.zip", device="cpu")
    assert resumed.num_timesteps == 1024
    np.testing.assert_array_equal(resumed.policy.features_extractor.scale.numpy(), scale)
    lines = (out / "evaluations.jsonl").read_text().splitlines()
    steps = [json.loads(x)["env_steps"] for x in lines]
    assert steps == [256, 512, 768, 1024]  # each once, the resumed run's appended
    assert list((out / "tensorboard").rglob("events.out.tfevents.*"))
    assert (out / "best.zip").is_file()
    # Resuming something that is not there is a clear error.
    assert main([*common, "--out", str(tmp_path / "none"), "--resume"]) == 2


def test_train_stops_early_and_ends_on_the_best_weights(tmp_path: Path) -> None:
    """--patience stops a run whose evaluations stop improving; --final best makes model.zip
    the best evaluation's weights, and the run record says why and which."""
    conf = _write_recipe(tmp_path / "ppo.yml", "ppo", {
        "n_envs": 4, "n_steps": 32, "batch_size": 64, "n_epochs": 1,
        "policy_kwargs": "dict(features_extractor_class=NormalizedFlatten, net_arch=[32])",
    })  # fmt: skip
    out = tmp_path / "run"
    common = ["train", "--algo", "ppo", "--env-id", "panda_rapier/PickAndPlaceDense-v0",
              "--conf", str(conf), "--quiet", "--eval-every", "128", "--eval-episodes", "2",
              "--checkpoint-every", "0", "--timesteps", "4096"]  # fmt: skip
    assert main([*common, "--out", str(out), "--patience", "2", "--final", "best"]) == 0
    lines = [json.loads(x) for x in (out / "evaluations.jsonl").read_text().splitlines()]
    # A random policy never places nor succeeds: the first evaluation stays the best, and
    # the two after it do not beat it.
    assert [x["env_steps"] for x in lines] == [128, 256, 384]
    run = json.loads((out / "run.json").read_text())
    assert run["env_steps"] == 384 and "patience 2" in run["stopped_early"]["reason"]
    assert run["final"] == "best" and run["final_weights"]["env_steps"] == 128
    final = PPO.load(out / "model.zip", device="cpu").policy.state_dict()
    best = PPO.load(out / "best.zip", device="cpu").policy.state_dict()
    assert final.keys() == best.keys()
    assert all(th.equal(final[k], best[k]) for k in final)
    assert read_run_info(out / "model.zip")["final_weights"]["env_steps"] == 128
    # Stopping is judged on evaluations, and bc runs have their own length.
    assert main([*common, "--out", str(tmp_path / "a"), "--eval-every", "0",
                 "--patience", "1"]) == 2  # fmt: skip
    assert main(["train", "--algo", "bc", "--out", str(tmp_path / "b"), "--final", "best"]) == 2
    with pytest.raises(SystemExit):
        main([*common, "--out", str(tmp_path / "c"), "--stop-at", "1.5"])


def test_a_recipe_file_says_how_its_runs_validate_stop_and_finish(tmp_path: Path) -> None:
    """A recipe file's ``validation`` entry (rl-zoo3 ignores it) is what a run does when no
    flag says otherwise: a run taken to its end needs no flag to end on its best weights."""
    env_id = "panda_rapier/PickAndPlaceDense-v0"
    recipe = {
        "n_envs": 4,
        "n_steps": 32,
        "batch_size": 64,
        "n_epochs": 1,
        "policy_kwargs": "dict(features_extractor_class=NormalizedFlatten, net_arch=[32])",
    }
    conf = tmp_path / "ppo.yml"
    validation = {"every": 128, "episodes": 2, "patience": 2, "final": "best"}
    conf.write_text(yaml.safe_dump({env_id: recipe, "validation": {env_id: validation}}))
    common = ["train", "--algo", "ppo", "--env-id", env_id, "--conf", str(conf), "--quiet",
              "--checkpoint-every", "0", "--timesteps", "1024"]  # fmt: skip
    assert main([*common, "--out", str(tmp_path / "a")]) == 0
    run = json.loads((tmp_path / "a/run.json").read_text())
    assert run["validation"] == validation
    # Random policies never succeed: the first evaluation stays the best, two more end it.
    assert run["env_steps"] == 384 and "patience 2" in run["stopped_early"]["reason"]
    assert run["final"] == "best" and run["final_weights"]["env_steps"] == 128
    # Flags win; --patience 0 is none.
    assert main([*common, "--out", str(tmp_path / "b"), "--patience", "0", "--final", "last",
                 "--eval-every", "512"]) == 0  # fmt: skip
    run = json.loads((tmp_path / "b/run.json").read_text())
    assert run["validation"] == {**validation, "every": 512, "patience": None, "final": "last"}
    assert run["env_steps"] == 1024 and run["final_weights"]["env_steps"] == 1024
    # No periodic evaluation: nothing to keep the best of, and the recipe's final is moot.
    assert main([*common, "--out", str(tmp_path / "c"), "--eval-every", "0"]) == 0
    assert json.loads((tmp_path / "c/run.json").read_text())["validation"]["final"] == "last"
    # A reproduced old run (no validation record) keeps what it had: the last weights.
    from panda_rapier.tools.reporting import _reproducing_command

    old = {"algo": "ppo", "env_id": env_id, "recipe": recipe, "final": None,
           "command": ["panda-rapier", "train", "--algo", "ppo", "--env-id", env_id,
                       "--conf", str(conf), "--eval-every", "128"]}  # fmt: skip
    reproduced, _ = _reproducing_command(old, tmp_path / "recipes")
    assert reproduced == [*old["command"], "--eval-episodes", "100", "--patience", "0",
                          "--final", "last"]  # fmt: skip
    # Bad entries are refused before anything runs.
    for bad in ({"every": -1}, {"final": "first"}, {"episodes": 0}, {"evry": 5}, [1]):
        conf.write_text(yaml.safe_dump({env_id: recipe, "validation": {env_id: bad}}))
        with pytest.raises(ConfigError, match="validation"):
            train("ppo", env_id, tmp_path / "d", conf=conf, progress=False)
    assert recipe_validation(env_id, None, "ppo")["final"] == "best"  # the package's


def test_stop_at_ends_a_run_once_validation_reaches_it() -> None:
    from panda_rapier.learning.runs import Recorder, stop_reason

    recorder = Recorder.__new__(Recorder)
    recorder.best, recorder.since_best = None, 0
    recorder.run = {"env_id": "panda_rapier/LiftDense-v0"}  # nothing to place
    line = {"success_rate": 0.96, "placed_rate": 0.0}
    assert recorder._rank(line)
    assert "--stop-at 0.95" in (stop_reason(recorder, line, None, 0.95) or "")
    assert stop_reason(recorder, line, None, 0.97) is None
    # On a task that places, the cube held at the goal is not enough: it must be let go.
    recorder.run = {"env_id": "panda_rapier/PickAndPlaceJointsDense-v0"}
    assert stop_reason(recorder, line, None, 0.95) is None
    placed = {"success_rate": 0.96, "placed_rate": 0.955}
    assert "placed 0.955 reached --stop-at 0.95" in (
        stop_reason(recorder, placed, None, 0.95) or ""
    )
    assert stop_reason(recorder, line, 3, None) is None
    worse = {"success_rate": 0.5, "placed_rate": 0.0}
    assert not recorder._rank(worse) and not recorder._rank(worse)
    assert stop_reason(recorder, worse, 3, None) is None
    assert not recorder._rank(worse)
    assert "patience 3" in (stop_reason(recorder, worse, 3, None) or "")


def test_a_run_that_never_succeeds_keeps_its_most_rewarded_policy() -> None:
    """Before the first success, best.zip follows the mean return (a PegInsertion run from
    scratch kept its first evaluation's policy for 6.5 M steps, return 179 against 538);
    once one evaluation succeeds, success decides, and equal rates keep the earlier one."""
    from panda_rapier.learning.runs import Recorder

    recorder = Recorder.__new__(Recorder)
    recorder.best, recorder.since_best = None, 0
    zero = {"success_rate": 0.0, "placed_rate": 0.0}
    assert recorder._rank({**zero, "mean_return": 179.0})
    assert recorder._rank({**zero, "mean_return": 538.0})
    assert not recorder._rank({**zero, "mean_return": 500.0})
    assert recorder._rank({"success_rate": 0.01, "placed_rate": 0.0, "mean_return": 100.0})
    assert not recorder._rank({"success_rate": 0.01, "placed_rate": 0.0, "mean_return": 900.0})
    assert not recorder._rank({**zero, "mean_return": 2000.0})


def test_train_init_from_starts_from_another_models_weights(tmp_path: Path) -> None:
    """Fine-tuning: a new run (here on the kinematic arm) starts from a saved model's weights
    and normaliser, and records where they came from; mismatched spaces are refused."""
    conf = _write_recipe(tmp_path / "ppo.yml", "ppo", {
        "n_envs": 4, "n_steps": 32, "batch_size": 64, "n_epochs": 1,
        "policy_kwargs": "dict(features_extractor_class=NormalizedFlatten, net_arch=[32])",
        "callback": "panda_rapier.learning.normalization.FitNormalizerCallback",
    })  # fmt: skip
    common = ["train", "--algo", "ppo", "--env-id", "panda_rapier/PickAndPlaceDense-v0",
              "--conf", str(conf), "--quiet", "--eval-every", "0", "--checkpoint-every", "0",
              "--timesteps", "128"]  # fmt: skip
    assert main([*common, "--out", str(tmp_path / "a")]) == 0
    source = PPO.load(tmp_path / "a" / "model.zip", device="cpu")
    assert main([*common, "--out", str(tmp_path / "b"), "--env-kwargs", "arm=kinematic",
                 "--init-from", str(tmp_path / "a" / "model.zip")]) == 0  # fmt: skip
    tuned = PPO.load(tmp_path / "b" / "model.zip", device="cpu")
    np.testing.assert_array_equal(
        tuned.policy.features_extractor.scale.numpy(),
        source.policy.features_extractor.scale.numpy(),
    )
    run = json.loads((tmp_path / "b" / "run.json").read_text())
    assert run["init_from"]["run"]["env_kwargs"] == {}
    assert run["env_kwargs"]["arm"] == "kinematic"
    joints = [*common, "--env-id", "panda_rapier/PickAndPlaceJointsDense-v0"]
    assert main([*joints, "--out", str(tmp_path / "c"),
                 "--init-from", str(tmp_path / "a" / "model.zip")]) == 2  # fmt: skip
    assert main([*common, "--out", str(tmp_path / "d"), "--init-from", "none.zip"]) == 2
    # The file is read by data: a model whose pickled entries would write a file when
    # unpickled gives its weights and runs nothing.
    marker = tmp_path / "ran"
    payload = hostile_payload(marker)
    hostile = poisoned(tmp_path / "a" / "model.zip", tmp_path / "hostile.zip", payload)
    assert main([*common, "--out", str(tmp_path / "e"), "--init-from", str(hostile)]) == 0
    assert not marker.exists()
    pickle.loads(base64.b64decode(payload)).close()  # what unpickling it would have done
    assert marker.exists()


def _warm_up_recipe(path: Path, env_id: str, n_epochs: int) -> Path:
    """A tiny PPO recipe that fine-tunes a cloned policy (its 3x256 actor; a 16-unit critic)
    with CriticWarmup's first 100 steps training the critic alone, written to ``path``."""
    recipe = {
        "n_envs": 2, "n_steps": 16, "batch_size": 32, "n_epochs": n_epochs,
        "policy_kwargs": "dict(features_extractor_class=NormalizedFlatten, net_arch=dict("
                         "pi=[256, 256, 256], vf=[16]), activation_fn=nn.ReLU, log_std_init=-2.0)",
        "callback": [{"panda_rapier.learning.finetune.CriticWarmup": {"steps": 100}}],
    }  # fmt: skip
    path.write_text(yaml.safe_dump({env_id: recipe}))
    return path


def test_fine_tuning_a_cloned_policy_takes_its_actor_and_warms_the_critic_up(
    tmp_path: Path,
) -> None:
    """From a cloned policy (a bc run's model), --init-from copies the actor and the
    normaliser but leaves the value network (here of another size) and the action noise as
    the recipe makes them; CriticWarmup then trains the value function alone: after the run
    the actor is still exactly the cloned one and the critic has moved."""
    cloned = Path(__file__).resolve().parents[2] / "models" / "bc-dagger-Stack-v0.zip"
    conf = _warm_up_recipe(tmp_path / "ppo.yml", "panda_rapier/StackDense-v0", n_epochs=2)
    assert main(["train", "--algo", "ppo", "--env-id", "panda_rapier/StackDense-v0",
                 "--conf", str(conf), "--quiet", "--eval-every", "0", "--checkpoint-every", "0",
                 "--timesteps", "64", "--out", str(tmp_path / "a"),
                 "--init-from", str(cloned)]) == 0  # fmt: skip
    source = PPO.load(cloned, device="cpu").policy.state_dict()
    tuned = PPO.load(tmp_path / "a" / "model.zip", device="cpu").policy.state_dict()
    actor = [k for k in source if k.startswith(("mlp_extractor.policy_net", "action_net"))]
    assert actor and all(th.equal(tuned[k], source[k]) for k in actor)
    assert th.equal(tuned["features_extractor.scale"], source["features_extractor.scale"])
    assert th.allclose(tuned["log_std"], th.full_like(tuned["log_std"], -2.0))
    assert tuned["mlp_extractor.value_net.0.weight"].shape[0] == 16
    # Past the warm-up the actor trains too.
    assert main(["train", "--algo", "ppo", "--env-id", "panda_rapier/StackDense-v0",
                 "--conf", str(conf), "--quiet", "--eval-every", "0", "--checkpoint-every", "0",
                 "--timesteps", "128", "--out", str(tmp_path / "b"),
                 "--init-from", str(cloned)]) == 0  # fmt: skip
    later = PPO.load(tmp_path / "b" / "model.zip", device="cpu").policy.state_dict()
    assert not all(th.equal(later[k], source[k]) for k in actor)


def test_patience_counts_from_the_end_of_the_critic_warm_up(tmp_path: Path) -> None:
    """Evaluations while CriticWarmup keeps the actor frozen show the policy the run started
    from; they are marked and do not count towards --patience, so a patience shorter than
    the warm-up does not end the run before the actor has trained."""
    cloned = Path(__file__).resolve().parents[2] / "models" / "bc-dagger-Reach-v0.zip"
    conf = _warm_up_recipe(tmp_path / "ppo.yml", "panda_rapier/ReachDense-v0", n_epochs=1)
    out = tmp_path / "run"
    assert main(["train", "--algo", "ppo", "--env-id", "panda_rapier/ReachDense-v0",
                 "--conf", str(conf), "--quiet", "--eval-every", "32", "--eval-episodes", "2",
                 "--patience", "1", "--checkpoint-every", "0", "--timesteps", "256",
                 "--out", str(out), "--init-from", str(cloned)]) == 0  # fmt: skip
    lines = [json.loads(x) for x in (out / "evaluations.jsonl").read_text().splitlines()]
    frozen = [line["env_steps"] for line in lines if line.get("actor_frozen")]
    # Rollouts of 32 steps: the actor trains from the update after the rollout that ends at
    # 128 steps, so the evaluations at 32 .. 128 saw the cloned actor (all alike: without the
    # rule, --patience 1 would have stopped the run at 64 steps).
    assert frozen == [32, 64, 96, 128]
    assert lines[-1]["env_steps"] > 128 and "actor_frozen" not in lines[-1]


def test_critic_warmup_refuses_what_it_cannot_do() -> None:
    from sb3_contrib import TQC

    from panda_rapier.learning.finetune import CriticWarmup

    for bad in (-1, 1.5, True):
        with pytest.raises(ValueError, match="whole number"):
            CriticWarmup(steps=bad)  # type: ignore[arg-type]
    env = make_vec_env("panda_rapier/ReachDense-v0", n_envs=1, seed=0)
    tqc = TQC("MultiInputPolicy", env, learning_starts=0, buffer_size=100, device="cpu")
    with pytest.raises(TypeError, match="value network"):
        tqc.learn(2, callback=CriticWarmup(steps=10))


def test_recipes_are_rl_zoo3_files_and_bad_ones_are_refused(tmp_path: Path) -> None:
    recipe = load_recipe("ppo", "panda_rapier/PickAndPlaceDense-v0")
    assert recipe["policy"] == "MultiInputPolicy" and "NormalizedFlatten" in recipe["policy_kwargs"]
    assert load_recipe("bc", "panda_rapier/PickAndPlaceJoints-v0")["dagger_rounds"] >= 1
    with pytest.raises(ConfigError, match="no recipe"):
        load_recipe("ppo", "panda_rapier/PickAndPlaceJoints-v0", _write_recipe(
            tmp_path / "a.yml", "ppo", {"n_envs": 2}))  # fmt: skip
    with pytest.raises(ConfigError, match="unknown bc recipe keys"):
        load_recipe("bc", "panda_rapier/PickAndPlace-v0",
                    _write_recipe(tmp_path / "b.yml", "bc", {"epochz": 2}))  # fmt: skip
    with pytest.raises(ConfigError, match="'normalize' is for ppo, sac and tqc"):
        load_recipe("bc", "panda_rapier/PickAndPlace-v0",
                    _write_recipe(tmp_path / "c.yml", "bc", {"normalize": True}))  # fmt: skip
    with pytest.raises(ConfigError, match="cannot read"):
        load_recipe("ppo", "panda_rapier/PickAndPlace-v0", tmp_path / "missing.yml")
    with pytest.raises(InvalidArgumentError):
        load_recipe("dqn", "panda_rapier/PickAndPlace-v0")


def test_curves_and_models_table(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    conf = _write_recipe(tmp_path / "bc.yml", "bc", {
        "demo_episodes": 4, "dagger_rounds": 1, "dagger_episodes": 4, "epochs": 1,
        "dagger_epochs": 1, "n_envs": 4,
        "policy_kwargs": "dict(features_extractor_class=NormalizedFlatten, net_arch=[16])",
    })  # fmt: skip
    run = tmp_path / "run"
    assert main(["train", "--algo", "bc", "--out", str(run), "--conf", str(conf), "--quiet",
                 "--eval-episodes", "2"]) == 0  # fmt: skip
    pytest.importorskip("matplotlib")
    reference = tmp_path / "reference.json"
    reference.write_text(json.dumps([{"label": "other", "env_steps_per_s": 10.0}]))
    png = tmp_path / "curves.png"
    assert main(["curves", str(run), "--out", str(png), "--reference", str(reference)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    models = tmp_path / "models"
    models.mkdir()
    (models / "tiny.zip").write_bytes((run / "model.zip").read_bytes())
    assert main(["models-table", str(models), "--episodes", "3", "--quiet"]) == 0
    table = (models / "README.md").read_text()
    # One group (pick-and-place, ee control): the random floor, the expert, the model.
    assert table.count("### ") == 1
    assert "### PickAndPlace, end-effector control (`PickAndPlace-v0`)" in table
    rows = [r for r in table.splitlines() if r.startswith("| ") and "---" not in r][1:]
    assert [r.split(" | ")[0] for r in rows] == ["| random", "| scripted", "| `tiny.zip`"]
    assert "| bc on `PickAndPlace-v0` | `{}` |" in rows[2]
    recorded = json.loads((models / "evaluations.json").read_text())
    assert set(recorded) == {
        "tiny.zip", "random panda_rapier/PickAndPlace-v0", "scripted panda_rapier/PickAndPlace-v0"
    }  # fmt: skip
    assert len(recorded["tiny.zip"]["success_by_episode"]) == 3
    assert recorded["tiny.zip"]["episodes"] == 3
    assert recorded["random panda_rapier/PickAndPlace-v0"]["inference"] == "random"
    assert recorded["scripted panda_rapier/PickAndPlace-v0"]["success_rate"] == 1.0
    assert "panda-rapier train --algo bc" in table
    assert "panda-rapier eval --policy random --env-id ID" in table
    digest = hashlib.sha256((models / "tiny.zip").read_bytes()).hexdigest()
    assert recorded["tiny.zip"]["model_sha256"] == digest
    # Run again: every row repeats its episodes, so every record (timings included) stays.
    evaluations = models / "evaluations.json"
    first = evaluations.read_text()
    assert main(["models-table", str(models), "--episodes", "3", "--quiet"]) == 0
    assert evaluations.read_text() == first
    capsys.readouterr()

    def table_again(edit: Callable[[dict[str, Any]], None]) -> tuple[dict[str, Any], str]:
        records = json.loads(first)
        edit(records["tiny.zip"])
        evaluations.write_text(json.dumps(records))
        assert main(["models-table", str(models), "--episodes", "3", "--quiet"]) == 0
        return json.loads(evaluations.read_text())["tiny.zip"], capsys.readouterr().err

    # Another model file under the same name: a new record.
    kept, said = table_again(lambda r: r.update(model_sha256="0" * 64))
    assert kept["model_sha256"] == digest and "tiny.zip: new record (model_sha256 changed)" in said

    def flip_first(r: dict[str, Any]) -> None:
        flags = r["success_by_episode"]
        r["success_by_episode"] = ("1" if flags[0] == "0" else "0") + flags[1:]

    # The same environment must repeat every episode: one flipped outcome is not kept.
    kept, said = table_again(flip_first)
    assert kept["success_by_episode"] == recorded["tiny.zip"]["success_by_episode"]
    assert "did not reproduce (per-episode)" in said

    # Recorded on another C library: a statistical check, which one episode passes.
    def elsewhere(r: dict[str, Any]) -> None:
        flip_first(r)
        r["environment"]["libc"] = "musl-1.2"

    kept, said = table_again(elsewhere)
    assert kept["environment"]["libc"] == "musl-1.2" and said == ""

    # --only: the rows named are evaluated, the others keep their records as they are.
    evaluations.write_text(first)
    marked = json.loads(first)
    marked["tiny.zip"]["mean_return"] = 12345.0
    evaluations.write_text(json.dumps(marked))
    assert main(["models-table", str(models), "--episodes", "3", "--quiet",
                 "--only", "random *"]) == 0  # fmt: skip
    assert json.loads(evaluations.read_text())["tiny.zip"]["mean_return"] == 12345.0
    # A LeRobot policy directory is a row of its group, with its run record's commands; kept
    # here from its record (this environment may have no lerobot to evaluate it).
    from panda_rapier.agents.model_file import RUN_MEMBER, model_digest

    act = models / "act-PickAndPlace"
    act.mkdir()
    (act / "config.json").write_text('{"type": "act"}')
    (act / "model.safetensors").write_bytes(b"weights")
    (act / RUN_MEMBER).write_text(json.dumps({
        "env_id": "panda_rapier/PickAndPlace-v0", "env_kwargs": {}, "algo": "act",
        "backend": "lerobot", "env_steps": 70_000, "wall_time_s": 600.0,
        "commands": [["panda-rapier", "demos", "--format", "lerobot"], ["lerobot-train"]],
        "saved_as": "out/checkpoints/last/pretrained_model",
    }))  # fmt: skip
    with_act = json.loads(evaluations.read_text())
    with_act["act-PickAndPlace"] = {**with_act["tiny.zip"], "model_sha256": model_digest(act)}
    evaluations.write_text(json.dumps(with_act))
    assert main(["models-table", str(models), "--episodes", "3", "--quiet",
                 "--only", "scripted *"]) == 0  # fmt: skip
    table = (models / "README.md").read_text()
    row = "| `act-PickAndPlace` | act (LeRobot) on `PickAndPlace-v0` | `{}` | 70,000 | 10.0 |"
    assert row in table
    assert (
        "- `act-PickAndPlace`: `panda-rapier demos --format lerobot`; then `lerobot-train`; "
        "then copy `out/checkpoints/last/pretrained_model` here" in table
    )
    # A row left out needs a record of the same model and episodes.
    (act / "model.safetensors").write_bytes(b"other weights")
    assert main(["models-table", str(models), "--episodes", "3", "--quiet",
                 "--only", "scripted *"]) == 2  # fmt: skip
    assert "act-PickAndPlace changed since evaluations.json recorded it" in capsys.readouterr().err
    del with_act["act-PickAndPlace"]
    evaluations.write_text(json.dumps(with_act))
    assert main(["models-table", str(models), "--episodes", "3", "--quiet",
                 "--only", "scripted *"]) == 2  # fmt: skip
    assert "act-PickAndPlace has no record in evaluations.json" in capsys.readouterr().err


def test_run_labels_tell_seeds_and_recipe_files_apart() -> None:
    """Curves of several runs of one id need legends that differ: a seed other than 0, a
    recipe file other than the package's, SB3's own PPO class and overlapped updates are
    named."""
    from panda_rapier.tools.reporting import run_label

    run = {"algo": "ppo", "env_id": "panda_rapier/PickAndPlaceDense-v0", "seed": 0,
           "env_kwargs": {"reward_weights": {"release": 1.0}},
           "recipe_file": "panda_rapier/learning/hyperparams/ppo.yml",
           "algorithm_class": "panda_rapier.learning.ppo.PPO"}  # fmt: skip
    assert run_label(run) == "ppo PickAndPlaceDense-v0 (dynamic arm, release=1.0)"
    stock = run_label({**run, "algorithm_class": "stable_baselines3.ppo.ppo.PPO"})
    assert stock.endswith("release=1.0, SB3's PPO class)")
    older = {k: v for k, v in run.items() if k != "algorithm_class"}  # before the class was
    assert run_label(older) == stock
    assert run_label({**run, "seed": 2}).endswith("release=1.0, seed 2)")
    assert run_label({**run, "recipe_file": "/tmp/x/ppo-e128.yml"}).endswith(", recipe ppo-e128)")
    # Runs recorded before 0.2 name the old recipe folder and PPO class: labelled alike.
    before = {**run, "recipe_file": "panda_rapier/hyperparams/ppo.yml",
              "algorithm_class": "panda_rapier.ppo.PPO"}  # fmt: skip
    assert run_label(before) == run_label(run)
    overlapped = run_label({**run, "overlap_updates": True})
    assert overlapped.endswith("release=1.0, updates overlapped)")
    assert run_label({**run, "overlap_updates": False}) == run_label(run)


def test_reproduce_commands_name_the_recipe_an_old_run_used(tmp_path: Path) -> None:
    """A run that read the package's recipe before it changed is reproduced with the recipe
    file in the models folder's ``recipes/`` that trains alike (passed as ``--conf``)."""
    from panda_rapier.tools.reporting import _reproducing_command

    env_id = "panda_rapier/PickAndPlaceDense-v0"
    today = load_recipe("ppo", env_id)
    command = ["panda-rapier", "train", "--algo", "ppo", "--env-id", env_id, "--out", "runs/x"]
    run = {"algo": "ppo", "env_id": env_id, "command": command, "recipe": dict(today)}
    recipes = tmp_path / "recipes"
    recipes.mkdir()
    # The package's recipe unchanged (rl-zoo3's monitor_kwargs does not count): as recorded.
    run["recipe"].pop("monitor_kwargs", None)
    # An old run had 100 episodes and kept its last weights; today's recipe file validates
    # on 200 and keeps the best: said explicitly.
    kept = ["--eval-episodes", "100", "--final", "last"]
    assert _reproducing_command(run, recipes) == ([*command, *kept], "")
    old = {**today, "gamma": 0.5}
    run["recipe"] = old
    command_now, caveat = _reproducing_command(run, recipes)
    assert command_now == command and "has changed or is not in the repository" in caveat
    _write_recipe(recipes / "a.yml", "ppo", {**today, "gamma": 0.7})
    _write_recipe(recipes / "b.yml", "ppo", old)
    assert _reproducing_command(run, recipes) == (
        [*command[:6], "--conf", (recipes / "b.yml").as_posix(), *command[6:]],
        "",
    )
    # A command that named a recipe file still there with its recipe is left alone.
    mine = _write_recipe(tmp_path / "mine.yml", "ppo", {**today, "gamma": 0.3})
    named = {**run, "recipe": {**today, "gamma": 0.3}, "command": [*command, "--conf", str(mine)]}
    assert _reproducing_command(named, recipes) == (named["command"], "")
    # A scratch recipe file that is gone, whose recipe is now the package's: no --conf.
    scratch = {**run, "recipe": dict(today), "command": [*command, "--conf", "gone.yml"]}
    assert _reproducing_command(scratch, recipes) == ([*command, *kept], "")


def test_train_tqc_with_her_saves_its_replay_buffer_and_resumes(tmp_path: Path) -> None:
    pytest.importorskip("sb3_contrib")
    conf = _write_recipe(tmp_path / "tqc.yml", "tqc", {
        "n_envs": 2, "batch_size": 32, "learning_starts": 160, "gamma": 0.95,
        "replay_buffer_class": "HerReplayBuffer",
        "replay_buffer_kwargs": "dict(goal_selection_strategy='future', n_sampled_goal=4)",
        "policy_kwargs": "dict(net_arch=[32, 32])",
    })  # fmt: skip
    out = tmp_path / "run"
    common = ["train", "--algo", "tqc", "--out", str(out), "--conf", str(conf), "--quiet",
              "--eval-every", "0", "--checkpoint-every", "200"]  # fmt: skip
    assert main([*common, "--timesteps", "200"]) == 0
    assert (out / "checkpoints" / "replay_buffer.pkl").is_file()
    # A replay buffer this user's runs did not sign (here: the recorded signature altered) is
    # not unpickled without --trust-model-file.
    state_file = out / "checkpoints" / "state.json"
    state = json.loads(state_file.read_text())
    signed = state["replay_buffer_hmac"]
    state_file.write_text(json.dumps({**state, "replay_buffer_hmac": "0" * 64}))
    assert main([*common, "--timesteps", "400", "--resume"]) == 2
    state_file.write_text(json.dumps({**state, "replay_buffer_hmac": signed}))
    assert main([*common, "--timesteps", "400", "--resume"]) == 0
    assert json.loads((out / "run.json").read_text())["env_steps"] == 400
    state = json.loads(state_file.read_text())
    state_file.write_text(json.dumps({**state, "replay_buffer_hmac": "0" * 64}))
    assert main([*common, "--timesteps", "600", "--resume", "--trust-model-file"]) == 0
    assert json.loads((out / "run.json").read_text())["env_steps"] == 600


def test_checkpoint_is_restored_by_data_exactly(tmp_path: Path) -> None:
    """Rebuilt from the recipe and filled by panda_rapier.learning.checkpoint.restore, the model
    holds exactly what stable-baselines3's own load gives (policy, optimizer state, counters), and a
    checkpoint whose pickled entries would write a file runs nothing."""
    from panda_rapier.learning import checkpoint
    from panda_rapier.learning.recipes import load_recipe, model_kwargs

    conf = _write_recipe(tmp_path / "ppo.yml", "ppo", {
        "n_envs": 4, "n_steps": 32, "batch_size": 64, "n_epochs": 2,
        "policy_kwargs": "dict(features_extractor_class=NormalizedFlatten, net_arch=[32])",
    })  # fmt: skip
    out = tmp_path / "run"
    assert main(["train", "--algo", "ppo", "--env-id", "panda_rapier/PickAndPlaceDense-v0",
                 "--out", str(out), "--conf", str(conf), "--quiet", "--eval-every", "0",
                 "--checkpoint-every", "256", "--timesteps", "256"]) == 0  # fmt: skip
    folder = out / "checkpoints"
    reference = PPO.load(folder / checkpoint.MODEL, device="cpu")
    marker = tmp_path / "ran"
    payload = hostile_payload(marker)
    poisoned(folder / checkpoint.MODEL, folder / checkpoint.MODEL, payload)

    recipe = load_recipe("ppo", "panda_rapier/PickAndPlaceDense-v0", conf)
    env = make_vec_env("panda_rapier/PickAndPlaceDense-v0", n_envs=4)
    model = PPO("MultiInputPolicy", env, device="cpu", **model_kwargs("ppo", recipe))
    checkpoint.restore(model, folder)
    assert not marker.exists()
    assert (model.num_timesteps, model._n_updates) == (
        reference.num_timesteps,
        reference._n_updates,
    )
    assert model.num_timesteps == 256
    for mine, theirs in ((model.policy, reference.policy),
                         (model.policy.optimizer, reference.policy.optimizer)):  # fmt: skip
        flat_mine, flat_theirs = _flatten(mine.state_dict()), _flatten(theirs.state_dict())
        assert flat_mine.keys() == flat_theirs.keys()
        for key, value in flat_theirs.items():
            if isinstance(value, th.Tensor):
                assert th.equal(flat_mine[key], value), key
            else:
                assert flat_mine[key] == value, key
    other = PPO("MultiInputPolicy", env, device="cpu", policy_kwargs={"net_arch": [8]})
    with pytest.raises(InvalidArgumentError, match="does not fit the run's recipe"):
        checkpoint.restore(other, folder)
    env.close()


def _flatten(tree: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(tree, dict):
        return {
            k: v for key, sub in tree.items() for k, v in _flatten(sub, f"{prefix}{key}/").items()
        }
    if isinstance(tree, list | tuple):
        return {
            k: v for i, sub in enumerate(tree) for k, v in _flatten(sub, f"{prefix}{i}/").items()
        }
    return {prefix: tree}


def test_fit_normalizer_callback_on_gym_make_envs() -> None:
    """rl-zoo3 trains on DummyVecEnv(gym.make(...)), whose environments leave the time limit
    to Gymnasium's TimeLimit; the recipe's callback still fits the normaliser there."""
    from stable_baselines3.common.env_util import make_vec_env as sb3_make_vec_env

    from panda_rapier.learning.normalization import FitNormalizerCallback

    env = sb3_make_vec_env("panda_rapier/PickAndPlaceDense-v0", n_envs=2, seed=0)
    model = _ppo(env, n_steps=16, batch_size=32)
    model.learn(32, callback=FitNormalizerCallback(episodes=2))
    assert (model.policy.features_extractor.scale.numpy() != 1).any()


def test_update_threads_give_the_update_every_core_and_rollouts_one() -> None:
    """torch's thread count follows the phase: rollout threads while the environments step,
    update threads in PPO's gradient steps, and what it was once training ends."""
    from panda_rapier.learning.threads import UpdateThreads, torch_threads

    env = make_vec_env("panda_rapier/ReachDense-v0", n_envs=2, seed=0)
    model = _ppo(env, pi=(16,), n_steps=8, batch_size=16, n_epochs=1)
    seen: dict[str, set[int]] = {"rollout": set(), "update": set()}
    train = model.train

    def spying_train() -> None:
        seen["update"].add(th.get_num_threads())
        train()

    model.train = spying_train  # type: ignore[method-assign]

    class Spy(UpdateThreads):
        def _on_step(self) -> bool:
            seen["rollout"].add(th.get_num_threads())
            return True

    before = th.get_num_threads()
    with torch_threads(1):
        model.learn(32, callback=Spy(update=3, rollout=1))
        assert th.get_num_threads() == 1
    assert th.get_num_threads() == before
    assert seen == {"rollout": {1}, "update": {3}}
    with pytest.raises(ValueError, match="update threads"):
        UpdateThreads(update=0)


def test_min_action_std_keeps_the_gripper_exploring() -> None:
    """The floor raises only the chosen dimension's log_std, before every rollout; policies
    without a state-independent log_std are refused, not silently ignored."""
    from sb3_contrib import TQC

    from panda_rapier.learning.exploration import MinActionStd

    env = make_vec_env("panda_rapier/PickAndPlaceDense-v0", n_envs=2, seed=0, arm="kinematic")
    model = PPO(
        "MultiInputPolicy", env, n_steps=8, batch_size=16, n_epochs=1, seed=0, device="cpu",
        policy_kwargs={"log_std_init": -3.0, "net_arch": [16]},
    )  # fmt: skip
    model.learn(32, callback=MinActionStd(min_std=0.5, dims=[-1]))
    log_std = model.policy.log_std.detach().numpy()
    # Raised to the floor before the last rollout, then moved by at most one small update.
    assert log_std[-1] == pytest.approx(np.log(0.5), abs=0.05)
    assert np.all(log_std[:-1] < -2.5), log_std
    with pytest.raises(ValueError, match="out of range"):
        model.learn(8, callback=MinActionStd(min_std=0.5, dims=[4]))
    with pytest.raises(ValueError, match="positive"):
        MinActionStd(min_std=0.0)
    tqc = TQC("MultiInputPolicy", env, learning_starts=0, buffer_size=100, device="cpu")
    with pytest.raises(TypeError, match="log_std"):
        tqc.learn(2, callback=MinActionStd(min_std=0.5))
