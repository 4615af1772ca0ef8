"""A stable-baselines3 ``VecEnv`` over the native Rust batch: SB3 trains on N episodes without
subprocesses.

Follows SB3's same-step autoreset (``DummyVecEnv``): when an episode ends, the returned
observation is the next episode's first, ``infos[i]["terminal_observation"]`` holds the last
one, and ``infos[i]["TimeLimit.truncated"]`` tells a truncation from a termination. The
episode totals are in ``infos[i]["shieldnav_episode"]`` (SB3's ``VecMonitor`` writes its own
``episode`` key). The same per-step entries, one array a key over the environments (an ended
episode's last step in its row), are in ``step_info`` after each step: the fast way to read
them across the batch.
"""

from __future__ import annotations

from typing import Any, Iterable, Sequence

import numpy as np

try:
    from stable_baselines3.common.vec_env.base_vec_env import VecEnv
except ImportError as err:  # pragma: no cover - exercised only without the extra
    raise ImportError('shieldnav.sb3 needs stable-baselines3: pip install "shieldnav[train]"') from err

import gymnasium as gym

from shieldnav.exceptions import InvalidArgumentError
from shieldnav.vector import CorridorInspectionVectorEnv

#: Attributes of the vector environment that ``get_attr`` answers per sub-environment.
_SINGLE = {"observation_space": "single_observation_space", "action_space": "single_action_space"}


class ShieldnavVecEnv(VecEnv):
    """``ShieldnavVecEnv("shieldnav/CorridorInspection-v0", num_envs=8, shield="composite")``.

    Keywords are those of the registered id (its registration kwargs are the defaults) plus
    ``threads``; episodes end at the id's ``time_limit``, or at the smaller of it and
    ``max_episode_steps`` when that is given (as for the vector environment).
    """

    def __init__(self, env_id: str, num_envs: int = 1, threads: int | None = None, **kwargs: Any) -> None:
        spec = gym.spec(env_id)
        if spec.vector_entry_point != "shieldnav.vector:make_vector":
            raise InvalidArgumentError(f"invalid `env_id`: {env_id!r} is not a shieldnav environment (ids: shieldnav.ENV_IDS)")
        if "autoreset_mode" in kwargs:
            raise InvalidArgumentError("invalid `autoreset_mode`: ShieldnavVecEnv resets as SB3's VecEnvs do (same step)")
        merged = {**spec.kwargs, **kwargs}
        self.vec = CorridorInspectionVectorEnv(num_envs, autoreset_mode="same_step", threads=threads, **merged)
        super().__init__(num_envs, self.vec.single_observation_space, self.vec.single_action_space)
        self.env_id = env_id
        self._actions: np.ndarray | None = None
        self.step_info: dict[str, np.ndarray] = {}

    def reset(self) -> np.ndarray:
        if any(self._options):
            options, self._options = self._options, [{} for _ in range(self.num_envs)]
            raise InvalidArgumentError(f"invalid `options`: ShieldnavVecEnv's reset takes none, got {options}")
        seeds = None if self._seeds[0] is None else [int(s) for s in self._seeds]
        obs, info = self.vec.reset(seed=seeds)
        self.reset_infos = [self._reset_info(info, i) for i in range(self.num_envs)]
        self._reset_seeds()
        return obs

    @staticmethod
    def _reset_info(info: dict[str, Any], i: int) -> dict[str, Any]:
        return {k: info[k][i].item() if isinstance(info[k][i], np.generic) else info[k][i] for k in ("seed", "coverage", "time", "site")}

    @staticmethod
    def _columns(step: dict[str, Any]) -> dict[str, np.ndarray]:
        """The per-environment entries of a step's info, one array a key."""
        return {k: v for k, v in step.items()
                if not k.startswith("_") and isinstance(v, np.ndarray) and k not in ("final_obs", "seed", "site")}

    @staticmethod
    def _rows(columns: dict[str, np.ndarray], n: int) -> list[dict[str, Any]]:
        """One dict an environment: Python scalars for scalar entries, the row for vector entries.
        (Built with ``zip``, not a comprehension per environment and key: this runs at every
        step of a training run.)"""
        keys = list(columns)
        values = [v.tolist() if v.ndim == 1 else list(v) for v in columns.values()]
        return [dict(zip(keys, row)) for row in zip(*values)] if keys else [{} for _ in range(n)]

    def step_async(self, actions: np.ndarray) -> None:
        actions = np.asarray(actions)
        if actions.shape != (self.num_envs, *self.action_space.shape):
            raise InvalidArgumentError(f"invalid `actions`: expected shape {(self.num_envs, *self.action_space.shape)}, got {actions.shape}")
        self._actions = actions

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
        assert self._actions is not None, "step_async first"
        obs, reward, terminated, truncated, info = self.vec.step(self._actions)
        dones = terminated | truncated
        # (every per-step entry, as a single environment reports it: an ended episode's last
        # step is in `final_info`, and the info of the reset after it in `reset_infos`). The
        # columns are split once per step, not per environment and key: the infos are a large
        # part of a training step's Python on the native batch
        columns = self._columns(info)
        infos = self._rows(columns, self.num_envs)
        if dones.any():
            final = info["final_info"]
            ended = self._columns(final)
            # (a key the running environments lack is one no environment stepped without ending)
            columns = {**ended, **{k: np.where(dones.reshape(-1, *([1] * (v.ndim - 1))), ended[k], v) if k in ended else v
                                   for k, v in columns.items()}}
            for i in np.flatnonzero(dones):
                d = {k: v[i : i + 1].tolist()[0] if v.ndim == 1 else v[i] for k, v in ended.items()}
                d["terminal_observation"] = info["final_obs"][i]
                d["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
                d["shieldnav_episode"] = {k: v[i].item() for k, v in final["shieldnav_episode"].items() if not k.startswith("_")}
                self.reset_infos[i] = self._reset_info(info, i)
                infos[i] = d
        self.step_info = columns
        return obs, reward.astype(np.float32), dones, infos

    def close(self) -> None:
        self.vec.close()

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        if attr_name == "spec":
            return [gym.spec(self.env_id) for _ in self._get_indices(indices)]
        value = getattr(self.vec, _SINGLE.get(attr_name, attr_name))
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        raise AttributeError(f"ShieldnavVecEnv sub-environments live in Rust; cannot set {attr_name!r}")

    def env_method(self, method_name: str, *method_args: Any, indices: Any = None, **method_kwargs: Any) -> list[Any]:
        if method_name == "summary":
            return [self.vec.summary(i) for i in self._get_indices(indices)]
        raise AttributeError(f"ShieldnavVecEnv has no sub-environment method {method_name!r} (only 'summary')")

    def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]

    def _get_indices(self, indices: None | int | Iterable[int]) -> Sequence[int]:
        if indices is None:
            return range(self.num_envs)
        if isinstance(indices, int):
            return [indices]
        return list(indices)


def info_column(venv: Any, infos: Sequence[dict[str, Any]], key: str, default: float) -> np.ndarray:
    """The last step's ``key`` of every environment, as floats: the column of a
    :class:`ShieldnavVecEnv`'s ``step_info`` where ``venv`` (or what it wraps) has one, else
    read from the SB3 infos, ``default`` where an info lacks it. Callbacks and wrappers that run
    at every training step read their columns here (no pass over the infos on the native batch)."""
    columns = getattr(getattr(venv, "unwrapped", venv), "step_info", None) if venv is not None else None
    if columns is not None and key in columns:
        return np.asarray(columns[key], dtype=float)
    return np.fromiter((float(info.get(key, default)) for info in infos), dtype=float, count=len(infos))
