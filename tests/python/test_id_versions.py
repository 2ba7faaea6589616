"""Every environment id does what it did when its version was given (docs/guide/versions.md):
8 episodes of the scripted expert per id, their outcomes and the first observation, against
the fingerprints recorded in id-fingerprints.json. A change that fails this test alters an id:
bump the id's version, or (before the id's first release) re-record with
PANDA_RAPIER_UPDATE_FINGERPRINTS=1 and say so in CHANGELOG.md. Rounded values and outcomes,
not raw bits, so the record holds on every CPU."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import panda_rapier
from panda_rapier.agents.evaluation import evaluate
from panda_rapier.registration import env_config

RECORD = Path(__file__).with_name("id-fingerprints.json")
EPISODES = 8


def fingerprint(env_id: str) -> dict[str, Any]:
    """What the id does on seeds 0-7 with the scripted expert acting."""
    config = env_config(env_id)
    report = evaluate(panda_rapier.ScriptedPolicy(config), config, EPISODES, num_envs=EPISODES)
    episodes = [
        [e.seed, e.success, e.placed, e.length, e.steps_to_success, round(e.episode_return, 3)]
        for e in sorted(report.episodes, key=lambda e: e.seed)
    ]
    env = gym.make(env_id)
    obs, _ = env.reset(seed=0)
    env.close()
    first = {key: np.round(value.astype(np.float64), 6).tolist() for key, value in obs.items()}
    return {"episodes": episodes, "first_observation": first}


def _recorded() -> dict[str, Any]:
    return json.loads(RECORD.read_text()) if RECORD.exists() else {}


@pytest.mark.parametrize("env_id", panda_rapier.ENV_IDS)
def test_id_does_what_its_version_promised(env_id: str) -> None:
    now = fingerprint(env_id)
    if os.environ.get("PANDA_RAPIER_UPDATE_FINGERPRINTS") == "1":
        record = _recorded()
        record[env_id] = now
        RECORD.write_text(
            json.dumps(record, indent=None, sort_keys=True).replace("]], ", "]],\n") + "\n"
        )
        return
    recorded = _recorded().get(env_id)
    assert recorded is not None, f"{env_id} has no fingerprint: record it (docs/guide/versions.md)"
    assert now["episodes"] == recorded["episodes"], (
        f"{env_id} no longer does what its version promised (episodes differ): bump its "
        "version or re-record before its first release (docs/guide/versions.md)"
    )
    for key, value in recorded["first_observation"].items():
        moved = f"{env_id}: first observation {key!r} moved"
        np.testing.assert_allclose(
            now["first_observation"][key], value, rtol=0, atol=2e-6, err_msg=moved
        )


def test_every_id_has_a_fingerprint() -> None:
    assert set(_recorded()) == set(panda_rapier.ENV_IDS)
