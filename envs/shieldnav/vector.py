"""The native vector environment: N episodes stepped in Rust, one FFI crossing per batch step.

``gymnasium.make_vec("shieldnav/CorridorInspection-v0", num_envs=64,
vectorization_mode="vector_entry_point")`` returns a :class:`CorridorInspectionVectorEnv`.
Sub-environment ``i`` is exactly the single environment reset with seed ``seed + i``: its
episode seeds are drawn from the same generator (``gymnasium.utils.seeding.np_random``) in the
same order, so a batch of N gives the results of N single environments bit for bit.
"""

from __future__ import annotations

import numbers
import os
from typing import Any, Mapping

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv

from shieldnav._core import Batch
from shieldnav.env import CorridorInspectionEnv, check_flag, episode_totals, site_args
from shieldnav.exceptions import InvalidArgumentError

_MODES = {"next_step": AutoresetMode.NEXT_STEP, "same_step": AutoresetMode.SAME_STEP}
#: The reset info's keys (the single environment's).
_RESET_KEYS = ("coverage", "time", "seed", "site")


def _is_int(value: Any) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_))


def _count(name: str, value: Any, optional: bool = True) -> int | None:
    """``value`` as a positive int (or None if ``optional``), else an error naming ``name``."""
    if value is None and optional:
        return None
    if not _is_int(value) or value < 1:
        raise InvalidArgumentError(f"invalid `{name}`: must be a positive integer, got {value!r}")
    return int(value)


def _mode(value: Any) -> str:
    """An autoreset mode (ours, Gymnasium's ``AutoresetMode`` or its value) as our name."""
    names = {**{m: m for m in _MODES}, **{v.value: k for k, v in _MODES.items()}}
    key = value.value if isinstance(value, AutoresetMode) else value
    if not isinstance(key, str) or key not in names:
        raise InvalidArgumentError(f"invalid `autoreset_mode`: expected one of {sorted(names)} or their AutoresetMode, got {value!r}")
    return names[key]


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
    ``"same_step"``, or the ``gymnasium.vector.AutoresetMode`` of either or its value), ``threads`` (worker
    threads; default: the usable cores) and ``max_episode_steps``. Episodes end at the smaller
    of ``max_episode_steps`` and ``time_limit`` (applied in Rust), as a single environment's
    do under Gymnasium's ``TimeLimit``: either one shortens them. Only the flat observation.

    ``info`` is laid out as Gymnasium's own vector environments lay out the single
    environment's: one array per key (``cost``, ``clearance``, ``H``, ``h_min``, ...) with its
    ``_key`` mask of the sub-environments that stepped; ``shieldnav_episode`` (a dict of arrays
    with their masks: the totals of episodes that ended, as the single environment's last
    ``info`` holds them); and for sub-environments reset in this call the single environment's
    reset info (``coverage``, ``time``, ``seed``, ``site``). In ``"next_step"`` mode an ended
    episode's sub-environment resets in the next call. In ``"same_step"`` mode it resets in the
    same call: its entries of ``obs`` and ``info`` are the new episode's, ``info["final_obs"]``
    ((N, L), masked by ``_final_obs``) holds the last observation of the ended ones and
    ``info["final_info"]`` (masked by ``_final_info``) their last step's info with
    ``shieldnav_episode``. A batch step either steps every sub-environment or, on a bad
    action, none.

    ``reset(seed=...)``: an int (sub-environment ``i`` gets ``seed + i``), a list (``None``
    entries draw a seed from the vector's generator), or ``None`` (every sub-environment gets a
    seed from that generator: deterministic after a seeded reset, but not what ``N`` single
    environments continuing their own generators would draw). Seeds are non-negative integers.
    Its info is the single environment's reset info per sub-environment.
    """

    def __init__(
        self,
        num_envs: int,
        *,
        preset: str | None = None,
        procedural: bool | None = None,
        map_path: str | None = None,
        scenario_path: str | None = None,
        default_site: Mapping[str, Any] | None = None,
        autoreset_mode: str = "next_step",
        threads: int | None = None,
        max_episode_steps: int | None = None,
        time_limit: int | None = None,
        observation: str = "flat",
        render_mode: str | None = None,
        report_timing: bool = False,
        **config: Any,
    ) -> None:
        num_envs = _count("num_envs", num_envs, optional=False)  # type: ignore[assignment]
        autoreset_mode = _mode(autoreset_mode)
        threads = _count("threads", threads)
        max_episode_steps, time_limit = _count("max_episode_steps", max_episode_steps), _count("time_limit", time_limit)
        report_timing = check_flag("report_timing", report_timing)
        if "seed" in config:
            raise InvalidArgumentError("invalid `seed`: not an environment keyword; seed the episodes with reset(seed=...)")
        if observation != "flat":
            raise InvalidArgumentError("invalid `observation`: the vector environment serves the flat observation only")
        if render_mode is not None:
            raise InvalidArgumentError("invalid `render_mode`: render a single environment instead")
        threads = threads if threads is not None else len(os.sched_getaffinity(0))
        limits = [v for v in (max_episode_steps, time_limit) if v is not None]
        limit = min(limits) if limits else None
        site = site_args(preset, procedural, map_path, scenario_path, default_site)
        self._seeds = EpisodeSeeds(num_envs)
        first = self._seeds.reseed(list(range(num_envs)))
        self._next = self._seeds.draw(np.ones(num_envs, bool))
        self._batch = Batch(num_envs, first, autoreset_mode=autoreset_mode, threads=threads, time_limit=limit, **site, **config)
        single = CorridorInspectionEnv(preset=preset, procedural=procedural, map_path=map_path, scenario_path=scenario_path, default_site=default_site, **config)
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

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        self._check_open()
        given = self._seed_list(seed)
        first = next((s for s in given if s is not None), None) if isinstance(given, list) else None
        super().reset(seed=first)
        if options:
            raise InvalidArgumentError(f"invalid `options`: reset takes no options, got {sorted(options)}")
        if given is None:
            seeds = [int(s) for s in self.np_random.integers(0, 2**31, self.num_envs)]
        else:
            seeds = [s if s is not None else int(self.np_random.integers(0, 2**31)) for s in given]
        first = self._seeds.reseed(seeds)
        obs = self._batch.reset(first)
        self._next = self._seeds.draw(np.ones(self.num_envs, bool))
        every = np.ones(self.num_envs, bool)
        return obs, self._reset_info({}, every, first)

    def _seed_list(self, seed: Any) -> list[int | None] | None:
        """``reset``'s ``seed`` as one entry per sub-environment (None: drawn), or None."""
        if seed is None:
            return None
        if _is_int(seed):
            if seed < 0:
                raise InvalidArgumentError(f"invalid `seed`: must be a non-negative integer, got {seed!r}")
            return [int(seed) + i for i in range(self.num_envs)]
        if isinstance(seed, (str, bytes)) or not hasattr(seed, "__len__"):
            raise InvalidArgumentError(f"invalid `seed`: expected an int, a list of {self.num_envs} ints (or None) or None, got {seed!r}")
        if len(seed) != self.num_envs:
            raise InvalidArgumentError(f"invalid `seed`: expected {self.num_envs} seeds, got {len(seed)}")
        for i, s in enumerate(seed):
            if s is not None and not (_is_int(s) and s >= 0):
                raise InvalidArgumentError(f"invalid `seed[{i}]`: expected a non-negative integer or None, got {s!r}")
        return [None if s is None else int(s) for s in seed]

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        # every sub-environment that may reset in this call gets its next seed; only those
        # that do reset consume it, exactly as a single environment would
        self._check_open()
        used = self._next
        obs, reward, terminated, truncated, raw, final_obs, reset = self._batch.step(np.asarray(actions), used)
        self._consume(reset)
        info = self._info(raw, reset, final_obs, used)
        return obs, reward, terminated, truncated, info

    def _consume(self, reset: np.ndarray) -> None:
        if reset.any():
            fresh = self._seeds.draw(reset)
            self._next = np.where(reset, fresh, self._next)

    def _reset_info(self, info: dict[str, Any], mask: np.ndarray, seeds: np.ndarray) -> dict[str, Any]:
        """``info`` with the single environment's reset info of the sub-environments in
        ``mask`` (reset with ``seeds``), as Gymnasium's vector environments add it."""
        n = self.num_envs
        values = {"coverage": np.zeros(n), "time": np.zeros(n), "seed": np.zeros(n, np.int64), "site": np.full(n, None, object)}
        for i in np.flatnonzero(mask):
            totals = self._batch.summary(int(i))
            values["coverage"][i], values["time"][i] = totals["coverage"], totals["time"]
            values["seed"][i], values["site"][i] = int(seeds[i]), self._batch.site_name(int(i))
        for key in _RESET_KEYS:
            if key in info:
                info[key][mask] = values[key][mask]
                info["_" + key] = info["_" + key] | mask
            else:
                info[key], info["_" + key] = values[key], mask.copy()
        return info

    def _info(self, raw: dict[str, Any], reset: np.ndarray, final_obs: np.ndarray, seeds: np.ndarray) -> dict[str, Any]:
        # laid out as Gymnasium's own vector environments lay out the single environments'
        # infos: a step's entries for the sub-environments that stepped (masked), the reset
        # info for those that reset in this call, and in same-step mode the ended episodes'
        # last step in `final_info`
        n = self.num_envs
        ended = raw.pop("ended")
        if not self._report_timing:
            del raw["solve_time_ns"]
        done = np.zeros(n, bool)
        done[list(ended)] = True
        stepped = ~reset if self._mode == "next_step" else ~done
        step_info: dict[str, Any] = dict(raw)
        if ended:
            first = episode_totals(next(iter(ended.values())), self._report_timing)
            totals: dict[str, Any] = {}
            for key, value in first.items():
                totals[key] = np.zeros(n, np.asarray(value).dtype)
                for i, e in ended.items():
                    totals[key][i] = e[key]
                totals["_" + key] = done
            step_info["shieldnav_episode"] = totals
        if self._mode == "same_step" and ended:
            final = {k: (v.copy() if k != "shieldnav_episode" else v) for k, v in step_info.items()}
            for key, value in raw.items():
                final[key][~done] = 0
                final["_" + key] = done
            final["_shieldnav_episode"] = done
            step_info.pop("shieldnav_episode")
        info: dict[str, Any] = {}
        for key, value in step_info.items():
            if key == "shieldnav_episode":
                info[key], info["_" + key] = value, done
            elif stepped.any():
                value[~stepped] = 0
                info[key], info["_" + key] = value, stepped
        if self._mode == "same_step" and ended:
            info["final_obs"], info["_final_obs"] = final_obs, done
            info["final_info"], info["_final_info"] = final, done
        if reset.any():
            self._reset_info(info, reset, seeds)
        return info

    def _check_open(self) -> None:
        if self._batch is None:
            raise gym.error.ClosedEnvironmentError("the vector environment is closed")

    def summary(self, i: int) -> dict[str, Any]:
        """Totals of sub-environment ``i``'s current episode."""
        self._check_open()
        return self._batch.summary(i)

    def close_extras(self, **kwargs: Any) -> None:
        self._batch = None  # type: ignore[assignment]


def make_vector(num_envs: int = 1, **kwargs: Any) -> CorridorInspectionVectorEnv:
    """The ``vector_entry_point`` of every registered id."""
    return CorridorInspectionVectorEnv(num_envs, **kwargs)
