"""Policies that see (panda_rapier.learning.student): the encoder, the DAgger loop with a privileged
teacher improving a student on a tiny budget, ``panda-rapier train --algo bc`` on images, and
the student's model file read by data (evaluable without trusting the file)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import torch as th
from stable_baselines3 import PPO

from panda_rapier import cli
from panda_rapier.agents.evaluation import evaluate
from panda_rapier.agents.inference import resolve_policy
from panda_rapier.agents.model_file import save_model
from panda_rapier.agents.student_model import (
    DEPTH_CLIP,
    PixelEncoder,
    SpatialSoftArgmax,
    load_student,
    policy_kwargs,
    student_architecture,
)
from panda_rapier.errors import ConfigError, InvalidArgumentError
from panda_rapier.learning.runner import train
from panda_rapier.learning.student import collect_student, distil
from panda_rapier.pixels import DEPTH_FAR, randomization_of
from panda_rapier.registration import env_config
from panda_rapier.sb3 import make_vec_env
from panda_rapier.tools.reporting import ROBUSTNESS_CONDITIONS, robustness_table

ENV_ID = "panda_rapier/PickAndPlace-v0"
#: A small image keeps the tests quick; the shipped recipe's size is in the recipe.
OBSERVATION = {"obs_mode": "proprio+rgb", "image_size": 48}
REPO = Path(__file__).resolve().parents[2]
#: The tiny run trains under visual randomisation (what it is evaluated with is the plain scene).
RANDOMISED = {**OBSERVATION, "visual_randomization": True}
TINY = {
    "env_kwargs": RANDOMISED,
    "student": {"channels": [8, 16, 8], "strides": [2, 2, 1], "net_arch": {"pi": [64], "vf": [64]}},
    "n_envs": 8,
    "demo_episodes": 8,
    "dagger_rounds": 1,
    "dagger_episodes": 8,
    "first_updates": 20,
    "round_updates": 10,
    "final_updates": 10,
    "batch_size": 32,
}


def _student(arch: dict[str, Any], observation: dict[str, Any] = OBSERVATION) -> PPO:
    env = make_vec_env(ENV_ID, n_envs=1, **observation)
    return PPO("MultiInputPolicy", env, policy_kwargs=policy_kwargs(arch), seed=0, device="cpu")


def _assert_dagger_learns(model: PPO, observation: dict[str, Any]) -> None:
    """Distils ``model`` on 24 episodes and asserts it then predicts the expert's actions in
    states it never saw far better than the best constant action does (the actions depend
    on where the cube is)."""
    config = env_config(ENV_ID)
    held_out, _ = collect_student(config, observation, 8, first_seed=10_000, num_envs=8)

    def loss() -> float:
        obs = {k: th.as_tensor(v) for k, v in held_out.observations.items()}
        with th.no_grad():
            mean = model.policy.get_distribution(obs).distribution.mean.numpy()
        return float(np.mean((mean - held_out.actions) ** 2))

    before = loss()
    distil(
        model, config, observation, demo_episodes=16, rounds=1, episodes_per_round=8,
        first_updates=300, round_updates=150, final_updates=100, first_seed=0, batch_size=64,
        learning_rate=1e-3, num_envs=8,
    )  # fmt: skip
    constant = float(np.mean((held_out.actions - held_out.actions.mean(axis=0)) ** 2))
    after = loss()
    assert after < 0.6 * constant < before, (before, constant, after)


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A student trained by ``panda-rapier train --algo bc`` on a budget of seconds."""
    out = tmp_path_factory.mktemp("student") / "run"
    recipe = tmp_path_factory.mktemp("recipe") / "bc-pixels.yml"
    recipe.write_text(json.dumps({ENV_ID: TINY}))  # JSON is YAML
    code = cli.main(
        ["train", "--algo", "bc", "--env-id", ENV_ID, "--conf", str(recipe), "--out", str(out),
         "--eval-episodes", "4", "--quiet"]
    )  # fmt: skip
    assert code == 0
    return out


def test_spatial_soft_argmax_finds_a_peak() -> None:
    layer = SpatialSoftArgmax(5, 9)
    maps = th.full((1, 2, 5, 9), -50.0)
    maps[0, 0, 0, 8] = 50.0  # top right
    maps[0, 1, 4, 0] = 50.0  # bottom left
    keypoints = layer(maps)[0].detach().numpy()
    # x of both channels, then y of both
    np.testing.assert_allclose(keypoints, [1.0, -1.0, -1.0, 1.0], atol=1e-4)


def test_the_encoder_sees_images_and_scales_the_rest() -> None:
    model = _student(student_architecture(TINY["student"]))
    encoder = model.policy.features_extractor
    assert isinstance(encoder, PixelEncoder)
    assert encoder.image_keys == ["rgb"]
    assert encoder.vector_keys == ["desired_goal", "proprioception"]
    assert encoder.features_dim == 2 * 8 + 3 + 25
    with pytest.raises(TypeError, match="image"):
        PixelEncoder(make_vec_env(ENV_ID, n_envs=1).observation_space)


@pytest.mark.parametrize(
    "spec",
    [
        [1, 2],
        {"channels": [8], "strides": [1, 2]},
        {"channels": [0], "strides": [1]},
        {"channels": [8], "strides": [True]},
        {"net_arch": {"pi": [64]}},
        {"depth": 3},
        {"depth_range": 0},
        {"depth_range": -0.05},
        {"depth_range": True},
        {"depth_range": "5 cm"},
        {"depth_range": float("nan")},
        {"depth_range": 3.0},
    ],
)
def test_bad_student_architectures_are_config_errors(spec: Any) -> None:
    with pytest.raises(ConfigError):
        student_architecture(spec)


def test_the_student_observation_holds_the_expert_s_labels() -> None:
    config = env_config(ENV_ID)
    data, stats = collect_student(config, OBSERVATION, 2, first_seed=7, num_envs=2)
    assert stats.success_rate == 1.0  # the expert drove
    assert set(data.observations) == {"desired_goal", "proprioception", "rgb"}
    assert data.observations["rgb"].shape == (len(data), 3, 48, 48)
    assert data.observations["rgb"].dtype == np.uint8
    assert len(data) == 2 * config["max_episode_steps"] == len(data.actions)
    assert data.episode_seeds == [7, 8]


def test_dagger_improves_the_student_on_a_tiny_budget() -> None:
    model = _student(student_architecture({"channels": [8, 16, 8], "strides": [2, 2, 1]}))
    _assert_dagger_learns(model, OBSERVATION)


DEPTH = {"obs_mode": "proprio+depth", "image_size": 48}


def test_the_encoder_sees_depth_clamped_and_standardised() -> None:
    arch = student_architecture(TINY["student"])
    model = _student(arch, {"obs_mode": "proprio+rgbd", "image_size": 48})
    encoder = model.policy.features_extractor
    assert isinstance(encoder, PixelEncoder)
    assert encoder.image_keys == ["rgb", "rgb_depth"]
    assert encoder.depth_keys == ["rgb_depth"]
    assert encoder.features_dim == 2 * (2 * 8) + 3 + 25
    # Two scenes: 1 m and 2 m everywhere, but for one pixel of the second seeing nothing.
    depths = np.stack([np.full((48, 48, 1), 1.0), np.full((48, 48, 1), 2.0)]).astype(np.float32)
    depths[1, 0, 0, 0] = DEPTH_FAR
    encoder.fit_depth([depths])
    mean = np.full((48, 48), 1.5)
    mean[0, 0] = (1.0 + DEPTH_CLIP) / 2  # clamped before averaging
    np.testing.assert_allclose(encoder.depth_mean[0, 0].numpy(), mean, rtol=1e-6)
    residuals = np.minimum(depths[..., 0], DEPTH_CLIP) - mean
    scale = np.sqrt(np.mean(residuals**2))
    assert encoder.depth_scale.item() == pytest.approx(scale)
    far = th.full((1, 48, 48, 1), DEPTH_FAR)
    image = encoder._input("rgb_depth", far)
    assert image.shape == (1, 1, 48, 48)
    np.testing.assert_allclose(image[0, 0].numpy(), (DEPTH_CLIP - mean) / scale, rtol=1e-5)
    with pytest.raises(InvalidArgumentError, match="one array per depth key"):
        encoder.fit_depth([])
    # A colour student's weights have no depth entries: shipped students load as before.
    colour = _student(arch).policy.state_dict()
    assert not any("depth" in key for key in colour)


def test_depth_range_clips_what_differs_from_the_usual_scene(tmp_path: Path) -> None:
    """With ``depth_range`` the depth image's difference from the mean image is clipped to
    the range and divided by it (a 5 cm object and a 50 cm arm both reach the limit); the
    setting is part of the architecture, recorded with the model and rebuilt from it."""
    arch = student_architecture({**TINY["student"], "depth_range": 0.05})
    assert arch["depth_range"] == 0.05
    assert "depth_range" not in student_architecture(TINY["student"])  # records as before
    model = _student(arch, DEPTH)
    encoder = model.policy.features_extractor
    assert isinstance(encoder, PixelEncoder) and encoder.depth_range == 0.05
    encoder.fit_depth([np.full((2, 48, 48, 1), 1.5, dtype=np.float32)])
    scene = th.full((1, 48, 48, 1), 1.5)
    scene[0, 0, 0, 0], scene[0, 1, 1, 0], scene[0, 2, 2, 0] = 1.47, 1.0, DEPTH_FAR
    image = encoder._input("rgb_depth", scene)[0, 0].numpy()
    assert image[0, 0] == pytest.approx(-0.6, rel=1e-4)  # 3 cm nearer
    assert (image[1, 1], image[2, 2], image[3, 3]) == (-1.0, 1.0, 0.0)
    run = {"env_id": ENV_ID, "env_kwargs": DEPTH, "student": arch}
    save_model(model, tmp_path / "model.zip", run)
    student = load_student(tmp_path / "model.zip")
    assert student.policy.features_extractor.depth_range == 0.05
    obs = make_vec_env(ENV_ID, n_envs=2, seed=5, **DEPTH).reset()
    ours, _ = student.predict(obs, deterministic=True)
    theirs, _ = model.predict(obs, deterministic=True)
    np.testing.assert_array_equal(ours, theirs)


def test_a_depth_student_learns_and_loads_by_data(tmp_path: Path) -> None:
    """Depth alone (no colour): 24 episodes take the student's prediction of the expert's
    actions in unseen states well under the best constant action's error, and its file
    rebuilds the same policy by data."""
    data, _ = collect_student(env_config(ENV_ID), DEPTH, 2, first_seed=7, num_envs=2)
    assert data.observations["rgb_depth"].shape == (len(data), 48, 48, 1)
    assert data.observations["rgb_depth"].dtype == np.float32
    arch = student_architecture({"channels": [8, 16, 8], "strides": [2, 2, 1]})
    model = _student(arch, DEPTH)
    _assert_dagger_learns(model, DEPTH)
    mean = model.policy.features_extractor.depth_mean.numpy()
    assert 1.0 < mean.min() <= mean.max() <= DEPTH_CLIP  # fitted to the scene's depths
    run = {"env_id": ENV_ID, "env_kwargs": DEPTH, "student": arch}
    save_model(model, tmp_path / "model.zip", run)
    student = load_student(tmp_path / "model.zip")
    assert student.observation == DEPTH
    obs = make_vec_env(ENV_ID, n_envs=3, seed=5, **DEPTH).reset()
    ours, _ = student.predict(obs, deterministic=True)
    theirs, _ = model.predict(obs, deterministic=True)
    np.testing.assert_array_equal(ours, theirs)


def test_train_writes_a_student_that_loads_by_data(tiny_run: Path) -> None:
    run = json.loads((tiny_run / "run.json").read_text())
    assert run["student"]["channels"] == [8, 16, 8]
    assert run["env_kwargs"] == RANDOMISED
    assert run["env_steps"] == 16 * 70
    lines = (tiny_run / "evaluations.jsonl").read_text().splitlines()
    assert len(lines) == 3  # after the first fit, the round and the final fit
    student = load_student(tiny_run / "model.zip")
    sb3 = PPO.load(tiny_run / "model.zip", device="cpu")
    env = make_vec_env(ENV_ID, n_envs=3, seed=5, **OBSERVATION)
    obs = env.reset()
    for _ in range(3):
        ours, _ = student.predict(obs, deterministic=True)
        theirs, _ = sb3.predict(obs, deterministic=True)
        np.testing.assert_array_equal(ours, theirs)
        obs, *_ = env.step(ours)
    env.close()


def test_a_student_is_evaluated_without_trusting_its_file(
    tiny_run: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    resolved = resolve_policy(tiny_run / "model.zip")
    # Trained under randomisation, evaluated on the plain scene unless asked.
    assert resolved.observation == OBSERVATION
    assert "obs_mode" not in resolved.config
    code = cli.main(["eval", "--policy", str(tiny_run / "model.zip"), "--episodes", "2", "--quiet"])
    assert code == 0
    assert "inference           torch-f32" in capsys.readouterr().out
    with pytest.raises(InvalidArgumentError, match="torch only"):
        resolve_policy(tiny_run / "model.zip", inference="native")


def test_the_robustness_table_evaluates_each_randomisation(tiny_run: Path) -> None:
    table, records = robustness_table([tiny_run / "model.zip"], episodes=3, progress=False)
    assert set(records) == {f"model.zip {c}" for c in ROBUSTNESS_CONDITIONS}
    assert "(proprio+rgb, trained under randomisation)" in table.splitlines()[0]
    assert len(table.splitlines()) == 2 + len(ROBUSTNESS_CONDITIONS)
    # The plain row is what `panda-rapier eval` reports on those seeds.
    plain = resolve_policy(tiny_run / "model.zip")
    report = evaluate(plain.policy, plain.config, 3, **plain.observation)
    assert records["model.zip off"]["success_by_episode"] == "".join(
        "1" if e.success else "0" for e in report.episodes
    )
    assert records["model.zip off"]["mean_return"] == report.summary()["mean_return"]

    # Each randomisation changes what the student sees, and so what it does.
    def first_actions(**observation: Any) -> np.ndarray:
        seen: list[np.ndarray] = []
        evaluate(
            plain.policy, plain.config, 1, on_step=lambda _o, a, *_: seen.append(a.copy()),
            **observation,
        )  # fmt: skip
        return np.concatenate(seen[:3])

    plain_actions = first_actions(**plain.observation)
    for condition in ROBUSTNESS_CONDITIONS[1:]:
        randomised = {**plain.observation, "visual_randomization": randomization_of(condition)}
        assert not np.array_equal(first_actions(**randomised), plain_actions), condition


def test_visual_randomization_in_eval_names_what_it_randomises(
    tiny_run: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert randomization_of("off") is None
    only_light = randomization_of("light")
    assert only_light is not None
    assert {k for k, v in only_light.items() if v and k != "seed"} == {
        "light_direction",
        "light_intensity",
    }
    with pytest.raises(ConfigError, match="unknown visual randomisation"):
        randomization_of("fog")
    args = ["eval", "--policy", str(tiny_run / "model.zip"), "--episodes", "2", "--quiet"]
    assert cli.main([*args, "--visual-randomization", "noise"]) == 0
    assert "visual randomisation noise" in capsys.readouterr().out
    # A policy that reads the state sees no pictures to randomise.
    assert cli.main(["eval", "--policy", "scripted", "--visual-randomization", "all"]) == 2
    assert "needs a policy that sees images" in capsys.readouterr().err


def test_a_damaged_or_foreign_student_file_is_refused(tiny_run: Path, tmp_path: Path) -> None:
    with pytest.raises(InvalidArgumentError, match="not a student"):
        load_student(REPO / "models" / "bc-dagger-Reach-v0.zip")
    # The record says one architecture, the weights are of another.
    import zipfile

    damaged = tmp_path / "model.zip"
    with zipfile.ZipFile(tiny_run / "model.zip") as source, zipfile.ZipFile(damaged, "w") as out:
        for item in source.namelist():
            content = source.read(item)
            if item == "panda_rapier_run.json":
                run = json.loads(content)
                run["student"]["channels"] = [8, 16, 4]
                content = json.dumps(run).encode()
            out.writestr(item, content)
    with pytest.raises(InvalidArgumentError, match="unfit"):
        load_student(damaged)


#: A PPO fine-tune of the tiny student on the dense reward, cut to seconds (the shipped recipe
#: is models/recipes/ppo-student-finetune.yml).
FINETUNE = {
    "n_envs": 4,
    "n_steps": 16,
    "batch_size": 32,
    "n_epochs": 1,
    "learning_rate": 1e-3,
    "policy_kwargs": "dict(log_std_init=-2.0, share_features_extractor=False)",
    "callback": [{"panda_rapier.learning.finetune.CriticWarmup": {"steps": 128}}],
}


def test_ppo_fine_tunes_a_student_from_its_file(tiny_run: Path, tmp_path: Path) -> None:
    dense = "panda_rapier/PickAndPlaceDense-v0"
    recipe = tmp_path / "ppo.yml"
    recipe.write_text(json.dumps({dense: FINETUNE}))
    common: dict[str, Any] = {"conf": recipe, "eval_every": 64, "eval_episodes": 2,
                              "progress": False, "say": lambda _: None}  # fmt: skip

    # Warm-up only: the actor, its encoder included, is the student's to the bit; the value
    # function has its own copy of the encoder (the recipe's share_features_extractor).
    warm = train("ppo", dense, tmp_path / "warm", timesteps=64, init_from=tiny_run / "model.zip",
                 **common)  # fmt: skip
    student_arch = json.loads((tiny_run / "run.json").read_text())["student"]
    assert warm["student"] == {**student_arch, "share_features_extractor": False}
    assert warm["env_kwargs"] == RANDOMISED  # it sees what the student saw
    source, tuned = load_student(tiny_run / "model.zip"), load_student(tmp_path / "warm/model.zip")
    env = make_vec_env(dense, n_envs=3, seed=7, **OBSERVATION)
    obs = env.reset()
    np.testing.assert_array_equal(source.predict(obs)[0], tuned.predict(obs)[0])
    values = [m.policy.predict_values(m.policy.obs_to_tensor(obs)[0]) for m in (source, tuned)]
    assert not th.equal(*values)  # the value function trained
    assert not tuned.policy.share_features_extractor
    pair = (tuned.policy.pi_features_extractor, tuned.policy.vf_features_extractor)
    encoders = [dict(m.named_parameters()) for m in pair]
    assert any(not th.equal(encoders[0][k], encoders[1][k]) for k in encoders[0])

    # Past the warm-up the actor trains; the run checkpoints and resumes like any PPO run.
    train("ppo", dense, tmp_path / "tuned", timesteps=128, init_from=tiny_run / "model.zip",
          checkpoint_every=64, **common)  # fmt: skip
    resumed = train("ppo", dense, tmp_path / "tuned", timesteps=192, resume=True, **common)
    assert resumed["env_steps"] == 192 and resumed["student"] == warm["student"]
    after = load_student(tmp_path / "tuned/model.zip")
    assert not np.array_equal(after.predict(obs)[0], source.predict(obs)[0])
    env.close()
    assert cli.main(["eval", "--policy", str(tmp_path / "tuned/model.zip"), "--episodes", "2",
                     "--quiet"]) == 0  # fmt: skip

    # The network is the student's: a recipe cannot give it another; only PPO fine-tunes it.
    recipe.write_text(json.dumps({dense: {**FINETUNE, "policy_kwargs": "dict(net_arch=[8])"}}))
    with pytest.raises(ConfigError, match="may set only"):
        train("ppo", dense, tmp_path / "c", timesteps=64, init_from=tiny_run / "model.zip",
              **common)  # fmt: skip
    with pytest.raises(InvalidArgumentError, match="fine-tuned with ppo"):
        train("sac", dense, tmp_path / "d", timesteps=64, init_from=tiny_run / "model.zip",
              conf=recipe, progress=False)  # fmt: skip


def test_image_runs_need_a_student_recipe(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="student recipe"):
        train("bc", ENV_ID, tmp_path / "a", env_kwargs=OBSERVATION, progress=False)
    recipe = tmp_path / "bc.yml"
    recipe.write_text(json.dumps({ENV_ID: {**TINY, "env_kwargs": {}}}))
    with pytest.raises(ConfigError, match="student recipe"):
        train("bc", ENV_ID, tmp_path / "b", conf=recipe, progress=False)


def test_the_student_view_example_draws_both_rows(tmp_path: Path) -> None:
    import subprocess
    import sys

    out = tmp_path / "view.png"
    command = [sys.executable, "student_view.py", "--policy",
               str(REPO / "models" / "student-PickAndPlace-v0.zip"), "--out", str(out),
               "--steps", "0", "3", "--size", "84"]  # fmt: skip
    done = subprocess.run(command, cwd=REPO / "examples", capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "172x172 written" in done.stdout  # two 84-pixel columns and two rows, 4-pixel gaps
    assert out.read_bytes().startswith(b"\x89PNG")
