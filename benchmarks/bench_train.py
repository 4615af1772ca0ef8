"""Training throughput: PPO under the default (braking) shield on CorridorInspection, side by
side with the environment alone.

Each configuration trains `agents.train` (stable-baselines3 PPO over the native batch, one
torch thread, the native batch's threads on the usable cores) for ``--timesteps`` steps with
evaluation and checkpoints out of the way, and reports training env steps/s from the run's
`run.json`; the first line is the native batch alone under random actions (the ceiling a
learner can approach). Configurations:

- ``sb3``: today's defaults (8 envs, ``n_steps`` 256, ``batch_size`` 256, 10 epochs);
- ``sb3-large``: 64 envs, ``n_steps`` 128, ``batch_size`` 4096, 4 epochs (few, large minibatches:
  the per-minibatch Python overhead amortised);
- ``sb3-large-2ep``: the same with 2 epochs;
- ``sb3-256``: 256 envs, ``n_steps`` 32, ``batch_size`` 8192, 4 epochs (the per-step overhead of
  the rollout amortised over more environments; four gradient steps a rollout);
- ``sb3-256-1k``: 256 envs, ``n_steps`` 32, ``batch_size`` 1024, 10 epochs (80 gradient steps a
  rollout of 8,192 steps, as many a sample as today's defaults).

    python benchmarks/bench_train.py                       # 3 configurations x 65,536 steps
    python benchmarks/bench_train.py --timesteps 131072 --configs sb3 sb3-large --out results/bench_train.json
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # agents, run as a script

import shieldnav

from benchmarks.bench_vector import run as env_alone

ENV_ID = "shieldnav/CorridorInspection-v0"
CONFIGS: dict[str, dict[str, Any]] = {
    "sb3": {"num_envs": 8, "hyperparams": {"n_steps": 256, "batch_size": 256}},
    "sb3-large": {"num_envs": 64, "hyperparams": {"n_steps": 128, "batch_size": 4096, "n_epochs": 4}},
    "sb3-large-2ep": {"num_envs": 64, "hyperparams": {"n_steps": 128, "batch_size": 4096, "n_epochs": 2}},
    "sb3-256": {"num_envs": 256, "hyperparams": {"n_steps": 32, "batch_size": 8192, "n_epochs": 4}},
    "sb3-256-1k": {"num_envs": 256, "hyperparams": {"n_steps": 32, "batch_size": 1024, "n_epochs": 10}},
}


def sb3(config: dict[str, Any], timesteps: int, seed: int) -> dict[str, Any]:
    from agents.train import train

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run"
        train("ppo", ENV_ID, "braking", timesteps, config["num_envs"], seed, out, eval_every=10 * timesteps, eval_episodes=1,
              tensorboard=False, progress=False, hyperparams=config["hyperparams"])
        run = json.loads((out / "run.json").read_text())
    return {"steps": run["timesteps"], "wall_s": run["wall_time_s"], "steps_per_s": run["steps_per_s"],
            "training_contact_steps": run["training_safety"].get("contact_steps")}


def main(argv: list[str] | None = None) -> list[dict[str, Any]]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--timesteps", type=int, default=65_536)
    ap.add_argument("--configs", nargs="+", default=list(CONFIGS), choices=list(CONFIGS))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--env-seconds", type=float, default=5.0, help="how long the native batch alone is timed")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    rows = [{"config": "env alone, 64 envs", "steps_per_s": env_alone(ENV_ID, 64, os.cpu_count() or 1, args.env_seconds)}]
    print(f"{rows[0]['config']:24} {rows[0]['steps_per_s']:10,.0f} steps/s", flush=True)
    for name in args.configs:
        r = {"config": name, **CONFIGS[name], **sb3(CONFIGS[name], args.timesteps, args.seed)}
        rows.append(r)
        print(f"{name:24} {r['steps_per_s']:10,.0f} steps/s  ({r['steps']:,} steps in {r['wall_s']:.1f} s, "
              f"training contact steps {r['training_contact_steps']})", flush=True)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        meta = {"machine": platform.machine(), "shieldnav": shieldnav.__version__, "timesteps": args.timesteps}
        args.out.write_text(json.dumps({"meta": meta, "rows": rows}, indent=1))
    return rows


if __name__ == "__main__":
    main()
