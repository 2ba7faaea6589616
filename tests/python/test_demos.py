"""Minari demonstrations: `panda-rapier demos` records the scripted expert, minari loads it
back, the environment is recovered from it, episodes replay bit for bit from their seeds, and
the behaviour-cloning example trains on it."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

minari = pytest.importorskip("minari")  # the demos extra, installed by the test command

from panda_rapier import InvalidArgumentError  # noqa: E402
from panda_rapier.cli import main  # noqa: E402
from panda_rapier.learning.demos import DEFAULT_FIRST_SEED, record, to_demonstrations  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def datasets(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    path = tmp_path / "minari"
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(path))
    return path


def test_demos_command_records_a_dataset_minari_loads(
    datasets: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["demos", "--env", "panda_rapier/PickAndPlace-v0", "--episodes", "4",
                 "--quiet"]) == 0  # fmt: skip
    out = capsys.readouterr().out
    assert "panda_rapier/PickAndPlace/expert-v0" in out and "success 1.000" in out
    assert (datasets / "panda_rapier" / "PickAndPlace" / "expert-v0").is_dir()
    dataset = minari.load_dataset("panda_rapier/PickAndPlace/expert-v0")
    assert dataset.total_episodes == 4 and dataset.total_steps == 4 * 70
    metadata = dataset.storage.metadata
    assert metadata["ref_max_score"] > metadata["ref_min_score"]
    assert metadata["requirements"][0].startswith("panda-rapier==")
    episodes = list(dataset.iterate_episodes())
    seeds = [m["seed"] for m in dataset.storage.get_episode_metadata(dataset.episode_indices)]
    assert seeds == [DEFAULT_FIRST_SEED + k for k in range(4)]
    first = episodes[0]
    assert first.observations["observation"].shape == (71, 41)
    assert first.actions.shape == (70, 4) and first.infos["is_placed"].shape == (71,)
    assert first.infos["is_placed"][-1] and first.truncations[-1]
    # The environment comes back from the dataset, and the seed and actions replay the
    # episode bit for bit.
    env = dataset.recover_environment()
    assert env.spec.id == "panda_rapier/PickAndPlace-v0"
    obs, _ = env.reset(seed=seeds[0])
    np.testing.assert_array_equal(obs["observation"], first.observations["observation"][0])
    for t, action in enumerate(first.actions):
        obs, reward, _, _, _ = env.step(action)
        np.testing.assert_array_equal(obs["observation"], first.observations["observation"][t + 1])
        assert reward == first.rewards[t]
    demos = to_demonstrations(dataset)
    assert len(demos) == 280 and demos.episode_seeds == seeds and all(demos.episode_placed)
    # Recording over an existing dataset is refused.
    assert main(["demos", "--env", "panda_rapier/PickAndPlace-v0", "--episodes", "1",
                 "--quiet"]) == 2  # fmt: skip
    assert "already exists" in capsys.readouterr().err


def test_noisy_joints_demonstrations_are_medium_quality(datasets: Path) -> None:
    summary = record("panda_rapier/PickAndPlaceJointsDense-v0", 2, noise=0.2,
                     reference_episodes=2, env_kwargs={"arm": "kinematic"})  # fmt: skip
    assert summary.dataset_id == "panda_rapier/PickAndPlaceJointsDense/medium-v0"
    dataset = minari.load_dataset(summary.dataset_id)
    episode = next(dataset.iterate_episodes())
    assert episode.actions.shape == (70, 8)
    assert np.all(np.abs(episode.actions) <= 1.0)
    assert "noise" in dataset.storage.metadata["algorithm_name"]
    env = dataset.recover_environment()
    assert env.unwrapped.config["arm"] == "kinematic"
    assert env.unwrapped.config["reward_type"] == "dense"
    with pytest.raises(InvalidArgumentError, match="noise"):
        record("panda_rapier/PickAndPlace-v0", 1, noise=float("nan"))
    with pytest.raises(InvalidArgumentError, match="Malformed dataset ID"):
        record("panda_rapier/PickAndPlace-v0", 1, dataset_id="no version")


def test_bc_from_minari_example_trains_on_the_dataset(datasets: Path, tmp_path: Path) -> None:
    pytest.importorskip("stable_baselines3")
    record("panda_rapier/PickAndPlace-v0", 3, reference_episodes=1)
    model = tmp_path / "bc.zip"
    done = subprocess.run(
        [sys.executable, str(ROOT / "examples/bc_from_minari.py"), "--epochs", "2",
         "--eval-episodes", "4", "--out", str(model)],
        capture_output=True, text=True, timeout=600,
        env={**os.environ, "MINARI_DATASETS_PATH": str(datasets)},
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    assert "3 episodes, 210 states" in done.stdout and "cloned policy on 4" in done.stdout
    assert main(["eval", "--policy", str(model), "--episodes", "2", "--quiet"]) == 0
