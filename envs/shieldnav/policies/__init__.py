"""Trained policies shipped with shieldnav, as plain arrays: evaluated with numpy, no torch.

``ppo``: PPO (stable-baselines3 ``MlpPolicy``: two tanh layers of 64, deterministic mean
action) trained 500,000 steps on ``shieldnav/CorridorInspection-v0`` under the default
braking shield with 1,000-step episodes and ``agents.train``'s hyperparameters, seed 2 (the
``ppo_braking`` run of ``experiments/safe_rl.yml``; ``python -m agents.train --max-episode-steps
1000 --seed 2``), exported with ``python -m agents.export_policy``. It reads the flat
observation of the default configuration (64 range bins)::

    import gymnasium as gym
    from shieldnav.policies import load

    env = gym.make("shieldnav/CorridorInspection-v0")
    policy = load("ppo", env)
    obs, info = env.reset(seed=0)
    action = policy.act(obs, info)
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from shieldnav.exceptions import InvalidArgumentError

#: Shipped policy name → its weights file.
POLICIES = {"ppo": Path(__file__).with_name("ppo_corridor.npz")}


class MlpPolicy:
    """A feed-forward policy: ``tanh`` hidden layers, a linear output clipped to ``[-1, 1]``
    (weights ``w0, b0, …`` as SB3's ``MlpPolicy`` keeps them: ``y = W x + b``)."""

    def __init__(self, weights: dict[str, np.ndarray]) -> None:
        n = len(weights) // 2
        self.layers = [(np.asarray(weights[f"w{k}"], np.float32), np.asarray(weights[f"b{k}"], np.float32)) for k in range(n)]
        self.obs_dim = self.layers[0][0].shape[1]
        self.action_dim = self.layers[-1][0].shape[0]

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """Actions for one observation ``(obs_dim,)`` or a batch ``(n, obs_dim)``."""
        x = np.asarray(obs, np.float32)
        for w, b in self.layers[:-1]:
            x = np.tanh(x @ w.T + b)
        w, b = self.layers[-1]
        return np.clip(x @ w.T + b, -1.0, 1.0).astype(np.float32)

    def act(self, obs: np.ndarray, info: dict[str, Any] | None = None) -> np.ndarray:
        """The ``obs, info -> action`` form the benchmark and the command line call."""
        return self(obs)

    def reset(self) -> None:
        """Nothing to reset: the policy has no state."""


def load(name: str, env: gym.Env[Any, Any] | None = None) -> MlpPolicy:
    """The shipped policy ``name`` (see :data:`POLICIES`); with ``env``, checked against its
    observation and action spaces."""
    if name not in POLICIES:
        raise InvalidArgumentError(f"invalid `policy`: expected one of the shipped policies {sorted(POLICIES)}, got {name!r}")
    with np.load(POLICIES[name]) as f:
        policy = MlpPolicy({k: f[k] for k in f.files})
    if env is not None:
        obs, act = env.observation_space, env.action_space
        if not (isinstance(obs, gym.spaces.Box) and obs.shape == (policy.obs_dim,)):
            raise InvalidArgumentError(f"invalid `policy`: {name!r} reads a flat observation of {policy.obs_dim} values, the environment gives {obs}")
        if not (isinstance(act, gym.spaces.Box) and act.shape == (policy.action_dim,)):
            raise InvalidArgumentError(f"invalid `policy`: {name!r} acts in {policy.action_dim} values, the environment takes {act}")
    return policy
