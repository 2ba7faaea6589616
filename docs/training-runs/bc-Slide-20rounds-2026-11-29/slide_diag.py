# Lab record, not part of the package (docs/training.md, 2026-11-29): where the 20-round Slide clone misses.
# Run as: python slide_diag.py runs/bc-Slide-a/model.zip panda_rapier/Slide-v0 200
"""Where a cloned Slide policy misses: per episode, the step the learner lets go against the
step the expert would (first label > 0 while gripping), the cube's end distance."""
import sys
import numpy as np, torch as th
from stable_baselines3 import PPO
from panda_rapier import ScriptedPolicy, _common
from panda_rapier.agents.evaluation import evaluate
from panda_rapier.registration import env_config
th.set_num_threads(1)
model_path, env_id, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
config = env_config(env_id)
schema = _common.Schema.of(_common.config_json(config))
print([s["name"] for s in schema.slots])
expert = ScriptedPolicy(config)
model = PPO.load(model_path, device="cpu")
ach, des, vel = schema.slot("cube_position"), schema.slot("desired_goal") if False else None, schema.slot("cube_linear_velocity")
rows = {}  # seed-slot -> list of (learner grip, expert grip, speed, dist)
def hook(flat, actions, running):
    labels = expert._native.act(flat)
    for i, r in enumerate(running):
        if r is None: continue
        rows.setdefault(r, []).append((actions[i, -1], labels[i, -1], np.linalg.norm(flat[i, vel][:2]), flat[i]))
report = evaluate(model, config, n, first_seed=500_000_000, on_step=hook, num_envs=32)
print("success", report.success_rate)
by_seed={e.seed: e for e in report.episodes}
# let-go step analysis
diffs=[]; 
for k, ep in sorted(rows.items()):
    lg = [a for a,_,_,_ in ep]; lab=[b for _,b,_,_ in ep]
    # first step where learner opens after having closed
    def first_open(seq):
        closed=False
        for t,g in enumerate(seq):
            if g < -0.5: closed=True
            elif closed and g > 0: return t
        return None
    fl, fe = first_open(lg), first_open(lab)
    diffs.append((k, fl, fe, by_seed[500_000_000+k].success))
import collections
print(collections.Counter([(None if a is None or b is None else int(np.clip(a-b,-3,3)), s) for _,a,b,s in diffs]))
ach_s, des_s = schema.slot("achieved_goal"), schema.slot("desired_goal")
tcp_s = schema.slot("tcp_position")
for k, fl, fe, s in diffs:
    if s: continue
    ep = rows[k]
    f0 = ep[0][3]; fN = ep[-1][3]
    start, goal, end = f0[ach_s], f0[des_s], fN[ach_s]
    line = (goal - start)[:2]; u = line/np.linalg.norm(line); left = np.array([-u[1], u[0]])
    e = (end - goal)[:2]
    print(f"k={k} letgo learner {fl} expert {fe} len {len(ep)} start-goal {np.linalg.norm(line):.3f} along {e@u:+.3f} side {e@left:+.3f} end speed {ep[-1][2]:.3f} maxtcpx {max(r[3][tcp_s][0] for r in ep):.3f}")
