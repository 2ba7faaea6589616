"""``panda_rapier.learning.ppo.PPO``: stable-baselines3's PPO with cheaper loops must do SB3's
arithmetic: from the same weights, rollout and generator state, its update ends at SB3's
weights (to float32 rounding) and logs the same statistics; its rollouts take the same actions
and bootstrap the same rewards; policies it cannot compute leanly take SB3's own update."""

from __future__ import annotations

import copy
from typing import Any

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
import stable_baselines3
import torch as th
from stable_baselines3.common.callbacks import CallbackList
from stable_baselines3.common.logger import Logger

from panda_rapier.learning.normalization import NormalizedFlatten
from panda_rapier.learning.ppo import PPO, lean_update_applies
from panda_rapier.sb3 import make_vec_env

ENV_ID = "panda_rapier/PickAndPlaceDense-v0"


class _Records(Logger):
    """A logger that keeps what ``train`` records."""

    def __init__(self) -> None:
        super().__init__(folder=None, output_formats=[])
        self.kept: dict[str, Any] = {}

    def record(self, key: str, value: Any, exclude: Any = None) -> None:
        self.kept[key] = value


def _pair(
    n_envs: int = 4, max_steps: int | None = None, **kwargs: Any
) -> tuple[stable_baselines3.PPO, PPO]:
    """SB3's PPO and ours on one environment, same hyperparameters, ours with SB3's weights."""
    options: dict[str, Any] = {"reward_weights": {"release": 1.0}}
    if max_steps is not None:
        options["max_episode_steps"] = max_steps
    settings: dict[str, Any] = {
        "n_steps": 16,
        "batch_size": 16,
        "n_epochs": 3,
        "policy_kwargs": {
            "features_extractor_class": NormalizedFlatten,
            "net_arch": {"pi": [32, 32], "vf": [32, 32]},
            "log_std_init": -0.5,
        },
        **kwargs,
    }
    # Each on its own environments, started from the same seeds.
    ours = PPO("MultiInputPolicy", make_vec_env(ENV_ID, n_envs=n_envs, seed=3, **options),
               seed=0, device="cpu", **settings)  # fmt: skip
    # SB3's constructor does not take our bounds loss.
    settings.pop("mean_bound_coef", None)
    theirs = stable_baselines3.PPO(
        "MultiInputPolicy", make_vec_env(ENV_ID, n_envs=n_envs, seed=3, **options), seed=0,
        device="cpu", **settings,
    )  # fmt: skip
    theirs.policy.load_state_dict(ours.policy.state_dict())
    return theirs, ours


def _start(model: stable_baselines3.PPO) -> CallbackList:
    model._setup_learn(10_000, None)
    model.set_logger(_Records())
    callback = CallbackList([])
    callback.init_callback(model)
    return callback


@pytest.mark.parametrize(
    "settings",
    [
        {},
        {"target_kl": 0.002, "n_epochs": 10},  # stops early, at the same minibatch
        {"clip_range_vf": 0.1, "normalize_advantage": False, "ent_coef": 0.01},
    ],
)
def test_update_ends_at_sb3_weights(settings: dict[str, Any]) -> None:
    theirs, ours = _pair(**settings)
    assert lean_update_applies(ours)
    callback = _start(theirs)
    _start(ours)
    assert theirs.collect_rollouts(theirs.env, callback, theirs.rollout_buffer, 16)
    ours.rollout_buffer = copy.deepcopy(theirs.rollout_buffer)
    np.random.seed(11)  # noqa: NPY002 (SB3 draws minibatches from the global generator)
    theirs.train()
    np.random.seed(11)  # noqa: NPY002 (SB3 draws minibatches from the global generator)
    ours.train()
    assert ours._n_updates == theirs._n_updates
    for (name, mine), (_, reference) in zip(
        ours.policy.named_parameters(), theirs.policy.named_parameters(), strict=True
    ):
        assert th.allclose(mine, reference, rtol=0, atol=1e-6), name
    # The update moved the weights: the comparison is not of two untouched copies.
    fresh = _pair(**settings)[1]
    moved = max(
        float((a - b).abs().max().detach())
        for a, b in zip(ours.policy.parameters(), fresh.policy.parameters(), strict=True)
    )
    assert moved > 1e-4
    kept_theirs = theirs.logger.kept  # type: ignore[attr-defined]
    kept_ours = ours.logger.kept  # type: ignore[attr-defined]
    assert kept_ours.keys() == kept_theirs.keys()
    for key, value in kept_theirs.items():
        assert kept_ours[key] == pytest.approx(value, rel=1e-4, abs=1e-6), key


def test_rollouts_take_sb3_actions_and_bootstrap_its_rewards() -> None:
    # Episodes of 5 steps: every fifth step cuts all four episodes by the time limit.
    theirs, ours = _pair(max_steps=5)
    callbacks = (_start(theirs), _start(ours))
    for model, callback in zip((theirs, ours), callbacks, strict=True):
        th.manual_seed(5)
        assert model.collect_rollouts(model.env, callback, model.rollout_buffer, 16)
    a, b = theirs.rollout_buffer, ours.rollout_buffer
    np.testing.assert_array_equal(a.actions, b.actions)
    for key in a.observations:
        np.testing.assert_array_equal(a.observations[key], b.observations[key])
    np.testing.assert_array_equal(a.episode_starts, b.episode_starts)
    # After the first row (the reset): three cuts of all four episodes, each bootstrapped.
    assert a.episode_starts[1:].sum() == 3 * 4
    np.testing.assert_allclose(b.rewards, a.rewards, rtol=0, atol=1e-6)
    np.testing.assert_allclose(b.returns, a.returns, rtol=0, atol=1e-5)


def test_other_policies_take_sb3s_update() -> None:
    # gSDE is not a plain diagonal Gaussian: SB3's own update runs, and it still learns.
    ours = _pair(use_sde=True)[1]
    assert not lean_update_applies(ours)
    callback = _start(ours)
    before = copy.deepcopy(ours.policy.state_dict())
    assert ours.collect_rollouts(ours.env, callback, ours.rollout_buffer, 16)
    ours.train()
    after = ours.policy.state_dict()
    assert any(not th.equal(before[k], after[k]) for k in before)
    assert "train/approx_kl" in ours.logger.kept  # type: ignore[attr-defined]


def _means_beyond_bounds(model: PPO) -> th.Tensor:
    """The Gaussian's means at the rollout's observations, after the action layer's bias is
    pushed beyond the bounds."""
    data = model._flat_buffer()
    with th.no_grad():
        latent = model.policy.mlp_extractor.forward_actor(data["pi_features"])
        return model.policy.action_net(latent)


def test_mean_bound_coef_pulls_means_beyond_the_bounds_back() -> None:
    # The same rollout and minibatches, with the means pushed to about +3: with the coefficient
    # the update brings them back towards the bounds, and logs its loss; without it, they stay.
    ends = {}
    for coef in (0.0, 1.0):
        ours = _pair(mean_bound_coef=coef)[1]
        with th.no_grad():
            ours.policy.action_net.bias.fill_(3.0)
        callback = _start(ours)
        assert ours.collect_rollouts(ours.env, callback, ours.rollout_buffer, 16)
        before = _means_beyond_bounds(ours)
        assert float(before.min()) > 2.0
        np.random.seed(11)  # noqa: NPY002 (the same minibatches)
        ours.train()
        ends[coef] = float((_means_beyond_bounds(ours) - before).mean())
        assert ("train/mean_bound_loss" in ours.logger.kept) == (coef > 0)  # type: ignore[attr-defined]
    assert ends[1.0] < ends[0.0] - 0.01, ends


def test_mean_bound_coef_is_saved_and_refused_where_it_cannot_apply(tmp_path: Any) -> None:
    ours = _pair(mean_bound_coef=0.5)[1]
    ours.save(tmp_path / "model.zip")
    assert PPO.load(tmp_path / "model.zip", device="cpu").mean_bound_coef == 0.5
    for bad in (-1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="mean_bound_coef"):
            _pair(mean_bound_coef=bad)
    with pytest.raises(ValueError, match="mean_bound_coef"):
        _pair(mean_bound_coef=0.5, use_sde=True)
