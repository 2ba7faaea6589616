"""The README's Python examples and the scripts in examples/ run as documented (tiny budgets)."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

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


def readme_python_blocks() -> list[str]:
    text = (ROOT / "README.md").read_text()
    return re.findall(r"```python\n(.*?)```", text, flags=re.DOTALL)


def test_readme_has_python_examples() -> None:
    assert len(readme_python_blocks()) >= 3


@pytest.mark.parametrize("index", range(len(readme_python_blocks())))
def test_readme_python_example_runs(index: int, tmp_path: Path) -> None:
    block = readme_python_blocks()[index]
    if "import ray" in block:
        pytest.importorskip("ray", reason="the README's Ray examples need '.[rllib]'")
    script = tmp_path / f"readme_{index}.py"
    script.write_text(block)
    subprocess.run([sys.executable, script], cwd=tmp_path, check=True, timeout=600)


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


def test_computed_torque_example_tracks_with_the_model() -> None:
    """The model's inverse dynamics make torque control track a trajectory that PD alone
    misses, and gravity compensation holds the arm."""
    out = run(ROOT / "examples/computed_torque.py", "--seconds", "1")
    errors = [float(x) for x in re.findall(r"max tracking error ([0-9.]+) mrad", out)]
    assert len(errors) == 2 and errors[0] < 5.0 and errors[1] > 10 * errors[0], out
    speed = float(re.search(r"fastest joint ([0-9.]+) rad/s", out).group(1))
    assert speed < 0.05, out
