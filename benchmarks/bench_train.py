"""Training speed and what it buys: PPO under the default (braking) shield on CorridorInspection,
configuration by configuration, beside the environment alone.

Each run trains `agents.train` in a fresh process (start-up included) with 1,000-step episodes
and an evaluation of 8 deterministic episodes every 25,000 steps, and reports:

- env steps/s of training (the evaluations' time left out);
- the wall time until an evaluation first reaches the scripted inspection agent's coverage on
  the same evaluation episodes, from the process's start (imports, environments, model) with
  the evaluations' time left out, and the steps it took;
- the final evaluation's coverage, and the training contact steps.

The first line is the native batch alone under random actions (the ceiling a learner can
approach). Configurations (``--configs``):

- ``defaults``: what ``python -m agents.train`` runs (``agents/hyperparams/ppo.yml``);
- ``sb3-8x256``: 8 environments, ``n_steps`` 256, ``batch_size`` 256, 10 epochs, learning rate
  3e-4 (stable-baselines3's own PPO settings with rl-zoo3's usual 8 environments);
- ``sb3-256x64-4k``: 256 environments, ``n_steps`` 64, ``batch_size`` 4096, 4 epochs, 1e-3 (few,
  large minibatches: 16 gradient steps a rollout of 16,384 samples).

    python benchmarks/bench_train.py                                   # 500k steps, seed 0
    python benchmarks/bench_train.py --seeds 0 1 2 --out results/bench_train.json
    python benchmarks/bench_train.py --timesteps 131072 --configs defaults sb3-8x256 --no-eval   # speed only
"""

from __future__ import annotations

import time

STARTED = time.perf_counter()  # the run's start-up is part of its time to the scripted coverage

import argparse  # noqa: E402
import json  # noqa: E402
import os  # noqa: E402
import platform  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # agents, run as a script

ENV_ID = "shieldnav/CorridorInspection-v0"
EPISODE_STEPS = 1000
EVAL_EPISODES = 8
#: Constructor keywords over the hyperparameter file's block (None: the block as it is).
CONFIGS: dict[str, dict[str, Any] | None] = {
    "defaults": None,
    "sb3-8x256": {"num_envs": 8, "hyperparams": {"n_steps": 256, "batch_size": 256, "n_epochs": 10, "learning_rate": 3e-4}},
    "sb3-256x64-4k": {"num_envs": 256, "hyperparams": {"n_steps": 64, "batch_size": 4096, "n_epochs": 4, "learning_rate": 1e-3}},
}


def scripted_coverage(seed: int) -> float:
    """The scripted agent's mean coverage on the evaluation episodes of a run seeded ``seed``."""
    import gymnasium as gym
    from shieldnav.scripted import InspectionAgent

    from agents.train import EVAL_SEED_OFFSET

    covered = []
    for k in range(EVAL_EPISODES):
        env = gym.make(ENV_ID, shield="braking", max_episode_steps=EPISODE_STEPS, time_limit=EPISODE_STEPS)
        agent = InspectionAgent(env)
        obs, info = env.reset(seed=seed + EVAL_SEED_OFFSET + k)
        agent.reset()
        done = False
        while not done:
            obs, _, terminated, truncated, info = env.step(agent.act(obs, info))
            done = terminated or truncated
        covered.append(info["shieldnav_episode"]["coverage"])
        env.close()
    return sum(covered) / len(covered)


def one_run(config: str, seed: int, timesteps: int, eval_every: int | None, target: float | None) -> dict[str, Any]:
    """One training run in this process; the figures of the module's text."""
    from agents import train

    spent = {"eval_s": 0.0}
    reached: dict[str, float] = {}
    plain = train.evaluate

    def timed(*args: Any, **kwargs: Any) -> dict[str, float]:
        t, before = time.perf_counter(), spent["eval_s"]
        stats = plain(*args, **kwargs)
        spent["eval_s"] += time.perf_counter() - t
        if target is not None and not reached and stats["coverage"] >= target:
            reached["wall_s"] = t - STARTED - before  # the time so far, earlier evaluations left out
        return stats

    train.evaluate = timed
    settings = CONFIGS[config] or {}
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run"
        train.train("ppo", ENV_ID, "braking", timesteps, settings.get("num_envs"), seed, out,
                    eval_every=eval_every or 10 * timesteps, eval_episodes=EVAL_EPISODES, tensorboard=False, progress=False,
                    max_episode_steps=EPISODE_STEPS, hyperparams=settings.get("hyperparams"))
        run = json.loads((out / "run.json").read_text())
    evals = run["eval"]
    training_s = run["wall_time_s"] - spent["eval_s"]
    steps_to = next((e["timesteps"] for e in evals if target is not None and e["coverage"] >= target), None)
    return {"config": config, "seed": seed, "num_envs": run["num_envs"], "hyperparams": run["hyperparams"], "steps": run["timesteps"],
            "training_s": training_s, "steps_per_s": run["timesteps"] / training_s, "to_scripted_s": reached.get("wall_s"),
            "to_scripted_steps": steps_to, "final_coverage": evals[-1]["coverage"] if evals else None,
            "curve": [[e["timesteps"], e["coverage"]] for e in evals], "training_contact_steps": run["training_safety"]["contact_steps"]}


def main(argv: list[str] | None = None) -> list[dict[str, Any]]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--timesteps", type=int, default=500_000)
    ap.add_argument("--configs", nargs="+", default=list(CONFIGS), choices=list(CONFIGS))
    ap.add_argument("--seeds", type=int, nargs="+", default=[0])
    ap.add_argument("--eval-every", type=int, default=25_000, help="env steps between evaluations")
    ap.add_argument("--no-eval", action="store_true", help="speed only: no evaluation, no scripted baseline")
    ap.add_argument("--env-seconds", type=float, default=5.0, help="how long the native batch alone is timed")
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--run", nargs=2, metavar=("CONFIG", "SEED"), help=argparse.SUPPRESS)  # one run, in a child process
    ap.add_argument("--target", type=float, default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.run:
        print(json.dumps(one_run(args.run[0], int(args.run[1]), args.timesteps, None if args.no_eval else args.eval_every, args.target)))
        return []
    import shieldnav

    from benchmarks.bench_vector import run as env_alone

    rows: list[dict[str, Any]] = [{"config": "env alone, 256 envs", "steps_per_s": env_alone(ENV_ID, 256, os.cpu_count() or 1, args.env_seconds)}]
    print(f"{rows[0]['config']:22} {rows[0]['steps_per_s']:9,.0f} steps/s", flush=True)
    targets = {} if args.no_eval else {seed: scripted_coverage(seed) for seed in args.seeds}
    for seed, target in targets.items():
        print(f"scripted agent, seed {seed}: coverage {target:.3f} on the evaluation episodes", flush=True)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    for name in args.configs:
        for seed in args.seeds:
            argv_child = [sys.executable, str(Path(__file__).resolve()), "--run", name, str(seed), "--timesteps", str(args.timesteps)]
            argv_child += ["--no-eval"] if args.no_eval else ["--eval-every", str(args.eval_every), "--target", repr(targets[seed])]
            done = subprocess.run(argv_child, env=env, capture_output=True, text=True)
            if done.returncode != 0:
                raise SystemExit(f"{name} seed {seed} failed:\n{done.stderr}")
            r = json.loads(done.stdout.strip().splitlines()[-1])
            rows.append(r)
            to = "–" if r["to_scripted_s"] is None else f"{r['to_scripted_s']:.1f} s ({r['to_scripted_steps']:,} steps)"
            cov = "–" if r["final_coverage"] is None else f"{r['final_coverage']:.3f}"
            print(f"{name:14} seed {seed} {r['steps_per_s']:9,.0f} steps/s  to the scripted coverage {to}  final coverage {cov}  "
                  f"training contact steps {r['training_contact_steps']}", flush=True)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        meta = {"machine": platform.machine(), "cpus": os.cpu_count(), "shieldnav": shieldnav.__version__, "timesteps": args.timesteps,
                "scripted_coverage": targets}
        args.out.write_text(json.dumps({"meta": meta, "rows": rows}, indent=1))
    return rows


if __name__ == "__main__":
    main()
