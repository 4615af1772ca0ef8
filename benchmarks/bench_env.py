"""Benchmark of the Gymnasium environments: `env.step` and `env.reset` through `gymnasium.make`
with the registered wrappers (TimeLimit, OrderEnforcing, PassiveEnvChecker, the episode
summary), the 1024-column LIDAR at 10 Hz, control at 50 Hz, under each shield of `--shields`
(default: the environments' braking shield and the paper's composite).

Random actions (drawn once, cycled) keep the robot moving without touching the policy's cost;
episodes that end are reset, and resets are timed apart from steps. Writes
`results/bench_env.json`.

    python benchmarks/bench_env.py [--steps 50000] [--resets 20] [--shields braking composite]
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import shieldnav
from tqdm import tqdm

IDS = ["shieldnav/CorridorInspection-v0", "shieldnav/ConstrictedPassage-v0", "shieldnav/OdometryJump-v0",
       "shieldnav/DynamicObstacles-v0", "shieldnav/MapInspection-v0"]


def bench_steps(env_id: str, steps: int, shield: str, seed: int = 0) -> dict[str, float]:
    env = gym.make(env_id, shield=shield)
    actions = np.random.default_rng(seed).uniform(-1, 1, (4096, 3)).astype(np.float32)
    env.reset(seed=seed)
    step_time, done_steps, resets = 0.0, 0, 0
    clock = time.perf_counter
    bar = tqdm(total=steps, desc=f"step {env_id.split('/')[1]}", leave=False, unit="step")
    while done_steps < steps:
        n = min(5000, steps - done_steps)
        t = clock()
        for k in range(n):
            _, _, terminated, truncated, _ = env.step(actions[(done_steps + k) & 4095])
            if terminated or truncated:
                break
        else:
            k = n - 1
        step_time += clock() - t
        done_steps += k + 1
        bar.update(k + 1)
        if terminated or truncated:
            env.reset()
            resets += 1
    bar.close()
    return {"steps_per_s": done_steps / step_time, "us_per_step": 1e6 * step_time / done_steps, "resets": resets}


def bench_resets(env_id: str, resets: int, shield: str) -> dict[str, float]:
    env = gym.make(env_id, shield=shield)
    env.reset(seed=0)
    times = []
    for s in tqdm(range(1, resets + 1), desc=f"reset {env_id.split('/')[1]}", leave=False):
        t = time.perf_counter()
        env.reset(seed=s)
        times.append(time.perf_counter() - t)
    ms = 1e3 * np.asarray(times)
    return {"reset_ms_median": float(np.median(ms)), "reset_ms_max": float(ms.max())}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=50_000, help="steps per environment")
    ap.add_argument("--resets", type=int, default=20, help="timed resets per environment")
    ap.add_argument("--shields", nargs="+", default=["braking", "composite"])
    ap.add_argument("--out", default="results/bench_env.json")
    args = ap.parse_args()
    rows = {}
    for env_id in IDS:
        for shield in args.shields:
            rows[f"{env_id} {shield}"] = {**bench_steps(env_id, args.steps, shield), **bench_resets(env_id, args.resets, shield)}
    print(f"{'environment, shield':46s} {'steps/s':>10s} {'µs/step':>8s} {'reset median':>13s} {'reset max':>10s}")
    for key, r in rows.items():
        print(f"{key:46s} {r['steps_per_s']:10.0f} {r['us_per_step']:8.1f} {r['reset_ms_median']:10.2f} ms {r['reset_ms_max']:7.2f} ms")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    meta = {"shieldnav": shieldnav.__version__, "python": platform.python_version(), "machine": platform.processor() or platform.machine()}
    out.write_text(json.dumps({"meta": meta, "results": rows}, indent=2))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
