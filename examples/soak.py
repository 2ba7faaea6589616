"""Soak test: millions of environment steps through the stable-baselines3 VecEnv, watching
memory and speed.

    python examples/soak.py --steps 10000000 --n-envs 64 --out runs/soak

Steps random actions (and autoresets) without pause; every ``--every`` environment steps it
records the process's resident memory and the steps per second since the last sample. At the
end it prints the table and the memory growth after warm-up (the first sample): a leak shows as
steady growth, a healthy run as a flat line. Writes ``soak.json`` and, with matplotlib
installed, ``soak.png`` (memory and speed over steps) to ``--out``. The JSON is rewritten at
every sample and Ctrl-C ends the run with its report, so an interrupted run keeps its figures
(``complete`` says whether all steps ran). The plot is drawn only at the end: importing
matplotlib mid-run adds about 35 MiB, which would read as a leak.
"""

from __future__ import annotations

import argparse
import json
import resource
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

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
    fig.suptitle(f"soak: {report['env_id']}, {report['n_envs']} envs, {report['arm']} arm")
    fig.tight_layout()
    fig.savefig(out / "soak.png", dpi=100)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env-id", default="panda_rapier/PickAndPlace-v0")
    parser.add_argument("--steps", type=int, default=10_000_000, help="environment steps")
    parser.add_argument("--n-envs", type=int, default=64)
    parser.add_argument("--every", type=int, default=250_000, help="sample period (env steps)")
    parser.add_argument("--arm", choices=("dynamic", "kinematic"), default="dynamic")
    parser.add_argument("--out", type=Path, default=Path("runs/soak"))
    parser.add_argument("--no-progress", action="store_true")
    args = parser.parse_args()

    venv = make_vec_env(args.env_id, n_envs=args.n_envs, seed=0, arm=args.arm)
    venv.reset()
    rng = np.random.default_rng(0)
    pool = rng.uniform(-1, 1, (256, args.n_envs, *venv.action_space.shape)).astype(np.float32)
    samples: list[dict[str, float]] = []
    report: dict[str, object] = {}
    episodes = unstable = 0
    done = last_done = 0
    last_time = start = time.perf_counter()
    bar = tqdm(total=args.steps, unit="step", unit_scale=True, disable=args.no_progress)
    try:
        while done < args.steps:
            _, rewards, dones, infos = venv.step(pool[(done // args.n_envs) % len(pool)])
            if not np.isfinite(rewards).all():
                raise SystemExit("a reward is not finite")
            if dones.any():
                episodes += int(dones.sum())
                unstable += sum(bool(infos[i]["physics_unstable"]) for i in np.flatnonzero(dones))
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
                    "env_id": args.env_id,
                    "arm": args.arm,
                    "n_envs": args.n_envs,
                    "steps_requested": args.steps,
                    "env_steps": done,
                    "complete": done >= args.steps,
                    "episodes": episodes,
                    "physics_unstable_episodes": unstable,
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
        f"{done:,} env steps, {episodes:,} episodes ({unstable} ended by a blow-up), "
        f"memory growth after warm-up {report['memory_growth_after_warmup']:+.2%} "
        f"(peak RSS {report['peak_rss_mib']:.0f} MiB), "
        f"{report['env_steps_per_s_overall']:,.0f} env-steps/s overall"
    )
    plot(args.out, report, samples)


if __name__ == "__main__":
    main()
