"""stable-baselines3's PPO with the same update and rollouts, computed with less Python.

:class:`PPO` is ``stable_baselines3.PPO`` (a subclass: the same constructor, hyperparameters,
callbacks, logger keys and saved files; a model it saves loads with ``stable_baselines3.PPO``)
whose two hot loops do the same arithmetic with fewer steps around it. ``panda-rapier train
--algo ppo`` uses it.

The update (:meth:`PPO.train`), where the policy allows it (a diagonal Gaussian without
gSDE, as every PPO recipe here has, and features extractors without weights, such as
:class:`~panda_rapier.learning.normalization.NormalizedFlatten` or SB3's ``CombinedExtractor`` of
flat inputs): the observations' features are computed once per update instead of once per
minibatch and epoch (they have no weights, so every epoch's are the same); minibatches are
cut from tensors instead of converting numpy rows per key; the Gaussian's log-density and
entropy are written out (the same expressions as ``torch.distributions.Normal``) instead of
building a distribution object per minibatch; the per-minibatch statistics are read in one
call. Minibatches are drawn from numpy's global generator exactly as SB3's rollout buffer
draws them, so from the same state both updates visit the same samples in the same order and
end at weights equal to float32 rounding (``tests/python/test_ppo.py`` checks this to 1e-6).
Other policies (gSDE, squashed or discrete actions, extractors with weights such as a
camera's CNN) take SB3's own update.

The rollouts (:meth:`PPO.collect_rollouts`): SB3's loop, except that the value of every
environment whose episode was cut by the time limit is predicted in one forward pass per step
instead of one per environment (the bootstrapped rewards equal SB3's to float32 rounding).

``mean_bound_coef`` (a constructor argument, 0 by default: SB3's loss) adds to the loss that
coefficient times the mean over the minibatch of ``sum_i max(|mu_i| - MEAN_BOUND, 0)^2``, the
Gaussian's means ``mu`` beyond ``MEAN_BOUND`` (1.1) of the action bounds ``[-1, 1]`` (the
bounds loss of rl_games' PPO). The environment clips actions to the bounds, so a mean beyond
them gives every sample the same action: the advantages no longer tell samples apart and
nothing in the policy gradient brings the mean back, so the policy loses the actions within
the bounds, such as holding the hand still (``docs/training.md``, 2026-12-02: 19-49 % of a
Stack policy's hand means near the goal were beyond 1.3). It needs the lean update (a
:class:`ValueError` otherwise).

With :attr:`PPO.overlap_updates` (``panda-rapier train --overlap-updates``) each update runs
in a learner process while the next rollout is collected, by the policy from before that
update (:mod:`panda_rapier.learning.overlap`): a different schedule, not the same arithmetic.

Measured on pick-and-place, the package recipe, 2 cores: ``docs/guide/throughput.md``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import stable_baselines3
import torch as th
from gymnasium import spaces
from stable_baselines3.common.buffers import DictRolloutBuffer, RolloutBuffer
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.distributions import DiagGaussianDistribution
from stable_baselines3.common.policies import ActorCriticPolicy
from stable_baselines3.common.preprocessing import preprocess_obs
from stable_baselines3.common.torch_layers import MlpExtractor
from stable_baselines3.common.utils import explained_variance, obs_as_tensor
from stable_baselines3.common.vec_env import VecEnv
from torch.nn import functional as F

__all__ = ["MEAN_BOUND", "PPO", "lean_update_applies"]

#: Where ``mean_bound_coef``'s loss starts: the Gaussian's means beyond this, either side.
MEAN_BOUND = 1.1

# log(sqrt(2 pi)), as torch.distributions.Normal writes it.
_LOG_SQRT_2PI = math.log(math.sqrt(2 * math.pi))
# The buffer arrays SB3's rollout buffer flattens before its first minibatch.
_BUFFER_ARRAYS = ("actions", "values", "log_probs", "advantages", "returns")


def _has_weights(module: th.nn.Module) -> bool:
    return any(True for _ in module.parameters())


def lean_update_applies(model: stable_baselines3.PPO) -> bool:
    """Whether :meth:`PPO.train` takes the lean path for ``model``'s policy (see the module's
    documentation), rather than SB3's own update."""
    policy = model.policy
    if not isinstance(policy, ActorCriticPolicy):
        return False
    extractors = (
        [policy.features_extractor]
        if policy.share_features_extractor
        else [policy.pi_features_extractor, policy.vf_features_extractor]
    )
    return (
        type(policy.action_dist) is DiagGaussianDistribution
        and isinstance(policy.mlp_extractor, MlpExtractor)
        and isinstance(model.action_space, spaces.Box)
        and not model.use_sde
        and not policy.squash_output
        and isinstance(model.rollout_buffer, (RolloutBuffer, DictRolloutBuffer))
        and not any(_has_weights(extractor) for extractor in extractors)
    )


class PPO(stable_baselines3.PPO):
    """``stable_baselines3.PPO``, the same algorithm with cheaper update and rollout loops
    (see the module's documentation).

    ``overlap_updates`` (default ``False``; an attribute, not saved with the model) makes
    :meth:`learn` run each update in a learner process while the next rollout is collected,
    by the policy from before that update (:mod:`panda_rapier.learning.overlap`)."""

    overlap_updates: bool = False

    def __init__(self, *args: Any, mean_bound_coef: float = 0.0, **kwargs: Any) -> None:
        coef = mean_bound_coef
        if not (isinstance(coef, (int, float)) and math.isfinite(coef) and coef >= 0):
            raise ValueError(f"mean_bound_coef must be a finite number, 0 or more, got {coef!r}")
        #: The weight of the loss on the Gaussian's means beyond :data:`MEAN_BOUND` (the
        #: module's documentation); saved with the model.
        self.mean_bound_coef = float(coef)
        super().__init__(*args, **kwargs)

    def _setup_model(self) -> None:
        super()._setup_model()
        if self.mean_bound_coef and not lean_update_applies(self):
            raise ValueError(
                "mean_bound_coef needs a diagonal Gaussian policy without gSDE or squashing and "
                "features extractors without weights (the lean update); this policy takes "
                "SB3's own update"
            )

    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), "overlap_updates"]

    def learn(
        self,
        total_timesteps: int,
        callback: Any = None,
        log_interval: int = 1,
        tb_log_name: str = "PPO",
        reset_num_timesteps: bool = True,
        progress_bar: bool = False,
    ) -> PPO:
        """SB3's ``learn``; with :attr:`overlap_updates` the same loop with each update run
        in a learner process while the next rollout is collected
        (:mod:`panda_rapier.learning.overlap`: rollout ``k + 1`` is collected by the policy from
        before update ``k``, whose result is taken in after it). Logs are dumped at the same points
        as SB3's loop."""
        if not self.overlap_updates:
            return super().learn(
                total_timesteps, callback, log_interval, tb_log_name, reset_num_timesteps,
                progress_bar,
            )  # fmt: skip
        from .overlap import UpdateProcess

        iteration = 0
        # The learner process imports its libraries while the run sets up (callbacks such as
        # FitNormalizerCallback work in on_training_start), then starts from the model as the
        # first rollout finds it.
        with UpdateProcess() as learner:
            total_timesteps, callback = self._setup_learn(
                total_timesteps, callback, reset_num_timesteps, tb_log_name, progress_bar
            )
            callback.on_training_start(locals(), globals())
            assert self.env is not None
            learner.load(self)
            while self.num_timesteps < total_timesteps:
                more = self.collect_rollouts(
                    self.env, callback, self.rollout_buffer, n_rollout_steps=self.n_steps
                )
                learner.finish(self, apply=more)
                if not more:
                    break
                iteration += 1
                self._update_current_progress_remaining(self.num_timesteps, total_timesteps)
                if log_interval is not None and iteration % log_interval == 0:
                    assert self.ep_info_buffer is not None
                    self.dump_logs(iteration)
                learner.start(self)
            learner.finish(self)
        callback.on_training_end()
        return self

    def train(self) -> None:
        """One update on the rollout buffer: SB3's (``stable_baselines3.PPO.train``), computed
        as the module's documentation says where :func:`lean_update_applies`."""
        if not lean_update_applies(self):  # never with mean_bound_coef (_setup_model refuses it)
            super().train()
            return
        policy = self.policy
        policy.set_training_mode(True)
        self._update_learning_rate(policy.optimizer)
        progress = self._current_progress_remaining
        clip_range = float(self.clip_range(progress))  # type: ignore[operator]
        clip_range_vf = (
            None if self.clip_range_vf is None else float(self.clip_range_vf(progress))  # type: ignore[operator]
        )
        data = self._flat_buffer()
        params = list(policy.parameters())
        pg_losses: list[float] = []
        value_losses: list[float] = []
        entropy_losses: list[float] = []
        clip_fractions: list[float] = []
        approx_kl_divs: list[float] = []
        bound_losses: list[float] = []
        loss = th.zeros(())
        size = len(data["returns"])
        continue_training = True
        for epoch in range(self.n_epochs):
            approx_kl_divs = []
            # SB3's rollout buffer draws this permutation per epoch (RolloutBuffer.get), from
            # numpy's global generator, which the algorithm's seed sets.
            order = th.as_tensor(np.random.permutation(size))  # noqa: NPY002
            for start in range(0, size, self.batch_size):
                rows = order[start : start + self.batch_size]
                values, log_prob, entropy, mean = self._evaluate(data, rows)
                advantages = data["advantages"][rows]
                if self.normalize_advantage and len(advantages) > 1:
                    advantages = (advantages - advantages.mean()) / (advantages.std() + 1e-8)
                log_ratio = log_prob - data["old_log_prob"][rows]
                ratio = th.exp(log_ratio)
                policy_loss_1 = advantages * ratio
                policy_loss_2 = advantages * th.clamp(ratio, 1 - clip_range, 1 + clip_range)
                policy_loss = -th.min(policy_loss_1, policy_loss_2).mean()
                if clip_range_vf is None:
                    values_pred = values
                else:
                    old_values = data["old_values"][rows]
                    values_pred = old_values + th.clamp(
                        values - old_values, -clip_range_vf, clip_range_vf
                    )
                value_loss = F.mse_loss(data["returns"][rows], values_pred)
                entropy_loss = -th.mean(entropy)
                loss = policy_loss + self.ent_coef * entropy_loss + self.vf_coef * value_loss
                if self.mean_bound_coef:
                    beyond = F.relu(mean.abs() - MEAN_BOUND)
                    bound_loss = (beyond**2).sum(dim=1).mean()
                    loss = loss + self.mean_bound_coef * bound_loss
                    bound_losses.append(bound_loss.item())
                with th.no_grad():
                    clip_fraction = th.mean((th.abs(ratio - 1) > clip_range).float())
                    approx_kl = th.mean((th.exp(log_ratio) - 1) - log_ratio)
                    stats = th.stack(
                        [policy_loss, value_loss, entropy_loss, clip_fraction, approx_kl]
                    ).tolist()
                pg_losses.append(stats[0])
                value_losses.append(stats[1])
                entropy_losses.append(stats[2])
                clip_fractions.append(stats[3])
                approx_kl_divs.append(stats[4])
                if self.target_kl is not None and stats[4] > 1.5 * self.target_kl:
                    continue_training = False
                    if self.verbose >= 1:
                        print(f"Early stopping at step {epoch} due to reaching max kl: "
                              f"{stats[4]:.2f}")  # fmt: skip
                    break
                policy.optimizer.zero_grad()
                loss.backward()
                th.nn.utils.clip_grad_norm_(params, self.max_grad_norm)
                policy.optimizer.step()
            self._n_updates += 1
            if not continue_training:
                break
        buffer = self.rollout_buffer
        explained_var = explained_variance(buffer.values.flatten(), buffer.returns.flatten())
        # The same records as SB3's update.
        self.logger.record("train/entropy_loss", np.mean(entropy_losses))
        self.logger.record("train/policy_gradient_loss", np.mean(pg_losses))
        self.logger.record("train/value_loss", np.mean(value_losses))
        self.logger.record("train/approx_kl", np.mean(approx_kl_divs))
        self.logger.record("train/clip_fraction", np.mean(clip_fractions))
        self.logger.record("train/loss", loss.item())
        self.logger.record("train/explained_variance", explained_var)
        self.logger.record("train/std", th.exp(policy.log_std).mean().item())
        if bound_losses:
            self.logger.record("train/mean_bound_loss", np.mean(bound_losses))
        self.logger.record("train/n_updates", self._n_updates, exclude="tensorboard")
        self.logger.record("train/clip_range", clip_range)
        if clip_range_vf is not None:
            self.logger.record("train/clip_range_vf", clip_range_vf)

    def _flat_buffer(self) -> dict[str, Any]:
        """The rollout buffer as tensors of one row per sample, in the order SB3's buffer
        indexes them, with the observations' features (computed once, without gradients:
        the extractors have no weights)."""
        buffer = self.rollout_buffer
        if not buffer.generator_ready:  # what RolloutBuffer.get does before its first batch
            if isinstance(buffer, DictRolloutBuffer):
                for key, obs in buffer.observations.items():
                    buffer.observations[key] = buffer.swap_and_flatten(obs)
            else:
                buffer.observations = buffer.swap_and_flatten(buffer.observations)
            for name in _BUFFER_ARRAYS:
                buffer.__dict__[name] = buffer.swap_and_flatten(buffer.__dict__[name])
            buffer.generator_ready = True
        policy = self.policy
        observations = (
            {key: th.as_tensor(obs) for key, obs in buffer.observations.items()}
            if isinstance(buffer, DictRolloutBuffer)
            else th.as_tensor(buffer.observations)
        )
        with th.no_grad():
            inputs = preprocess_obs(observations, policy.observation_space, policy.normalize_images)
            if policy.share_features_extractor:
                pi_features = vf_features = policy.features_extractor(inputs)
            else:
                pi_features = policy.pi_features_extractor(inputs)
                vf_features = policy.vf_features_extractor(inputs)
        return {
            "pi_features": pi_features,
            "vf_features": vf_features,
            "actions": th.as_tensor(buffer.actions),
            "old_values": th.as_tensor(buffer.values.flatten()),
            "old_log_prob": th.as_tensor(buffer.log_probs.flatten()),
            "advantages": th.as_tensor(buffer.advantages.flatten()),
            "returns": th.as_tensor(buffer.returns.flatten()),
        }

    def _evaluate(
        self, data: dict[str, Any], rows: th.Tensor
    ) -> tuple[th.Tensor, th.Tensor, th.Tensor, th.Tensor]:
        """``policy.evaluate_actions`` on the samples ``rows``: values, log-density of the
        taken actions and entropy, as SB3's diagonal Gaussian computes them, and the
        Gaussian's means."""
        policy = self.policy
        mlp = policy.mlp_extractor
        latent_pi = mlp.forward_actor(data["pi_features"][rows])
        latent_vf = mlp.forward_critic(data["vf_features"][rows])
        mean = policy.action_net(latent_pi)
        values = policy.value_net(latent_vf).flatten()
        # DiagGaussianDistribution: Normal(mean, ones_like(mean) * exp(log_std)), log-density
        # and entropy summed over the action's entries.
        scale = th.ones_like(mean) * policy.log_std.exp()
        log_scale = scale.log()
        actions = data["actions"][rows]
        log_prob = -((actions - mean) ** 2) / (2 * scale**2) - log_scale - _LOG_SQRT_2PI
        log_prob = log_prob.sum(dim=1)
        entropy = (0.5 + _LOG_SQRT_2PI + log_scale).sum(dim=1)
        return values, log_prob, entropy, mean

    def collect_rollouts(
        self,
        env: VecEnv,
        callback: BaseCallback,
        rollout_buffer: RolloutBuffer,
        n_rollout_steps: int,
    ) -> bool:
        """SB3's rollout loop (``OnPolicyAlgorithm.collect_rollouts``), with the values of the
        environments cut by the time limit predicted in one forward pass per step."""
        assert self._last_obs is not None, "No previous observation was provided"
        self.policy.set_training_mode(False)
        n_steps = 0
        rollout_buffer.reset()
        if self.use_sde:
            self.policy.reset_noise(env.num_envs)
        callback.on_rollout_start()
        new_obs: Any = self._last_obs
        dones = np.zeros(env.num_envs, dtype=bool)
        while n_steps < n_rollout_steps:
            if self.use_sde and self.sde_sample_freq > 0 and n_steps % self.sde_sample_freq == 0:
                self.policy.reset_noise(env.num_envs)
            with th.no_grad():
                obs_tensor = obs_as_tensor(self._last_obs, self.device)
                actions, values, log_probs = self.policy(obs_tensor)
            actions = actions.cpu().numpy()
            clipped_actions = actions
            if isinstance(self.action_space, spaces.Box):
                if self.policy.squash_output:
                    clipped_actions = self.policy.unscale_action(clipped_actions)
                else:
                    space = self.action_space
                    clipped_actions = np.clip(actions, space.low, space.high)
            new_obs, rewards, dones, infos = env.step(clipped_actions)
            self.num_timesteps += env.num_envs
            callback.update_locals(locals())
            if not callback.on_step():
                return False
            self._update_info_buffer(infos, dones)
            n_steps += 1
            if isinstance(self.action_space, spaces.Discrete):
                actions = actions.reshape(-1, 1)
            self._bootstrap_time_limits(rewards, dones, infos)
            rollout_buffer.add(
                self._last_obs,  # type: ignore[arg-type]
                actions,
                rewards,
                self._last_episode_starts,  # type: ignore[arg-type]
                values,
                log_probs,
            )
            self._last_obs = new_obs
            self._last_episode_starts = dones
        with th.no_grad():
            values = self.policy.predict_values(obs_as_tensor(new_obs, self.device))
        rollout_buffer.compute_returns_and_advantage(last_values=values, dones=dones)
        callback.update_locals(locals())
        callback.on_rollout_end()
        return True

    def _bootstrap_time_limits(
        self, rewards: np.ndarray, dones: np.ndarray, infos: list[dict[str, Any]]
    ) -> None:
        """Adds ``gamma`` times the value of the final observation to the reward of every
        environment whose episode the time limit cut (SB3's timeout bootstrapping), with one
        forward pass for all of them."""
        cut = [
            i
            for i in np.flatnonzero(dones)
            if infos[i].get("terminal_observation") is not None
            and infos[i].get("TimeLimit.truncated", False)
        ]
        if not cut:
            return
        finals = [infos[i]["terminal_observation"] for i in cut]
        if isinstance(finals[0], dict):
            batch: Any = {key: np.stack([final[key] for final in finals]) for key in finals[0]}
        else:
            batch = np.stack(finals)
        with th.no_grad():
            terminal_values = self.policy.predict_values(self.policy.obs_to_tensor(batch)[0])
        rewards[cut] += self.gamma * terminal_values.numpy().reshape(-1)
