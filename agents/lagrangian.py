"""PPO-Lagrangian over stable-baselines3's PPO: constrained RL on ``info["cost"]``.

The policy maximises the return subject to a budget on the expected episode cost,
``E[Σ c] ≤ cost_limit``, through the Lagrangian ``max_π min_{λ≥0} J_r(π) − λ (J_c(π) − cost_limit)``:

- the policy update is PPO's on the reward ``r − λ·c`` (λ held fixed during a rollout);
- the multiplier takes one step of projected dual ascent after each rollout,
  ``λ ← max(0, λ + lagrangian_lr · (Ĵ_c − cost_limit))`` (`lagrange_update`), where
  ``Ĵ_c`` is the rollout's mean cost per step times ``episode_steps`` (the episode's length):
  the mean episode cost, estimated from every step of the rollout rather than only from the
  few episodes that end inside it.

λ is logged as ``lagrangian/lambda`` with ``lagrangian/episode_cost`` (Ĵ_c). The returns SB3's
``VecMonitor`` records (placed below the penalty) are the environment's own.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from shieldnav.sb3 import info_column
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper


def lagrange_update(lam: float, episode_cost: float, cost_limit: float, lr: float) -> float:
    """One projected dual-ascent step: λ rises while the cost exceeds the budget, falls while it
    is below, and never goes under 0."""
    return max(0.0, lam + lr * (episode_cost - cost_limit))


class CostPenalty(VecEnvWrapper):
    """Hands the agent ``r − λ·c`` (``c = info["cost"]``) with ``λ = owner.lagrange_multiplier``,
    and sums the cost and the steps since the last `take`."""

    def __init__(self, venv: VecEnv, owner: PPOLagrangian) -> None:
        super().__init__(venv)
        self.owner = owner
        self.cost = 0.0
        self.steps = 0

    def reset(self) -> Any:
        return self.venv.reset()

    def step_wait(self) -> Any:
        obs, rewards, dones, infos = self.venv.step_wait()
        costs = info_column(self.venv, infos, "cost", 0.0)
        self.cost += float(costs.sum())
        self.steps += len(costs)
        return obs, rewards - np.float32(self.owner.lagrange_multiplier) * costs.astype(np.float32), dones, infos

    def take(self) -> tuple[float, int]:
        """The cost and step count since the last call; resets both."""
        out = (self.cost, self.steps)
        self.cost, self.steps = 0.0, 0
        return out


class PPOLagrangian(PPO):
    """PPO with a Lagrange multiplier on the episode cost (see the module's text).

    ``cost_limit``: the budget on the expected cost per episode (contact steps per episode in
    shieldnav). ``lagrangian_lr``: the dual step size. ``lagrangian_init``: λ at the start.
    ``episode_steps``: the episode length that scales the cost rate to an episode cost."""

    def __init__(self, policy: Any, env: VecEnv, cost_limit: float = 10.0, lagrangian_lr: float = 0.005, lagrangian_init: float = 0.0,
                 episode_steps: int = 1000, **kwargs: Any) -> None:
        if cost_limit < 0 or lagrangian_lr <= 0 or lagrangian_init < 0 or episode_steps < 1:
            raise ValueError(f"PPOLagrangian needs cost_limit ≥ 0, lagrangian_lr > 0, lagrangian_init ≥ 0 and episode_steps ≥ 1; got "
                             f"{cost_limit}, {lagrangian_lr}, {lagrangian_init}, {episode_steps}")
        self.cost_limit, self.lagrangian_lr, self.episode_steps = float(cost_limit), float(lagrangian_lr), int(episode_steps)
        self.lagrange_multiplier = float(lagrangian_init)
        self.multiplier_history: list[tuple[int, float, float]] = []
        self._penalty = CostPenalty(env, self) if env is not None else None
        super().__init__(policy, self._penalty if env is not None else env, **kwargs)

    def collect_rollouts(self, env: Any, callback: Any, rollout_buffer: Any, n_rollout_steps: int) -> bool:
        if self._penalty is not None:
            self._penalty.take()
        finished = super().collect_rollouts(env, callback, rollout_buffer, n_rollout_steps)
        if self._penalty is not None:
            cost, steps = self._penalty.take()
            if steps:
                episode_cost = cost / steps * self.episode_steps
                self.lagrange_multiplier = lagrange_update(self.lagrange_multiplier, episode_cost, self.cost_limit, self.lagrangian_lr)
                self.multiplier_history.append((self.num_timesteps, episode_cost, self.lagrange_multiplier))
                self.logger.record("lagrangian/lambda", self.lagrange_multiplier)
                self.logger.record("lagrangian/episode_cost", episode_cost)
        return finished

    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), "_penalty"]
