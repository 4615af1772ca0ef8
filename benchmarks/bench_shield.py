"""Python benchmark of the whole `Shield.filter` call (numpy points in, u* out).

Times each call on its own with `perf_counter_ns` and reports median, p99.6 and max per N, for
the composite shield (float32 scans, planar and 3D) and the distance baseline's N-row
Clarabel QP side by side. Writes `results/bench_shield.json`.

    python benchmarks/bench_shield.py [--quick]
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

import numpy as np
from shieldnav import Shield
from tqdm import tqdm

SIZES = [100, 400, 800, 1300, 5000, 20_000]


def corridor(n: int, dim: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = rng.uniform(-3, 3, n)
    y = np.where(rng.random(n) < 0.5, 1.0, -1.0) * (1 + rng.uniform(-0.02, 0.02, n))
    cols = [x, y] + ([rng.uniform(-0.4, 1.0, n)] if dim == 3 else [])
    return np.ascontiguousarray(np.stack(cols, axis=1), dtype=np.float32)


def time_calls(shield: Shield, pts: np.ndarray, calls: int, **kw) -> np.ndarray:
    dim = shield.dim
    u = np.full(dim, 0.8)
    for _ in range(max(calls // 10, 5)):
        shield.filter(pts, u, **kw)
    out = np.empty(calls, dtype=np.int64)
    clock = time.perf_counter_ns
    for i in range(calls):
        t0 = clock()
        shield.filter(pts, u, **kw)
        out[i] = clock() - t0
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="fewer calls per size")
    ap.add_argument("--out", default="results/bench_shield.json")
    args = ap.parse_args()
    budget = 200_000 if args.quick else 2_000_000
    rows = []
    jobs = [(m, d, n) for m in ("composite", "distance") for d in (2, 3) for n in SIZES
            if not (m == "distance" and d == 3)]
    for method, dim, n in tqdm(jobs, desc="shield bench", unit="case"):
        axes = (0.9, 0.45) if dim == 2 else (0.9, 0.45, 0.3)
        shield = Shield(semi_axes=axes, u_max=(1.0,) * dim, method=method)
        pts = corridor(n, dim, seed=n)
        kw = {"yaw": 0.3, "omega": 0.2} if dim == 2 else {"omega": [0.0, 0.0, 0.2]}
        per_call = n if method == "composite" else 200 * n
        calls = int(np.clip(budget // per_call, 30, 100_000))
        t = time_calls(shield, pts, calls, **kw) / 1e3
        rows.append({"method": method, "dim": dim, "N": n, "calls": calls,
                     "median_us": float(np.median(t)), "p99_6_us": float(np.percentile(t, 99.6)),
                     "max_us": float(t.max())})
    print("\n| method | dim | N | median µs | p99.6 µs | max µs |")
    print("|---|---|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r['method']} | {r['dim']} | {r['N']} | {r['median_us']:.2f} | {r['p99_6_us']:.2f} | {r['max_us']:.1f} |")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    meta = {"python": platform.python_version(), "machine": platform.machine(),
            "simd_level": Shield().simd_level}
    out.write_text(json.dumps({"meta": meta, "rows": rows}, indent=2))
    print(f"\nwrote {out}")


if __name__ == "__main__":
    main()
