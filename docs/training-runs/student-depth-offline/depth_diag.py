# The offline comparison of docs/training.md (2026-11-29, a student that sees depth), with the
# held-out error also split into the first 15 steps of each episode and the rest (second
# session, 2026-11-30). A lab record, not part of the package: run as
# python depth_diag.py TRAIN_EPISODES HELD_OUT UPDATES [NAME FILTER...]. output.txt: the first session's
# run (without the split); output-early.txt: the second's. With CLOSED=N in the environment, each
# fitted student then also drives N episodes itself (third session, 2026-11-30: output-closed.txt):
# its success, how near its hand comes to the cube, and its error against the expert's labels in
# its own states, by step.
"""Held-out action error of students on fixed expert data: colour against depth standardised
three ways (one mean and scale; a mean image and one scale; a mean image and a scale image)."""
import os, sys, time
import numpy as np, torch as th
from stable_baselines3 import PPO
from panda_rapier.agents import student_model as sm
from panda_rapier.agents.student_model import PixelEncoder, policy_kwargs, student_architecture, DEPTH_CLIP
from panda_rapier.learning.student import collect_student, fit_student, StudentData
from panda_rapier import _common
from panda_rapier.registration import env_config
from panda_rapier.sb3 import make_vec_env
th.set_num_threads(2)
ENV = "panda_rapier/PickAndPlace-v0"
config = env_config(ENV)
obs = {"obs_mode": "proprio+rgbd", "image_size": 84}
TRAIN, HELD, UPDATES = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
t = time.time()
train, _ = collect_student(config, obs, TRAIN, first_seed=0, num_envs=16)
held, _ = collect_student(config, obs, HELD, first_seed=10_000, num_envs=16)
print(f"data {len(train)} / {len(held)} rows, {time.time()-t:.0f} s", flush=True)

class Global(PixelEncoder):
    def __init__(self, *a, **k):
        super().__init__(*a, **k)
        if self.depth_keys:
            self.register_buffer("depth_mean", th.zeros(len(self.depth_keys)))
    def fit_depth(self, depths):
        c = np.minimum(depths[0].astype(np.float64), DEPTH_CLIP)
        self.depth_mean[0] = float(c.mean()); self.depth_scale[0] = max(float(c.std()), 0.01)

class PixelScale(PixelEncoder):
    FLOOR = 0.02
    def __init__(self, *a, **k):
        super().__init__(*a, **k)
        if self.depth_keys:
            h, w = self.depth_mean.shape[-2:]
            self.register_buffer("depth_scale", th.ones(len(self.depth_keys), 1, h, w))
    def fit_depth(self, depths):
        c = np.minimum(depths[0].astype(np.float64), DEPTH_CLIP)
        m = c.mean(axis=0); s = np.maximum(c.std(axis=0), self.FLOOR)
        self.depth_mean[0] = th.as_tensor(m.transpose(2, 0, 1)); self.depth_scale[0] = th.as_tensor(s.transpose(2, 0, 1))

def subset(data, keys):
    return StudentData({k: data.observations[k] for k in keys}, data.actions, data.episode_index, data.episode_seeds)

# Each held-out row's step within its episode (rows of an episode come in time order).
EARLY = 15
step_in_episode = np.zeros(len(held), dtype=np.int64)
seen: dict[int, int] = {}
for i, e in enumerate(held.episode_index):
    step_in_episode[i] = seen.get(int(e), 0)
    seen[int(e)] = step_in_episode[i] + 1
early = step_in_episode < EARLY
print(f"held-out rows in steps 0-{EARLY - 1}: {int(early.sum())} of {len(held)}", flush=True)
constant = float(np.mean((held.actions - held.actions.mean(axis=0)) ** 2))
print(f"constant action: {constant:.4f}", flush=True)
const_rows = np.mean((held.actions - held.actions.mean(axis=0)) ** 2, axis=1)
print(f"constant action, steps 0-{EARLY - 1}: {const_rows[early].mean():.4f}, later {const_rows[~early].mean():.4f}", flush=True)
variants = [("colour", "proprio+rgb", "rgb", PixelEncoder), ("depth, one mean and scale", "proprio+depth", "rgb_depth", Global),
            ("depth, mean image and one scale", "proprio+depth", "rgb_depth", PixelEncoder), ("depth, mean image and scale image", "proprio+depth", "rgb_depth", PixelScale)]
only = sys.argv[4:] 
for name, mode, image, cls in variants:
    if only and not any(o in name for o in only):
        continue
    keys = ["desired_goal", "proprioception", image]
    env = make_vec_env(ENV, n_envs=1, obs_mode=mode, image_size=84)
    kw = policy_kwargs(student_architecture(None)); kw["features_extractor_class"] = cls
    model = PPO("MultiInputPolicy", env, policy_kwargs=kw, seed=0, device="cpu")
    enc = model.policy.features_extractor
    enc.fit(np.concatenate([train.observations[k] for k in enc.vector_keys], axis=1))
    if enc.depth_keys:
        enc.fit_depth([train.observations["rgb_depth"]])
    t = time.time()
    tr, he = subset(train, keys), subset(held, keys)
    def loss(d, rows=None):
        out = []
        for i in range(0, len(d), 512):
            b = {k: th.as_tensor(v[i:i+512]) for k, v in d.observations.items()}
            with th.no_grad():
                out.append(model.policy.get_distribution(b).distribution.mean.numpy())
        err = np.mean((np.concatenate(out) - d.actions) ** 2, axis=1)
        return float(np.mean(err if rows is None else err[rows]))
    curve = []
    for chunk in range(4):
        fit_student(model, tr, updates=UPDATES // 4, batch_size=128, learning_rate=5e-4, seed=chunk)
        curve.append(f"{loss(he):.4f}")
    print(f"{name}: held-out MSE by quarter {curve}; train {loss(tr):.4f}; {time.time()-t:.0f} s", flush=True)
    print(f"{name}: held-out MSE, steps 0-{EARLY - 1} of each episode {loss(he, early):.4f}, the later steps {loss(he, ~early):.4f}", flush=True)
    closed = int(os.environ.get("CLOSED", "0"))
    if closed:
        own, stats = collect_student(config, {"obs_mode": mode, "image_size": 84}, closed, first_seed=20_000, actor=model, num_envs=16)
        schema = _common.Schema.of(_common.config_json(config))
        b = {k: th.as_tensor(v) for k, v in subset(own, keys).observations.items()}
        with th.no_grad():
            acted = np.concatenate([model.policy.get_distribution({k: v[i:i+512] for k, v in b.items()}).distribution.mean.numpy() for i in range(0, len(own), 512)])
        err = np.mean((acted - own.actions) ** 2, axis=1)
        step = np.zeros(len(own), dtype=np.int64); seen2: dict[int, int] = {}
        for i, e in enumerate(own.episode_index):
            step[i] = seen2.get(int(e), 0); seen2[int(e)] = step[i] + 1
        buckets = [(0, 5), (5, 10), (10, 15), (15, 25), (25, 40), (40, 70)]
        by = ", ".join(f"{a}-{z - 1}: {err[(step >= a) & (step < z)].mean():.4f}" for a, z in buckets if ((step >= a) & (step < z)).any())
        print(f"{name}: drove {closed} episodes: success {stats.success_rate:.3f}, placed {stats.placed_rate:.3f}; its error against the expert in its own states by step {by}", flush=True)
        # The expert's action's first three entries move the hand; how far the student's hand
        # command points away from the expert's, per episode, at the first step it errs by > 0.05.
        first_bad = []
        for e in np.unique(own.episode_index):
            idx = np.flatnonzero(own.episode_index == e)
            bad = idx[err[idx] > 0.05]
            first_bad.append(int(step[bad[0]]) if len(bad) else -1)
        print(f"{name}: first step with an error over 0.05, per episode: {first_bad}", flush=True)
