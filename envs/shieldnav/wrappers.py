"""Wrappers of the shieldnav environments, one behaviour each."""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
from gymnasium.utils import RecordConstructorArgs


class RecordEpisodeSummary(gym.Wrapper[Any, Any, Any, Any], RecordConstructorArgs):
    """Adds the episode totals of the Rust episode to ``info["episode"]`` (and
    ``info["shieldnav_episode"]``, which SB3's ``Monitor`` leaves alone) on the step that
    ends an episode, including a truncation by an inner ``TimeLimit``.

    Registered ids apply it after their time limit.
    """

    def __init__(self, env: gym.Env[Any, Any]) -> None:
        RecordConstructorArgs.__init__(self)
        gym.Wrapper.__init__(self, env)
        if not hasattr(env.unwrapped, "episode"):
            raise TypeError(f"RecordEpisodeSummary needs a shieldnav environment, got {type(env.unwrapped).__name__}")

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        if (terminated or truncated) and "shieldnav_episode" not in info:
            summary = self.env.unwrapped.episode.summary()  # type: ignore[attr-defined]
            info["episode"] = summary
            info["shieldnav_episode"] = summary
        return obs, reward, terminated, truncated, info
