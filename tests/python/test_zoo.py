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


#: rl-zoo3's panda-gym ids and the ids of this package each one's recipe is applied to.
ZOO_PANDA_IDS = {
    "PandaReach-v1": ("Reach", "ReachJoints"),
    "PandaPush-v1": ("Push", "PushJoints"),
    "PandaSlide-v1": ("Slide", "SlideJoints"),
    "PandaPickAndPlace-v1": ("PickAndPlace", "PickAndPlaceJoints"),
    "PandaStack-v1": ("Stack", "StackJoints"),
}


def test_tqc_recipes_are_rl_zoo3_panda_gym_hyperparameters_unchanged() -> None:
    """hyperparams/tqc.yml gives each matching id rl-zoo3's own panda-gym entry, key for key
    (string-valued kwargs compared as the dicts they evaluate to), plus only the Monitor's
    info keywords, which rl-zoo3 alone reads."""
    import rl_zoo3
    import yaml

    from panda_rapier.learning.recipes import evaluate_expression, load_recipe, recipe_ids

    zoo = yaml.safe_load((Path(rl_zoo3.__file__).parent / "hyperparams" / "tqc.yml").read_text())

    def parsed(entry: dict) -> dict:
        out = {k: v for k, v in entry.items() if k != "monitor_kwargs"}
        for key in ("policy_kwargs", "replay_buffer_kwargs"):
            if isinstance(out.get(key), str):
                out[key] = evaluate_expression(out[key])
        return out

    covered = set()
    for zoo_id, names in ZOO_PANDA_IDS.items():
        for name in names:
            env_id = f"panda_rapier/{name}-v0"
            assert parsed(load_recipe("tqc", env_id)) == parsed(zoo[zoo_id]), env_id
            covered.add(env_id)
    assert set(recipe_ids("tqc")) == covered


def _zoo_run(folder: Path, args_text: str) -> Path:
    """A run folder laid out as rl-zoo3 writes one: ENV/args.yml, evaluations.npz (two
    evaluations of 5 episodes) and a training Monitor file."""
    import numpy as np

    (folder / "PandaReach-v3").mkdir(parents=True)
    (folder / "PandaReach-v3" / "args.yml").write_text(args_text)
    np.savez(folder / "evaluations.npz", timesteps=np.array([100, 200]),
             results=np.zeros((2, 5)), ep_lengths=np.full((2, 5), 50),
             successes=np.array([[0, 0, 1, 0, 0], [1, 1, 1, 1, 0]]))  # fmt: skip
    rows = "".join(f"-50.0,50,{2.5 * (i + 1)},False\n" for i in range(4))
    (folder / "0.monitor.csv").write_text('#{"t_start": 0.0}\nr,l,t,is_success\n' + rows)
    return folder


def test_curves_read_rl_zoo3_runs_by_data(tmp_path: Path) -> None:
    """``panda-rapier curves`` draws an rl-zoo3 run (a panda-gym one, to compare with) beside
    its own: success per evaluation and the wall time from the Monitor file. Its args.yml is
    read by data: a tag that would run code is an error, and nothing runs."""
    import collections

    import yaml

    from panda_rapier.cli import main
    from panda_rapier.tools.zoo_runs import zoo_curve

    args = yaml.dump(collections.OrderedDict([("algo", "tqc"), ("env", "PandaReach-v3"),
                                              ("seed", 3)]))  # fmt: skip
    assert args.startswith("!!python/object/apply:collections.OrderedDict")
    run = _zoo_run(tmp_path / "zoo", args)
    label, lines = zoo_curve(run)
    assert label == "tqc (rl-zoo3) PandaReach-v3 (seed 3)"
    assert [line["success_rate"] for line in lines] == [0.2, 0.8]
    assert [line["wall_time_s"] for line in lines] == [5.0, 10.0]
    assert main(["curves", str(run), "--out", str(tmp_path / "c.png")]) == 0
    assert (tmp_path / "c.png").stat().st_size > 10_000

    marker = tmp_path / "ran"
    hostile = f"!!python/object/apply:os.system ['touch {marker}']\n"
    bad = _zoo_run(tmp_path / "bad", hostile)
    assert main(["curves", str(bad), "--out", str(tmp_path / "d.png")]) == 2
    assert not marker.exists()
