"""panda_rapier.agents.evaluation.evaluate: one native evaluator (refill schedule, per-episode
records) shared with the Rust ``panda_rapier_policies::evaluate``."""

from __future__ import annotations

from dataclasses import asdict

import numpy as np
import pytest

from panda_rapier import (
    ConfigError,
    InvalidArgumentError,
    RandomPolicy,
    ResetNeededError,
    ScriptedPolicy,
    _common,
    _native,
)
from panda_rapier._native import evaluate_scripted
from panda_rapier.agents.evaluation import evaluate
from panda_rapier.registration import env_config

# Success ends an episode: lengths differ, so refill hands episodes to environments out of
# round-robin order and environments go idle at different times.
CONFIG = env_config("panda_rapier/PickAndPlace-v0", terminate_on_success=True)


@pytest.mark.parametrize(("episodes", "num_envs", "first_seed"), [(40, 8, 3), (9, 4, 0)])
def test_python_and_rust_evaluations_of_the_scripted_policy_agree(
    episodes: int, num_envs: int, first_seed: int
) -> None:
    python = evaluate(
        ScriptedPolicy(CONFIG), CONFIG, episodes, num_envs=num_envs, first_seed=first_seed
    )
    rust = evaluate_scripted(_common.config_json(CONFIG), episodes, num_envs, None, first_seed)
    assert [asdict(e) for e in python.episodes] == rust["episodes"]
    assert (python.env_steps, python.idle_env_steps) == (rust["env_steps"], rust["idle_env_steps"])
    assert [e.seed for e in python.episodes] == list(range(first_seed, first_seed + episodes))
    assert len({e.length for e in python.episodes}) > 1, "success termination varies lengths"
    assert python.success_rate > 0.8


def test_records_do_not_depend_on_threads_and_prefixes_agree() -> None:
    policy = ScriptedPolicy(CONFIG)
    one = evaluate(policy, CONFIG, 24, num_envs=6, num_threads=1)
    two = evaluate(policy, CONFIG, 24, num_envs=6, num_threads=2)
    assert one.episodes == two.episodes and one.env_steps == two.env_steps
    shorter = evaluate(policy, CONFIG, 10, num_envs=6, num_threads=2)
    assert shorter.episodes == one.episodes[:10]
    # Honest step count: recorded steps plus the idle environments' steps.
    assert sum(e.length for e in one.episodes) == one.env_steps - one.idle_env_steps
    assert one.idle_env_steps > 0
    assert one.summary()["idle_env_steps"] == one.idle_env_steps


def test_random_policy_acts_by_episode() -> None:
    """The benchmark's random row keeps the evaluation's contract: each episode's actions come
    from its own stream (its seed's), so the same (config, first_seed, num_envs) gives the same
    records for any number of threads, a shorter evaluation the first records of a longer one,
    and another policy seed other actions."""

    def outcomes(report):  # type: ignore[no-untyped-def]
        return [(e.seed, e.env_index, e.episode_return, e.length) for e in report.episodes]

    config = env_config("panda_rapier/ReachDense-v0")  # returns differ between episodes
    one = evaluate(RandomPolicy(config), config, 12, num_envs=5, num_threads=1)
    two = evaluate(RandomPolicy(config), config, 12, num_envs=5, num_threads=2)
    assert one.inference == two.inference == "random"
    assert outcomes(one) == outcomes(two)
    shorter = evaluate(RandomPolicy(config), config, 7, num_envs=5)
    assert outcomes(shorter) == outcomes(one)[:7]
    other = evaluate(RandomPolicy(config, seed=1), config, 12, num_envs=5)
    assert [r for *_, r, _ in outcomes(other)] != [r for *_, r, _ in outcomes(one)]
    # Called directly: actions in [-1, 1] of the task's action shape, one row per observation.
    action, _ = RandomPolicy("panda_rapier/ReachJoints-v0").predict(
        np.zeros((3, RandomPolicy("panda_rapier/ReachJoints-v0").flat_dim), np.float32)
    )
    assert action.shape == (3, 8) and np.all(np.abs(action) <= 1)
    with pytest.raises(InvalidArgumentError, match="seed"):
        RandomPolicy(config, seed=-1)


def test_refill_schedule_as_seen_by_the_step_hook() -> None:
    seen: list[list[int | None]] = []

    def hook(observations: np.ndarray, actions: np.ndarray, running: list[int | None]) -> None:
        assert observations.shape[0] == 3
        assert actions.shape == (3, 4)
        seen.append(list(running))

    report = evaluate(ScriptedPolicy(CONFIG), CONFIG, 7, num_envs=3, on_step=hook)
    assert seen[0] == [0, 1, 2]
    assert seen[-1].count(None) >= 1  # the last steps have idle environments
    handed_out = [k for k in dict.fromkeys(e for row in seen for e in row) if k is not None]
    assert handed_out == list(range(7)), "episodes start in order"
    for k, record in enumerate(report.episodes):
        steps = [row for row in seen if k in row]
        assert len(steps) == record.length
        assert all(row[record.env_index] == k for row in steps)


def test_native_evaluation_checks_its_call_order() -> None:
    config = env_config("panda_rapier/PickAndPlace-v0", max_episode_steps=2)
    evaluation = _native.Evaluation(_common.config_json(config), 1, 4, 1, 0)
    assert evaluation.num_envs == 1 and not evaluation.done
    actions = np.zeros((1, evaluation.action_dim), dtype=np.float32)
    with pytest.raises(ResetNeededError, match="not over"):
        evaluation.report()
    assert evaluation.step(actions) == 0
    assert evaluation.step(actions) == 1
    with pytest.raises(ResetNeededError, match="refill"):
        evaluation.step(actions)
    assert not evaluation.refill()[0]
    assert evaluation.running() == [None] and evaluation.done
    with pytest.raises(ResetNeededError, match="over"):
        evaluation.step(actions)
    report = evaluation.report()
    assert report["env_steps"] == 2 and report["episodes"][0]["length"] == 2
    with pytest.raises(InvalidArgumentError):
        _native.Evaluation(_common.config_json(config), 1, 1).step(np.zeros((2, 4), np.float32))


def test_bad_arguments() -> None:
    policy = ScriptedPolicy(CONFIG)
    with pytest.raises(InvalidArgumentError):
        evaluate(policy, CONFIG, 0)
    with pytest.raises(InvalidArgumentError):
        evaluate(policy, CONFIG, 2, first_seed=2**64 - 1)
    with pytest.raises(ConfigError, match="time limit"):
        evaluate(policy, {**CONFIG, "max_episode_steps": None}, 2)
    with pytest.raises(ConfigError, match="max_episode_steps"):
        _native.Evaluation(_common.config_json({**CONFIG, "max_episode_steps": None}), 1, 1)


def test_statistics_are_the_rust_evaluators_and_match_numpy() -> None:
    """One place computes the statistics (the Rust evaluator's ``summarize``); they agree with
    numpy's definitions: population standard deviation, the median of an even count, the
    Wilson interval's edge cases."""
    from panda_rapier.agents.evaluation import EpisodeRecord, EvaluationReport, wilson_interval

    rng = np.random.default_rng(3)
    episodes = [
        EpisodeRecord(
            seed=k,
            env_index=k % 4,
            episode_return=float(rng.normal(10, 3)),
            length=int(rng.integers(20, 70)),
            # Successful at some step where k % 3; not at the last step where also k % 4 == 1.
            success=bool(k % 3) and k % 4 != 1,
            placed=bool(k % 5),
            steps_to_success=int(rng.integers(5, 20)) if k % 3 else None,
            steps_to_placed=int(rng.integers(10, 30)) if k % 5 else None,
            physics_unstable=k == 7,
        )
        for k in range(40)
    ]
    report = EvaluationReport("p", {}, 0, 4, 1, 0, 1.0, episodes)
    stats = report.statistics()
    returns = np.array([e.episode_return for e in episodes])
    to_success = [e.steps_to_success for e in episodes if e.steps_to_success is not None]
    assert stats["success_rate"] == pytest.approx(np.mean([e.success for e in episodes]))
    # Success at some step: steps_to_success recorded (here also where the last step failed).
    once = [e.success or e.steps_to_success is not None for e in episodes]
    assert np.mean(once) > np.mean([e.success for e in episodes])
    assert stats["success_once_rate"] == pytest.approx(np.mean(once))
    assert report.summary()["success_once_ci95"] == list(wilson_interval(sum(once), len(once)))
    assert stats["placed_rate"] == pytest.approx(np.mean([e.placed for e in episodes]))
    assert stats["mean_return"] == pytest.approx(returns.mean(), rel=1e-12)
    assert stats["std_return"] == pytest.approx(returns.std(), rel=1e-12)
    assert stats["median_steps_to_success"] == pytest.approx(np.median(to_success))
    assert stats["physics_unstable_episodes"] == 1
    assert report.summary()["success_ci95"] == list(report.success_ci95)
    assert wilson_interval(0, 0) == (0.0, 1.0)
    low, high = wilson_interval(10, 10)
    assert high == pytest.approx(1.0) and 0.6 < low < 0.8
    with pytest.raises(InvalidArgumentError):
        wilson_interval(3, 2)
