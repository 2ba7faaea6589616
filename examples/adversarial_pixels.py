"""Adversarial actions with image observations: every id (every task, both action modes) in
``obs_mode="rgb"`` and ``"state+rgb"``, the native vector env with same-step autoreset, actions
at +-1 flipping at random every 1-5 steps (the joints' bang-bang; in ee control the hand
driven hard in every direction, into the table and the objects). Counts steps, episodes,
non-finite numbers in the state entries and rewards (must be 0), images of the wrong shape or
dtype (must be 0) and blow-ups detected (``physics_unstable``).

    python examples/adversarial_pixels.py --steps 1000000 --json runs/adversarial_pixels.json
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
from tqdm import tqdm

import panda_rapier


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=1_000_000, help="environment steps in all")
    parser.add_argument("--num-envs", type=int, default=16)
    parser.add_argument("--image-size", type=int, default=84)
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--no-progress", action="store_true")
    args = parser.parse_args()

    ids = [i for i in panda_rapier.ENV_IDS if "Dense" not in i]
    runs = [(env_id, mode) for env_id in ids for mode in ("rgb", "state+rgb")]
    rounds = max(1, args.steps // (len(runs) * args.num_envs))
    rng = np.random.default_rng(0)
    rows = []
    bar = tqdm(
        total=rounds * len(runs) * args.num_envs,
        unit="step",
        unit_scale=True,
        disable=args.no_progress,
    )
    for env_id, mode in runs:
        envs = gym.make_vec(
            env_id,
            num_envs=args.num_envs,
            vectorization_mode="vector_entry_point",
            obs_mode=mode,
            image_size=args.image_size,
            autoreset_mode="same_step",
        )
        obs, _ = envs.reset(seed=0)
        shape = envs.action_space.shape
        signs = np.ones(shape, np.float32)
        hold = np.zeros(shape, np.int64)
        tally = {
            "env_id": env_id,
            "obs_mode": mode,
            "steps": 0,
            "episodes": 0,
            "non_finite": 0,
            "bad_images": 0,
            "blow_ups": 0,
        }
        start = time.perf_counter()
        for _ in range(rounds):
            flip = hold == 0
            signs[flip] = rng.choice(np.array([-1.0, 1.0], np.float32), size=int(flip.sum()))
            hold[flip] = rng.integers(1, 6, size=int(flip.sum()))
            hold -= 1
            obs, rewards, terminated, truncated, info = envs.step(signs)
            tally["steps"] += args.num_envs
            tally["episodes"] += int(np.sum(terminated | truncated))
            tally["non_finite"] += int(np.sum(~np.isfinite(rewards)))
            for value in obs.values():
                if value.dtype == np.uint8:
                    expected = (args.num_envs, args.image_size, args.image_size, 3)
                    tally["bad_images"] += int(value.shape != expected)
                else:
                    tally["non_finite"] += int(np.sum(~np.isfinite(value)))
            tally["blow_ups"] += int(np.sum(info["physics_unstable"]))
            bar.update(args.num_envs)
        tally["seconds"] = round(time.perf_counter() - start, 1)
        envs.close()
        rows.append(tally)
    bar.close()
    print(
        f"{'id':<40} {'obs_mode':<10} {'steps':>8} {'episodes':>8} {'non-finite':>10} "
        f"{'bad images':>10} {'blow-ups':>8}"
    )
    for t in rows:
        print(
            f"{t['env_id']:<40} {t['obs_mode']:<10} {t['steps']:>8} {t['episodes']:>8} "
            f"{t['non_finite']:>10} {t['bad_images']:>10} {t['blow_ups']:>8}"
        )
    total = {
        k: sum(int(t[k]) for t in rows)
        for k in ("steps", "episodes", "non_finite", "bad_images", "blow_ups")
    }
    print("total:", ", ".join(f"{k} {v:,}" for k, v in total.items()))
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"total": total, "runs": rows}, indent=1))
    if total["non_finite"] or total["bad_images"]:
        raise SystemExit("non-finite numbers or malformed images seen")


if __name__ == "__main__":
    main()
