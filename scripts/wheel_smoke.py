"""What a user who installed the wheel (no Rust, no extras) does first, as a check: every
environment id made and stepped, a vector env, the scripted expert solving an episode, and
``panda-rapier eval`` of a shipped model. Run by ``scripts/wheel --test`` from outside the
source tree with the wheel's virtualenv; argument: the repository's ``models`` folder."""

from __future__ import annotations

import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import gymnasium as gym
import numpy as np

import panda_rapier

models = Path(sys.argv[1])
site = Path(sysconfig.get_paths()["purelib"])
assert Path(panda_rapier.__file__).is_relative_to(site), f"not the wheel: {panda_rapier.__file__}"
assert shutil.which("cargo") is None and shutil.which("rustc") is None, "Rust is on PATH"
native = next(Path(panda_rapier.__file__).parent.glob("_native*.so"))
assert native.name == "_native.abi3.so", native.name

for env_id in panda_rapier.ENV_IDS:
    env = gym.make(env_id)
    env.reset(seed=0)
    for _ in range(3):
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
    assert np.isfinite(obs["observation"]).all(), env_id
    env.close()

envs = gym.make_vec(
    "panda_rapier/PickAndPlaceJoints-v0", num_envs=4, vectorization_mode="vector_entry_point"
)
envs.reset(seed=0)
obs, rewards, terminated, truncated, info = envs.step(envs.action_space.sample())
assert obs["observation"].shape[0] == 4 and rewards.shape == (4,)
envs.close()

env = gym.make("panda_rapier/PickAndPlace-v0")
policy = panda_rapier.ScriptedPolicy(env)
obs, info = env.reset(seed=1)
done = False
while not done:
    obs, reward, terminated, truncated, info = env.step(policy(obs))
    done = terminated or truncated
assert info["is_success"], "the scripted expert did not place the cube on seed 1"
env.close()

model = models / "bc-dagger-PickAndPlace-v0.zip"
done = subprocess.run(
    ["panda-rapier", "eval", "--policy", str(model), "--episodes", "8", "--num-envs", "4"],
    capture_output=True,
    text=True,
    check=False,
)
assert done.returncode == 0, done.stderr
assert "native-f64" in done.stdout, done.stdout
assert "torch" not in sys.modules
print(
    f"wheel smoke test passed: panda_rapier {panda_rapier.__version__} on Python "
    f"{sys.version.split()[0]}; {len(panda_rapier.ENV_IDS)} ids stepped, vector env, scripted "
    f"expert, panda-rapier eval of {model.name} without torch"
)
print("\n".join(line for line in done.stdout.splitlines() if "success" in line))
