"""``panda-rapier bench-train``: recipe variants trained round by round, with the end-to-end
rate and where the wall time went; and ``train``'s record of that split."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

pytest.importorskip("stable_baselines3")
yaml = pytest.importorskip("yaml")

from panda_rapier import ConfigError, InvalidArgumentError  # noqa: E402
from panda_rapier.cli import main  # noqa: E402
from panda_rapier.learning.phases import PHASES, describe_split  # noqa: E402
from panda_rapier.tools.train_bench import benchmark_training, parse_variant  # noqa: E402

TINY = ["n_envs=4", "n_steps=16", "batch_size=32", "policy_kwargs=dict(net_arch=[16])"]


def test_variants_are_parsed_and_bad_ones_refused() -> None:
    assert parse_variant(["fast", "n_epochs=4", "gamma=0.9", "target_kl=null"]) == (
        "fast", {"n_epochs": 4, "gamma": 0.9, "target_kl": None}
    )  # fmt: skip
    assert parse_variant(["as-is"]) == ("as-is", {})
    for tokens in ([], ["n_epochs=4"], ["x", "n_epochs"], ["x", "update_threads=0"],
                   ["x", "update_threads=true"]):  # fmt: skip
        with pytest.raises(InvalidArgumentError):
            parse_variant(tokens)
    env_id = "panda_rapier/ReachDense-v0"
    with pytest.raises(InvalidArgumentError, match="differ"):
        benchmark_training("ppo", env_id, [("a", {}), ("a", {})])
    with pytest.raises(InvalidArgumentError, match="bc"):
        benchmark_training("bc", env_id, [("a", {})])
    with pytest.raises(InvalidArgumentError, match="steps"):
        benchmark_training("ppo", env_id, [("a", {})], steps=0)
    with pytest.raises(ConfigError, match="variant bad"):
        benchmark_training("ppo", env_id, [parse_variant(["bad", *TINY, "frame_stack=2"])],
                           steps=64, rounds=1)  # fmt: skip


def test_bench_train_measures_every_variant_in_every_round(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "report.json"
    argv = ["bench-train", "--env-id", "panda_rapier/ReachDense-v0", "--steps", "128",
            "--rounds", "2", "--quiet", "--json", str(out),
            "--variant", "two", *TINY, "n_epochs=2",
            "--variant", "one", *TINY, "n_epochs=1", "update_threads=1",
            "--variant", "stock", *TINY, "n_epochs=2", "backend=sb3-stock",
            "--variant", "overlap", *TINY, "n_epochs=2", "overlap=true"]  # fmt: skip
    assert main(argv) == 0
    report = json.loads(out.read_text())
    assert [row["variant"] for row in report["variants"]] == ["two", "one", "stock", "overlap"]
    assert report["variants"][3]["overrides"]["overlap"] is True
    assert report["variants"][1]["overrides"] == {
        "n_envs": 4, "n_steps": 16, "batch_size": 32, "policy_kwargs": "dict(net_arch=[16])",
        "n_epochs": 1, "update_threads": 1,
    }  # fmt: skip
    for row in report["variants"]:
        assert len(row["rounds"]) == 2
        for one in row["rounds"]:
            assert one["env_steps"] == 128
            assert all(one[phase] > 0 for phase in PHASES), one
            assert one["env_steps_per_s"] == pytest.approx(128 / one["seconds"])
    assert report["variants"][0]["ratio_to_first"] == 1.0
    printed = capsys.readouterr().out
    assert "| two |" in printed and "| one |" in printed and "env-steps/s" in printed
    with pytest.raises(InvalidArgumentError, match="sb3-stock"):
        benchmark_training("tqc", "panda_rapier/PickAndPlace-v0",
                           [("s", {"backend": "sb3-stock"})], steps=64, rounds=1)  # fmt: skip
    for overrides in ({"overlap": "yes"}, {"overlap": True, "backend": "sb3-stock"}):
        with pytest.raises(InvalidArgumentError, match="overlap"):
            benchmark_training("ppo", "panda_rapier/ReachDense-v0", [("o", overrides)],
                               steps=64, rounds=1)  # fmt: skip
    with pytest.raises(InvalidArgumentError, match="overlap"):
        benchmark_training("tqc", "panda_rapier/PickAndPlace-v0", [("o", {"overlap": True})],
                           steps=64, rounds=1)  # fmt: skip


def test_train_names_the_class_that_trained(tmp_path: Path) -> None:
    """``panda-rapier train`` trains PPO with panda_rapier.learning.ppo.PPO, SB3's own on request,
    and says which in run.json."""
    conf = tmp_path / "tiny.yml"
    conf.write_text(yaml.safe_dump({"panda_rapier/ReachDense-v0": {
        "n_envs": 4, "n_steps": 16, "batch_size": 32, "n_epochs": 1,
        "policy": "MultiInputPolicy", "policy_kwargs": "dict(net_arch=[16])"}}))  # fmt: skip
    from panda_rapier.learning.runner import train

    for stock, name in ((False, "panda_rapier.learning.ppo.PPO"),
                        (True, "stable_baselines3.ppo.ppo.PPO")):  # fmt: skip
        out = tmp_path / f"run-{stock}"
        run = train("ppo", "panda_rapier/ReachDense-v0", out, conf=conf, timesteps=64,
                    progress=False, say=lambda _: None, stock_sb3=stock)  # fmt: skip
        assert run["algorithm_class"] == name
        assert json.loads((out / "run.json").read_text())["algorithm_class"] == name


def test_describe_split_gives_each_phases_share() -> None:
    text = describe_split({"env_step": 3.0, "policy_forward": 1.0, "rollout_other": 0.0,
                           "update": 6.0})  # fmt: skip
    assert text.startswith("env stepping 30 %, policy in rollouts 10 %")
    assert "updates 60 %" in text and "(of 0.2 min)" in text
    assert describe_split({}) == "no time recorded"
