"""Copy a trained ACT checkpoint into models/ as a LeRobot policy directory with its run record
(panda_rapier_run.json), which `panda-rapier models-table` reads (issue 61).

    python docs/training-runs/act-state-2026-11-30/ship.py \
        TASK DATASET RUN ACTIONS RECORDING_S TRAINING_S

TASK (PickAndPlace, Lift), DATASET and RUN as train.sh names them under /work/lr, ACTIONS as
train.sh's fourth argument, RECORDING_S the dataset recording's wall time and TRAINING_S
lerobot-train's (both measured when they ran: the lab notes of 2026-11-30). Everything else is
read from the dataset and the checkpoint.
"""

from __future__ import annotations

import json
import shutil
import sys
from importlib.metadata import version
from pathlib import Path

ROOT = Path("/work/lr")
MODELS = Path(__file__).resolve().parents[3] / "models"


def main(task: str, dataset: str, run: str, actions: str, recording: str, training: str) -> None:
    data = ROOT / dataset
    meta = json.loads((data / "meta" / "panda_rapier.json").read_text())
    info = json.loads((data / "meta" / "info.json").read_text())
    checkpoint = ROOT / run / "checkpoints" / "last" / "pretrained_model"
    train = json.loads((checkpoint / "train_config.json").read_text())
    assert meta["env_id"] == f"panda_rapier/{task}-v0", meta["env_id"]
    episodes = len(meta["episodes"])
    out = MODELS / f"lerobot-act-{task}-v0"
    if out.exists():
        shutil.rmtree(out)
    shutil.copytree(checkpoint, out)
    runs = f"runs/{dataset}"
    demos = ["panda-rapier", "demos", "--env", meta["env_id"], "--format", "lerobot", "--root",
             runs, "--episodes", str(episodes), "--num-envs", str(meta["num_envs"]),
             "--first-seed", str(meta["first_seed"]), "--environment-state", "--quiet"]  # fmt: skip
    lerobot_train = [
        "lerobot-train", f"--dataset.repo_id=panda_rapier/{task}-expert",
        f"--dataset.root={runs}", "--policy.type=act", "--policy.device=cpu",
        "--policy.push_to_hub=false", "--policy.pretrained_backbone_weights=null",
        "--policy.dim_model=256", "--policy.dim_feedforward=1024", "--policy.n_heads=4",
        "--policy.n_encoder_layers=2", "--policy.n_decoder_layers=1", "--policy.chunk_size=20",
        f"--policy.n_action_steps={actions}", "--policy.use_vae=false",
        "--policy.optimizer_lr=1e-4", f"--steps={train['steps']}",
        f"--batch_size={train['batch_size']}", "--log_freq=100", "--save_freq=1000",
        f"--output_dir=runs/{run}", "--wandb.enable=false", "--num_workers=1",
        f"--seed={train['seed']}",
    ]  # fmt: skip
    record = {
        "env_id": meta["env_id"],
        "env_kwargs": {},
        "algo": "act",
        "backend": "lerobot",
        "observation": ["observation.state", "observation.environment_state"],
        "env_steps": int(info["total_frames"]),
        "wall_time_s": float(recording) + float(training),
        "dataset": {"episodes": episodes, "first_seed": meta["first_seed"],
                    "frames": int(info["total_frames"]), "recording_s": float(recording),
                    "expert_success_rate": sum(e["success"] for e in meta["episodes"]) / episodes},
        "training": {"updates": train["steps"], "batch_size": train["batch_size"],
                     "seed": train["seed"], "wall_time_s": float(training),
                     "n_action_steps": int(actions)},
        "versions": {"panda_rapier": meta["panda_rapier_version"], "lerobot": version("lerobot"),
                     "torch": version("torch")},
        "commands": [demos, lerobot_train],
        "saved_as": f"runs/{run}/checkpoints/last/pretrained_model",
        "note": "lerobot 0.6.1, torch 2.11 on CPU; `docs/training-runs/act-state-2026-11-30`",
    }  # fmt: skip
    (out / "panda_rapier_run.json").write_text(json.dumps(record, indent=1) + "\n")
    print(f"{out}: {sum(f.stat().st_size for f in out.iterdir())} bytes")


if __name__ == "__main__":
    main(*sys.argv[1:])
