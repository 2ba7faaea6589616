"""The panda-rapier command line: eval with the scripted policy and a saved SB3 model."""

from __future__ import annotations

import json
import subprocess
import sys
import weakref
from pathlib import Path

import pytest

from panda_rapier.cli import main
from panda_rapier.tools import bench


def console_script() -> list[str]:
    script = Path(sys.executable).parent / "panda-rapier"
    assert script.is_file(), "the package installs a panda-rapier console script"
    return [str(script)]


def test_eval_scripted_writes_a_valid_json_report(tmp_path: Path) -> None:
    out = tmp_path / "report" / "eval.json"
    result = subprocess.run(
        [*console_script(), "eval", "--policy", "scripted", "--episodes", "6", "--num-envs", "4",
         "--seed", "3", "--control", "joints", "--json", str(out)],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert "success rate" in result.stdout and "95 % CI" in result.stdout
    assert "episodes" in result.stderr  # the progress bar
    report = json.loads(out.read_text())
    assert report["episodes"] == 6 and report["num_envs"] == 4
    assert report["control_mode"] == "joints" and report["max_episode_steps"] == 70
    low, high = report["success_ci95"]
    assert 0.0 <= low <= report["success_rate"] <= high <= 1.0
    assert report["success_rate"] >= 0.5
    assert report["mean_length"] == 70.0
    assert report["env_steps_per_s"] > 0 and report["env_steps"] >= 6 * 70
    records = report["episode_records"]
    assert [r["seed"] for r in records] == [3, 4, 5, 6, 7, 8]
    assert {r["env_index"] for r in records} <= {0, 1, 2, 3}
    for record in records:
        assert record["length"] == 70
        if record["success"]:
            assert 1 <= record["steps_to_success"] <= 70
    assert report["config"]["control_mode"] == "joints"


def test_eval_is_reproducible(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    reports = []
    for name in ("a", "b"):
        path = tmp_path / f"{name}.json"
        args = ["eval", "--episodes", "3", "--num-envs", "2", "--quiet", "--json", str(path)]
        assert main([*args, "--env-id", "panda_rapier/PickAndPlaceDense-v0"]) == 0
        reports.append(json.loads(path.read_text()))
    for report in reports:
        for key in ("wall_time_s", "env_steps_per_s"):
            report.pop(key)
    assert reports[0] == reports[1]
    assert reports[0]["reward_type"] == "dense"
    assert "success rate" in capsys.readouterr().out


def test_eval_random_policy_is_the_seeded_floor(tmp_path: Path) -> None:
    """``--policy random``: uniform actions drawn per episode seed, so a rerun repeats it."""
    reports = []
    for name in ("a", "b"):
        path = tmp_path / f"{name}.json"
        args = ["eval", "--policy", "random", "--env-id", "panda_rapier/ReachDense-v0",
                "--episodes", "4", "--num-envs", "2", "--quiet", "--json", str(path)]  # fmt: skip
        assert main(args) == 0
        reports.append(json.loads(path.read_text()))
    assert reports[0]["inference"] == "random" and reports[0]["policy"] == "random"
    assert reports[0]["episode_records"] == reports[1]["episode_records"]
    assert len({r["episode_return"] for r in reports[0]["episode_records"]}) == 4


def test_eval_rejects_bad_arguments(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["eval", "--policy", str(tmp_path / "missing.zip"), "--quiet"]) == 2
    assert "does not exist" in capsys.readouterr().err
    not_a_model = tmp_path / "model.zip"
    not_a_model.write_text("not a zip")
    pytest.importorskip("stable_baselines3")
    assert main(["eval", "--policy", str(not_a_model), "--quiet", "--episodes", "1"]) == 2
    assert "panda-rapier eval:" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["eval", "--episodes", "0"])
    with pytest.raises(SystemExit):
        main(["eval", "--env-id", "CartPole-v1"])


def test_eval_loads_a_saved_sb3_model(tmp_path: Path) -> None:
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import PPO

    from panda_rapier.sb3 import make_vec_env

    env = make_vec_env("panda_rapier/PickAndPlaceJoints-v0", n_envs=2, seed=0)
    model = PPO("MultiInputPolicy", env, n_steps=32, batch_size=32, n_epochs=1, seed=0,
                device="cpu")  # fmt: skip
    model.learn(64)
    model.save(tmp_path / "ppo.zip")
    out = tmp_path / "eval.json"
    # No run.json beside the model: the action mode comes from the model's action space.
    assert main(["eval", "--policy", str(tmp_path / "ppo.zip"), "--episodes", "2",
                 "--num-envs", "2", "--quiet", "--json", str(out)]) == 0  # fmt: skip
    report = json.loads(out.read_text())
    assert report["control_mode"] == "joints" and report["episodes"] == 2
    assert report["policy"].endswith("ppo.zip")


def test_bench_reports_speed_next_to_accuracy(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "bench.json"
    args = ["bench", "--num-envs", "1", "2", "--rounds", "2", "--env-steps", "16", "--no-peers",
            "--quiet", "--json", str(out)]  # fmt: skip
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "env-steps/s" in text and "accuracy: tutorial grasp carry slip" in text
    report = json.loads(out.read_text())
    rows = {(r["target"], r["policy"], r["num_envs"]) for r in report["results"]}
    expected = {("gym.make", p, 1) for p in ("random", "scripted")}
    expected |= {(t, p, n) for t in ("vector", "sb3") for p in ("random", "scripted")
                 for n in (1, 2)}  # fmt: skip
    assert rows == expected
    for row in report["results"]:
        assert len(row["runs"]) == 2 and all(rate > 0 for rate in row["runs"])
        assert row["sim_s_per_s"] == pytest.approx(row["env_steps_per_s"] * 0.04)
    assert report["ratios"] == [] and report["machine"]["cpus"] >= 1
    fidelity = report["fidelity"]
    assert fidelity["on_platform"] and fidelity["carry_slip_mm"] < 5.0
    assert not fidelity["non_finite_seen"]


def test_bench_frees_each_case_before_building_the_next(monkeypatch: pytest.MonkeyPatch) -> None:
    # A full run with envpool's MuJoCo peers was OOM-killed at 24 GB while measured cases still
    # held their batches; each case must be gone before the next one is built.
    batches: list[weakref.ref[object]] = []

    class Batch:
        def close(self) -> None:
            pass

    def build(env_id: str, policy: str, steps: int, config: dict[str, object]) -> bench.BenchCase:
        assert all(ref() is None for ref in batches), "a measured case still holds its batch"
        batch = Batch()
        batches.append(weakref.ref(batch))
        return bench.BenchCase("gym.make", policy, 1, 0.04, runner=lambda n: (batch, 1e3)[1],
                               close=batch.close)  # fmt: skip

    monkeypatch.setattr(bench, "_single_env_case", build)
    report = bench.run_benchmark(num_envs=(), targets=("gym.make",), rounds=3, peers=False,
                                 env_steps=8)  # fmt: skip
    assert len(batches) == 6 and all(ref() is None for ref in batches)
    assert [row["runs"] for row in report["results"]] == [[1e3] * 3] * 2
