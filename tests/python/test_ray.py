"""Scale-out on Ray, on a real local Ray (2 CPUs): RLlib (new API stack) with the native vector
env in every EnvRunner (panda_rapier.scale.rllib), Ray Tune over the stable-baselines3 recipes
(panda_rapier.scale.tuning), and the two example scripts.

Over 600 lines: one local Ray session (started once, module-scoped) serves every test of the
RLlib configs, connectors, recipe module and Tune sweeps; splitting the file would start Ray
once more per file. The multi-node tests are in test_ray_cluster.py."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("ray", reason="needs Ray: pip install '.[rllib]'")
pytest.importorskip("ray.rllib", reason="needs RLlib: pip install '.[rllib]'")
pytest.importorskip("ray.tune", reason="needs Ray Tune: pip install '.[rllib]'")
pytest.importorskip("sb3_contrib", reason="the Tune sweeps train the SB3 recipes: '.[train]'")

import ray
from gymnasium.vector import AutoresetMode
from ray import tune
from ray.rllib.algorithms.ppo import PPOConfig
from ray.rllib.env.single_agent_episode import SingleAgentEpisode
from ray.rllib.utils.metrics.metrics_logger import MetricsLogger

from panda_rapier import ConfigError, InvalidArgumentError, PandaVectorEnv, env_config
from panda_rapier._common import DICT_KEYS
from panda_rapier.scale.rllib import (
    MAX_RUN_SEED,
    RLLIB_FIRST_SEED,
    EpisodeOutcomes,
    configure_env_runners,
    flat_observations_to_module,
    flatten_observations,
    ppo_config,
    rllib_seed,
    runner_seed,
    sac_config,
    sampled_actions_to_env,
    tqc_config,
)
from panda_rapier.scale.tuning import METRICS, check_sweep, sb3_trainable, sb3_tuner

ROOT = Path(__file__).resolve().parents[2]
DENSE = "panda_rapier/PickAndPlaceDense-v0"
SEED = 3
NUM_ENVS = 4


def run(*args: str | Path) -> str:
    result = subprocess.run(
        [sys.executable, *map(str, args)], capture_output=True, text=True, timeout=600, check=False
    )
    assert result.returncode == 0, result.stderr[-3000:]
    return result.stdout


# The example scripts start their own local Ray: they run first, before this module's.


def test_rllib_example_trains_and_checkpoints(tmp_path: Path) -> None:
    out = run(ROOT / "examples/rllib_train.py", "--iterations", "1", "--num-env-runners", "1",
              "--num-envs-per-env-runner", "2", "--train-batch-size", "140",
              "--minibatch-size", "70", "--num-cpus", "2", "--json", tmp_path / "lines.json",
              "--checkpoint", tmp_path / "checkpoint")  # fmt: skip
    (line,) = json.loads((tmp_path / "lines.json").read_text())
    assert line["env_steps"] == 140 and line["episodes"] == 2
    assert math.isfinite(line["episode_return_mean"]) and 0 <= line["success_rate"] <= 1
    assert "iteration 1: 140 env steps, 2 episodes" in out
    assert (tmp_path / "checkpoint" / "algorithm_state.pkl").is_file()


def test_tune_example_sweeps_learning_rates(tmp_path: Path) -> None:
    out = run(ROOT / "examples/tune_sb3.py", "--algo", "ppo", "--env-id", DENSE, "--seeds", "0",
              "--learning-rates", "1e-4", "3e-4", "--set", "n_steps=8", "--set", "batch_size=64",
              "--timesteps", "128", "--n-envs", "16", "--eval-episodes", "8", "--num-cpus", "2",
              "--storage", tmp_path, "--name", "sweep",
              "--json", tmp_path / "rows.json")  # fmt: skip
    rows = json.loads((tmp_path / "rows.json").read_text())
    assert sorted(r["hyperparams"]["learning_rate"] for r in rows) == [1e-4, 3e-4]
    assert all(r["env_steps"] == 128 and 0 <= r["success_rate"] <= 1 for r in rows)
    assert "best: seed 0" in out


@pytest.fixture(scope="module")
def ray_session() -> Iterator[None]:
    ray.init(address="local", num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


@pytest.fixture(scope="class")
def ppo(ray_session: None) -> Iterator[Any]:
    """PPO with 2 EnvRunners x 4 environments, 70-step fragments: one iteration is exactly one
    whole episode per environment."""
    config = ppo_config(
        DENSE,
        seed=SEED,
        num_env_runners=2,
        num_envs_per_env_runner=NUM_ENVS,
        num_cpus_per_env_runner=1,
        train_batch_size_per_learner=2 * NUM_ENVS * 70,
        minibatch_size=140,
        num_epochs=1,
    )
    algo = config.build_algo()
    yield algo
    algo.stop()


class TestPPO:
    """One PPO algorithm (its runners hold both CPUs: it is stopped before the next tests)."""

    def test_iteration_samples_whole_episodes_of_the_native_vector_env(self, ppo: Any) -> None:
        result = ppo.train()
        runners = result["env_runners"]
        assert result["num_env_steps_sampled_lifetime"] == 2 * NUM_ENVS * 70
        assert runners["num_env_steps_sampled"] == 2 * NUM_ENVS * 70
        assert runners["num_episodes"] == 2 * NUM_ENVS
        assert runners["episode_len_min"] == runners["episode_len_max"] == 70
        for key in ("episode_return_mean", "episode_return_min", "episode_return_max"):
            assert math.isfinite(runners[key])
        assert 0 <= runners["success_rate"] <= 1 and 0 <= runners["placed_rate"] <= 1
        learner = result["learners"]["default_policy"]
        assert all(math.isfinite(learner[k]) for k in ("total_loss", "policy_loss", "vf_loss"))

        def describe(runner: Any) -> dict[str, Any]:
            env = runner.env.unwrapped
            return {
                "index": runner.worker_index,
                "type": type(env),
                "num_envs": env.num_envs,
                "num_threads": env.num_threads,
                "autoreset": env.metadata["autoreset_mode"],
                "observation_space": env.single_observation_space,
                "release": env.config["reward_weights"]["release"],
            }

        described = ppo.env_runner_group.foreach_env_runner(describe, local_env_runner=False)
        assert sorted(d["index"] for d in described) == [1, 2]
        for d in described:
            assert d["type"] is PandaVectorEnv
            assert d["num_envs"] == NUM_ENVS and d["num_threads"] == 1
            assert d["autoreset"] == AutoresetMode.NEXT_STEP and d["release"] == 1.0
            assert d["observation_space"].shape == (47,)  # obs_mode="flat"

    def test_runners_draw_distinct_reproducible_streams(self, ppo: Any) -> None:
        def first_observations(runner: Any) -> tuple[int, np.ndarray]:
            """Runner ``k``'s first observations after building its env afresh (the env's flat
            observations), one row per environment. (Nested: Ray pickles it by value.)"""
            runner.make_env()
            episodes = runner.sample(num_timesteps=runner.num_envs, random_actions=True)
            return runner.worker_index, np.stack([e.get_observations(0) for e in episodes])

        first = dict(
            ppo.env_runner_group.foreach_env_runner(first_observations, local_env_runner=False)
        )
        again = dict(
            ppo.env_runner_group.foreach_env_runner(first_observations, local_env_runner=False)
        )
        assert sorted(first) == [1, 2]
        for k in (1, 2):
            np.testing.assert_array_equal(first[k], again[k])  # reproducible
            # Runner k's environment i is the stream (runner_seed(seed, k), i) of the vector env.
            env = PandaVectorEnv(
                NUM_ENVS, num_threads=1, **env_config(DENSE, reward_weights={"release": 1.0})
            )
            obs, _ = env.reset(seed=runner_seed(SEED, k))
            env.close()
            np.testing.assert_array_equal(
                first[k], np.concatenate([obs[key] for key in DICT_KEYS], axis=1)
            )
        # No environment of runner 1 starts like any of runner 2's, nor like another of its own.
        rows = np.concatenate([first[1], first[2]])
        assert len({row.tobytes() for row in rows}) == 2 * NUM_ENVS


@pytest.mark.parametrize(
    "builder",
    [
        sac_config,
        pytest.param(
            tqc_config,
            # RLlib's TQC learner broadcasts (B, 25, 1) against (B, 1, 46) on purpose (the
            # pairwise quantile Huber loss); torch warns about the shapes on every update.
            marks=pytest.mark.filterwarnings("ignore:Using a target size:UserWarning"),
        ),
    ],
)
def test_off_policy_configs_train(ray_session: None, builder: Any) -> None:
    algo = builder(
        seed=SEED,
        num_env_runners=1,
        num_envs_per_env_runner=NUM_ENVS,
        num_steps_sampled_before_learning_starts=64,
        train_batch_size_per_learner=32,
    ).build_algo()
    try:
        result = algo.train()
        (kind,) = algo.env_runner_group.foreach_env_runner(
            lambda r: type(r.env.unwrapped), local_env_runner=False
        )
    finally:
        algo.stop()
    assert kind is PandaVectorEnv
    assert result["num_env_steps_sampled_lifetime"] >= 100
    learner = result["learners"]["default_policy"]
    losses = {k: v for k, v in learner.items() if k.endswith("_loss")}
    assert {"qf_loss", "policy_loss", "alpha_loss"} <= set(losses)
    assert all(math.isfinite(v) for v in losses.values())
    assert learner["num_module_steps_trained_lifetime"] > 0


def test_checkpoints_restore_and_train_on(ray_session: None, tmp_path: Path) -> None:
    from ray.rllib.algorithms.algorithm import Algorithm

    config = ppo_config(
        DENSE,
        seed=SEED,
        num_env_runners=1,
        num_envs_per_env_runner=2,
        train_batch_size_per_learner=140,
        minibatch_size=70,
        num_epochs=1,
    )
    algo = config.build_algo()
    algo.train()
    algo.save_to_path(str(tmp_path))
    algo.stop()
    restored = Algorithm.from_checkpoint(str(tmp_path))
    try:
        result = restored.train()
        (kind,) = restored.env_runner_group.foreach_env_runner(
            lambda r: type(r.env.unwrapped), local_env_runner=False
        )
    finally:
        restored.stop()
    assert kind is PandaVectorEnv
    assert result["training_iteration"] == 2 and result["num_env_steps_sampled_lifetime"] == 280


def test_batched_connectors_sample_what_rllib_s_default_pipeline_samples(
    ray_session: None,
) -> None:
    """The flat-observation connectors (``FlatObservationsToModule``, ``SampledActionsToEnv``)
    replace RLlib's default env-to-module and module-to-env pipelines without changing a bit
    of what is sampled: observations, actions, their log-probabilities and distribution
    inputs, rewards; exploring, and acting deterministically."""

    def sample(default_pipelines: bool) -> list[list[np.ndarray]]:
        config = ppo_config(DENSE, seed=SEED, num_env_runners=0, num_envs_per_env_runner=3)
        if default_pipelines:
            config = config.env_runners(
                env_to_module_connector=None,
                module_to_env_connector=None,
                add_default_connectors_to_env_to_module_pipeline=True,
                add_default_connectors_to_module_to_env_pipeline=True,
            )
        algo = config.build_algo()
        runner = algo.env_runner
        episodes = runner.sample(num_timesteps=150) + runner.sample(num_timesteps=150)
        episodes += runner.sample(num_episodes=3, explore=False)
        algo.stop()
        return [
            [np.asarray(column) for column in (
                e.get_observations(), e.get_actions(), e.get_rewards(),
                e.get_extra_model_outputs("action_logp"),
                e.get_extra_model_outputs("action_dist_inputs"),
            )]
            for e in episodes
        ]  # fmt: skip

    batched, default = sample(False), sample(True)
    assert len(batched) == len(default) >= 9
    for ours, theirs in zip(batched, default, strict=True):
        for a, b in zip(ours, theirs, strict=True):
            assert a.dtype == b.dtype
            np.testing.assert_array_equal(a, b)


def test_batched_connectors_refuse_recurrent_modules() -> None:
    from panda_rapier.scale.rllib import FlatObservationsToModule, SampledActionsToEnv

    class Recurrent:
        def is_stateful(self) -> bool:
            return True

    for connector in (FlatObservationsToModule(), SampledActionsToEnv()):
        with pytest.raises(ConfigError, match="stateless"):
            connector(rl_module=Recurrent(), batch={}, episodes=[])


def test_flat_observations_go_to_the_runner_s_device() -> None:
    """The factory passes the runner's device on (a runner with a GPU gets its tensors
    there); here the CPU, by name."""
    import torch

    from panda_rapier.scale.rllib import flat_observations_to_module

    class Stateless:
        def is_stateful(self) -> bool:
            return False

    class Episode:
        def __init__(self, row: np.ndarray) -> None:
            self.row = row

        def get_observations(self, index: int) -> np.ndarray:
            assert index == -1
            return self.row

    rows = np.arange(6, dtype=np.float32).reshape(2, 3)
    for device in (None, "cpu"):
        connector = flat_observations_to_module(device=device)
        batch = connector(rl_module=Stateless(), batch={}, episodes=[Episode(r) for r in rows])
        obs = batch["obs"]
        assert str(obs.device) == "cpu" and obs.dtype == torch.float32
        np.testing.assert_array_equal(obs.numpy(), rows)


def test_episode_outcomes_are_logged_as_rates() -> None:
    logger = MetricsLogger()
    for success, placed in [(True, True), (False, True), (False, False), (True, True)]:
        infos = [{}, {"is_success": np.bool_(success), "is_placed": np.bool_(placed)}]
        episode = SingleAgentEpisode(observations=[np.zeros(3), np.ones(3)],
                                     actions=[np.zeros(4)], rewards=[0.0], infos=infos,
                                     terminated=True)  # fmt: skip
        EpisodeOutcomes().on_episode_end(episode=episode, metrics_logger=logger, env_index=0)
    assert logger.peek("success_rate") == 0.5 and logger.peek("placed_rate") == 0.75


def test_seed_ranges() -> None:
    assert rllib_seed(0) == RLLIB_FIRST_SEED == runner_seed(0, 0)
    assert runner_seed(1, 2) == 2_002_000_002
    assert runner_seed(1, 2, evaluation=True) == 2_003_000_002
    # The last run seed's evaluation runners stay below the Minari datasets' seeds (3e9) and
    # below 2**32 (RLlib seeds numpy's global generator with it).
    assert runner_seed(MAX_RUN_SEED - 1, 999_999, evaluation=True) < 3_000_000_000 < 2**32
    # Consecutive run seeds never share a runner seed, evaluation runners included.
    assert runner_seed(0, 999_999, evaluation=True) < runner_seed(1, 0)
    for bad in (-1, MAX_RUN_SEED, 1.0, True):
        with pytest.raises(InvalidArgumentError, match="seed"):
            rllib_seed(bad)  # type: ignore[arg-type]
    with pytest.raises(InvalidArgumentError, match="worker_index"):
        runner_seed(0, -1)
    with pytest.raises(InvalidArgumentError, match="worker_index"):
        runner_seed(0, 1_000_000)


def test_config_builders_refuse_bad_input() -> None:
    with pytest.raises(ConfigError, match="unknown environment id"):
        ppo_config("panda_rapier/NoSuchTask-v0")
    with pytest.raises(ConfigError, match="hindsight"):
        sac_config("panda_rapier/PickAndPlace-v0")
    with pytest.raises(ConfigError, match="hindsight"):
        tqc_config("panda_rapier/ReachJoints-v0")
    with pytest.raises(ConfigError, match="num_cpus_per_env_runner"):
        ppo_config(env_kwargs={"num_threads": 4})
    with pytest.raises(ConfigError, match="num_envs_per_env_runner"):
        ppo_config(env_kwargs={"num_envs": 4})
    with pytest.raises(ConfigError, match="next_step"):
        ppo_config(env_kwargs={"autoreset_mode": "same_step"})
    with pytest.raises(ConfigError, match="control_frequency"):
        ppo_config(env_kwargs={"control_frequency": -5})
    with pytest.raises(InvalidArgumentError, match="num_env_runners"):
        ppo_config(num_env_runners=-1)
    with pytest.raises(InvalidArgumentError, match="num_envs_per_env_runner"):
        sac_config(DENSE, num_envs_per_env_runner=0)
    with pytest.raises(InvalidArgumentError, match="num_cpus_per_env_runner"):
        tqc_config(DENSE, num_cpus_per_env_runner=0.5)  # type: ignore[arg-type]
    with pytest.raises(InvalidArgumentError, match="seed"):
        ppo_config(seed=-1)


def test_configs_set_the_env_runner_side() -> None:
    config = configure_env_runners(
        PPOConfig(), "panda_rapier/ReachJointsDense-v0", seed=2, num_env_runners=3,
        num_envs_per_env_runner=8, num_cpus_per_env_runner=2, env_kwargs={"control_frequency": 50},
    )  # fmt: skip
    assert config.env == "panda_rapier:panda_rapier/ReachJointsDense-v0"
    assert config.env_config == {
        "control_frequency": 50,
        "obs_mode": "flat",
        "num_threads": 2,
        "autoreset_mode": "next_step",
    }
    # The state comes flat from the env, goes to the module and back by our two batched
    # connectors in place of RLlib's defaults, and the env clips actions itself.
    assert config._env_to_module_connector is flat_observations_to_module
    assert config._module_to_env_connector is sampled_actions_to_env
    assert not config.add_default_connectors_to_env_to_module_pipeline
    assert not config.add_default_connectors_to_module_to_env_pipeline
    assert not config.normalize_actions and not config.clip_actions
    images = configure_env_runners(PPOConfig(), DENSE, env_kwargs={"obs_mode": "state+rgb"})
    assert images.env_config["obs_mode"] == "state+rgb"
    assert images._env_to_module_connector is flatten_observations
    assert images.add_default_connectors_to_env_to_module_pipeline
    assert config.gym_env_vectorize_mode == "vector_entry_point"
    assert (config.num_env_runners, config.num_envs_per_env_runner) == (3, 8)
    assert config.num_cpus_per_env_runner == 2 and config.seed == rllib_seed(2)
    assert ppo_config().env_config["reward_weights"] == {"release": 1.0}
    assert ppo_config(env_kwargs={"reward_weights": {}}).env_config["reward_weights"] == {}
    assert tqc_config().n_quantiles == 25 and tqc_config(n_quantiles=10).n_quantiles == 10
    assert ppo_config(lr=1e-4).lr == 1e-4


def test_sweeps_are_checked_before_they_start() -> None:
    assert check_sweep("tqc", "panda_rapier/PickAndPlace-v0")["batch_size"] == 2048
    with pytest.raises(InvalidArgumentError, match="algo"):
        check_sweep("bc", "panda_rapier/PickAndPlace-v0")
    with pytest.raises(ConfigError, match="unknown environment id"):
        check_sweep("ppo", "panda_rapier/Nope-v0")
    with pytest.raises(ConfigError, match="no recipe"):
        check_sweep("ppo", "panda_rapier/Reach-v0")
    with pytest.raises(ConfigError, match="lerning_rate"):
        check_sweep("ppo", DENSE, {"lerning_rate": 1e-3})
    # PPO's own argument and the ones it forwards to SB3's PPO are all recipe keys.
    swept = {"learning_rate": 1e-4, "n_steps": 8, "batch_size": 64, "mean_bound_coef": 0.1}
    assert check_sweep("ppo", DENSE, swept)["n_envs"] > 0
    with pytest.raises(ConfigError, match="kwargs"):
        check_sweep("ppo", DENSE, {"kwargs": {}})
    with pytest.raises(InvalidArgumentError, match="seeds"):
        sb3_tuner("ppo", DENSE, seeds=[])
    with pytest.raises(InvalidArgumentError, match="cpus_per_trial"):
        sb3_tuner("ppo", DENSE, cpus_per_trial=0)
    with pytest.raises(ConfigError, match="unknown sb3_trainable config keys"):
        sb3_trainable({"algo": "ppo", "env_id": DENSE, "sed": 1})


def test_tune_sweep_of_tqc_her_reports_success_rate(ray_session: None, tmp_path: Path) -> None:
    learning_rates = [1e-3, 3e-4]
    tuner = sb3_tuner(
        "tqc",
        "panda_rapier/PickAndPlace-v0",
        seeds=[0],
        hyperparams={
            "learning_rate": tune.grid_search(learning_rates),
            "learning_starts": 140,
            "batch_size": 64,
            "buffer_size": 10_000,
            "policy_kwargs": "dict(net_arch=[64, 64], n_critics=2)",
        },
        timesteps=280,
        eval_every=140,
        eval_episodes=8,
        storage_path=tmp_path,
        name="sweep",
    )
    results = tuner.fit()
    assert len(results) == 2 and not results.errors
    seen = []
    for result in results:
        assert set(METRICS) <= set(result.metrics)
        assert result.metrics["training_iteration"] == 2  # evaluations at 140 and 280 steps
        assert result.metrics["env_steps"] == 280 and 0 <= result.metrics["success_rate"] <= 1
        history = result.metrics_dataframe
        assert list(history["env_steps"]) == [140, 280]
        trial = Path(result.path)
        lines = [json.loads(x) for x in (trial / "run/evaluations.jsonl").read_text().splitlines()]
        assert [x["success_rate"] for x in lines] == list(history["success_rate"])
        assert (trial / "run/model.zip").is_file()
        recipe = (trial / "recipe.yml").read_text()
        assert "HerReplayBuffer" in recipe and "batch_size: 64" in recipe
        run_info = json.loads((trial / "run/run.json").read_text())
        assert run_info["seed"] == 0 and run_info["recipe"]["batch_size"] == 64
        seen.append(run_info["recipe"]["learning_rate"])
    assert sorted(seen) == sorted(learning_rates)
    assert results.get_best_result().metrics["success_rate"] == max(
        r.metrics["success_rate"] for r in results
    )


def test_ppo_config_follows_the_sb3_recipe() -> None:
    from panda_rapier.learning.recipes import load_recipe
    from panda_rapier.scale.rllib import recipe_training
    from panda_rapier.scale.rllib_recipe import RecipePPOTorchRLModule

    recipe = load_recipe("ppo", DENSE)
    settings = recipe_training(recipe)
    assert settings["train_batch_size_per_learner"] == recipe["n_envs"] * recipe["n_steps"]
    assert settings["minibatch_size"] == recipe["batch_size"] == 1024
    assert (settings["num_epochs"], settings["gamma"], settings["lambda_"]) == (8, 0.8, 0.9)
    assert settings["use_kl_loss"] and settings["kl_target"] == recipe["target_kl"] == 0.1
    assert settings["vf_clip_param"] == math.inf and settings["vf_loss_coeff"] == 0.5
    reach = recipe_training(load_recipe("ppo", "panda_rapier/ReachDense-v0"))
    assert reach["lr"] == [[0, 3e-4], [1_000_000, 0.0]] and not reach["use_kl_loss"]
    config = ppo_config(DENSE)
    assert config.rl_module_spec.module_class is RecipePPOTorchRLModule
    model = config.model_config
    assert model["fcnet_hiddens"] == [128, 128] and model["fcnet_activation"] == "relu"
    assert model["free_log_std"] and not model["vf_share_layers"]
    assert (model["log_std_init"], model["min_action_std"], model["action_std_dims"]) == (
        -0.5,
        0.3,
        [-1],
    )
    assert len(model["observation_mean"]) == len(model["observation_scale"]) == 47
    assert min(model["observation_scale"]) >= np.float32(0.01)
    assert "observation_mean" in ppo_config("panda_rapier/PushDense-v0").model_config
    assert "min_action_std" not in ppo_config("panda_rapier/PushDense-v0").model_config
    with pytest.raises(ConfigError, match="no recipe"):
        ppo_config("panda_rapier/PickAndPlace-v0")
    # The RLlib module standardises the flat observation only: other features are refused.
    from panda_rapier.scale.rllib_recipe import recipe_model_config

    cube = {"policy_kwargs": "dict(features_extractor_class=CubeOrientationFeatures)"}
    with pytest.raises(ConfigError, match="CubeOrientationFeatures is for panda-rapier train"):
        recipe_model_config(cube, env_config("panda_rapier/Flip-v0"))


def _recipe_module() -> Any:
    import gymnasium as gym
    from ray.rllib.core import DEFAULT_MODULE_ID

    config = ppo_config(DENSE)
    space = gym.spaces.Box(-np.inf, np.inf, (47,), np.float32)
    action = gym.spaces.Box(-1.0, 1.0, (4,), np.float32)
    spaces = {DEFAULT_MODULE_ID: (space, action)}
    return config.get_rl_module_spec(spaces=spaces, inference_only=False).build()


def test_recipe_module_standardises_and_floors_the_gripper_noise() -> None:
    import torch
    from ray.rllib.core.columns import Columns

    module = _recipe_module()
    mean = module.observation_mean.numpy()
    scale = module.observation_scale.numpy()
    rng = np.random.default_rng(0)
    obs = torch.as_tensor(mean + scale * rng.normal(size=(5, 47)).astype(np.float32))
    with torch.no_grad():
        inputs = module.forward_inference({Columns.OBS: obs})[Columns.ACTION_DIST_INPUTS]
        np.testing.assert_allclose(inputs[:, 4:].numpy(), -0.5)  # log_std_init
        module.pi.log_std.fill_(-3.0)
        inputs = module.forward_inference({Columns.OBS: obs})[Columns.ACTION_DIST_INPUTS]
        # The gripper's (last) log std stays at log(0.3); the others follow the parameter.
        np.testing.assert_allclose(inputs[:, 4:7].numpy(), -3.0)
        np.testing.assert_allclose(inputs[:, 7].numpy(), math.log(0.3), rtol=1e-6)
        # The encoders see (obs - mean) / scale: shifting obs by the mean and scaling by the
        # scale is what the module undoes.
        encoder = module.encoder.actor_encoder
        plain = encoder({Columns.OBS: (obs - module.observation_mean) / module.observation_scale})
        seen = module.encoder(module._standardised({Columns.OBS: obs}))
        np.testing.assert_allclose(
            plain["encoder_out"].numpy(), seen["encoder_out"]["actor"].numpy(), rtol=1e-6
        )
        values = module.compute_values({Columns.OBS: obs})
        assert values.shape == (5,) and torch.isfinite(values).all()


def test_exported_policy_acts_as_the_module(tmp_path: Path) -> None:
    import gymnasium as gym
    import torch
    from ray.rllib.core.columns import Columns

    from panda_rapier.agents.inference import PolicyNetwork
    from panda_rapier.agents.model_file import read_run_info
    from panda_rapier.learning.recipes import load_recipe
    from panda_rapier.scale.rllib_recipe import export_policy

    module = _recipe_module()
    with torch.no_grad():
        for p in module.parameters():
            p.add_(0.05 * torch.randn_like(p))
    run = {"env_id": DENSE, "env_kwargs": {"reward_weights": {"release": 1.0}},
           "config": env_config(DENSE, reward_weights={"release": 1.0})}  # fmt: skip
    path = export_policy(module, tmp_path / "m.zip", recipe=load_recipe("ppo", DENSE), run=run)
    assert read_run_info(path)["env_id"] == DENSE
    network = PolicyNetwork.from_zip(path)
    env = gym.make(DENSE)
    rows = []
    for seed in range(4):
        obs, _ = env.reset(seed=seed)
        rows.append(np.concatenate([obs[k] for k in DICT_KEYS]))
    env.close()
    flat = np.stack(rows).astype(np.float32)
    with torch.no_grad():
        inputs = module.forward_inference({Columns.OBS: torch.as_tensor(flat)})
    means = inputs[Columns.ACTION_DIST_INPUTS][:, :4].numpy()
    np.testing.assert_allclose(network.act(flat), np.clip(means, -1, 1), rtol=1e-5, atol=1e-6)


def test_train_with_the_rllib_backend_writes_a_run_eval_reads(
    ray_session: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from panda_rapier.cli import main

    out = tmp_path / "run"

    def train(timesteps: int, *extra: str) -> int:
        return main(["train", "--algo", "ppo", "--backend", "rllib", "--env-id", DENSE,
                     "--out", str(out), "--timesteps", str(timesteps), "--eval-every", "4096",
                     "--checkpoint-every", "4096", "--eval-episodes", "4",
                     "--num-env-runners", "1", "--num-envs-per-env-runner", "8",
                     "--final", "best", "--quiet", *extra])  # fmt: skip

    assert train(8192) == 0
    run_info = json.loads((out / "run.json").read_text())
    assert run_info["backend"] == "rllib" and run_info["env_steps"] >= 8192
    lines = [json.loads(x) for x in (out / "evaluations.jsonl").read_text().splitlines()]
    assert len(lines) == 2 and all(0 <= x["success_rate"] <= 1 for x in lines)
    assert (out / "best.zip").is_file() and (out / "checkpoints" / "state.json").is_file()
    assert main(["eval", "--policy", str(out / "model.zip"), "--episodes", "4", "--quiet"]) == 0
    # Resumed with more steps, it goes on from its checkpoint.
    assert train(12288, "--resume") == 0
    run_info = json.loads((out / "run.json").read_text())
    assert run_info["env_steps"] >= 12288 and len(run_info["resumed_with"]) == 1
    capsys.readouterr()
    wrong = [
        (["--algo", "sac", "--backend", "rllib"], "ppo only"),
        (["--algo", "ppo", "--backend", "rllib", "--init-from", "x.zip"], "--init-from"),
        (["--algo", "ppo", "--num-env-runners", "3"], "are for --backend rllib"),
    ]
    for extra, message in wrong:
        assert main(["train", "--out", str(tmp_path / "x"), *extra]) == 2
        assert message in capsys.readouterr().err
