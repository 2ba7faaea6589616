"""rl-zoo3 trains with the recipes shipped in the package (the `zoo` extra)."""

from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import panda_rapier
from panda_rapier.learning.recipes import default_recipe_path


def test_rl_zoo3_trains_ppo_with_our_recipe_and_logs_success(tmp_path: Path) -> None:
    import rl_zoo3  # noqa: F401  (the extra is installed by the test command)
    from stable_baselines3 import PPO

    env_id = "panda_rapier/PickAndPlaceDense-v0"
    command = [
        sys.executable, "-m", "rl_zoo3.train", "--algo", "ppo", "--env", env_id,
        "--gym-packages", "panda_rapier", "-conf", str(default_recipe_path("ppo")),
        # One 70-step episode in each of 4 environments, instead of the recipe's 64.
        "-params", "n_envs:4", "n_steps:70", "batch_size:140", "-n", "280",
        "--eval-freq", "-1", "--vec-env", "dummy", "--seed", "0", "-f", str(tmp_path),
    ]  # fmt: skip
    done = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    run = tmp_path / "ppo" / f"{env_id.replace('/', '-')}_1"
    monitors = sorted(run.glob("*.monitor.csv"))
    assert len(monitors) == 4
    for monitor in monitors:
        lines = monitor.read_text().splitlines()[1:]  # the first line is Monitor's JSON header
        rows = list(csv.DictReader(lines))
        assert len(rows) == 1 and int(rows[0]["l"]) == panda_rapier.MAX_EPISODE_STEPS
        assert rows[0]["is_success"] in ("True", "False")
        assert rows[0]["is_placed"] in ("True", "False")
    model = PPO.load(run / f"{env_id.replace('/', '-')}.zip", device="cpu")
    # The recipe's callback fitted the observation normaliser inside the network.
    assert (model.policy.features_extractor.scale.numpy() != 1).any()
    # rl-zoo3 made the environments with the recipe's options (the release term is on).
    config = (run / env_id.replace("/", "-") / "config.yml").read_text()
    assert "reward_weights" in config and "release" in config
