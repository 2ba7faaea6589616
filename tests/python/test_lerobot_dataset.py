"""LeRobot datasets (issue 61): the scripted expert's episodes written with LeRobot's writer,
read back with ``lerobot.datasets.LeRobotDataset`` (frames, actions and episode boundaries as
the environment produced them) and replayed exactly from their seeds and streams; bad input
is a typed error. LeRobot needs Python >= 3.12: ``scripts/test`` runs this file in its own
virtualenv with lerobot (the main suite, without it, checks the missing-extra error only).
Seeds: 7501 to 7599 are this file's."""

from __future__ import annotations

import importlib.util
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from panda_rapier.errors import ConfigError, InvalidArgumentError

HAS_LEROBOT = importlib.util.find_spec("lerobot") is not None
needs_lerobot = pytest.mark.skipif(not HAS_LEROBOT, reason="lerobot is not installed")

ENV_ID = "panda_rapier/PickAndPlace-v0"


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    from panda_rapier.learning.lerobot_dataset import record_lerobot
    from panda_rapier.pixels import DEFAULT_CAMERA

    root = tmp_path_factory.mktemp("lerobot") / "pick"
    summary = record_lerobot(
        ENV_ID,
        3,
        root,
        cameras={"front": DEFAULT_CAMERA},
        image_size=32,
        use_videos=False,
        num_envs=2,
        first_seed=7501,
    )
    return root, summary


@needs_lerobot
def test_a_dataset_reads_back_with_lerobot(recorded: tuple[Path, object]) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    root, summary = recorded
    meta = json.loads((root / "meta" / "panda_rapier.json").read_text())
    lengths = [e["length"] for e in meta["episodes"]]
    assert [e["seed"] for e in meta["episodes"]] == [7501, 7502, 7503]
    # Episodes 0 and 1 start together on environments 0 and 1; episode 2 on whichever ends first.
    assert [e["env_index"] for e in meta["episodes"]][:2] == [0, 1]
    assert summary.frames == sum(lengths)

    dataset = LeRobotDataset(summary.repo_id, root=root)
    assert dataset.fps == 25
    assert len(dataset) == sum(lengths)
    assert dataset.num_episodes == 3
    episode_index = np.array([int(dataset[i]["episode_index"]) for i in range(len(dataset))])
    assert np.array_equal(episode_index, np.repeat(np.arange(3), lengths))
    first = dataset[0]
    assert first["observation.state"].shape == (47,)
    assert first["action"].shape == (4,)
    assert first["task"].startswith("pick")
    image = first["observation.images.front"]
    assert tuple(image.shape) == (3, 32, 32)
    assert float(image.max()) > float(image.min())  # a picture, not a blank
    names = dataset.features["action"]["names"]
    assert names == ["dx", "dy", "dz", "gripper"]
    assert dataset.features["observation.state"]["names"][0] == "achieved_goal.0"


@needs_lerobot
def test_every_recorded_episode_replays_bit_for_bit(recorded: tuple[Path, object]) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    from panda_rapier.learning.lerobot_dataset import replay_lerobot_episode

    root, summary = recorded
    for k in range(3):
        dataset = LeRobotDataset(summary.repo_id, root=root, episodes=[k])
        states = np.stack(
            [np.asarray(dataset[i]["observation.state"]) for i in range(len(dataset))]
        )
        replay = replay_lerobot_episode(root, k)
        assert replay["observation.state"].shape == states.shape
        assert np.array_equal(replay["observation.state"], states), f"episode {k}"
    # The expert succeeded where the environment said so.
    meta = json.loads((root / "meta" / "panda_rapier.json").read_text())
    assert summary.success_rate == np.mean([e["success"] for e in meta["episodes"]])


@needs_lerobot
def test_bad_input_is_a_typed_error(recorded: tuple[Path, object], tmp_path: Path) -> None:
    from panda_rapier.learning.lerobot_dataset import record_lerobot, replay_lerobot_episode

    root, _ = recorded
    with pytest.raises(InvalidArgumentError, match="already exists"):
        record_lerobot(ENV_ID, 1, root)
    with pytest.raises(InvalidArgumentError, match="episodes"):
        record_lerobot(ENV_ID, 0, tmp_path / "none")
    with pytest.raises(ConfigError, match="unknown environment id"):
        record_lerobot("panda_rapier/Nothing-v0", 1, tmp_path / "none")
    with pytest.raises(InvalidArgumentError, match="episode_index"):
        replay_lerobot_episode(root, 3)


@needs_lerobot
def test_the_cli_writes_a_lerobot_dataset(tmp_path: Path) -> None:
    root = tmp_path / "reach"
    run = subprocess.run(
        [
            sys.executable,
            "-m",
            "panda_rapier.cli",
            "demos",
            "--format",
            "lerobot",
            "--root",
            str(root),
            "--env",
            "panda_rapier/ReachJoints-v0",
            "--episodes",
            "2",
            "--num-envs",
            "2",
            "--first-seed",
            "7510",
            "--quiet",
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert run.returncode == 0, run.stderr
    assert "recorded 2 episodes" in run.stdout
    meta = json.loads((root / "meta" / "panda_rapier.json").read_text())
    assert meta["env_id"] == "panda_rapier/ReachJoints-v0"
    assert (root / "meta" / "info.json").is_file()


def test_lerobot_options_need_the_lerobot_format(tmp_path: Path) -> None:
    run = subprocess.run(
        [
            sys.executable,
            "-m",
            "panda_rapier.cli",
            "demos",
            "--camera",
            "front",
            "--episodes",
            "1",
            "--quiet",
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert run.returncode != 0
    assert "--format lerobot" in run.stderr


@pytest.mark.skipif(HAS_LEROBOT, reason="lerobot is installed")
def test_without_lerobot_the_error_names_the_extra(tmp_path: Path) -> None:
    from panda_rapier.learning.lerobot_dataset import record_lerobot

    with pytest.raises(ImportError, match=r"panda-rapier\[lerobot\]"):
        record_lerobot(ENV_ID, 1, tmp_path / "x")
    # panda-rapier eval on a LeRobot policy's directory says the same (exit 2, no traceback).
    policy = tmp_path / "pretrained_model"
    policy.mkdir()
    for name in ("config.json", "model.safetensors"):
        (policy / name).write_text("{}")
    for name in ("policy_preprocessor.json", "policy_postprocessor.json"):
        (policy / name).write_text(json.dumps({"steps": []}))
    done = subprocess.run(
        [sys.executable, "-m", "panda_rapier.cli", "eval", "--policy", str(policy), "--env",
         ENV_ID, "--episodes", "1", "--quiet"],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert done.returncode == 2 and "panda-rapier[lerobot]" in done.stderr, done.stderr
    assert "Traceback" not in done.stderr


@needs_lerobot
def test_the_benchmark_env_has_lerobots_keys_and_reports_success() -> None:
    from panda_rapier import ScriptedPolicy
    from panda_rapier.learning.lerobot_env import LeRobotObservation, PandaRapierEnv

    env = LeRobotObservation("PickAndPlace-v0", cameras=["front"], image_size=32)
    assert env.task_description.startswith("pick")
    assert env._max_episode_steps == 70
    # LeRobot marks its resets with an option of its own; the environment ignores it.
    obs, info = env.reset(seed=7530, options={"lerobot_new_rollout": True})
    assert set(obs) == {"agent_pos", "pixels"}
    assert obs["agent_pos"].shape == (47,) and obs["agent_pos"].dtype == np.float32
    assert obs["pixels"]["front"].shape == (32, 32, 3)
    assert env.observation_space.contains(obs)
    expert = ScriptedPolicy("panda_rapier/PickAndPlace-v0")
    successes = []
    for _ in range(70):
        obs, _, terminated, truncated, info = env.step(expert.predict(obs["agent_pos"])[0])
        successes.append(bool(info["is_success"]))
        if terminated or truncated:
            break
    assert successes[-1], "the expert, acting on agent_pos, places the cube (seed 7530)"
    config = PandaRapierEnv(task="PickAndPlaceJoints-v0", cameras=["front"], image_size=32)
    assert config.type == "panda_rapier"
    assert config.features["action"].shape == (8,)
    assert config.features_map["pixels/front"] == "observation.images.front"
    vec = config.create_envs(2)["panda_rapier"][0]
    obs, _ = vec.reset(seed=7531)
    assert obs["agent_pos"].shape == (2, 47)
    vec.close()
    with pytest.raises(ConfigError, match=r"env\.task"):
        PandaRapierEnv(task="Nothing-v0")


def _train_tiny_act(root: Path, out: Path) -> Path:
    """A tiny ACT trained two steps by lerobot-train on the dataset at ``root``; returns its
    checkpoint's ``pretrained_model`` directory."""
    train = subprocess.run(
        [str(Path(sys.executable).parent / "lerobot-train"),
         "--dataset.repo_id=panda_rapier/PickAndPlace-expert",
         f"--dataset.root={root}", "--policy.type=act", "--policy.device=cpu",
         "--policy.push_to_hub=false", "--policy.pretrained_backbone_weights=null",
         "--policy.dim_model=32", "--policy.dim_feedforward=64", "--policy.n_heads=2",
         "--policy.n_encoder_layers=1", "--policy.n_decoder_layers=1", "--policy.use_vae=false",
         "--policy.chunk_size=5", "--policy.n_action_steps=5", "--steps=2", "--batch_size=2",
         f"--output_dir={out}", "--save_freq=2", "--wandb.enable=false", "--num_workers=0"],
        capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip
    assert train.returncode == 0, train.stderr[-3000:]
    return out / "checkpoints" / "last" / "pretrained_model"


@needs_lerobot
def test_lerobot_train_and_lerobot_eval_run_on_a_recorded_dataset(tmp_path: Path) -> None:
    """The documented commands: a tiny ACT trained two steps by lerobot-train on a dataset
    from panda-rapier demos, evaluated by lerobot-eval on --env.type=panda_rapier (the plugin
    lerobot_env_panda_rapier must be installed, as scripts/lerobot-tests does)."""
    from panda_rapier.learning.lerobot_dataset import record_lerobot
    from panda_rapier.pixels import DEFAULT_CAMERA

    root = tmp_path / "data"
    record_lerobot(ENV_ID, 2, root, cameras={"front": DEFAULT_CAMERA}, image_size=32,
                   num_envs=2, first_seed=7540)  # fmt: skip
    bin_dir = Path(sys.executable).parent
    policy = _train_tiny_act(root, tmp_path / "train")
    assert (policy / "model.safetensors").is_file()
    evaluation = subprocess.run(
        [str(bin_dir / "lerobot-eval"), f"--policy.path={policy}", "--env.type=panda_rapier",
         "--env.task=PickAndPlace-v0", "--env.cameras=[front]", "--env.image_size=32",
         "--eval.n_episodes=2", "--eval.batch_size=2", "--policy.device=cpu", "--seed=7550",
         f"--output_dir={tmp_path / 'eval'}"],
        capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip
    assert evaluation.returncode == 0, evaluation.stderr[-3000:]
    report = json.loads((tmp_path / "eval" / "eval_info.json").read_text())
    overall = report["overall"]
    assert overall["n_episodes"] == 2
    assert 0.0 <= overall["pc_success"] <= 100.0
    # The same policy acted out by panda-rapier eval (the id read from its dataset), on the
    # same seeds, from the same camera at the size the policy's input has.
    ours = subprocess.run(
        [sys.executable, "-m", "panda_rapier.cli", "eval", "--policy", str(policy),
         "--episodes", "2", "--num-envs", "2", "--seed", "7550", "--quiet",
         "--json", str(tmp_path / "ours.json")],
        capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip
    assert ours.returncode == 0, ours.stderr[-3000:]
    mine = json.loads((tmp_path / "ours.json").read_text())
    assert mine["episodes"] == 2 and mine["inference"] == "lerobot-torch-f32"
    assert [e["seed"] for e in mine["episode_records"]] == [7550, 7551]
    assert mine["environment"]["lerobot"] and mine["config"]["task"]["name"] == "pick_and_place"


@needs_lerobot
def test_the_documented_lerobot_examples_run(tmp_path: Path) -> None:
    """The guide's Python examples that use LeRobot (test_examples.py skips them where
    lerobot is not installed)."""
    page = Path(__file__).resolve().parents[2] / "docs" / "guide" / "demonstrations.md"
    blocks = [
        b
        for b in re.findall(r"```python\n(.*?)```", page.read_text(), flags=re.DOTALL)
        if "lerobot" in b
    ]
    assert blocks, "the Demonstrations guide has a LeRobot example"
    for i, block in enumerate(blocks):
        script = tmp_path / f"example{i}.py"
        script.write_text(block)
        run = subprocess.run(
            [sys.executable, script], cwd=tmp_path, capture_output=True, text=True,
            timeout=600, check=False,
        )  # fmt: skip
        assert run.returncode == 0, run.stderr[-3000:]


@needs_lerobot
def test_environment_state_splits_the_state_and_replays(tmp_path: Path) -> None:
    """With environment_state=True the objects' entries are observation.environment_state
    and the goals' and robot's observation.state: together exactly the flat observation, in
    the columns state_split names, and a replay reproduces both."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    from panda_rapier import _common
    from panda_rapier.learning.lerobot_dataset import (
        record_lerobot,
        replay_lerobot_episode,
        state_split,
    )
    from panda_rapier.registration import env_config

    root = tmp_path / "split"
    summary = record_lerobot(ENV_ID, 2, root, num_envs=2, first_seed=7560, environment_state=True)
    schema = _common.Schema.of(_common.config_json(env_config(ENV_ID)))
    state_columns, environment_columns = state_split(schema)
    assert sorted(state_columns + environment_columns) == list(range(schema.flat_dim))
    dataset = LeRobotDataset(summary.repo_id, root=root)
    state_names = dataset.features["observation.state"]["names"]
    environment_names = dataset.features["observation.environment_state"]["names"]
    assert state_names[:3] == ["achieved_goal.0", "achieved_goal.1", "achieved_goal.2"]
    assert "tcp_position.0" in state_names and "cube_position.0" not in state_names
    assert environment_names[0] == "cube_position.0"
    assert len(environment_names) == len(environment_columns) == 16
    for k in range(2):
        episode = LeRobotDataset(summary.repo_id, root=root, episodes=[k])
        replay = replay_lerobot_episode(root, k)
        for key in ("observation.state", "observation.environment_state"):
            recorded = np.stack([np.asarray(episode[i][key]) for i in range(len(episode))])
            assert np.array_equal(replay[key], recorded), f"episode {k}, {key}"
    with pytest.raises(ConfigError, match="environment_state"):
        record_lerobot("panda_rapier/Reach-v0", 1, tmp_path / "reach", environment_state=True)


@needs_lerobot
def test_a_state_only_act_trains_and_evaluates_with_environment_state(tmp_path: Path) -> None:
    """ACT refuses inputs without an image or an environment state: on a dataset recorded
    with --environment-state it trains from state alone, and lerobot-eval runs it on
    --env.environment_state=true, whose observations match the dataset's features."""
    from panda_rapier.learning.lerobot_env import LeRobotObservation, PandaRapierEnv

    root = tmp_path / "data"
    record = subprocess.run(
        [sys.executable, "-m", "panda_rapier.cli", "demos", "--env", ENV_ID, "--format",
         "lerobot", "--root", str(root), "--episodes", "2", "--num-envs", "2",
         "--first-seed", "7570", "--environment-state", "--quiet"],
        capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip
    assert record.returncode == 0, record.stderr[-3000:]
    config = PandaRapierEnv(task="PickAndPlace-v0", environment_state=True)
    assert config.features["agent_pos"].shape == (31,)
    assert config.features["environment_state"].shape == (16,)
    assert config.features_map["environment_state"] == "observation.environment_state"
    env = LeRobotObservation("PickAndPlace-v0", environment_state=True)
    obs, _ = env.reset(seed=7571)
    assert obs["agent_pos"].shape == (31,) and obs["environment_state"].shape == (16,)
    assert env.observation_space.contains(obs)
    env.close()

    bin_dir = Path(sys.executable).parent
    policy = _train_tiny_act(root, tmp_path / "train")
    # The guide's resume: from the last checkpoint's saved configuration, two more updates.
    resumed = subprocess.run(
        [str(bin_dir / "lerobot-train"), f"--config_path={policy / 'train_config.json'}",
         "--resume=true", "--steps=4"],
        capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip
    assert resumed.returncode == 0, resumed.stderr[-3000:]
    assert "Resuming" in resumed.stdout + resumed.stderr
    checkpoints = tmp_path / "train" / "checkpoints"
    assert (checkpoints / "last").resolve() == (checkpoints / "000004").resolve()
    policy = checkpoints / "last" / "pretrained_model"
    evaluation = subprocess.run(
        [str(bin_dir / "lerobot-eval"), f"--policy.path={policy}", "--env.type=panda_rapier",
         "--env.task=PickAndPlace-v0", "--env.environment_state=true", "--eval.n_episodes=2",
         "--eval.batch_size=2", "--policy.device=cpu", "--seed=7575",
         f"--output_dir={tmp_path / 'eval'}"],
        capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip
    assert evaluation.returncode == 0, evaluation.stderr[-3000:]
    report = json.loads((tmp_path / "eval" / "eval_info.json").read_text())
    assert report["overall"]["n_episodes"] == 2

    # panda-rapier eval acts it out too. Each environment has its own view of the policy (ACT's
    # queue of planned actions), reset when a new episode starts there, so an episode's actions
    # depend on neither the episodes beside it nor the one before. An episode also depends on
    # the environment's random stream (its env_index), so the episodes compared are those that
    # ran on environment 0 in both evaluations. 23 steps, not a multiple of the 5 actions ACT
    # plans at a time: a queue not reset would carry actions into the next episode; the dense
    # reward makes every step show in the return.
    from panda_rapier.agents.evaluation import evaluate
    from panda_rapier.agents.inference import resolve_policy

    resolved = resolve_policy(policy)
    assert resolved.env_id == ENV_ID  # read from the dataset the policy was trained on
    # The same with ACT's temporal ensembling (a new chunk every step, averaged with the earlier
    # ones' predictions for it): the ensembler, too, is each environment's own.
    ensembled = tmp_path / "ensembled"
    shutil.copytree(policy, ensembled)
    config = json.loads((ensembled / "config.json").read_text())
    config.update(n_action_steps=1, temporal_ensemble_coeff=0.01)
    (ensembled / "config.json").write_text(json.dumps(config))
    for saved in (policy, ensembled):
        dense = resolve_policy(
            saved, "panda_rapier/PickAndPlaceDense-v0", {"max_episode_steps": 23}
        )
        on_env_0 = []
        for num_envs in (1, 3):
            report = evaluate(dense.policy, dense.config, 7, num_envs=num_envs, first_seed=7576)
            assert report.inference == "lerobot-torch-f32"
            on_env_0.append({e.seed: e.episode_return for e in report.episodes if e.env_index == 0})
        assert len(on_env_0[1]) >= 2  # environment 0 ran a second episode with 3 environments
        assert {seed: on_env_0[0][seed] for seed in on_env_0[1]} == on_env_0[1]
        assert len(set(on_env_0[0].values())) > 1  # the episodes differ: the test can fail

    # Bad input: an environment whose observation does not fit the policy, a directory that is
    # no policy, a processor step named by a Python class path (which loading would import).
    with pytest.raises(ConfigError, match=r"observation\.state"):
        resolve_policy(policy, "panda_rapier/Stack-v0")
    with pytest.raises(InvalidArgumentError, match="not a LeRobot policy"):
        resolve_policy(tmp_path)
    hostile = tmp_path / "hostile"
    shutil.copytree(policy, hostile)
    pipeline = json.loads((hostile / "policy_preprocessor.json").read_text())
    step = pipeline["steps"][0]
    step["class"] = "os.system"
    del step["registry_name"]
    (hostile / "policy_preprocessor.json").write_text(json.dumps(pipeline))
    from panda_rapier.agents.model_file import UntrustedModelError

    with pytest.raises(UntrustedModelError, match="--trust-model-file"):
        resolve_policy(hostile)


MODELS = Path(__file__).resolve().parents[2] / "models"
#: The LeRobot policies shipped in models/ (directories; their records in evaluations.json).
SHIPPED = sorted(p.name for p in MODELS.iterdir() if (p / "panda_rapier_run.json").is_file())


@needs_lerobot
@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_lerobot_policy_reproduces_its_recorded_evaluation(name: str) -> None:
    """Each LeRobot policy in models/ evaluated as `panda-rapier eval --policy models/NAME`
    does (the environment from its run record, 32 environments, seeds from 0): where the
    recorded outcome fields match this machine's (package, CPU architecture, C library, torch
    and its kernels, LeRobot) the first 100 episodes repeat exactly; elsewhere, over the first
    300, the rates do not fall significantly below the recorded ones (check_reproduction)."""
    import os

    from panda_rapier.agents.evaluation import (
        OUTCOME_FIELDS,
        check_reproduction,
        evaluate,
        evaluation_environment,
    )
    from panda_rapier.agents.inference import resolve_policy
    from panda_rapier.agents.model_file import model_digest

    recorded = json.loads((MODELS / "evaluations.json").read_text())[name]
    assert recorded["model_sha256"] == model_digest(MODELS / name), f"{name} changed"
    # Loading the policy imports torch and lerobot, whose versions are outcome fields.
    resolved = resolve_policy(MODELS / name)
    here = evaluation_environment(recorded["inference"])
    fields = OUTCOME_FIELDS[recorded["inference"]]
    exact = all(recorded["environment"].get(k) == here.get(k) for k in fields)
    episodes = 100 if exact else int(os.environ.get("PANDA_RAPIER_REPRODUCTION_EPISODES", "300"))
    report = evaluate(resolved.policy, resolved.config, episodes, num_envs=32,
                      first_seed=0, **resolved.observation)  # fmt: skip
    assert report.inference == recorded["inference"] == "lerobot-torch-f32"
    check = check_reproduction(recorded, report)
    print(name, exact, check)
    assert check.passed, check


@needs_lerobot
def test_the_guides_commands_run_a_shipped_policy(tmp_path: Path) -> None:
    """The Demonstrations guide's commands on a shipped LeRobot policy run as written (on 10
    episodes, not 100): `panda-rapier eval` and `lerobot-eval` load the directory, its run
    record beside LeRobot's files."""
    import shlex

    page = (MODELS.parent / "docs" / "guide" / "demonstrations.md").read_text()
    block = next(b for b in re.findall(r"```sh\n(.*?)```", page, flags=re.DOTALL)
                 if "--policy models/lerobot-act" in b)  # fmt: skip
    commands = [shlex.split(c) for c in block.replace("\\\n", " ").splitlines()]
    bin_dir = Path(sys.executable).parent
    ran = 0
    for command in commands:
        if command[0] not in ("panda-rapier", "lerobot-eval"):
            continue
        command = [c.replace("=100", "=10") for c in command]
        if "--episodes" in command:
            command[command.index("--episodes") + 1] = "10"
        if command[0] == "lerobot-eval":
            command.append(f"--output_dir={tmp_path / 'eval'}")
        run = subprocess.run([str(bin_dir / command[0]), *command[1:]], cwd=MODELS.parent,
                             capture_output=True, text=True, timeout=600, check=False)  # fmt: skip
        assert run.returncode == 0, (command, run.stderr[-3000:])
        ran += 1
        if command[0] == "panda-rapier":
            assert "success at any step" in run.stdout, run.stdout
        else:
            assert "pc_success" in run.stdout + run.stderr
    assert ran == 2, commands
