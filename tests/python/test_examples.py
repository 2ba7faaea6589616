"""The Python examples of the README and of the documentation pages (docs/), and the scripts
in examples/, run as documented (tiny budgets)."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from panda_rapier.registration import TASK_NAMES

pytest.importorskip("stable_baselines3")
pytest.importorskip("sb3_contrib")
pytest.importorskip("tqdm")

ROOT = Path(__file__).resolve().parents[2]


def run(*args: str | Path) -> str:
    result = subprocess.run(
        [sys.executable, *map(str, args)], capture_output=True, text=True, timeout=600, check=False
    )
    assert result.returncode == 0, result.stderr[-3000:]
    return result.stdout


def python_blocks(page: Path) -> list[str]:
    return re.findall(r"```python\n(.*?)```", page.read_text(), flags=re.DOTALL)


#: Every page with Python examples: the README and the documentation's Markdown sources.
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]


def documented_python_blocks() -> list[tuple[str, str]]:
    """(where, code) of every Python example, each distinct block once (the README repeats
    some of the quick start's)."""
    seen: dict[str, str] = {}
    for page in PAGES:
        for i, block in enumerate(python_blocks(page)):
            seen.setdefault(block, f"{page.relative_to(ROOT)}#{i}")
    return [(where, block) for block, where in seen.items()]


def test_readme_has_python_examples() -> None:
    assert len(python_blocks(ROOT / "README.md")) >= 3


@pytest.mark.parametrize(
    "where,block", documented_python_blocks(), ids=[w for w, _ in documented_python_blocks()]
)
def test_documented_python_example_runs(where: str, block: str, tmp_path: Path) -> None:
    if "import ray" in block:
        pytest.importorskip("ray", reason=f"the Ray example {where} needs '.[rllib]'")
    if "lerobot" in block:
        # Python >= 3.12 only: test_lerobot_dataset.py runs it in LeRobot's virtualenv.
        pytest.importorskip("lerobot", reason=f"the LeRobot example {where} needs '.[lerobot]'")
    script = tmp_path / "example.py"
    script.write_text(block)
    # A Ray example's `ray.init(num_cpus=2)` starts its own Ray, as on a user's machine; it
    # would join the simulated cluster another test file may be running (Ray's address file).
    env = {**os.environ, "RAY_ADDRESS": "local"}
    subprocess.run([sys.executable, script], cwd=tmp_path, check=True, timeout=600, env=env)


def test_her_throughput_script_measures_the_recipe(tmp_path: Path) -> None:
    out = tmp_path / "her.json"
    text = run(ROOT / "examples/her_throughput.py", "--steps", "3", "--learning-starts", "80",
               "--no-panda-gym", "--json", out)  # fmt: skip
    (item,) = json.loads(out.read_text())
    assert item["label"].startswith("panda_rapier") and item["env_steps_per_s"] > 0
    assert "env-steps/s" in text


def test_soak_script_reports_memory_and_speed(tmp_path: Path) -> None:
    out = run(ROOT / "examples/soak.py", "--steps", "256", "--every", "128", "--n-envs", "16",
              "--no-progress", "--out", tmp_path)  # fmt: skip
    assert "memory growth after warm-up" in out
    report = json.loads((tmp_path / "soak.json").read_text())
    assert report["env_steps"] == 256 and len(report["samples"]) == 2 and report["complete"]
    assert all(s["rss_mib"] > 0 and s["env_steps_per_s"] > 0 for s in report["samples"])
    # The whole family on both arms (every task, both action modes, both arms) alive at
    # once, stepped in turn.
    run(ROOT / "examples/soak.py", "--env-id", "family", "--arm", "dynamic", "kinematic",
        "--steps", "320", "--every", "160", "--n-envs", "2", "--no-progress",
        "--out", tmp_path / "family")  # fmt: skip
    report = json.loads((tmp_path / "family" / "soak.json").read_text())
    family = len(TASK_NAMES) * 2 * 2
    assert len(report["per_id_and_arm"]) == family and report["complete"]


def test_adversarial_pixels_script_counts_every_id(tmp_path: Path) -> None:
    out = run(ROOT / "examples/adversarial_pixels.py", "--steps", "800", "--num-envs", "2",
              "--image-size", "32", "--no-progress", "--json", tmp_path / "a.json")  # fmt: skip
    assert "total: steps" in out
    report = json.loads((tmp_path / "a.json").read_text())
    # Every task, both action modes, rgb and state+rgb.
    assert len(report["runs"]) == len(TASK_NAMES) * 2 * 2
    assert report["total"]["non_finite"] == 0 and report["total"]["bad_images"] == 0


def test_computed_torque_example_tracks_with_the_model() -> None:
    """The model's inverse dynamics make torque control track a trajectory that PD alone
    misses, and gravity compensation holds the arm."""
    out = run(ROOT / "examples/computed_torque.py", "--seconds", "1")
    errors = [float(x) for x in re.findall(r"max tracking error ([0-9.]+) mrad", out)]
    assert len(errors) == 2 and errors[0] < 5.0 and errors[1] > 10 * errors[0], out
    speed = float(re.search(r"fastest joint ([0-9.]+) rad/s", out).group(1))
    assert speed < 0.05, out
