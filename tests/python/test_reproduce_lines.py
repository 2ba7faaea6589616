"""``models-table``'s reproducing commands (:mod:`panda_rapier.tools.reporting`): a run trained
into an absolute ``--out`` (the training machine's path) is reproduced into ``runs/NAME``."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("yaml")

from panda_rapier.learning.recipes import load_recipe
from panda_rapier.tools.reporting import _reproducing_command


@pytest.mark.parametrize(
    ("out", "shown"),
    [("/work/runs/bc-PickObject-20", "runs/bc-PickObject-20"), ("runs/x", "runs/x"),
     ("here", "here")],
)  # fmt: skip
def test_an_absolute_out_is_shown_under_runs(tmp_path: Path, out: str, shown: str) -> None:
    env_id = "panda_rapier/Reach-v0"
    command = ["panda-rapier", "train", "--algo", "bc", "--env-id", env_id, "--out", out]
    run = {"algo": "bc", "env_id": env_id, "command": command, "recipe": load_recipe("bc", env_id)}
    reproduced, caveat = _reproducing_command(run, tmp_path)
    assert caveat == ""
    assert reproduced[reproduced.index("--out") + 1] == shown
    assert command[-1] == out, "the run record is not changed"
