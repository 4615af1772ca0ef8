"""Benchmark of the native vector environment: N episodes stepped in Rust per call (1024-column
LIDAR at 10 Hz, control at 50 Hz, the default braking shield), random actions drawn once and cycled.
Reports environment steps per second for several batch sizes and thread counts. Writes
`results/bench_vector.json`.

    python benchmarks/bench_vector.py [--env shieldnav/DynamicObstacles-v0] [--seconds 5] [--shields braking composite]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import shieldnav  # noqa: F401


def run(env_id: str, num_envs: int, threads: int, seconds: float, shield: str = "braking") -> float:
    v = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point", threads=threads, report_timing=False, shield=shield)
    v.reset(seed=0)
    actions = np.random.default_rng(0).uniform(-1, 1, (64, num_envs, 3)).astype(np.float32)
    for k in range(20):
        v.step(actions[k % 64])
    steps, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        for k in range(50):
            v.step(actions[k % 64])
        steps += 50 * num_envs
    rate = steps / (time.perf_counter() - t0)
    v.close()
    return rate


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--env", default="shieldnav/DynamicObstacles-v0")
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--shields", nargs="+", default=["braking"], help="shields measured side by side (default: the environments' braking shield)")
    ap.add_argument("--out", default="results/bench_vector.json")
    args = ap.parse_args()
    cores = len(os.sched_getaffinity(0))
    rows = []
    for threads in sorted({1, cores}):
        for n in (16, 64, 256):
            for shield in args.shields:
                rate = run(args.env, n, threads, args.seconds, shield)
                rows.append({"num_envs": n, "threads": threads, "shield": shield, "steps_per_s": rate})
                print(f"{args.env}  {shield:9s}  num_envs={n:4d}  threads={threads}  {rate:10.0f} env steps/s")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"env": args.env, "cores": cores, "results": rows}, indent=1))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
