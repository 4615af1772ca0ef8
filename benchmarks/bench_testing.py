"""Wall time of ``shieldnav.testing.run_episodes``: the scripted agent on the 4 built-in ids ×
10 seeds (full episodes, the default shield) on 1 and on N worker processes, and the speed-up.
Checks that both give the same summaries.

    python benchmarks/bench_testing.py [--seeds 10] [--workers 2] [--max-steps N]
"""

from __future__ import annotations

import argparse
import os
import time

from shieldnav.testing import assert_safe_episodes, default_workers, run_episodes

IDS = ["shieldnav/ConstrictedPassage-v0", "shieldnav/OdometryJump-v0", "shieldnav/DynamicObstacles-v0", "shieldnav/CorridorInspection-v0"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--workers", type=int, default=default_workers())
    ap.add_argument("--max-steps", type=int, default=None, help="shorter episodes (default: each id's time limit)")
    args = ap.parse_args()
    print(f"{len(IDS)} ids × {args.seeds} seeds, scripted agent, default shield; {default_workers()} CPUs available, load {os.getloadavg()[0]:.1f}")
    tables, times = {}, {}
    for workers in sorted({1, args.workers}):
        t0 = time.perf_counter()
        tables[workers] = run_episodes("scripted", IDS, range(args.seeds), workers=workers, max_steps=args.max_steps)
        times[workers] = time.perf_counter() - t0
        steps = sum(r.steps for r in tables[workers])
        print(f"  {workers} worker(s): {times[workers]:6.1f} s wall, {steps} steps ({steps / times[workers]:,.0f} steps/s)")
    if args.workers != 1:
        print(f"  speed-up {times[1] / times[args.workers]:.2f}×; same summaries: {list(tables[1]) == list(tables[args.workers])}")
    try:
        assert_safe_episodes(tables[args.workers], deadlock=False)
        print("  no contact in any episode")
    except AssertionError as err:
        print(f"  {err}")


if __name__ == "__main__":
    main()
