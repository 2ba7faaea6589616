"""The native policy network (panda_rapier.agents.inference): the same actions as torch up to float
rounding, the same bits on every CPU capability, model files read without unpickling, and the
reproduction check that compares evaluations across machines."""

from __future__ import annotations

import base64
import io
import json
import os
import pickle
import platform
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import torch as th
from conftest import WritesAFile, hostile_payload, poisoned
from stable_baselines3 import PPO, SAC, TD3

from panda_rapier import InvalidArgumentError, _common
from panda_rapier.agents.evaluation import (
    OUTCOME_FIELDS,
    EpisodeRecord,
    EvaluationReport,
    check_reproduction,
    evaluate,
    evaluation_environment,
)
from panda_rapier.agents.inference import (
    NATIVE,
    TORCH,
    PolicyNetwork,
    UnsupportedModelError,
    UntrustedModelError,
    load_policy,
)
from panda_rapier.agents.model_file import (
    RUN_MEMBER,
    _load_weights,
    _rebuild_tensor,
    load_sb3_model,
    read_run_info,
)
from panda_rapier.agents.student_model import is_student
from panda_rapier.cli import main
from panda_rapier.learning.imitation import collect
from panda_rapier.learning.normalization import NormalizedFlatten, fit_normalizers
from panda_rapier.registration import env_config, variant
from panda_rapier.sb3 import make_vec_env

th.set_num_threads(1)

MODELS = Path(__file__).resolve().parents[2] / "models"
#: The shipped models the native network acts out: all but the students that see (torch).
SHIPPED = sorted(p.name for p in MODELS.glob("*.zip") if not is_student(read_run_info(p)))


def _states(name: str) -> np.ndarray:
    """Flat observations a model meets: its environment's expert episodes."""
    run = read_run_info(MODELS / name)
    assert run is not None
    demos, _ = collect(env_config(run["env_id"], **run["env_kwargs"]), 4, first_seed=123)
    return demos.observations


@pytest.mark.parametrize("name", SHIPPED)
def test_native_network_is_the_torch_policy_up_to_rounding(name: str) -> None:
    """The native float64 actions equal torch's float64 forward pass of the same weights to
    float32 rounding, and torch's float32 actions to its float32 error (PPO and cloned models
    as actor-critics, TQC's squashed Gaussian actor as SAC's)."""
    algo = str((read_run_info(MODELS / name) or {}).get("saved_algo") or "ppo")
    model = load_sb3_model(MODELS / name, algo=algo, trust=True)  # zips of 0.1: quietly
    native = PolicyNetwork.from_zip(MODELS / name)
    family = {"ppo": "actor-critic", "sac": "sac", "tqc": "sac"}[algo]
    assert native.algorithm == family and native.inference == NATIVE
    rows = _states(name)
    actions = native.act(rows)
    assert actions.dtype == np.float32 and actions.shape == (len(rows), native.action_dim)
    # Split by the model's own task layout (Stack's goals are 6-D).
    run = read_run_info(MODELS / name)
    schema = _common.Schema.of(_common.config_json(env_config(run["env_id"], **run["env_kwargs"])))
    obs = _common.split_observation(rows, schema)
    single, _ = model.predict(obs, deterministic=True)
    np.testing.assert_allclose(actions, single, atol=1e-4)
    # One policy, two ways in: a model in memory gives the same bits as its file.
    np.testing.assert_array_equal(PolicyNetwork.from_sb3(model).act(rows), actions)
    policy = model.policy.double()
    with th.no_grad():
        tensors = {k: th.as_tensor(v, dtype=th.float64) for k, v in obs.items()}
        double = policy._predict(tensors, deterministic=True).numpy()
    np.testing.assert_allclose(actions, np.clip(double, -1, 1), rtol=1e-6, atol=1e-7)
    # predict takes the goal dict, batched or single, like stable-baselines3's.
    np.testing.assert_array_equal(native.predict(obs)[0], actions)
    np.testing.assert_array_equal(native.predict({k: v[0] for k, v in obs.items()})[0], actions[0])


_DIGEST = r"""
import hashlib, sys
import numpy as np, torch
torch.set_num_threads(1)
from panda_rapier.agents.inference import PolicyNetwork
from stable_baselines3 import PPO
path, rows = sys.argv[1], np.load(sys.argv[2])
native = PolicyNetwork.from_zip(path).act(rows)
torch_actions = PPO.load(path, device="cpu").predict(
    {"achieved_goal": rows[:, :3], "desired_goal": rows[:, 3:6], "observation": rows[:, 6:]},
    deterministic=True)[0]
print(hashlib.sha256(native.tobytes()).hexdigest(), torch.backends.cpu.get_cpu_capability(),
      hashlib.sha256(np.asarray(torch_actions, np.float32).tobytes()).hexdigest())
"""


def test_native_actions_do_not_depend_on_torch_cpu_capability(tmp_path: Path) -> None:
    """Under every kernel path torch offers here (ATEN_CPU_CAPABILITY), the native actions are
    the same bits; torch's own may differ (not asserted: it depends on the CPU)."""
    name = "ppo-PickAndPlaceDense-v0.zip"
    np.save(tmp_path / "rows.npy", _states(name))
    seen = {}
    for capability in ("default", "avx2", None):
        env = {k: v for k, v in os.environ.items() if k != "ATEN_CPU_CAPABILITY"}
        if capability is not None:
            env["ATEN_CPU_CAPABILITY"] = capability
        out = subprocess.run(
            [sys.executable, "-c", _DIGEST, str(MODELS / name), str(tmp_path / "rows.npy")],
            env=env, capture_output=True, text=True, check=True,
        )  # fmt: skip
        native, used, torch_digest = out.stdout.split()
        seen[capability] = (native, used, torch_digest)
    assert len({native for native, _, _ in seen.values()}) == 1, seen
    assert seen["default"][1] == "DEFAULT", seen


def _tiny(algorithm, **kwargs):
    env = make_vec_env("panda_rapier/PickAndPlace-v0", n_envs=1, arm="kinematic")
    return algorithm("MultiInputPolicy", env, seed=0, device="cpu", **kwargs)


@pytest.mark.parametrize(
    ("algorithm", "kwargs", "family"),
    [
        (SAC, {"buffer_size": 64, "policy_kwargs": {"net_arch": [32, 16]}}, "sac"),
        (TD3, {"buffer_size": 64, "policy_kwargs": {"net_arch": [32]}}, "td3"),
        (PPO, {"n_steps": 8, "batch_size": 8, "policy_kwargs": {
            "features_extractor_class": NormalizedFlatten, "net_arch": [24, 24],
            "activation_fn": th.nn.Tanh, "share_features_extractor": False,
            "features_extractor_kwargs": {"clip": 3.0}}}, "actor-critic"),
    ],
)  # fmt: skip
def test_other_algorithms_and_options(tmp_path: Path, algorithm, kwargs, family) -> None:
    model = _tiny(algorithm, **kwargs)
    rows = _states("bc-dagger-PickAndPlace-v0.zip")
    if family == "actor-critic":
        fit_normalizers(model.policy, rows)
    model.save(tmp_path / "m.zip")
    native = PolicyNetwork.from_zip(tmp_path / "m.zip")
    assert native.algorithm == family
    obs = {k: v for k, v in zip(("achieved_goal", "desired_goal", "observation"),
                                np.split(rows, [3, 6], axis=1), strict=True)}  # fmt: skip
    expected, _ = model.predict(obs, deterministic=True)
    np.testing.assert_allclose(native.act(rows), expected, atol=1e-5)
    np.testing.assert_array_equal(PolicyNetwork.from_sb3(model).act(rows), native.act(rows))


def test_unsupported_models_fall_back_to_stable_baselines3(tmp_path: Path) -> None:
    model = _tiny(PPO, n_steps=8, batch_size=8,
                  policy_kwargs={"net_arch": [16], "activation_fn": th.nn.ELU})  # fmt: skip
    model.save(tmp_path / "elu.zip")
    with pytest.raises(UnsupportedModelError, match="ELU"):
        PolicyNetwork.from_zip(tmp_path / "elu.zip")
    with pytest.raises(UnsupportedModelError):
        PolicyNetwork.from_sb3(model)
    env_id = "panda_rapier/PickAndPlace-v0"
    with pytest.raises(UntrustedModelError, match=r"ELU.*trust-model-file"):
        load_policy(tmp_path / "elu.zip", env_id, {"arm": "kinematic"})
    policy, overrides, _, why = load_policy(
        tmp_path / "elu.zip", env_id, {"arm": "kinematic"}, trust=True
    )
    assert isinstance(policy, PPO) and "ELU" in str(why)
    assert overrides == {"arm": "kinematic", "control_mode": "ee"}
    with pytest.raises(UnsupportedModelError):
        load_policy(tmp_path / "elu.zip", env_id, {}, inference="native")
    config = env_config(env_id, arm="kinematic", max_episode_steps=5)
    assert evaluate(policy, config, 2).inference == TORCH
    with pytest.raises(InvalidArgumentError, match="not a stable-baselines3 model"):
        PolicyNetwork.from_zip(tmp_path / "missing.zip")


def test_a_her_model_loads_with_the_environment_its_record_names(tmp_path: Path) -> None:
    """stable-baselines3 needs an environment to load a model saved with HerReplayBuffer: the
    run record's id gives one; without a record the message says to pass ``env=``."""
    model = load_sb3_model(MODELS / "tqc-Reach-v0.zip", trust=True)
    assert type(model).__name__ == "TQC" and model.get_env().num_envs == 1
    bare = tmp_path / "bare.zip"
    with zipfile.ZipFile(MODELS / "tqc-Reach-v0.zip") as source, zipfile.ZipFile(bare, "w") as out:
        for item in source.infolist():
            if item.filename != RUN_MEMBER:
                out.writestr(item, source.read(item.filename))
    assert read_run_info(bare) is None
    with pytest.raises(InvalidArgumentError, match=r"HerReplayBuffer.*pass env="):
        load_sb3_model(bare, trust=True)
    loaded = load_sb3_model(bare, env=make_vec_env("panda_rapier/Reach-v0"), trust=True)
    assert type(loaded).__name__ == "TQC"


def test_a_model_file_is_read_without_unpickling(tmp_path: Path) -> None:
    """Every pickled entry of the data replaced by a payload that writes a file: the native
    network reads the file without running it (stable-baselines3's load would)."""
    marker = tmp_path / "ran"
    payload = hostile_payload(marker)
    source = MODELS / "bc-dagger-PickAndPlace-v0.zip"
    hostile = poisoned(source, tmp_path / "hostile.zip", payload)
    policy = PolicyNetwork.from_zip(hostile)
    assert not marker.exists()
    rows = _states("bc-dagger-PickAndPlace-v0.zip")[:5]
    np.testing.assert_array_equal(policy.act(rows), PolicyNetwork.from_zip(source).act(rows))
    # A hostile file the native network cannot act out: panda-rapier eval refuses it rather
    # than unpickling it.
    model = _tiny(PPO, n_steps=8, batch_size=8,
                  policy_kwargs={"net_arch": [16], "activation_fn": th.nn.ELU})  # fmt: skip
    model.save(tmp_path / "elu.zip")
    poisoned(tmp_path / "elu.zip", tmp_path / "hostile-elu.zip", payload)
    argv = ["eval", "--policy", str(tmp_path / "hostile-elu.zip"), "--episodes", "1", "--quiet"]
    assert main(argv) == 2
    assert not marker.exists()
    pickle.loads(base64.b64decode(payload)).close()  # the payload does work when unpickled
    assert marker.exists()


@pytest.mark.parametrize("name", SHIPPED)
def test_weights_are_read_without_torch_bit_for_bit(name: str) -> None:
    """The state dict the torch-free reader rebuilds is torch.load's, array for array."""
    raw = zipfile.ZipFile(MODELS / name).read("policy.pth")
    ours = _load_weights(raw)
    theirs = th.load(io.BytesIO(raw), map_location="cpu", weights_only=True)
    assert list(ours) == list(theirs)
    for key, tensor in theirs.items():
        assert ours[key].dtype == tensor.numpy().dtype and ours[key].shape == tensor.shape
        np.testing.assert_array_equal(ours[key], tensor.numpy())


def test_weights_reader_rebuilds_views_and_dtypes() -> None:
    base = th.arange(12.0).reshape(3, 4)
    tensors = {"transposed": base.t(), "offset": base[1:, 2:], "scalar": th.tensor(True),
               "empty": th.zeros(0, 3), "half": base.half(), "long": base.long()}  # fmt: skip
    buffer = io.BytesIO()
    th.save(tensors, buffer)
    ours = _load_weights(buffer.getvalue())
    for key, tensor in tensors.items():
        assert ours[key].dtype == tensor.numpy().dtype and ours[key].shape == tensor.shape, key
        np.testing.assert_array_equal(ours[key], tensor.numpy())


def _replaced(raw: bytes, suffix: str, content: bytes) -> bytes:
    """A copy of torch's zip serialisation ``raw`` with the entry ending in ``suffix`` replaced."""
    out = io.BytesIO()
    with zipfile.ZipFile(io.BytesIO(raw)) as archive, zipfile.ZipFile(out, "w") as copy:
        for item in archive.infolist():
            copy.writestr(item, content if item.filename.endswith(suffix) else archive.read(item))
    return out.getvalue()


def test_weights_that_name_a_callable_are_refused_unrun(tmp_path: Path) -> None:
    """A policy.pth whose pickle calls ``open`` (a file writer) is refused by name; nothing
    runs, and a damaged or overreaching tensor is a clear error, not a crash."""
    marker = tmp_path / "ran"
    buffer = io.BytesIO()
    th.save({"weight": WritesAFile(marker)}, buffer)
    with pytest.raises(UnsupportedModelError, match=r"names io\.open"):
        _load_weights(buffer.getvalue())
    assert not marker.exists()
    source = MODELS / "bc-dagger-PickAndPlace-v0.zip"
    hostile = tmp_path / "hostile-weights.zip"
    with zipfile.ZipFile(source) as archive, zipfile.ZipFile(hostile, "w") as out:
        for item in archive.infolist():
            raw = archive.read(item)
            if item.filename == "policy.pth":
                pickled = zipfile.ZipFile(io.BytesIO(buffer.getvalue())).read("archive/data.pkl")
                raw = _replaced(raw, "/data.pkl", pickled)
            out.writestr(item, raw)
    argv = ["eval", "--policy", str(hostile), "--episodes", "1", "--quiet"]
    assert main(argv) == 2
    assert not marker.exists()
    buffer = io.BytesIO()
    th.save({"weight": th.zeros(8)}, buffer)
    with pytest.raises(InvalidArgumentError, match="unreadable policy weights"):
        _load_weights(_replaced(buffer.getvalue(), "/data/0", b"\0" * 3))
    with pytest.raises(InvalidArgumentError, match="past its storage"):
        _rebuild_tensor(np.zeros(4, np.float32), 3, (2,), (1,), False)
    with pytest.raises(InvalidArgumentError, match="too large"):
        _rebuild_tensor(np.zeros(4, np.float32), 0, (1 << 20, 1 << 20), (0, 0), False)
    with pytest.raises(InvalidArgumentError, match="unreadable policy weights: File is not a zip"):
        _load_weights(b"not a zip")


def test_shipped_model_evaluates_without_torch(tmp_path: Path) -> None:
    """The base install (no torch, no stable-baselines3) evaluates a shipped model."""
    script = (
        "import sys; sys.modules['torch'] = None; sys.modules['stable_baselines3'] = None\n"
        "from panda_rapier.cli import main\n"
        f"raise SystemExit(main(['eval', '--policy', {str(MODELS / SHIPPED[0])!r}, "
        "'--episodes', '4', '--num-envs', '4', '--quiet']))\n"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          cwd=tmp_path, timeout=300)  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "native-f64" in done.stdout


def test_network_policy_refuses_bad_input() -> None:
    policy = PolicyNetwork.from_zip(MODELS / "bc-dagger-PickAndPlace-v0.zip")
    rows = np.zeros((2, policy.observation_dim), np.float32)
    rows[1, 3] = np.nan
    with pytest.raises(InvalidArgumentError, match="finite"):
        policy.act(rows)
    with pytest.raises(InvalidArgumentError, match="shape"):
        policy.act(np.zeros((2, 5), np.float32))
    with pytest.raises(InvalidArgumentError, match="deterministically"):
        policy.predict(rows[:1], deterministic=False)
    from panda_rapier import _native

    low, high = -np.ones(3, np.float32), np.ones(3, np.float32)
    weight = np.ones((3, 2), np.float32)
    with pytest.raises(InvalidArgumentError, match="bias"):
        _native.PolicyNetwork(2, [(weight, np.ones(2, np.float32))], "relu", "clip", low, high)
    with pytest.raises(InvalidArgumentError, match="activation"):
        _native.PolicyNetwork(2, [(weight, np.ones(3, np.float32))], "gelu", "clip", low, high)
    with pytest.raises(InvalidArgumentError, match="low < high"):
        _native.PolicyNetwork(2, [(weight, np.ones(3, np.float32))], "relu", "clip", high, low)


def _report(success: str, placed: str, environment: dict[str, str]) -> EvaluationReport:
    episodes = [
        EpisodeRecord(i, 0, 0.0, 70, s == "1", p == "1", None, None, False)
        for i, (s, p) in enumerate(zip(success, placed, strict=True))
    ]
    return EvaluationReport("p", {}, 0, 32, 1, 0, 1.0, episodes, 0, NATIVE, environment)


def test_check_reproduction_per_episode_and_statistical() -> None:
    rng = np.random.default_rng(0)
    recorded_success = "".join("1" if x else "0" for x in rng.random(1000) < 0.95)
    here = evaluation_environment(NATIVE)
    recorded = {"environment": here, "success_by_episode": recorded_success,
                "placed_by_episode": recorded_success}  # fmt: skip
    same = recorded_success[:300]
    check = check_reproduction(recorded, _report(same, same, here))
    assert check.kind == "per-episode" and check.passed, check
    # torch's capability is not an outcome field of the native network.
    other_kernels = {**here, "torch_cpu_capability": "something else"}
    assert check_reproduction(recorded, _report(same, same, other_kernels)).kind == "per-episode"
    flipped = ("0" if same[7] == "1" else "1").join((same[:7], same[8:]))
    check = check_reproduction(recorded, _report(flipped, same, here))
    assert not check.passed and "episode 7" in check.details
    # Another C library: the rates must hold, not the episodes.
    elsewhere = {**here, "libc": "glibc-0.0"}
    shuffled = "".join(rng.permutation(list(same)))
    check = check_reproduction(recorded, _report(shuffled, shuffled, elsewhere))
    assert check.kind == "statistical" and check.passed, check
    assert check.differing == {"libc": (here["libc"], "glibc-0.0")}
    # A real regression (0.95 -> 0.85) fails it.
    worse = "".join("1" if x else "0" for x in rng.random(300) < 0.85)
    check = check_reproduction(recorded, _report(worse, same, elsewhere))
    assert not check.passed and "success" in check.details, check


def test_cli_eval_reports_its_inference(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    model = str(MODELS / "bc-dagger-PickAndPlace-v0.zip")
    reports = {}
    for inference in ("auto", "torch"):
        out = tmp_path / f"{inference}.json"
        argv = ["eval", "--policy", model, "--episodes", "2", "--quiet", "--json", str(out),
                "--max-episode-steps", "10", "--inference", inference]  # fmt: skip
        if inference == "torch":
            assert main(argv) == 2  # unpickling the file takes consent
            argv.append("--trust-model-file")
        assert main(argv) == 0
        reports[inference] = json.loads(out.read_text())
    assert reports["auto"]["inference"] == NATIVE
    assert reports["torch"]["inference"] == TORCH
    assert reports["auto"]["environment"]["machine"]
    assert "inference           native-f64" in capsys.readouterr().out


def test_saved_network_round_trips_without_torch(tmp_path: Path) -> None:
    policy = PolicyNetwork.from_zip(MODELS / "ppo-PickAndPlaceDense-v0.zip")
    policy.save(tmp_path / "net.npz")
    back = PolicyNetwork.load(tmp_path / "net.npz")
    rows = _states("ppo-PickAndPlaceDense-v0.zip")
    np.testing.assert_array_equal(back.act(rows), policy.act(rows))
    assert back.algorithm == policy.algorithm and back.source == policy.source
    with pytest.raises(InvalidArgumentError, match="cannot read"):
        PolicyNetwork.load(MODELS / "README.md")


#: Emulated CPUs (qemu-user): AVX2 and FMA without AVX-512; SSE4.2 without AVX.
EMULATED_CPUS = ("Haswell-v4", "Nehalem")
#: Env steps per model under each emulated CPU (at least one episode): what is tested is that
#: each CPU-specific code path gives the same bits, and an episode of every model exercises
#: them (each model's recorded episodes are checked natively, test_benchmark.py). qemu's
#: speed depends on the host and the CPU it emulates: on an Intel Xeon host, its AVX2
#: emulation (Haswell) ran about 27 env-steps/s, and 4 episodes of each of 22 models took
#: 358 s of CI's budget; Nehalem's took 75 s. On the 2-core development machine Nehalem's 280
#: steps took 100 s (stop 72), the suite's slowest test, so it runs 140 (one or two episodes).
EMULATED_STEPS = {"Haswell-v4": 70, "Nehalem": 140}
#: The OpenBLAS kernels (numpy's BLAS) each emulated CPU runs: the ones OpenBLAS picks on that
#: CPU itself. Left to detect the CPU under qemu 7.2 (Debian 12), OpenBLAS picked a kernel
#: Nehalem cannot run and `import numpy` died of an illegal instruction (2026-12-02, numpy
#: 2.2.6 to 2.4.6 alike).
OPENBLAS_CORETYPES = {"Haswell-v4": "Haswell", "Nehalem": "Nehalem"}


#: The models the emulated CPUs run: every shipped one but those whose task loads an object set
#: (PickObject: reading ten meshes and planning their grasps takes about 4 s natively and
#: minutes under qemu, which tripled these tests' time; the physics, maths routines and
#: network they would exercise are those of the other models). Caching the grasp plans on
#: disk with the decompositions would let them back in.
def _task(name: str) -> str:
    run = read_run_info(MODELS / name)
    assert run is not None
    return str(variant(run["env_id"])["task"])


EMULATED = [name for name in SHIPPED if _task(name) != "pick_object"]

_EMULATED = r"""
import json, sys
from pathlib import Path
from panda_rapier.agents.evaluation import check_reproduction, evaluate
from panda_rapier.agents.inference import PolicyNetwork
folder = Path(sys.argv[1])
recorded = json.loads(Path(sys.argv[2]).read_text())
results = {}
for npz in sorted(folder.glob("*.npz")):
    config = json.loads(npz.with_suffix(".json").read_text())
    episodes = max(1, int(sys.argv[3]) // config["max_episode_steps"])
    report = evaluate(PolicyNetwork.load(npz), config, episodes, num_envs=episodes)
    check = check_reproduction(recorded[npz.stem + ".zip"], report)
    results[npz.stem] = [check.kind, check.passed, check.details]
assert "torch" not in sys.modules
print(json.dumps(results))
"""


@pytest.mark.skipif(
    platform.machine() != "x86_64" or shutil.which("qemu-x86_64") is None,
    reason="needs qemu-user on x86-64 (scripts/test installs it)",
)
@pytest.mark.parametrize("cpu", EMULATED_CPUS)
def test_emulated_cpus_repeat_every_shipped_episode(tmp_path: Path, cpu: str) -> None:
    """Under qemu emulating a CPU without AVX-512 (Haswell) and one without AVX (Nehalem), the
    physics, glibc's maths routines and the native network pick their CPU-specific code for
    that CPU; every shipped model's first episodes (EMULATED_STEPS env steps' worth; the
    models of EMULATED) must still repeat exactly. (The weights
    go through PolicyNetwork.save, so the emulated process never imports torch.)"""
    for name in EMULATED:
        PolicyNetwork.from_zip(MODELS / name).save(tmp_path / f"{Path(name).stem}.npz")
        run = read_run_info(MODELS / name)
        assert run is not None
        config = env_config(run["env_id"], **run["env_kwargs"])
        (tmp_path / f"{Path(name).stem}.json").write_text(json.dumps(config))
    command = ["qemu-x86_64", "-cpu", cpu, sys.executable, "-c", _EMULATED, str(tmp_path),
               str(MODELS / "evaluations.json"), str(EMULATED_STEPS[cpu])]  # fmt: skip
    env = {**os.environ, "OPENBLAS_CORETYPE": OPENBLAS_CORETYPES[cpu]}
    out = subprocess.run(command, capture_output=True, text=True, timeout=540, env=env)
    assert out.returncode == 0, out.stderr[-2000:]
    results = json.loads(out.stdout.strip().splitlines()[-1])
    assert len(results) == len(EMULATED)
    recorded = json.loads((MODELS / "evaluations.json").read_text())
    here = evaluation_environment(NATIVE)
    for name, (kind, passed, details) in results.items():
        environment = recorded[f"{name}.zip"]["environment"]
        same = all(environment.get(k) == here.get(k) for k in OUTCOME_FIELDS[NATIVE])
        # Where the recorded C library matches this machine's, the episodes must repeat.
        assert kind == ("per-episode" if same else "statistical") and passed, (name, details)
