"""Moving-obstacle benchmark: what tracking the movers buys and costs.

On each mover site of ``agents.movers`` (pedestrians crossing, head-on and overtaking, a
chaser, a pushed chair and a swung door; draw 0) and on a static procedural site, a cruising
robot (straight ahead at 0.8 m/s, the ``cruise`` attacker) and commands held at the limits
(``held``) run under the braking shield with the mover tracker (``track_movers=True``, the
default), the braking shield taking every return as static (``track_movers=False``) and the
paper's composite shield, one environment at a time (``gym.make``, one thread).

Per site and configuration: contact steps, contact events and those begun with the robot
moving, mean shield time per step inside the episodes (ns) and the environment's steps/s (the
tracker's time included).

    python benchmarks/bench_movers.py                       # 6 sites x 3 configurations x 2 policies x 4 seeds
    python benchmarks/bench_movers.py --seeds 1 --out results/bench_movers.json
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # agents.movers, run as a script

import gymnasium as gym
import numpy as np
import shieldnav

from agents.movers import mover_sites
from agents.tight import scenario_file

CONFIGS = {"braking, tracked": {"shield": "braking"}, "braking, static": {"shield": "braking", "track_movers": False}, "composite": {"shield": "composite"}}
STEPS = 750  # 15 s at 50 Hz


def run(site: dict[str, Any], config: dict[str, Any], policy: str, seed: int) -> dict[str, float]:
    kwargs = {"procedural": True} if site["scenario"] is None else {"scenario_path": scenario_file(site["scenario"])}
    env = gym.make("shieldnav/CorridorInspection-v0", terminate_at_goal=False, **kwargs, **config)
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    action, hold = np.zeros(3, dtype=np.float32), 0
    started = time.perf_counter()
    for _ in range(STEPS):
        if policy == "cruise":
            action = np.array([0.5, 0.0, 0.0], dtype=np.float32)
        else:
            hold -= 1
            if hold <= 0:
                action, hold = rng.choice([-1.0, 1.0], size=3).astype(np.float32), int(rng.integers(5, 51))
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            break
    elapsed = time.perf_counter() - started
    s = env.unwrapped.episode.summary()
    env.close()
    return {"steps": s["steps"], "contact_steps": s["contact_steps"], "contact_events": s["contact_events"], "moving_events": s["moving_collisions"],
            "shield_ns": s["solve_time_mean_ns"], "steps_per_s": s["steps"] / elapsed}


def main(argv: list[str] | None = None) -> list[dict[str, Any]]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    sites = [{"site": "procedural (static)", "scenario": None}] + [{"site": m["site"], "scenario": m["scenario"]} for m in mover_sites(0)]
    rows = []
    for site in sites:
        for name, config in CONFIGS.items():
            for policy in ("cruise", "held"):
                runs = [run(site, config, policy, seed) for seed in range(args.seeds)]
                row = {"site": site["site"], "config": name, "policy": policy, "episodes": len(runs),
                       **{k: int(sum(r[k] for r in runs)) for k in ("steps", "contact_steps", "contact_events", "moving_events")},
                       "shield_ns": float(np.mean([r["shield_ns"] for r in runs])), "steps_per_s": float(np.mean([r["steps_per_s"] for r in runs]))}
                rows.append(row)
                print(f"{row['site']:20} {name:17} {policy:6} contact steps {row['contact_steps']:5} events {row['contact_events']:3} "
                      f"begun moving {row['moving_events']:3}  shield {row['shield_ns'] / 1000:6.1f} µs  {row['steps_per_s']:8,.0f} steps/s", flush=True)
    print("\n| configuration | contact steps | contact events | begun moving | shield per step (µs) | steps/s |\n|---|---:|---:|---:|---:|---:|")
    for name in CONFIGS:
        rs = [r for r in rows if r["config"] == name]
        movers = [r for r in rs if r["site"] != "procedural (static)"]
        print(f"| {name} | {sum(r['contact_steps'] for r in movers):,} | {sum(r['contact_events'] for r in movers):,} | {sum(r['moving_events'] for r in movers):,} | "
              f"{np.mean([r['shield_ns'] for r in rs]) / 1000:.1f} | {np.mean([r['steps_per_s'] for r in rs]):,.0f} |")
    print(f"\n{platform.processor() or platform.machine()}, shieldnav {shieldnav.__version__}, SIMD {shieldnav.Shield().simd_level}")
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(rows, indent=1))
    return rows


if __name__ == "__main__":
    main()
