"""rl-zoo3's ``normalize`` recipe key under ``panda-rapier train``: the same running statistics
as stable-baselines3's ``VecNormalize``, kept inside the saved network, through checkpoints;
bad values are typed errors."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from panda_rapier.cli import main
from panda_rapier.errors import ConfigError

pytest.importorskip("sb3_contrib")

ENV_ID = "panda_rapier/Reach-v0"
#: rl-zoo3's PandaReach-v1 recipe (hyperparams/tqc.yml) with a short warm-up and small
#: batches, so that a test run is seconds long; the keys are the zoo's.
RECIPE = {
    "policy": "MultiInputPolicy",
    "buffer_size": 10_000,
    "ent_coef": "auto",
    "batch_size": 32,
    "gamma": 0.95,
    "learning_rate": 0.001,
    "learning_starts": 150,
    "normalize": True,
    "replay_buffer_class": "HerReplayBuffer",
    "replay_buffer_kwargs": "dict(goal_selection_strategy='future', n_sampled_goal=4)",
    "policy_kwargs": "dict(net_arch=[32, 32], n_critics=1)",
}


def _conf(path: Path, **changes: object) -> Path:
    path.write_text(yaml.safe_dump({ENV_ID: {**RECIPE, **changes}}))
    return path


def _extractor_buffers(model: object) -> list[tuple[np.ndarray, np.ndarray]]:
    from panda_rapier.learning.normalization import NormalizedFlatten

    return [
        (m.mean.numpy().copy(), m.scale.numpy().copy())
        for m in model.policy.modules()  # type: ignore[attr-defined]
        if isinstance(m, NormalizedFlatten)
    ]


def test_normalize_keeps_vecnormalize_statistics_inside_the_network(tmp_path: Path) -> None:
    """Before learning starts the actions are the action space's samples, so a run of the
    recipe and stable-baselines3's TQC on ``VecNormalize`` see the same observations: the saved
    model's extractors hold VecNormalize's running mean and sqrt(var + eps) of them, and the
    checkpoint holds its return statistics."""
    from sb3_contrib import TQC
    from stable_baselines3 import HerReplayBuffer
    from stable_baselines3.common.vec_env import VecNormalize

    from panda_rapier.sb3 import make_vec_env
    from panda_rapier.seeds import TRAIN_FIRST_SEED

    steps = 120
    out = tmp_path / "run"
    conf = _conf(tmp_path / "tqc.yml")
    assert main(["train", "--algo", "tqc", "--env-id", ENV_ID, "--out", str(out), "--conf",
                 str(conf), "--quiet", "--eval-every", "0", "--checkpoint-every", str(steps),
                 "--timesteps", str(steps), "--n-envs", "2"]) == 0  # fmt: skip
    run = json.loads((out / "run.json").read_text())
    assert run["normalize"]["norm_obs"] and run["normalize"]["gamma"] == 0.95
    mine = TQC.load(out / "model.zip", env=make_vec_env(ENV_ID), device="cpu")
    buffers = _extractor_buffers(mine)
    assert len(buffers) == 3  # actor, critic, target critic

    env = VecNormalize(make_vec_env(ENV_ID, n_envs=2, seed=TRAIN_FIRST_SEED), gamma=0.95)
    theirs = TQC("MultiInputPolicy", env, seed=0, device="cpu", buffer_size=10_000,
                 batch_size=32, gamma=0.95, learning_starts=150,
                 replay_buffer_class=HerReplayBuffer,
                 replay_buffer_kwargs={"goal_selection_strategy": "future", "n_sampled_goal": 4},
                 policy_kwargs={"net_arch": [32, 32], "n_critics": 1})  # fmt: skip
    theirs.learn(steps)
    keys = sorted(env.obs_rms)
    mean = np.concatenate([env.obs_rms[k].mean for k in keys])
    scale = np.sqrt(np.concatenate([env.obs_rms[k].var for k in keys]) + env.epsilon)
    for got_mean, got_scale in buffers:
        np.testing.assert_allclose(got_mean, mean, rtol=1e-6, atol=1e-7)
        np.testing.assert_allclose(got_scale, scale, rtol=1e-6, atol=1e-7)
    assert float(scale.min()) < 0.5  # the statistics moved away from the identity
    state = json.loads((out / "checkpoints" / "state.json").read_text())
    saved = state["normalize"]
    np.testing.assert_allclose(saved["obs"]["mean"], mean, rtol=1e-9, atol=1e-12)
    assert saved["obs"]["count"] == pytest.approx(env.obs_rms[keys[0]].count)
    assert saved["return"]["var"][0] == pytest.approx(float(env.ret_rms.var), rel=1e-9)

    # Resumed, the statistics go on from the checkpoint's (not from a fresh start).
    assert main(["train", "--algo", "tqc", "--env-id", ENV_ID, "--out", str(out), "--conf",
                 str(conf), "--quiet", "--eval-every", "0", "--checkpoint-every", str(steps),
                 "--timesteps", str(2 * steps), "--resume"]) == 0  # fmt: skip
    resumed = json.loads((out / "checkpoints" / "state.json").read_text())["normalize"]
    assert resumed["obs"]["count"] == pytest.approx(saved["obs"]["count"] + steps)  # 2 x 60


def test_a_normalize_model_acts_without_its_training_environment(tmp_path: Path) -> None:
    """The model a normalize recipe saves is self-contained: ``panda-rapier eval`` and the
    native network read it with no statistics file, and agree."""
    from panda_rapier.agents.evaluation import evaluate
    from panda_rapier.agents.inference import PolicyNetwork, resolve_policy

    out = tmp_path / "run"
    conf = _conf(tmp_path / "tqc.yml", learning_starts=100)
    assert main(["train", "--algo", "tqc", "--env-id", ENV_ID, "--out", str(out), "--conf",
                 str(conf), "--quiet", "--eval-every", "0", "--timesteps", "200"]) == 0  # fmt: skip
    resolved = resolve_policy(str(out / "model.zip"), None)
    report = evaluate(resolved.policy, resolved.config, 4)
    assert len(report.episodes) == 4 and report.inference.startswith("native")
    from sb3_contrib import TQC

    from panda_rapier.sb3 import make_vec_env

    env = make_vec_env(ENV_ID, n_envs=8, seed=5)
    obs = env.reset()
    model = TQC.load(out / "model.zip", env=env, device="cpu")
    assert _extractor_buffers(model)[0][1].min() < 0.5  # the running statistics came along
    torch_actions, _ = model.predict(obs, deterministic=True)
    native_actions, _ = PolicyNetwork.from_zip(out / "model.zip").predict(obs)
    np.testing.assert_allclose(native_actions, torch_actions, atol=1e-5)


def test_a_run_started_from_a_model_continues_its_statistics(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``--init-from`` a normalize run's model: the new run's running statistics start as the
    model's network holds them (mean, scale squared less epsilon, its env steps as the count),
    not from the new run's first observations, which would rescale the taken network's
    inputs."""
    from panda_rapier.learning.normalization import RunningNormalizer

    started: list[tuple[np.ndarray, np.ndarray, float]] = []
    start = RunningNormalizer._on_training_start

    def spy(self: RunningNormalizer) -> None:
        start(self)
        started.append((self.obs_rms.mean.copy(), self.obs_rms.var.copy(), self.obs_rms.count))

    monkeypatch.setattr(RunningNormalizer, "_on_training_start", spy)
    from stable_baselines3 import PPO

    from panda_rapier.sb3 import make_vec_env

    recipe = {"policy": "MultiInputPolicy", "normalize": True, "n_steps": 32, "batch_size": 32,
              "n_epochs": 1, "policy_kwargs": "dict(net_arch=[16])"}  # fmt: skip
    conf = tmp_path / "ppo.yml"
    conf.write_text(yaml.safe_dump({ENV_ID: recipe}))
    first, second = tmp_path / "first", tmp_path / "second"
    common = ["--conf", str(conf), "--quiet", "--eval-every", "0", "--n-envs", "2"]
    assert main(["train", "--algo", "ppo", "--env-id", ENV_ID, "--out", str(first),
                 "--timesteps", "128", *common]) == 0  # fmt: skip
    taken = PPO.load(first / "model.zip", env=make_vec_env(ENV_ID), device="cpu")
    mean, scale = _extractor_buffers(taken)[0]
    taken_file = str(first / "model.zip")
    assert main(["train", "--algo", "ppo", "--env-id", ENV_ID, "--out", str(second),
                 "--timesteps", "64", "--init-from", taken_file, *common]) == 0  # fmt: skip
    assert len(started) == 2
    fresh_count = started[0][2]  # the first run's: its first observations alone
    continued_mean, continued_var, count = started[1]
    assert fresh_count < 3 and count == 128
    np.testing.assert_array_equal(continued_mean, mean.astype(np.float64))
    np.testing.assert_allclose(np.sqrt(continued_var + 1e-8), scale, rtol=1e-5)
    # And so the second run's network still scales the observations about as the first's did.
    _, scale_after = _extractor_buffers(PPO.load(second / "model.zip", device="cpu"))[0]
    np.testing.assert_allclose(scale_after, scale, rtol=0.5)


@pytest.mark.parametrize(
    ("value", "words"),
    [
        ("maybe", "must be true, false or a mapping"),
        ({"norm_obs": True, "clip": 5}, "unknown arguments ['clip']"),
        ({"norm_reward": "yes"}, "norm_reward must be true or false"),
        ({"gamma": 1.5}, "gamma must be in (0, 1]"),
        ({"clip_obs": float("nan")}, "clip_obs must be a positive finite number"),
    ],
)
def test_bad_normalize_values_are_config_errors(tmp_path: Path, value: object, words: str) -> None:
    from panda_rapier.learning.recipes import load_recipe, model_kwargs

    conf = _conf(tmp_path / "tqc.yml", normalize=value)
    with pytest.raises(ConfigError, match="normalize") as error:
        model_kwargs("tqc", load_recipe("tqc", ENV_ID, conf))
    assert words in str(error.value)


def test_normalize_with_its_own_extractor_is_refused(tmp_path: Path) -> None:
    from panda_rapier.learning.recipes import load_recipe, model_kwargs

    conf = _conf(
        tmp_path / "tqc.yml",
        policy_kwargs="dict(features_extractor_class=NormalizedFlatten, net_arch=[32])",
    )
    with pytest.raises(ConfigError, match="features_extractor_class"):
        model_kwargs("tqc", load_recipe("tqc", ENV_ID, conf))
    assert main(["train", "--algo", "tqc", "--env-id", ENV_ID, "--out", str(tmp_path / "r"),
                 "--conf", str(conf), "--quiet", "--timesteps", "10"]) == 2  # fmt: skip
