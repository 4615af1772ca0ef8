"""The native vector environment: N episodes stepped in Rust, one FFI crossing per batch step.

``gymnasium.make_vec("shieldnav/CorridorInspection-v0", num_envs=64,
vectorization_mode="vector_entry_point")`` returns a :class:`CorridorInspectionVectorEnv`.
Sub-environment ``i`` is exactly the single environment reset with seed ``seed + i``: its
episode seeds are drawn from the same generator (``gymnasium.utils.seeding.np_random``) in the
same order, so a batch of N gives the results of N single environments bit for bit.
"""

from __future__ import annotations

import os
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv

from shieldnav._core import Batch
from shieldnav.env import CorridorInspectionEnv, site_args
from shieldnav.exceptions import InvalidArgumentError

_MODES = {"next_step": AutoresetMode.NEXT_STEP, "same_step": AutoresetMode.SAME_STEP}


class EpisodeSeeds:
    """Per sub-environment episode seeds, drawn as the single environment draws them."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.rngs: list[np.random.Generator] = []

    def reseed(self, seeds: list[int]) -> np.ndarray:
        """New generators from ``seeds``; returns each one's first episode seed."""
        self.rngs = [seeding.np_random(int(s))[0] for s in seeds]
        return self.draw(np.ones(self.n, bool))

    def draw(self, mask: np.ndarray) -> np.ndarray:
        """The next episode seed of the sub-environments in ``mask`` (0 elsewhere)."""
        out = np.zeros(self.n, np.uint64)
        for i in np.flatnonzero(mask):
            out[i] = self.rngs[i].integers(0, 2**63)
        return out


class CorridorInspectionVectorEnv(VectorEnv[Any, np.ndarray, np.ndarray]):
    """N :class:`~shieldnav.env.CorridorInspectionEnv` episodes in one Rust batch.

    Arguments are those of the single environment (site, configuration keys) plus
    ``num_envs``, ``autoreset_mode`` (``"next_step"``, Gymnasium's default, or
    ``"same_step"``, or the ``gymnasium.vector.AutoresetMode`` of either), ``threads`` (worker
    threads; default: the usable cores) and ``max_episode_steps``. Episodes end at the smaller
    of ``max_episode_steps`` and ``time_limit`` (applied in Rust), as a single environment's
    do under Gymnasium's ``TimeLimit``: either one shortens them. Only the flat observation.

    ``info`` holds one array per key (``cost``, ``clearance``, ``H``, ``h_min``, ...) with its
    ``_key`` mask, and ``shieldnav_episode`` (the episode totals of sub-environments whose
    episode ended, masked by ``_shieldnav_episode``). In ``"same_step"`` mode
    ``info["final_obs"]`` holds the last observation of those episodes and
    ``info["final_info"]`` (masked by ``_final_info``) their last step's info with the totals.

    ``reset(seed=...)``: an int (sub-environment ``i`` gets ``seed + i``), a list (``None``
    entries draw a seed from the vector's generator), or ``None`` (every sub-environment gets a
    seed from that generator: deterministic after a seeded reset, but not what ``N`` single
    environments continuing their own generators would draw). Its info is the single
    environment's reset info (``seed``, the episode's own; ``coverage``; ``time``) per
    sub-environment.
    """

    def __init__(
        self,
        num_envs: int,
        *,
        preset: str | None = None,
        procedural: bool = False,
        map_path: str | None = None,
        scenario_path: str | None = None,
        autoreset_mode: str = "next_step",
        threads: int | None = None,
        max_episode_steps: int | None = None,
        time_limit: int | None = None,
        observation: str = "flat",
        render_mode: str | None = None,
        report_timing: bool = False,
        **config: Any,
    ) -> None:
        if not isinstance(num_envs, int) or num_envs < 1:
            raise InvalidArgumentError(f"invalid `num_envs`: must be a positive integer, got {num_envs!r}")
        if isinstance(autoreset_mode, AutoresetMode):
            autoreset_mode = {v: k for k, v in _MODES.items()}.get(autoreset_mode, autoreset_mode.value)
        if autoreset_mode not in _MODES:
            raise InvalidArgumentError(f"invalid `autoreset_mode`: expected one of {sorted(_MODES)} (or their AutoresetMode), got {autoreset_mode!r}")
        if observation != "flat":
            raise InvalidArgumentError("invalid `observation`: the vector environment serves the flat observation only")
        if render_mode is not None:
            raise InvalidArgumentError("invalid `render_mode`: render a single environment instead")
        threads = threads if threads is not None else len(os.sched_getaffinity(0))
        limits = [v for v in (max_episode_steps, time_limit) if v is not None]
        limit = min(limits) if limits else None
        site = site_args(preset, procedural, map_path, scenario_path)
        self._seeds = EpisodeSeeds(num_envs)
        first = self._seeds.reseed(list(range(num_envs)))
        self._next = self._seeds.draw(np.ones(num_envs, bool))
        self._batch = Batch(num_envs, first, autoreset_mode=autoreset_mode, threads=threads, time_limit=limit, **site, **config)
        single = CorridorInspectionEnv(preset=preset, procedural=procedural, map_path=map_path, scenario_path=scenario_path, **config)
        self.num_envs = num_envs
        self.single_observation_space = single.observation_space
        self.single_action_space = single.action_space
        self.observation_space = gym.vector.utils.batch_space(self.single_observation_space, num_envs)
        self.action_space = gym.vector.utils.batch_space(self.single_action_space, num_envs)
        self.metadata = {"autoreset_mode": _MODES[autoreset_mode]}
        self.render_mode = None
        self.config = single.config
        self._report_timing = report_timing
        self._mode = autoreset_mode
        single.close()

    def reset(self, *, seed: int | list[int] | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        self._check_open()
        first = seed if seed is None or isinstance(seed, int) else next((int(s) for s in seed if s is not None), None)
        super().reset(seed=first)
        if options:
            raise InvalidArgumentError(f"invalid `options`: reset takes no options, got {sorted(options)}")
        if seed is None:
            seeds = [int(s) for s in self.np_random.integers(0, 2**31, self.num_envs)]
        elif isinstance(seed, int):
            seeds = [seed + i for i in range(self.num_envs)]
        else:
            if len(seed) != self.num_envs:
                raise InvalidArgumentError(f"invalid `seed`: expected {self.num_envs} seeds, got {len(seed)}")
            seeds = [int(s) if s is not None else int(self.np_random.integers(0, 2**31)) for s in seed]
        first = self._seeds.reseed(seeds)
        obs = self._batch.reset(first)
        self._next = self._seeds.draw(np.ones(self.num_envs, bool))
        # the single environment's reset info, one array per key with its mask
        every = np.ones(self.num_envs, bool)
        zeros = np.zeros(self.num_envs)
        info = {"seed": first.astype(np.uint64), "coverage": zeros, "time": zeros.copy()}
        return obs, {**info, **{"_" + k: every for k in info}}

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        # every sub-environment that may reset in this call gets its next seed; only those
        # that do reset consume it, exactly as a single environment would
        self._check_open()
        obs, reward, terminated, truncated, raw, final_obs, reset = self._batch.step(np.asarray(actions), self._next)
        self._consume(reset)
        info = self._info(raw, reset, final_obs)
        return obs, reward, terminated, truncated, info

    def _consume(self, reset: np.ndarray) -> None:
        if reset.any():
            fresh = self._seeds.draw(reset)
            self._next = np.where(reset, fresh, self._next)

    def _info(self, raw: dict[str, Any], reset: np.ndarray, final_obs: np.ndarray) -> dict[str, Any]:
        ended = raw.pop("ended")
        if not self._report_timing:
            del raw["solve_time_ns"]
        stepped = ~reset if self._mode == "next_step" else np.ones(self.num_envs, bool)
        info: dict[str, Any] = {}
        for key, value in raw.items():
            info[key] = value
            info["_" + key] = stepped
        if ended:
            keys = next(iter(ended.values())).keys()
            mask = np.zeros(self.num_envs, bool)
            mask[list(ended)] = True
            info["shieldnav_episode"] = {k: np.array([ended[i][k] if i in ended else 0 for i in range(self.num_envs)]) for k in keys}
            info["_shieldnav_episode"] = mask
            if self._mode == "same_step":
                info["final_obs"] = final_obs
                info["_final_obs"] = mask
                # (Gymnasium's same-step contract: the ended episodes' last step info)
                info["final_info"] = {k: v for k, v in info.items() if k not in ("final_obs", "_final_obs")}
                info["_final_info"] = mask
        return info

    def _check_open(self) -> None:
        if self._batch is None:
            raise gym.error.ClosedEnvironmentError("the vector environment is closed")

    def summary(self, i: int) -> dict[str, Any]:
        """Totals of sub-environment ``i``'s current episode."""
        return self._batch.summary(i)

    def close_extras(self, **kwargs: Any) -> None:
        self._batch = None  # type: ignore[assignment]


def make_vector(num_envs: int = 1, **kwargs: Any) -> CorridorInspectionVectorEnv:
    """The ``vector_entry_point`` of every registered id."""
    return CorridorInspectionVectorEnv(num_envs, **kwargs)
