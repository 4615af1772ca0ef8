"""Train PPO, SAC or PPO-Lagrangian (``--algo ppo_lagrangian``, `agents.lagrangian`; stable-baselines3)
on the corridor environments, with the shield in the
loop (the policy's command is filtered during training; ``--shield braking``, the default) or
without (``--shield none``).

Training runs on the native Rust batch (``shieldnav.sb3.ShieldnavVecEnv``, no subprocesses).
An evaluation callback runs deterministic episodes on a separate environment and logs return,
episodes with contact, deadlock rate and coverage; checkpoints and TensorBoard logs (or, without
TensorBoard, ``progress.csv``) go to the run folder, and ``model.zip`` is what ``python -m agents.benchmark --policy`` loads.
Safety over every training step (contact steps, episodes with contact, interventions,
infeasible, braked and recovering steps) is logged as ``train_safety/*`` and kept in
``run.json`` under ``training_safety``.

Hyperparameters, the number of environments and the run's length come from an rl-zoo3-style
file, ``agents/hyperparams/<algo>.yml`` (``--hyperparams FILE`` for another); flags override them.

    python -m agents.train --algo ppo --env shieldnav/CorridorInspection-v0 --shield braking --seed 0 --out runs/ppo_braking
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import shieldnav  # noqa: F401  (registers the ids)
from shieldnav.exceptions import InvalidArgumentError

try:
    import torch
    from stable_baselines3 import PPO, SAC
    from stable_baselines3.common.callbacks import BaseCallback, CallbackList, CheckpointCallback
    from stable_baselines3.common.logger import configure as configure_logger
    from stable_baselines3.common.vec_env import VecCheckNan, VecMonitor
except ImportError as err:  # pragma: no cover
    raise ImportError('training needs stable-baselines3 and torch: pip install "shieldnav[train]"') from err

from shieldnav.registration import ENV_IDS
from shieldnav.sb3 import ShieldnavVecEnv, info_column
from shieldnav.vector import CorridorInspectionVectorEnv

from agents import benchmark
from agents.lagrangian import PPOLagrangian

ALGOS = {"ppo": PPO, "sac": SAC, "ppo_lagrangian": PPOLagrangian}
#: The hyperparameter files, one an algorithm (``<algo>.yml``), in rl-zoo3's format.
HYPERPARAMS = Path(__file__).with_name("hyperparams")
#: The keys of a hyperparameter block that are not constructor keywords (rl-zoo3's names).
RUN_KEYS = ("policy", "n_timesteps", "n_envs")


def hyperparameters(algo: str, env_id: str, path: Path | None = None) -> dict[str, Any]:
    """The block for ``env_id`` of the rl-zoo3-style file ``path`` (default:
    ``agents/hyperparams/<algo>.yml``): ``policy``, ``n_envs``, ``n_timesteps`` and the
    algorithm's constructor keywords."""
    import yaml

    path = Path(path) if path is not None else HYPERPARAMS / f"{algo}.yml"
    try:
        blocks = yaml.safe_load(path.read_text())
    except OSError as err:
        raise InvalidArgumentError(f"invalid `hyperparams`: cannot read {path} ({err.strerror or err})") from err
    except yaml.YAMLError as err:
        raise InvalidArgumentError(f"invalid `hyperparams`: {path} is not YAML ({err})") from err
    if not isinstance(blocks, dict) or not isinstance(blocks.get(env_id), dict):
        raise InvalidArgumentError(f"invalid `hyperparams`: {path} has no block for {env_id!r} (rl-zoo3's format: a block per environment id)")
    block = dict(blocks[env_id])
    for key in ("n_envs", "n_timesteps"):
        value = block.get(key, 1)
        if not isinstance(value, (int, float)) or isinstance(value, bool) or value < 1 or value != int(value):
            raise InvalidArgumentError(f"invalid `hyperparams`: {path}: {env_id}: `{key}` must be a whole number ≥ 1, got {value!r}")
        if key in block:
            block[key] = int(value)
    return block


#: The evaluation episodes of a run seeded ``seed`` are seeded ``seed + EVAL_SEED_OFFSET + k``.
EVAL_SEED_OFFSET = 10_000
#: Seeds SB3 accepts are below this (it seeds NumPy's global generator).
SEED_END = 2**32


def progress_bar_missing() -> str | None:
    """Why SB3's progress bar (tqdm's rich bar) cannot be shown, or None when it can."""
    try:
        importlib.import_module("tqdm.rich")
    except ImportError as err:
        return f"the progress bar needs tqdm and rich ({err}): pip install tqdm rich"
    return None


def seed_number(text: str) -> int:
    """argparse type: a seed SB3 accepts."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if not 0 <= value < SEED_END:
        raise argparse.ArgumentTypeError(f"must be in 0 … 2**32 − 1, got {value}")
    return value


def evaluate(model: Any, env_id: str, episodes: int, seed: int, **kwargs: Any) -> dict[str, float]:
    """Deterministic episodes of ``model``, seeded ``seed + k``, side by side on the native batch
    (one sub-environment an episode, each stopped at its first episode's end): the same
    episodes as single environments reset with those seeds, at the batch's speed."""
    kwargs = {**gym.spec(env_id).kwargs, **kwargs}
    venv = CorridorInspectionVectorEnv(episodes, autoreset_mode="next_step", **kwargs)
    obs, _ = venv.reset(seed=seed)
    returns = np.zeros(episodes)
    running = np.ones(episodes, dtype=bool)
    rows = np.zeros((episodes, 4))
    while running.any():
        action, _ = model.predict(obs, deterministic=True)
        obs, reward, terminated, truncated, info = venv.step(action)
        returns += np.where(running, reward, 0.0)
        ended = running & (terminated | truncated)
        if ended.any():
            totals = info["shieldnav_episode"]
            rows[ended] = np.stack([totals["collisions"] > 0, totals["deadlock"], totals["coverage"], totals["contact_time"]], axis=1)[ended]
            running &= ~ended
    venv.close()
    return {"return": returns.mean(), "episodes_with_contact": rows[:, 0].mean(), "deadlock_rate": rows[:, 1].mean(),
            "coverage": rows[:, 2].mean(), "contact_time": rows[:, 3].mean()}


class EvalSafety(BaseCallback):
    """Every ``every`` steps: evaluate and log ``eval/*`` (return, contact, deadlock, coverage)."""

    def __init__(self, env_id: str, every: int, episodes: int, seed: int, env_kwargs: dict[str, Any]) -> None:
        super().__init__()
        self.env_id, self.every, self.episodes, self.seed, self.env_kwargs = env_id, every, episodes, seed, env_kwargs
        self.history: list[dict[str, float]] = []
        self._next = every

    def _on_step(self) -> bool:
        if self.num_timesteps >= self._next:
            self._next += self.every
            stats = evaluate(self.model, self.env_id, self.episodes, self.seed, **self.env_kwargs)
            for k, v in stats.items():
                self.logger.record(f"eval/{k}", v)
            self.history.append({"timesteps": self.num_timesteps, **stats})
        return True


class TrainingSafety(BaseCallback):
    """Safety over every training step, not only evaluation: contact steps (the sum of
    ``info["cost"]``), episodes with contact, shield interventions (steps where the shield
    changed the command), infeasible, braked and recovering steps. Logged as ``train_safety/*``
    and kept in ``totals``. Every training episode that ends is kept in ``episodes``: the step
    count at its end, its return (the environment's, as ``VecMonitor`` records it), length,
    coverage, contact steps, and the contact steps of the whole run so far — the learning curves."""

    def __init__(self) -> None:
        super().__init__()
        self.totals = {k: 0 for k in ("steps", "contact_steps", "episodes", "episodes_with_contact", "interventions",
                                       "infeasible_steps", "braked_steps", "recovering_steps")}
        self.episodes: list[dict[str, float]] = []
        self._touched: np.ndarray | None = None
        self._contacts: np.ndarray | None = None

    def _on_step(self) -> bool:
        infos, dones = self.locals["infos"], self.locals["dones"]
        if self._touched is None or self._contacts is None:
            self._touched = np.zeros(len(infos), dtype=bool)
            self._contacts = np.zeros(len(infos), dtype=np.int64)
        t = self.totals
        n = len(infos)
        # (a column per key, not a dict update per environment and key: this callback runs at
        # every vector step of a training run)
        def column(key: str, default: float) -> np.ndarray:
            return info_column(self.training_env, infos, key, default)

        cost = column("cost", 0.0) > 0.0
        t["steps"] += n
        t["contact_steps"] += int(cost.sum())
        t["interventions"] += int((column("intervention", 0.0) > 1e-9).sum())
        t["infeasible_steps"] += int((column("shield_feasible", 1.0) == 0.0).sum())
        t["braked_steps"] += int(column("shield_braked", 0.0).sum())
        t["recovering_steps"] += int(column("shield_recovering", 0.0).sum())
        self._touched |= cost
        self._contacts += cost
        for i in np.flatnonzero(dones):
            info = infos[i]
            t["episodes"] += 1
            t["episodes_with_contact"] += int(self._touched[i])
            monitor, summary = info.get("episode", {}), info.get("shieldnav_episode", {})
            self.episodes.append({"timesteps": self.num_timesteps, "return": float(monitor.get("r", np.nan)), "length": int(monitor.get("l", 0)),
                                  "coverage": float(summary.get("coverage", np.nan)), "contact_steps": int(self._contacts[i]),
                                  "run_contact_steps": t["contact_steps"]})
            self._touched[i] = False
            self._contacts[i] = 0
        for k, v in t.items():
            self.logger.record(f"train_safety/{k}", v)
        return True


def train(algo: str, env_id: str, shield: str, timesteps: int | None, num_envs: int | None, seed: int, out: Path,
          eval_every: int = 50_000, eval_episodes: int = 8, tensorboard: bool = True, progress: bool = True,
          max_episode_steps: int | None = None, hyperparams: dict[str, Any] | None = None, policy: str | None = None,
          threads: int | None = None, hyperparams_file: Path | None = None, **env_kwargs: Any) -> Path:
    """Trains and saves ``out/model.zip``; returns its path. The hyperparameters are the block
    for ``env_id`` of ``hyperparams_file`` (default ``agents/hyperparams/<algo>.yml``, see
    `hyperparameters`): ``timesteps``, ``num_envs`` and ``policy`` left ``None`` take its
    ``n_timesteps``, ``n_envs`` and ``policy``; ``hyperparams`` go to the algorithm's
    constructor over its other keys. Every argument is
    checked, and the environments built, before ``out`` is created. ``out/run.json`` (the run's
    settings, safety totals, training episodes, evaluations, wall time and env steps/s) is
    written last, whole or not at all: its presence means the run finished. ``threads``: the
    native batch's worker threads (default: the usable cores)."""
    if algo not in ALGOS:
        raise InvalidArgumentError(f"invalid `algo`: expected one of {sorted(ALGOS)}, got {algo!r}")
    if env_id not in ENV_IDS:
        raise InvalidArgumentError(f"invalid `env_id`: expected a shieldnav id ({', '.join(sorted(ENV_IDS))}), got {env_id!r}")
    if shield not in benchmark.SHIELDS:
        raise InvalidArgumentError(f"invalid `shield`: expected one of {benchmark.SHIELDS}, got {shield!r}")
    if not 0 <= seed < SEED_END:
        raise InvalidArgumentError(f"invalid `seed`: must be in 0 … 2**32 − 1, got {seed}")
    block = hyperparameters(algo, env_id, hyperparams_file)
    timesteps = timesteps if timesteps is not None else block.get("n_timesteps", 200_000)
    num_envs = num_envs if num_envs is not None else block.get("n_envs", 8)
    policy = policy if policy is not None else block.get("policy", "MlpPolicy")
    counts = {"timesteps": timesteps, "num_envs": num_envs, "eval_every": eval_every, "eval_episodes": eval_episodes}
    if max_episode_steps is not None:
        counts["max_episode_steps"] = max_episode_steps
    for name, value in counts.items():
        if value < 1:
            raise InvalidArgumentError(f"invalid `{name}`: must be at least 1, got {value}")
    if progress and (missing := progress_bar_missing()):
        raise ImportError(f"{missing}, or pass progress=False")
    eval_kwargs = {"shield": shield, **env_kwargs}
    if max_episode_steps is not None:
        eval_kwargs["max_episode_steps"] = eval_kwargs["time_limit"] = max_episode_steps
    gym.make(env_id, **eval_kwargs).close()  # the environment's settings, checked before the run folder
    torch.manual_seed(seed)
    torch.set_num_threads(1)
    kwargs = {"shield": shield, **env_kwargs}
    if max_episode_steps is not None:
        kwargs["max_episode_steps"] = max_episode_steps
    venv = VecCheckNan(VecMonitor(ShieldnavVecEnv(env_id, num_envs=num_envs, threads=threads, **kwargs)), raise_exception=True)
    venv.seed(seed)
    tb = None
    if tensorboard:
        try:
            import tensorboard  # noqa: F401

            tb = str(out / "tb")
        except ImportError:
            print("tensorboard not installed: no TensorBoard logs (pip install tensorboard)")
    Algo = ALGOS[algo]
    params: dict[str, Any] = {**{k: v for k, v in block.items() if k not in RUN_KEYS}, **(hyperparams or {})}
    if algo == "ppo_lagrangian":
        params.setdefault("episode_steps", max_episode_steps or ENV_IDS[env_id][1])
    try:
        model = Algo(policy, venv, seed=seed, device="cpu", tensorboard_log=tb, verbose=0, **params)
    except (TypeError, ValueError, AssertionError) as err:  # an unknown or out-of-range keyword (SB3 asserts some): name it
        venv.close()
        raise InvalidArgumentError(f"invalid `hyperparams` for {algo} on {env_id}: {err}") from err
    out.mkdir(parents=True, exist_ok=True)
    if tb is None:
        # SB3 would otherwise log to a new folder under the system's temp folder on every run
        model.set_logger(configure_logger(str(out), ["csv"]))
    evaluator = EvalSafety(env_id, eval_every, eval_episodes, seed + EVAL_SEED_OFFSET, eval_kwargs)
    checkpoints = CheckpointCallback(save_freq=max(eval_every // num_envs, 1), save_path=str(out / "checkpoints"), name_prefix=algo)
    safety = TrainingSafety()
    start = time.perf_counter()
    model.learn(timesteps, callback=CallbackList([safety, evaluator, checkpoints]), progress_bar=progress, tb_log_name=f"{algo}_{shield}")
    wall = time.perf_counter() - start
    model.logger.close()  # flushes and closes the log files
    path = out / "model.zip"
    model.save(path)
    meta = {"algo": algo, "env_id": env_id, "shield": shield, "timesteps": timesteps, "num_envs": num_envs, "seed": seed,
            "policy": policy, "hyperparams": {k: v for k, v in params.items()}, "env_kwargs": env_kwargs,
            "max_episode_steps": max_episode_steps, "training_safety": safety.totals, "eval": evaluator.history,
            "episodes": safety.episodes, "wall_time_s": wall, "steps_per_s": model.num_timesteps / wall}
    if isinstance(model, PPOLagrangian):
        meta["lagrangian"] = [{"timesteps": t, "episode_cost": c, "lambda": lam} for t, c, lam in model.multiplier_history]
    write_json_atomically(out / "run.json", meta)
    venv.close()
    return path


def write_json_atomically(path: Path, data: Any) -> None:
    """Writes ``path`` whole or not at all (a temporary file in the same folder, then a rename)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(data, indent=1, default=float))
    os.replace(tmp, path)


def main(argv: list[str] | None = None) -> Path:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--algo", default="ppo", choices=sorted(ALGOS))
    ap.add_argument("--env", type=benchmark.env_id, default="shieldnav/CorridorInspection-v0")
    ap.add_argument("--shield", default="braking", choices=benchmark.SHIELDS)
    ap.add_argument("--timesteps", type=benchmark.positive_int, default=None, help="default: the hyperparameter block's n_timesteps")
    ap.add_argument("--num-envs", type=benchmark.positive_int, default=None, help="default: the hyperparameter block's n_envs")
    ap.add_argument("--hyperparams", type=Path, default=None, metavar="FILE",
                    help="rl-zoo3-style hyperparameter file (default agents/hyperparams/<algo>.yml)")
    ap.add_argument("--seed", type=seed_number, default=0)
    ap.add_argument("--eval-every", type=benchmark.positive_int, default=50_000, help="env steps between evaluations")
    ap.add_argument("--eval-episodes", type=benchmark.positive_int, default=8, help="deterministic episodes an evaluation")
    ap.add_argument("--max-episode-steps", type=benchmark.positive_int, default=None)
    ap.add_argument("--out", default=None, help="run folder (default runs/<algo>_<shield>_<seed>)")
    ap.add_argument("--no-tensorboard", action="store_true")
    ap.add_argument("--no-progress", action="store_true", help="no progress bar (it needs tqdm and rich)")
    args = ap.parse_args(argv)
    if not args.no_progress and (missing := progress_bar_missing()):
        ap.error(f"{missing}, or pass --no-progress")
    out = Path(args.out or f"runs/{args.algo}_{args.shield}_{args.seed}")
    path = train(args.algo, args.env, args.shield, args.timesteps, args.num_envs, args.seed, out, args.eval_every,
                 args.eval_episodes, not args.no_tensorboard, not args.no_progress, args.max_episode_steps,
                 hyperparams_file=args.hyperparams)
    totals = json.loads((path.parent / "run.json").read_text())["training_safety"]
    print(f"saved {path}; during training: {totals['contact_steps']} contact steps, "
          f"{totals['episodes_with_contact']} of {totals['episodes']} episodes with contact")
    return path


if __name__ == "__main__":
    main()
