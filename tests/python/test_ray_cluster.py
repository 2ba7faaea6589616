"""RLlib on a simulated multi-node Ray cluster (``ray.cluster_utils.Cluster``): a head with no
CPUs for tasks and worker nodes of one CPU each, so every EnvRunner (one CPU) lands on a worker
node of its own. Placement, whole-episode iterations, per-runner seed streams, a checkpoint
written by runners on some nodes and restored onto others, and a worker node removed in the
middle of training. (The learner runs in the driver, on the head.)"""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("ray.rllib", reason="needs RLlib: pip install '.[rllib]'")
pytest.importorskip("stable_baselines3", reason="the RLlib recipe reads the SB3 recipe")

import ray
from ray.cluster_utils import Cluster

from panda_rapier import PandaVectorEnv, env_config
from panda_rapier._common import DICT_KEYS
from panda_rapier.scale.rllib import ppo_config, runner_seed

DENSE = "panda_rapier/PickAndPlaceDense-v0"
SEED = 5
NUM_ENVS = 4
#: One 70-step episode per environment per iteration, from 2 runners.
BATCH = 2 * NUM_ENVS * 70


@pytest.fixture(scope="module")
def cluster() -> Iterator[Any]:
    """A head (0 CPUs) and two worker nodes (1 CPU each); ``cluster.workers`` lists them."""
    if ray.is_initialized():
        ray.shutdown()
    cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 0})
    cluster.workers = [cluster.add_node(num_cpus=1) for _ in range(2)]
    cluster.wait_for_nodes()
    ray.init(address=cluster.address)
    yield cluster
    ray.shutdown()
    cluster.shutdown()


def _config(**extra: Any) -> Any:
    return ppo_config(
        DENSE,
        seed=SEED,
        num_env_runners=2,
        num_envs_per_env_runner=NUM_ENVS,
        num_cpus_per_env_runner=1,
        train_batch_size_per_learner=BATCH,
        minibatch_size=BATCH // 2,
        num_epochs=1,
        **extra,
    )


def _placement(algo: Any) -> dict[int, dict[str, Any]]:
    def describe(runner: Any) -> tuple[int, dict[str, Any]]:
        env = runner.env.unwrapped
        return runner.worker_index, {
            "node": ray.get_runtime_context().get_node_id(),
            "type": type(env),
            "num_envs": env.num_envs,
        }

    return dict(algo.env_runner_group.foreach_env_runner(describe, local_env_runner=False))


def _weights(algo: Any) -> dict[int, dict[str, np.ndarray]]:
    def state(runner: Any) -> tuple[int, dict[str, np.ndarray]]:
        return runner.worker_index, {
            k: v.detach().cpu().numpy().copy() for k, v in runner.module.state_dict().items()
        }

    return dict(algo.env_runner_group.foreach_env_runner(state, local_env_runner=False))


def test_runners_on_separate_nodes_sample_whole_episodes_from_own_streams(cluster: Any) -> None:
    algo = _config().build_algo()
    try:
        placed = _placement(algo)
        result = algo.train()

        def first_observations(runner: Any) -> tuple[int, np.ndarray]:
            runner.make_env()
            episodes = runner.sample(num_timesteps=runner.num_envs, random_actions=True)
            return runner.worker_index, np.stack([e.get_observations(0) for e in episodes])

        first = dict(
            algo.env_runner_group.foreach_env_runner(first_observations, local_env_runner=False)
        )
    finally:
        algo.stop()
    worker_ids = {node.node_id for node in cluster.workers}
    assert sorted(placed) == [1, 2]
    assert {p["node"] for p in placed.values()} == worker_ids  # one runner per worker node
    for p in placed.values():
        assert p["type"] is PandaVectorEnv and p["num_envs"] == NUM_ENVS
    runners = result["env_runners"]
    assert result["num_env_steps_sampled_lifetime"] == BATCH
    assert runners["num_episodes"] == 2 * NUM_ENVS
    assert runners["episode_len_min"] == runners["episode_len_max"] == 70
    assert result["fault_tolerance"] == {
        "env_runners": 2,
        "healthy_env_runners": 2,
        "env_runner_restarts": 0,
        "failures": 0,
        "env_steps_lost_at_most": 0,
    }
    # Runner k (on its node) draws the streams (runner_seed(SEED, k), i), as locally.
    options = env_config(DENSE, reward_weights={"release": 1.0})
    for k in (1, 2):
        env = PandaVectorEnv(NUM_ENVS, num_threads=1, **options)
        obs, _ = env.reset(seed=runner_seed(SEED, k))
        env.close()
        np.testing.assert_array_equal(
            first[k], np.concatenate([obs[key] for key in DICT_KEYS], axis=1)
        )
    rows = np.concatenate([first[1], first[2]])
    assert len({row.tobytes() for row in rows}) == 2 * NUM_ENVS


def test_checkpoint_restores_onto_runners_on_other_nodes(cluster: Any, tmp_path: Path) -> None:
    from ray.rllib.algorithms.algorithm import Algorithm
    from ray.rllib.core import DEFAULT_MODULE_ID

    algo = _config().build_algo()
    try:
        algo.train()
        learner = algo.learner_group.get_weights(module_ids=[DEFAULT_MODULE_ID])
        saved = {k: np.asarray(v) for k, v in learner[DEFAULT_MODULE_ID].items()}
        before = _placement(algo)
        algo.save_to_path(str(tmp_path))
    finally:
        algo.stop()
    restored = Algorithm.from_checkpoint(str(tmp_path))
    try:
        after = _placement(restored)
        weights = restored.learner_group.get_weights(module_ids=[DEFAULT_MODULE_ID])
        learner = {k: np.asarray(v) for k, v in weights[DEFAULT_MODULE_ID].items()}
        # What every iteration does before sampling: the learner's weights to the runners.
        restored.env_runner_group.sync_weights(
            from_worker_or_learner_group=restored.learner_group, inference_only=True,
            timeout_seconds=None,
        )  # fmt: skip
        loaded = _weights(restored)
        result = restored.train()
    finally:
        restored.stop()
    assert {p["node"] for p in before.values()} == {p["node"] for p in after.values()}
    # The restored learner holds the checkpoint's weights bit for bit, and so does every
    # restored runner, on whichever node, once synced (a runner's module is the actor part).
    assert learner.keys() == saved.keys()
    for name, value in saved.items():
        np.testing.assert_array_equal(learner[name], value)
    for k in (1, 2):
        assert loaded[k] and set(loaded[k]) <= set(saved)
        assert any(name.startswith("encoder.actor_encoder") for name in loaded[k])
        for name, value in loaded[k].items():
            np.testing.assert_array_equal(value, saved[name])
    assert result["training_iteration"] == 2
    assert result["num_env_steps_sampled_lifetime"] == 2 * BATCH


def test_training_goes_on_when_a_worker_node_dies(cluster: Any) -> None:
    """A third worker node joins (one of the three stays free); the node of runner 1 is
    removed after the first iteration.
    RLlib fills the iterations from the healthy runner until runner 1, recreated on the spare
    node, is back; the results count the failure."""
    spare = cluster.add_node(num_cpus=1)
    cluster.wait_for_nodes()
    config = _config().fault_tolerance(
        restart_failed_env_runners=True,
        delay_between_env_runner_restarts_s=0.0,
        env_runner_health_probe_timeout_s=10.0,
    )
    algo = config.build_algo()
    try:
        algo.train()
        placed = _placement(algo)
        nodes = [*cluster.workers, spare]
        victim = next(n for n in nodes if n.node_id == placed[1]["node"])
        (free,) = [n for n in nodes if n.node_id not in {p["node"] for p in placed.values()}]
        cluster.remove_node(victim)
        results = [algo.train()]
        # Ray restarts the actor on the spare node; RLlib's health probe before each
        # iteration takes it back once it is up.
        deadline = time.monotonic() + 120
        while results[-1]["fault_tolerance"]["healthy_env_runners"] < 2:
            assert time.monotonic() < deadline, results[-1]["fault_tolerance"]
            results.append(algo.train())
        results.append(algo.train())
        after = _placement(algo)
    finally:
        algo.stop()
    steps = [r["num_env_steps_sampled_lifetime"] for r in results]
    assert all(b - a >= BATCH for a, b in zip([BATCH, *steps], steps, strict=False))
    last = results[-1]["fault_tolerance"]
    assert last["failures"] >= 1
    assert last["env_steps_lost_at_most"] == last["failures"] * NUM_ENVS * 70
    # Recreated on the node that was free (the only one with a free CPU), beside runner 2.
    assert last["env_runner_restarts"] >= 1 and last["healthy_env_runners"] == 2
    assert after[1]["node"] == free.node_id and after[2]["node"] == placed[2]["node"]
    for r in results:
        assert np.isfinite(r["learners"]["default_policy"]["total_loss"])


def test_tune_retries_a_trial_whose_node_dies_from_its_last_checkpoint(
    cluster: Any, tmp_path: Path
) -> None:
    """A one-trial PPO sweep on two fresh worker nodes; the node running the trial is removed
    once the trial has reported a checkpoint. Tune starts the trial again on the other node,
    from that checkpoint, and it finishes."""
    import json
    import threading

    from panda_rapier.scale.tuning import sb3_tuner

    fresh = [cluster.add_node(num_cpus=1) for _ in range(2)]
    cluster.wait_for_nodes()
    for node in cluster.list_all_nodes():  # the earlier tests' worker nodes: out of the way
        if node is not cluster.head_node and node not in fresh:
            cluster.remove_node(node)
    tuner = sb3_tuner(
        "ppo",
        DENSE,
        seeds=[0],
        hyperparams={"n_steps": 64, "batch_size": 128, "n_epochs": 1},
        timesteps=4096,  # 16 checkpoints: seconds left to remove the node after the first
        n_envs=4,
        eval_every=256,
        eval_episodes=4,
        storage_path=tmp_path,
        name="sweep",
        max_failures=2,
    )
    outcome: dict[str, Any] = {}
    fitting = threading.Thread(target=lambda: outcome.update(results=tuner.fit()))
    fitting.start()
    deadline = time.monotonic() + 240
    # The trial's first checkpoint in Tune's storage names the node it runs on.
    first: dict[str, Any] = {}
    while time.monotonic() < deadline and fitting.is_alive() and not first:
        for path in sorted(tmp_path.glob("sweep/*/checkpoint_*/attempts.jsonl")):
            text = path.read_text()
            if text.endswith("\n"):  # copied whole
                first = json.loads(text.splitlines()[0])
                break
        time.sleep(0.05)
    assert first, "the trial never reported a checkpoint"
    victim = next(n for n in fresh if n.node_id == first["node_id"])
    cluster.remove_node(victim)
    fitting.join(timeout=300)
    assert not fitting.is_alive()
    results = outcome["results"]
    assert len(results) == 1 and not results.errors
    result = results[0]
    assert result.metrics["env_steps"] == 4096
    lines = [
        json.loads(x) for x in (Path(result.path) / "run/attempts.jsonl").read_text().splitlines()
    ]
    assert len(lines) == 2
    assert lines[0]["resumed_from_env_steps"] == 0
    assert lines[1]["resumed_from_env_steps"] >= 256  # from its checkpoint, not the start
    assert lines[1]["node_id"] != victim.node_id
    run_info = json.loads((Path(result.path) / "run/run.json").read_text())
    assert len(run_info["resumed_with"]) == 1
    steps = [
        json.loads(x)["env_steps"]
        for x in (Path(result.path) / "run/evaluations.jsonl").read_text().splitlines()
    ]
    assert steps == sorted(set(steps)) and steps[-1] == 4096
