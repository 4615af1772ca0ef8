"""Episode checks for controllers and policies: run them on env ids × seeds and assert safety.

    from shieldnav.testing import run_episodes, assert_safe_episodes

    def my_controller(obs, info):
        return np.array([0.5, 0.0, 0.0], dtype=np.float32)

    summaries = run_episodes(my_controller, ["shieldnav/ConstrictedPassage-v0"], seeds=range(10), time_limit=500)
    assert_safe_episodes(summaries, min_coverage=0.0)

``policy`` is a callable ``(obs, info) -> action``, an object with ``act(obs, info)`` (the
shipped policies), a stable-baselines3 model (``predict``, deterministic actions), or one of the
names ``"scripted"`` (:class:`shieldnav.InspectionAgent`) and ``"ppo"`` (the shipped PPO policy).
``env_ids`` holds registered ids and files: a ROS map_server map (``.yaml``/``.yml``, run as
``shieldnav/MapInspection-v0`` with ``map_path``) or a JSON scenario file (``.json``, run as
``shieldnav/CorridorInspection-v0`` with ``scenario_path``).

Two ways to run the episodes, both giving summaries that depend on the seeds only (1 and N
workers give the same table):

- **the native batch**, for vectorisable policies (a stable-baselines3 model, ``"ppo"``, an
  object with ``act_batch(obs, info)``, or any policy with ``vectorised=True``): every seed of an
  id is a sub-environment of one Rust batch (``gymnasium.make_vec``, ``threads=workers``) and
  the policy acts on the ``(n, L)`` observation batch;
- **worker processes** otherwise (one per available CPU by default): the policy goes to each
  episode as a fresh copy (pickled once, unpickled per episode, in the workers as in this
  process).

Both run the same episodes: sub-environment ``i`` of the batch is the single environment reset
with seed ``i``'s. Their summaries are equal when the policy's batched actions equal its
one-by-one actions bit for bit (elementwise policies do; a matrix product may round the last bit
differently for a batch).

The assertion helpers raise ``AssertionError`` naming env id, seed, step and time of the first
violation of each failing episode; with ``gif_dir`` they re-run the first failing episode with
``render_mode="rgb_array"`` and write a GIF of it there.
"""

from __future__ import annotations

import atexit
import concurrent.futures
import concurrent.futures.process
import copy
import math
import multiprocessing
import numbers
import os
import pickle
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

import numpy as np

from shieldnav.exceptions import InvalidArgumentError, ShieldnavError

#: The policy names ``run_episodes`` resolves itself.
POLICY_NAMES = ("scripted", "ppo")
#: GIF frames: every ``_GIF_EVERY``-th step, and this many steps after the violation.
_GIF_EVERY = 5
_GIF_AFTER = 50


@dataclass(frozen=True)
class EpisodeSummary:
    """One episode of :func:`run_episodes`. Steps count from 1; times are simulated seconds.

    ``first_contact_step`` / ``first_deadlock_step`` (and their times) are ``None`` when the
    episode had no contact / no deadlock. ``episode_return`` is the sum of the rewards."""

    env_id: str
    seed: int
    steps: int
    time: float
    contact_steps: int
    first_contact_step: int | None
    first_contact_time: float | None
    deadlock: bool
    first_deadlock_step: int | None
    first_deadlock_time: float | None
    coverage: float
    episode_return: float
    terminated: bool
    truncated: bool

    @property
    def label(self) -> str:
        """``env id, seed N``: how the messages name the episode."""
        return f"{self.env_id} seed {self.seed}"

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


class EpisodeTable(list):  # type: ignore[type-arg]
    """The summaries of :func:`run_episodes` (a list, sorted by env id then seed), remembering
    how they were run so that a failing episode can be re-run (:meth:`rerun`, GIFs)."""

    def __init__(
        self, rows: Iterable[EpisodeSummary], policy_blob: bytes | None, policy: Any, env_kwargs: dict[str, Any], gif_dir: str | None = None, vectorised: bool = False
    ) -> None:
        super().__init__(rows)
        #: Whether the episodes ran on the native batch (a re-run feeds the policy batches of one).
        self.vectorised = vectorised
        self._policy_blob = policy_blob
        self._policy = policy
        self.env_kwargs = dict(env_kwargs)
        #: Where the assertion helpers write the GIF of a failing episode (``None``: nowhere).
        self.gif_dir = gif_dir

    def rerun(self, summary: EpisodeSummary, gif_path: str | os.PathLike[str] | None = None, stop_step: int | None = None) -> EpisodeSummary:
        """Runs ``summary``'s episode again (same policy, keywords and seed); with ``gif_path``
        writes a GIF of it (every 5th step), up to ``stop_step`` if given. Episodes of the
        native batch re-run in a single environment, the policy acting on batches of one."""
        policy = pickle.loads(self._policy_blob) if self._policy_blob is not None else self._policy
        if self.vectorised:
            batch_act = _batch_actor(policy)
            policy = lambda obs, info: np.asarray(batch_act(np.asarray(obs)[None], info))[0]  # noqa: E731
        return _run_one(summary.env_id, summary.seed, policy, self.env_kwargs, gif_path=gif_path, stop_step=stop_step)


def _short(env_id: str) -> str:
    if Path(env_id).suffix.lower() in _FILE_SITES:
        return Path(env_id).stem
    return env_id.split("/", 1)[-1]


#: File suffixes ``env_ids`` takes, and the id that runs them with which keyword.
_FILE_SITES = {".yaml": ("shieldnav/MapInspection-v0", "map_path"), ".yml": ("shieldnav/MapInspection-v0", "map_path"),
               ".json": ("shieldnav/CorridorInspection-v0", "scenario_path")}


def _is_file_entry(entry: Any) -> bool:
    return isinstance(entry, os.PathLike) or (isinstance(entry, str) and Path(entry).suffix.lower() in _FILE_SITES)


def _target(env_id: str) -> tuple[str, dict[str, Any]]:
    """The registered id and site keywords that run an entry of ``env_ids`` (as checked)."""
    suffix = Path(env_id).suffix.lower()
    if suffix not in _FILE_SITES:
        return env_id, {}
    gym_id, key = _FILE_SITES[suffix]
    return gym_id, {key: env_id}


def _check_env_ids(env_ids: Any) -> list[str]:
    """Registered ids (``shieldnav/`` may be left out) and map or scenario files, as strings."""
    from shieldnav.registration import ENV_IDS

    if isinstance(env_ids, (str, os.PathLike)):
        env_ids = [env_ids]
    try:
        ids = list(env_ids)
    except TypeError:
        raise InvalidArgumentError(f"invalid `env_ids`: expected an env id or a list of them, got {env_ids!r}") from None
    if not ids:
        raise InvalidArgumentError("invalid `env_ids`: empty; give at least one of " + ", ".join(sorted(ENV_IDS)))
    out = []
    for env_id in ids:
        if _is_file_entry(env_id):
            path = Path(os.fspath(env_id)).expanduser()
            if path.suffix.lower() not in _FILE_SITES:
                raise InvalidArgumentError(f"invalid `env_ids`: {os.fspath(env_id)!r} is neither a ROS map (.yaml, .yml) nor a scenario file (.json)")
            if not path.is_file():
                raise InvalidArgumentError(f"invalid `env_ids`: no such map or scenario file: {os.fspath(env_id)!r}")
            out.append(str(path))
            continue
        full = env_id if isinstance(env_id, str) and "/" in env_id else f"shieldnav/{env_id}"
        if not isinstance(env_id, str) or full not in ENV_IDS:
            raise InvalidArgumentError(
                f"invalid `env_ids`: unknown environment id {env_id!r}; known ids are {', '.join(sorted(ENV_IDS))}, "
                "or give a ROS map (.yaml) or scenario (.json) file"
            )
        out.append(full)
    return list(dict.fromkeys(out))


def make_env(env_id: str, **kwargs: Any) -> Any:
    """``gymnasium.make`` of an entry of ``env_ids``: a registered id or a map or scenario file."""
    import gymnasium as gym

    import shieldnav  # noqa: F401  (registers the ids in a fresh worker)

    (entry,) = _check_env_ids([env_id])
    gym_id, site = _target(entry)
    return gym.make(gym_id, **site, **kwargs)


def _check_seeds(seeds: Any) -> list[int]:
    if isinstance(seeds, numbers.Integral) and not isinstance(seeds, bool):
        seeds = [seeds]
    try:
        values = list(seeds)
    except TypeError:
        raise InvalidArgumentError(f"invalid `seeds`: expected a seed or a list of seeds (non-negative ints), got {seeds!r}") from None
    if not values:
        raise InvalidArgumentError("invalid `seeds`: empty; give at least one seed (e.g. seeds=range(10))")
    for s in values:
        if isinstance(s, bool) or not isinstance(s, numbers.Integral) or s < 0:
            raise InvalidArgumentError(f"invalid `seeds`: expected non-negative ints, got {s!r}")
    return list(dict.fromkeys(int(s) for s in values))


def _check_count(name: str, value: Any, allow_none: bool = True) -> int | None:
    if value is None and allow_none:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
        raise InvalidArgumentError(f"invalid `{name}`: expected a positive int{' or None' if allow_none else ''}, got {value!r}")
    return int(value)


def _check_policy(policy: Any) -> None:
    if isinstance(policy, str):
        if policy not in POLICY_NAMES:
            raise InvalidArgumentError(f"invalid `policy`: expected a callable (obs, info) -> action, an SB3 model or one of {POLICY_NAMES}, got {policy!r}")
        return
    if not any(callable(policy if m is None else getattr(policy, m, None)) for m in (None, "predict", "act", "act_batch")):
        raise InvalidArgumentError(
            "invalid `policy`: expected a callable (obs, info) -> action, an object with act(obs, info), act_batch(obs, info) or predict(obs), "
            f"or one of {POLICY_NAMES}; "
            f"got {type(policy).__name__}"
        )


def default_workers() -> int:
    """The CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _actor(policy: Any, env: Any) -> Callable[[Any, dict[str, Any]], Any]:
    """``(obs, info) -> action`` for ``policy`` on ``env`` (called once per episode, after reset)."""
    if isinstance(policy, str):
        if policy == "scripted":
            from shieldnav.scripted import InspectionAgent

            agent = InspectionAgent(env)
            agent.reset()
            return agent.act
        from shieldnav.policies import load

        return load(policy, env).act
    if callable(getattr(policy, "predict", None)) and not callable(getattr(policy, "act", None)):
        return lambda obs, info: policy.predict(obs, deterministic=True)[0]
    if callable(getattr(policy, "reset", None)):
        policy.reset()
    if callable(getattr(policy, "act", None)):
        return policy.act
    if callable(getattr(policy, "act_batch", None)) and not callable(policy):
        return lambda obs, info: np.asarray(policy.act_batch(np.asarray(obs)[None], info))[0]
    return policy


def _run_one(env_id: str, seed: int, policy: Any, env_kwargs: dict[str, Any], gif_path: Any = None, stop_step: int | None = None) -> EpisodeSummary:
    env = make_env(env_id, render_mode="rgb_array" if gif_path is not None else None, **env_kwargs)
    frames = []
    try:
        obs, info = env.reset(seed=seed)
        act = _actor(policy, env)
        steps, contact_steps, ret = 0, 0, 0.0
        first_contact = first_deadlock = None
        terminated = truncated = False
        while not (terminated or truncated):
            action = np.asarray(act(obs, info), dtype=np.float32)
            obs, reward, terminated, truncated, info = env.step(action)
            steps += 1
            ret += float(reward)
            if info.get("collision") or info.get("contacts", 0) > 0:
                contact_steps += 1
                if first_contact is None:
                    first_contact = (steps, float(info["time"]))
            if info.get("deadlock") and first_deadlock is None:
                first_deadlock = (steps, float(info["time"]))
            if gif_path is not None and (steps % _GIF_EVERY == 1 or steps == stop_step):
                frames.append(env.render())
            if stop_step is not None and steps >= stop_step + _GIF_AFTER:
                break
        summary = EpisodeSummary(
            env_id=env_id, seed=seed, steps=steps, time=float(info.get("time", math.nan)), contact_steps=contact_steps,
            first_contact_step=first_contact and first_contact[0], first_contact_time=first_contact and first_contact[1],
            deadlock=first_deadlock is not None,
            first_deadlock_step=first_deadlock and first_deadlock[0], first_deadlock_time=first_deadlock and first_deadlock[1],
            coverage=float(info.get("coverage", 0.0)), episode_return=ret, terminated=bool(terminated), truncated=bool(truncated),
        )
    finally:
        env.close()
    if gif_path is not None:
        from shieldnav.rendering import save_video

        save_video(frames, gif_path, fps=10)
    return summary


def _run_task(env_id: str, seed: int, policy_blob: bytes | None, policy: Any, env_kwargs: dict[str, Any]) -> EpisodeSummary:
    """One episode with a fresh copy of the policy (the same in a worker and in this process)."""
    if policy_blob is not None:
        policy = pickle.loads(policy_blob)
    return _run_one(env_id, seed, policy, env_kwargs)


def _batch_actor(policy: Any) -> Callable[[np.ndarray, dict[str, Any]], Any]:
    """``(obs batch, info) -> action batch`` for a vectorisable policy."""
    if isinstance(policy, str):
        from shieldnav.policies import load

        return load(policy).act
    if callable(getattr(policy, "reset", None)):
        policy.reset()
    if callable(getattr(policy, "act_batch", None)):
        return policy.act_batch
    if callable(getattr(policy, "predict", None)) and not callable(getattr(policy, "act", None)):
        return lambda obs, info: policy.predict(obs, deterministic=True)[0]
    if callable(getattr(policy, "act", None)):
        return policy.act
    return policy


def _vectorisable(policy: Any) -> bool:
    """Whether a policy acts on observation batches by itself: an SB3 model, ``"ppo"``, an
    object with ``act_batch``."""
    if isinstance(policy, str):
        return policy == "ppo"
    if callable(getattr(policy, "act_batch", None)):
        return True
    return callable(getattr(policy, "predict", None)) and not callable(getattr(policy, "act", None))


def _run_batch(env_id: str, seeds: list[int], policy: Any, env_kwargs: dict[str, Any], threads: int) -> list[EpisodeSummary]:
    """One episode per seed, every seed a sub-environment of one native batch (sub-environment
    ``i`` is the single environment reset with ``seeds[i]``); the policy acts on the batch."""
    import gymnasium as gym

    import shieldnav  # noqa: F401  (registers the ids)

    gym_id, site = _target(env_id)
    n = len(seeds)
    venv = gym.make_vec(gym_id, num_envs=n, vectorization_mode="vector_entry_point", threads=threads, **site, **env_kwargs)
    try:
        obs, info = venv.reset(seed=seeds)  # type: ignore[arg-type]  # (a seed per sub-environment)
        act = _batch_actor(policy)
        want = (n, *(venv.single_action_space.shape or ()))
        active = np.ones(n, bool)
        steps = np.zeros(n, np.int64)
        contact_steps = np.zeros(n, np.int64)
        ret = np.zeros(n)
        first_contact: list[tuple[int, float] | None] = [None] * n
        first_deadlock: list[tuple[int, float] | None] = [None] * n
        rows: list[EpisodeSummary | None] = [None] * n
        while active.any():
            actions = np.asarray(act(obs, info), dtype=np.float32)
            if actions.shape != want:
                raise InvalidArgumentError(
                    f"invalid `policy`: on a batch of {n} observations it returned actions of shape {actions.shape}, "
                    f"expected {want}; pass vectorised=False to run it one observation at a time"
                )
            obs, reward, terminated, truncated, info = venv.step(actions)
            steps[active] += 1
            ret[active] += reward[active]
            touched = active & (info["collision"] | (info["contacts"] > 0))
            contact_steps += touched
            for i in np.flatnonzero(touched | (active & info["deadlock"])):
                t = (int(steps[i]), float(info["time"][i]))
                if touched[i] and first_contact[i] is None:
                    first_contact[i] = t
                if info["deadlock"][i] and first_deadlock[i] is None:
                    first_deadlock[i] = t
            for i in np.flatnonzero(active & (terminated | truncated)):
                fc, fd = first_contact[i], first_deadlock[i]
                rows[i] = EpisodeSummary(
                    env_id=env_id, seed=seeds[i], steps=int(steps[i]), time=float(info["time"][i]), contact_steps=int(contact_steps[i]),
                    first_contact_step=fc and fc[0], first_contact_time=fc and fc[1], deadlock=fd is not None,
                    first_deadlock_step=fd and fd[0], first_deadlock_time=fd and fd[1],
                    coverage=float(info["coverage"][i]), episode_return=float(ret[i]), terminated=bool(terminated[i]), truncated=bool(truncated[i]),
                )
                active[i] = False
    finally:
        venv.close()
    return [r for r in rows if r is not None]


def run_episodes(
    policy: Any,
    env_ids: str | Sequence[str],
    seeds: int | Iterable[int],
    workers: int | None = None,
    max_steps: int | None = None,
    gif_dir: str | os.PathLike[str] | None = None,
    vectorised: bool | None = None,
    **env_kwargs: Any,
) -> EpisodeTable:
    """Runs ``policy`` for one episode on every env id × seed and returns the summaries, sorted
    by (env id, seed).

    ``workers``: processes to run on (default: the CPUs available, at most one per episode; 1
    runs in this process), or the native batch's threads.
    ``vectorised``: run on the native batch (True), in processes (False), or decide from the
    policy (None: an SB3 model, ``"ppo"`` and objects with ``act_batch`` run on the batch;
    ``"scripted"`` and plain callables in processes). With True, a plain callable is called as
    ``policy(obs_batch, info)`` and must return an ``(n, 3)`` action batch. A policy that cannot be pickled (a lambda, a closure) runs in this
    process when ``workers`` is not given, and is an error with ``workers > 1``. The worker
    processes are spawned (they import the main module: guard a script's code with
    ``if __name__ == "__main__":``) and kept for the next call with as many workers.
    ``max_steps``: the episodes' ``time_limit`` (default: each id's registered one).
    ``gif_dir``: where the assertion helpers write the GIF of a failing episode.
    Every other keyword goes to ``gymnasium.make`` (``shield="none"``, ``deadlock_window=2.0``, …).
    """
    ids = _check_env_ids(env_ids)
    seed_list = _check_seeds(seeds)
    _check_policy(policy)
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, numbers.Integral) or workers < 1):
        raise InvalidArgumentError(f"invalid `workers`: expected a positive int (processes) or None for the CPUs available, got {workers!r}")
    max_steps = _check_count("max_steps", max_steps)
    if "render_mode" in env_kwargs:
        raise InvalidArgumentError("invalid `render_mode`: run_episodes runs without rendering; pass gif_dir= for a GIF of a failing episode")
    if max_steps is not None:
        if "time_limit" in env_kwargs:
            raise InvalidArgumentError("invalid `max_steps`: give max_steps or time_limit, not both")
        env_kwargs["time_limit"] = max_steps
    if gif_dir is not None and not isinstance(gif_dir, (str, os.PathLike)):
        raise InvalidArgumentError(f"invalid `gif_dir`: expected a folder path, got {gif_dir!r}")
    if vectorised is not None and not isinstance(vectorised, bool):
        raise InvalidArgumentError(f"invalid `vectorised`: expected True, False or None, got {vectorised!r}")
    if vectorised and policy == "scripted":
        raise InvalidArgumentError("invalid `vectorised`: the scripted agent keeps a plan per environment and runs one environment at a time")
    flat = env_kwargs.get("observation", "flat") == "flat"  # (the native batch serves the flat observation only)
    if vectorised and not flat:
        raise InvalidArgumentError(f"invalid `vectorised`: the native batch serves the flat observation only (got observation={env_kwargs['observation']!r})")
    use_batch = vectorised if vectorised is not None else (_vectorisable(policy) and flat)

    try:
        blob: bytes | None = pickle.dumps(policy)
        pickle_error = None
    except (pickle.PicklingError, TypeError, AttributeError) as err:
        blob, pickle_error = None, err
    if use_batch:
        threads = default_workers() if workers is None else int(workers)
        rows = [r for env_id in ids for r in _run_batch(env_id, seed_list, pickle.loads(blob) if blob is not None else _fresh(policy), env_kwargs, threads)]
        rows.sort(key=lambda r: (r.env_id, r.seed))
        return EpisodeTable(rows, blob, policy, env_kwargs, gif_dir=None if gif_dir is None else os.fspath(gif_dir), vectorised=True)
    tasks = [(env_id, seed) for env_id in ids for seed in seed_list]
    n = min(default_workers() if workers is None else int(workers), len(tasks))
    if blob is None and n > 1:
        if workers is not None:
            raise InvalidArgumentError(
                f"invalid `policy`: {type(policy).__name__} cannot be pickled to send to worker processes ({pickle_error}); "
                "pass workers=1 to run it in this process, or define it at module level"
            )
        n = 1  # runs in this process: a lambda or closure cannot travel
    if n == 1:
        # a deep copy per episode where pickling fails, so that state does not leak between episodes
        rows = [_run_task(e, s, blob, policy if blob is not None else _fresh(policy), env_kwargs) for e, s in tasks]
    else:
        pool = _pool(n)
        try:
            futures = [pool.submit(_run_task, e, s, blob, None, env_kwargs) for e, s in tasks]
            rows = [f.result() for f in futures]
        except concurrent.futures.process.BrokenProcessPool as err:
            _POOLS.pop(n, None)
            raise ShieldnavError(
                "a worker process of run_episodes died: run from a file whose script code sits under `if __name__ == \"__main__\":` "
                "(worker processes are spawned and import the main module), or pass workers=1 to run in this process"
            ) from err
    rows.sort(key=lambda r: (r.env_id, r.seed))
    return EpisodeTable(rows, blob, policy, env_kwargs, gif_dir=None if gif_dir is None else os.fspath(gif_dir))


#: Worker pools by size, kept for the next call (starting a worker imports shieldnav: about a second).
_POOLS: dict[int, concurrent.futures.ProcessPoolExecutor] = {}


def _pool(n: int) -> concurrent.futures.ProcessPoolExecutor:
    pool = _POOLS.get(n)
    if pool is None:
        pool = _POOLS[n] = concurrent.futures.ProcessPoolExecutor(max_workers=n, mp_context=multiprocessing.get_context("spawn"))
    return pool


def _shutdown_pools() -> None:
    for pool in _POOLS.values():
        pool.shutdown(cancel_futures=True)
    _POOLS.clear()


atexit.register(_shutdown_pools)


def _fresh(policy: Any) -> Any:
    try:
        return copy.deepcopy(policy)
    except Exception:  # noqa: BLE001 - an uncopyable policy is used as it is
        return policy


def cases(env_ids: str | Sequence[str], seeds: int | Iterable[int]) -> list[Any]:
    """``pytest.param(env_id, seed)`` for every id × seed, with ids like ``ConstrictedPassage-v0-seed3``::

        @pytest.mark.parametrize("env_id, seed", cases(["ConstrictedPassage-v0"], range(3)))
        def test_safe(env_id, seed): ...
    """
    import pytest

    return [pytest.param(e, s, id=f"{_short(e)}-seed{s}") for e in _check_env_ids(env_ids) for s in _check_seeds(seeds)]


# ----------------------------------------------------------------------------------------------
# assertion helpers


def _rows(summaries: Any) -> list[EpisodeSummary]:
    if isinstance(summaries, EpisodeSummary):
        return [summaries]
    rows = list(summaries)
    for r in rows:
        if not isinstance(r, EpisodeSummary):
            raise InvalidArgumentError(f"invalid `summaries`: expected EpisodeSummary items (from run_episodes), got {type(r).__name__}")
    return rows


def _fmt_time(t: float | None) -> str:
    return "n/a" if t is None else f"{t:.2f} s"


def _contact(r: EpisodeSummary) -> tuple[int, str] | None:
    if r.first_contact_step is None:
        return None
    return r.first_contact_step, (
        f"first contact at step {r.first_contact_step} (t = {_fmt_time(r.first_contact_time)}), {r.contact_steps} steps in contact"
    )


def _deadlock(r: EpisodeSummary) -> tuple[int, str] | None:
    if r.first_deadlock_step is None:
        return None
    return r.first_deadlock_step, f"deadlock detected at step {r.first_deadlock_step} (t = {_fmt_time(r.first_deadlock_time)})"


def _coverage(minimum: float) -> Callable[[EpisodeSummary], tuple[int, str] | None]:
    def check(r: EpisodeSummary) -> tuple[int, str] | None:
        if r.coverage >= minimum:
            return None
        return r.steps, f"coverage {100 * r.coverage:.1f} % < {100 * minimum:.1f} % at the end, step {r.steps} (t = {_fmt_time(r.time)})"

    return check


def _check(summaries: Any, checks: Sequence[tuple[str, Callable[[EpisodeSummary], tuple[int, str] | None]]], gif_dir: Any) -> None:
    rows = _rows(summaries)
    failures: list[tuple[EpisodeSummary, str, int, str]] = []
    for r in rows:
        found = [(kind, v) for kind, check in checks if (v := check(r)) is not None]
        if found:
            kind, (step, _) = min(found, key=lambda kv: kv[1][0])  # the first violation in time
            failures.append((r, kind, step, f"{r.label}: " + "; ".join(msg for _, (_, msg) in found)))
    if not failures:
        return
    names = ", ".join(kind for kind, _ in checks)
    lines = [f"{len(failures)} of {len(rows)} episodes failed ({names}):"] + [f"  {msg}" for _, _, _, msg in failures]
    gif_dir = gif_dir if gif_dir is not None else getattr(summaries, "gif_dir", None)
    if gif_dir is not None:
        r, kind, step, _ = failures[0]
        if isinstance(summaries, EpisodeTable):
            folder = Path(gif_dir)
            folder.mkdir(parents=True, exist_ok=True)
            path = folder / f"{_short(r.env_id)}-seed{r.seed}-{kind}.gif"
            try:
                summaries.rerun(r, gif_path=path, stop_step=step)
                lines.append(f"GIF of {r.label}: {path}")
            except Exception as err:  # noqa: BLE001 - the assertion matters more than the GIF
                lines.append(f"(no GIF of {r.label}: {type(err).__name__}: {err})")
        else:
            lines.append("(no GIF: these summaries do not come from run_episodes, which keeps the policy to re-run them)")
    raise AssertionError("\n".join(lines))


def assert_no_contact(summaries: Any, gif_dir: str | os.PathLike[str] | None = None) -> None:
    """Fails naming env id, seed, step and time of each episode's first contact."""
    _check(summaries, [("contact", _contact)], gif_dir)


def assert_no_deadlock(summaries: Any, gif_dir: str | os.PathLike[str] | None = None) -> None:
    """Fails naming env id, seed, step and time of each episode's first deadlock (the env's
    ``deadlock_window`` / ``deadlock_displacement`` decide what one is)."""
    _check(summaries, [("deadlock", _deadlock)], gif_dir)


def _check_fraction(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not 0.0 <= float(value) <= 1.0:
        raise InvalidArgumentError(f"invalid `{name}`: expected a fraction in [0, 1], got {value!r}")
    return float(value)


def assert_coverage_at_least(summaries: Any, minimum: float, gif_dir: str | os.PathLike[str] | None = None) -> None:
    """Fails naming each episode that ended with less than ``minimum`` (a fraction) of the walls inspected."""
    _check(summaries, [("coverage", _coverage(_check_fraction("minimum", minimum)))], gif_dir)


def assert_safe_episodes(
    summaries: Any, *, contact: bool = True, deadlock: bool = True, min_coverage: float | None = None, gif_dir: str | os.PathLike[str] | None = None
) -> None:
    """The checks combined: no contact, no deadlock and (with ``min_coverage``) enough coverage;
    one message lists every failing episode with its first violation."""
    checks: list[tuple[str, Callable[[EpisodeSummary], tuple[int, str] | None]]] = []
    if contact:
        checks.append(("contact", _contact))
    if deadlock:
        checks.append(("deadlock", _deadlock))
    if min_coverage is not None:
        checks.append(("coverage", _coverage(_check_fraction("min_coverage", min_coverage))))
    if not checks:
        raise InvalidArgumentError("invalid arguments: every check is off (contact=False, deadlock=False, min_coverage=None)")
    _check(summaries, checks, gif_dir)


__all__ = [
    "EpisodeSummary",
    "EpisodeTable",
    "assert_coverage_at_least",
    "assert_no_contact",
    "assert_no_deadlock",
    "assert_safe_episodes",
    "cases",
    "default_workers",
    "make_env",
    "run_episodes",
]
