"""Lab record (docs/training.md, 2026-11-30, the night session). Offline: does another encoding
of the orientations make Flip's expert easier to fit? The held-out action MSE (every tenth
episode held out) of a 3x256 MLP on the afternoon run's 440,000 expert-labelled rows
(runs/bc-Flip-phase/demonstrations.npz, all its DAgger rounds), per encoding:
`python offline_fit.py ENCODING EPOCHS` with ENCODING quat (the observation as it is), matrix
(the quaternions as rotation matrices), matrix+rel (and the cube's rotation to the goal),
invariant (the rotation to the goal and the cube's symmetric fourth-order tensor, the raw
quaternions dropped: CubeOrientationFeatures' features) or invariant-keepq (the same, the
observation's own cube quaternion kept, as CubeOrientationFeatures keeps it).
`python offline_fit.py matrix 5 phases` also splits the held-out error by the expert's phase
(offline_phases.log)."""
import sys, time
import numpy as np, torch
torch.set_num_threads(1)
torch.manual_seed(0)
d = np.load("runs/bc-Flip-phase/demonstrations.npz")
obs, act, ep = d["observations"].astype(np.float64), d["actions"], d["episode_index"]

def mat(q):  # x y z w -> 9
    x, y, z, w = q.T
    return np.stack([1-2*(y*y+z*z), 2*(x*y-z*w), 2*(x*z+y*w),
                     2*(x*y+z*w), 1-2*(x*x+z*z), 2*(y*z-x*w),
                     2*(x*z-y*w), 2*(y*z+x*w), 1-2*(x*x+y*y)], 1)

def rel(qa, qb):  # R_a^T R_b flattened
    A, B = mat(qa).reshape(-1, 3, 3), mat(qb).reshape(-1, 3, 3)
    return np.einsum("nji,njk->nik", A, B).reshape(-1, 9)

enc = sys.argv[1]
by_phase = len(sys.argv) > 3 and sys.argv[3] == "phases"
if by_phase:
    from panda_rapier.policy import ScriptedPolicy

    phases = np.array(ScriptedPolicy("panda_rapier/Flip-v0").phases(d["observations"]))
if enc == "quat":
    X = obs
elif enc == "matrix":
    keep = [i for i in range(49) if not (0 <= i < 8 or 36 <= i < 40)]
    X = np.concatenate([obs[:, keep], mat(obs[:, 0:4]), mat(obs[:, 4:8])], 1)
elif enc == "matrix+rel":
    keep = [i for i in range(49) if not (0 <= i < 8 or 36 <= i < 40)]
    X = np.concatenate([obs[:, keep], mat(obs[:, 0:4]), mat(obs[:, 4:8]), rel(obs[:, 0:4], obs[:, 4:8])], 1)
elif enc in ("invariant", "invariant-keepq"):
    keep = [i for i in range(49) if not (0 <= i < 8 or (enc == "invariant" and 36 <= i < 40))]
    Rq, Rg = mat(obs[:, 0:4]).reshape(-1, 3, 3), mat(obs[:, 4:8]).reshape(-1, 3, 3)
    D = np.einsum("nij,nkj->nik", Rg, Rq).reshape(-1, 9)  # R_g R_q^T
    idx = [(j, k, l, m) for j in range(3) for k in range(j, 3) for l in range(k, 3) for m in range(l, 3)]
    T = np.stack([np.einsum("ni,ni,ni,ni->n", Rq[:, j], Rq[:, k], Rq[:, l], Rq[:, m]) for j, k, l, m in idx], 1)
    X = np.concatenate([obs[:, keep], D, T], 1)
X = X.astype(np.float32)
test = ep % 10 == 0
mu, sd = X[~test].mean(0), X[~test].std(0) + 1e-6
X = (X - mu) / sd
Xtr, Ytr = torch.tensor(X[~test]), torch.tensor(act[~test])
Xte, Yte = torch.tensor(X[test]), torch.tensor(act[test])
net = torch.nn.Sequential(torch.nn.Linear(X.shape[1], 256), torch.nn.ReLU(), torch.nn.Linear(256, 256), torch.nn.ReLU(),
                          torch.nn.Linear(256, 256), torch.nn.ReLU(), torch.nn.Linear(256, 4), torch.nn.Tanh())
opt = torch.optim.Adam(net.parameters(), 1e-3)
t0 = time.time()
for epoch in range(int(sys.argv[2])):
    perm = torch.randperm(len(Xtr))
    for i in range(0, len(perm), 256):
        b = perm[i:i + 256]
        loss = ((net(Xtr[b]) - Ytr[b]) ** 2).mean()
        opt.zero_grad(); loss.backward(); opt.step()
    with torch.no_grad():
        e = ((net(Xte) - Yte) ** 2).mean(0)
    print(f"{enc} epoch {epoch} test mse {e.mean():.5f} per-dim {e.numpy().round(5)} {time.time()-t0:.0f}s", flush=True)

if by_phase:
    with torch.no_grad():
        err = ((net(Xte) - Yte) ** 2).sum(1).numpy()
    ph = phases[test]
    for p in sorted(set(ph)):
        m = ph == p
        print(f"{p:10s} rows {m.mean():.3f} mse-sum {err[m].mean():.4f} share-of-error {err[m].sum()/err.sum():.3f} action-var {Yte.numpy()[m].var(0).sum():.3f}")
