"""Soak test: millions of environment steps through the stable-baselines3 VecEnv, watching
memory and speed.

    python examples/soak.py --steps 10000000 --n-envs 64 --out runs/soak
    python examples/soak.py --env-id family --arm dynamic kinematic --n-envs 16   # every task

Steps random actions (and autoresets) without pause, on one id or on the whole family
(``family``: every task in both action modes), on one arm model or both: one SB3 VecEnv of
``--n-envs`` environments per id and arm, all alive at once and stepped in turn. Every
``--every`` environment steps it records the process's resident memory and the steps per
second since the last sample. At the end it prints the table and the memory growth after
warm-up (the first sample): a leak shows as steady growth, a healthy run as a flat line.
Writes ``soak.json`` and, with matplotlib installed, ``soak.png`` (memory and speed over
steps) to ``--out``. The JSON is rewritten at every sample and Ctrl-C ends the run with its
report, so an interrupted run keeps its figures (``complete`` says whether all steps ran).
The plot is drawn only at the end: importing matplotlib mid-run adds about 35 MiB, which
would read as a leak.
"""

from __future__ import annotations

import argparse
import json
import resource
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

import panda_rapier
from panda_rapier.sb3 import make_vec_env


def rss_mib() -> float:
    """Current resident set size (MiB), from /proc (Linux); falls back to the peak."""
    try:
        pages = int(Path("/proc/self/statm").read_text().split()[1])
        return pages * resource.getpagesize() / 2**20
    except (OSError, IndexError, ValueError):
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def growth_after_warmup(samples: list[dict[str, float]]) -> float:
    """Peak resident memory over the first sample's, minus one (the first sample is taken after
    ``--every`` steps, when allocators and caches have warmed up)."""
    base = samples[0]["rss_mib"]
    return (max(s["rss_mib"] for s in samples) - base) / base


def write_json(out: Path, report: dict[str, object]) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / "soak.json").write_text(json.dumps(report, indent=2))


def plot(out: Path, report: dict[str, object], samples: list[dict[str, float]]) -> None:
    """soak.png: memory and speed over steps (needs matplotlib)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
    steps = [s["env_steps"] / 1e6 for s in samples]
    fig, (memory, speed) = plt.subplots(2, 1, sharex=True, figsize=(7, 5))
    memory.plot(steps, [s["rss_mib"] for s in samples], marker=".")
    memory.set_ylabel("resident memory (MiB)")
    speed.plot(steps, [s["env_steps_per_s"] for s in samples], marker=".")
    speed.set_ylabel("env-steps/s")
    speed.set_xlabel("million environment steps")
    what = report["env_id"] if len(report["env_ids"]) == 1 else f"{len(report['env_ids'])} ids"
    arms = " and ".join(report["arms"])
    fig.suptitle(f"soak: {what}, {report['n_envs']} envs each, {arms} arm")
    fig.tight_layout()
    fig.savefig(out / "soak.png", dpi=100)
    plt.close(fig)


#: ``--env-id family``: every task in both action modes (the sparse ids; the dense ones step
#: the same physics).
FAMILY = "family"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env-id", nargs="+", default=["panda_rapier/PickAndPlace-v0"],
                        help=f"ids, or {FAMILY!r} for every task in both action modes")  # fmt: skip
    parser.add_argument("--steps", type=int, default=10_000_000, help="environment steps")
    parser.add_argument("--n-envs", type=int, default=64, help="environments per id and arm")
    parser.add_argument("--every", type=int, default=250_000, help="sample period (env steps)")
    parser.add_argument("--arm", nargs="+", choices=("dynamic", "kinematic"), default=["dynamic"])
    parser.add_argument("--out", type=Path, default=Path("runs/soak"))
    parser.add_argument("--no-progress", action="store_true")
    args = parser.parse_args()

    ids = args.env_id
    if ids == [FAMILY]:
        ids = [i for i in panda_rapier.ENV_IDS if not i.endswith("Dense-v0")]
    pairs = [(env_id, arm) for env_id in ids for arm in args.arm]
    venvs = [make_vec_env(i, n_envs=args.n_envs, seed=k, arm=a) for k, (i, a) in enumerate(pairs)]
    rng = np.random.default_rng(0)
    pools = {}
    for venv in venvs:
        venv.reset()
        shape = venv.action_space.shape
        if shape not in pools:
            pools[shape] = rng.uniform(-1, 1, (256, args.n_envs, *shape)).astype(np.float32)
    samples: list[dict[str, float]] = []
    report: dict[str, object] = {}
    episodes = unstable = 0
    per_pair = {f"{i} ({a})": {"episodes": 0, "physics_unstable": 0} for i, a in pairs}
    done = last_done = rounds = 0
    last_time = start = time.perf_counter()
    bar = tqdm(total=args.steps, unit="step", unit_scale=True, disable=args.no_progress)
    try:
        while done < args.steps:
            k = rounds % len(venvs)
            venv = venvs[k]
            pool = pools[venv.action_space.shape]
            _, rewards, dones, infos = venv.step(pool[(rounds // len(venvs)) % len(pool)])
            rounds += 1
            if not np.isfinite(rewards).all():
                raise SystemExit(f"a reward is not finite ({pairs[k]})")
            if dones.any():
                ended = np.flatnonzero(dones)
                blown = sum(bool(infos[i]["physics_unstable"]) for i in ended)
                episodes += len(ended)
                unstable += blown
                tally = per_pair[f"{pairs[k][0]} ({pairs[k][1]})"]
                tally["episodes"] += len(ended)
                tally["physics_unstable"] += blown
            done += args.n_envs
            bar.update(args.n_envs)
            if done - last_done >= args.every or done >= args.steps:
                now = time.perf_counter()
                samples.append(
                    {
                        "env_steps": done,
                        "rss_mib": rss_mib(),
                        "env_steps_per_s": (done - last_done) / (now - last_time),
                        "elapsed_s": now - start,
                    }
                )
                report = {
                    "env_id": ids[0],
                    "env_ids": ids,
                    "arm": args.arm[0],
                    "arms": args.arm,
                    "n_envs": args.n_envs,
                    "steps_requested": args.steps,
                    "env_steps": done,
                    "complete": done >= args.steps,
                    "episodes": episodes,
                    "physics_unstable_episodes": unstable,
                    "per_id_and_arm": per_pair,
                    "rss_after_warmup_mib": samples[0]["rss_mib"],
                    "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                    "memory_growth_after_warmup": growth_after_warmup(samples),
                    "env_steps_per_s_overall": done / (now - start),
                    "samples": samples,
                }
                write_json(args.out, report)
                last_done, last_time = done, time.perf_counter()
    except KeyboardInterrupt:
        print(f"interrupted after {done:,} env steps")
    finally:
        bar.close()
    if not samples:
        return
    print(f"{'env steps':>12} {'RSS MiB':>9} {'env-steps/s':>12}")
    for s in samples:
        print(f"{s['env_steps']:>12,} {s['rss_mib']:>9.1f} {s['env_steps_per_s']:>12,.0f}")
    print(
        f"{done:,} env steps on {len(pairs)} id/arm pairs, {episodes:,} episodes ({unstable} "
        f"ended by a blow-up), memory growth after warm-up "
        f"{report['memory_growth_after_warmup']:+.2%} (peak RSS {report['peak_rss_mib']:.0f} "
        f"MiB), {report['env_steps_per_s_overall']:,.0f} env-steps/s overall"
    )
    plot(args.out, report, samples)


if __name__ == "__main__":
    main()
