"""One benchmark episode as a self-contained task: build the env, run a policy, return the
episode's metrics and (optionally) its time series and video frames.

Tasks are plain dicts in and out, so that a process pool or Ray can run them; the same task
gives the same metrics (everything but wall times) on any backend.
"""

from __future__ import annotations

import importlib
import sys
import time
from pathlib import Path
from typing import Any, Callable

import gymnasium as gym
import numpy as np
import shieldnav  # noqa: F401  (registers the ids)
from shieldnav.exceptions import InvalidArgumentError

Policy = Callable[[Any, dict[str, Any]], np.ndarray]


def load_policy(spec: str, env: gym.Env[Any, Any]) -> tuple[Policy, Callable[[], None]]:
    """``(act, reset)`` for a policy spec: ``"scripted"`` (the inspection agent), ``"ppo"``
    (the shipped PPO policy, numpy only), a saved SB3
    model (``*.zip``, PPO or SAC), or ``"module:callable"`` where ``callable(env)`` returns
    ``act(obs, info) -> action`` (and may have a ``reset()``)."""
    if spec == "ppo":
        from shieldnav.policies import load

        policy = load("ppo", env)
        return policy.act, policy.reset
    if spec == "scripted":
        from shieldnav.scripted import InspectionAgent

        agent = InspectionAgent(env)
        return agent.act, agent.reset
    if spec.endswith(".zip"):
        try:
            from stable_baselines3 import PPO, SAC
        except ImportError as err:
            raise InvalidArgumentError(f'invalid `policy`: loading {spec} needs stable-baselines3 ({err}): pip install "shieldnav[train]"') from err

        if not Path(spec).exists():
            raise InvalidArgumentError(f"invalid `policy`: the model file {spec} does not exist")
        errors = []
        for algo in (PPO, SAC):
            try:
                model = algo.load(spec, device="cpu")
                break
            except Exception as err:  # noqa: BLE001 - report every loader's reason below
                errors.append(f"{algo.__name__}: {err}")
        else:
            raise InvalidArgumentError(f"invalid `policy`: {spec} is not a PPO or SAC model ({'; '.join(errors)})")
        for what, made_for, env_space in (("observation", model.observation_space, env.observation_space),
                                          ("action", model.action_space, env.action_space)):
            if made_for != env_space:
                theirs, ours = _space(made_for), _space(env_space)
                if theirs == ours:
                    theirs += " with other bounds"
                name = env.spec.id if env.spec else "the environment"
                raise InvalidArgumentError(f"invalid `policy`: {spec} was made for the {what} space {theirs}, {name} has {ours}")

        def act(obs: Any, info: dict[str, Any]) -> np.ndarray:
            return model.predict(obs, deterministic=True)[0]

        return act, lambda: None
    if ":" in spec:
        module, name = spec.split(":", 1)
        try:
            imported = importlib.import_module(module)
        except Exception as err:  # noqa: BLE001 - the user's module may fail in any way: name it
            raise InvalidArgumentError(f"invalid `policy`: cannot import the module {module!r} ({type(err).__name__}: {err})") from err
        if not hasattr(imported, name):
            raise InvalidArgumentError(f"invalid `policy`: the module {module!r} has no {name!r}")
        factory = getattr(imported, name)
        if not callable(factory):
            raise InvalidArgumentError(f"invalid `policy`: {spec} is not callable")
        try:
            policy = factory(env)
        except Exception as err:  # noqa: BLE001 - the user's factory: name it and its error
            raise InvalidArgumentError(f"invalid `policy`: {spec}(env) raised {type(err).__name__}: {err}") from err
        if not callable(policy):
            raise InvalidArgumentError(f"invalid `policy`: {spec}(env) returned {type(policy).__name__}, not a callable act(obs, info)")
        return policy, getattr(policy, "reset", lambda: None)
    raise InvalidArgumentError(f"invalid `policy`: expected 'scripted', a .zip SB3 model or 'module:callable', got {spec!r}")


def _space(space: Any) -> str:
    """A space in a few words (a Box's bounds can run to hundreds of numbers)."""
    text = str(space)
    return text if len(text) <= 60 else f"{type(space).__name__} of shape {space.shape}, {space.dtype}"


def check_policy(task: dict[str, Any]) -> None:
    """Loads the task's policy on the task's environment and steps it once from a reset:
    raises :class:`InvalidArgumentError` for a policy that does not load, whose factory or
    ``act`` fails, or whose action does not fit the action space, before any episode runs."""
    spec = task.get("policy", "scripted")
    env = gym.make(task["env_id"], shield=task["shield"], **task.get("kwargs", {}))
    try:
        act, reset = load_policy(spec, env)
        obs, info = env.reset(seed=int(task.get("seed", 0)))
        try:
            reset()
            action = act(obs, info)
        except Exception as err:  # noqa: BLE001 - the policy's own code: name it and its error
            raise InvalidArgumentError(f"invalid `policy`: {spec} raised {type(err).__name__} on a reset observation: {err}") from err
        try:
            env.step(action)
        except InvalidArgumentError as err:
            raise InvalidArgumentError(f"invalid `policy`: {spec}'s action does not fit {_space(env.action_space)}: {err}") from err
    finally:
        env.close()


def run_episode(task: dict[str, Any]) -> dict[str, Any]:
    """Runs ``task = {env_id, shield, seed, policy, kwargs, trace, video_every}``.

    Returns the task, the episode summary, wall-clock figures, the shield's per-step times and
    point counts, and with ``trace`` the time series (t, u_nom, u*, H, h_min) and with
    ``video_every > 0`` every n-th rendered frame. ``steps_per_s`` times the policy and the
    environment's step only: the tracing is not timed and the frames, captured during the
    episode, are drawn after it, so episodes with and without a video compare.
    """
    kwargs = {"report_timing": True, **task.get("kwargs", {})}  # (the shield's time per step)
    video_every = int(task.get("video_every", 0))
    env = gym.make(task["env_id"], shield=task["shield"], **kwargs)
    act, reset = load_policy(task.get("policy", "scripted"), env)
    obs, info = env.reset(seed=int(task["seed"]))
    reset()
    solve, points, frames = [], [], []
    series: dict[str, list[Any]] = {k: [] for k in ("t", "u_nom", "u_star", "H", "h_min", "clearance")}
    wall = 0.0
    steps = 0
    while True:
        t0 = time.perf_counter()
        obs, _, terminated, truncated, info = env.step(act(obs, info))
        wall += time.perf_counter() - t0
        steps += 1
        solve.append(info["solve_time_ns"])
        points.append(info["num_points"])
        if task.get("trace"):
            series["t"].append(info["time"])
            series["u_nom"].append(info["u_nom"][:2].tolist())
            series["u_star"].append(info["u_filtered"][:2].tolist())
            series["H"].append(info["H"])
            series["h_min"].append(info["h_min"])
            series["clearance"].append(info["clearance"])
        if video_every and steps % video_every == 0:
            frames.append(env.unwrapped.render_frame())  # type: ignore[attr-defined]
        if terminated or truncated:
            break
    summary = env.unwrapped.episode.summary()  # type: ignore[attr-defined]
    env.close()
    if frames:  # what env.render() draws, drawn here so that the step timing leaves it out
        from shieldnav.rendering import TopDownRenderer

        renderer = TopDownRenderer()
        frames = [renderer.draw(f) for f in frames]
    return {
        "task": {k: v for k, v in task.items() if k != "kwargs"} | {"kwargs": kwargs},
        "summary": summary,
        "steps_per_s": steps / wall,
        "solve_time_ns": np.asarray(solve, dtype=np.int64),
        "num_points": np.asarray(points, dtype=np.int32),
        "series": series if task.get("trace") else None,
        "frames": frames,
    }


if __name__ == "__main__":  # a library module: say which modules are command lines
    print("agents.episodes is not a command line; the command lines are python -m agents.train, agents.benchmark "
          "and agents.sweep (each with --help)", file=sys.stderr)
    sys.exit(2)
