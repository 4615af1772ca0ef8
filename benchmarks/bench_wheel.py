"""The release wheel against a local build, side by side in one run: the hot calls timed from
two interpreters, in alternating rounds (A, B, A, B, ...) so that the machine's drift falls on
both.

- `Shield.filter`, braking and composite, a planar float32 scan of 1,300 points: median µs
  per call;
- `env.step` through `gymnasium.make` (CorridorInspection, braking shield): steps/s;
- the native batch (`make_vec`, 64 environments): steps/s.

The wheel is installed into a fresh virtual environment (its dependencies from the index);
`--against` is the other interpreter (default: `.venv`, the local release build of
`scripts/main.sh`).

    python benchmarks/bench_wheel.py --wheel dist/shieldnav-*.whl [--against .venv/bin/python] [--rounds 3]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

PROBE = r"""
import json, time
import numpy as np
import gymnasium as gym
import shieldnav
from shieldnav import Shield

out = {"simd": Shield().simd_level}
rng = np.random.default_rng(0)
x = rng.uniform(-3, 3, 1300)
y = np.where(rng.random(1300) < 0.5, 1.0, -1.0) * (1 + rng.uniform(-0.02, 0.02, 1300))
pts = np.ascontiguousarray(np.stack([x, y], axis=1), dtype=np.float32)
for method in ("braking", "composite"):
    s = Shield(method=method)
    u = np.array([0.8, 0.0])
    kw = {"velocity": [0.5, 0.0, 0.0]} if method == "braking" else {}
    for _ in range(500):
        s.filter(pts, u, **kw)
    t = []
    for _ in range(5000):
        t0 = time.perf_counter_ns(); s.filter(pts, u, **kw); t.append(time.perf_counter_ns() - t0)
    out[f"shield_{method}_us"] = float(np.median(t)) / 1e3
env = gym.make("shieldnav/CorridorInspection-v0")
env.reset(seed=0)
acts = np.random.default_rng(1).uniform(-1, 1, (1000, 3)).astype(np.float32)
t0 = time.perf_counter()
for k in range(5000):
    _, _, term, trunc, _ = env.step(acts[k % 1000])
    if term or trunc:
        env.reset()
out["env_steps_per_s"] = 5000 / (time.perf_counter() - t0)
vec = gym.make_vec("shieldnav/CorridorInspection-v0", num_envs=64, vectorization_mode="vector_entry_point")
vec.reset(seed=0)
a = np.random.default_rng(2).uniform(-1, 1, (64, 3)).astype(np.float32)
t0 = time.perf_counter()
for _ in range(200):
    vec.step(a)
out["batch_steps_per_s"] = 64 * 200 / (time.perf_counter() - t0)
vec.close()
print(json.dumps(out))
"""

KEYS = [("shield_braking_us", "Shield.filter braking, N = 1,300 (µs, median)"), ("shield_composite_us", "Shield.filter composite, N = 1,300 (µs, median)"),
        ("env_steps_per_s", "env.step, CorridorInspection braking (steps/s)"), ("batch_steps_per_s", "native batch, 64 envs (steps/s)")]


def probe(python: str) -> dict[str, float]:
    run = subprocess.run([python, "-c", PROBE], check=True, capture_output=True, text=True)
    return json.loads(run.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--wheel", required=True, help="the wheel to install into a fresh virtual environment")
    ap.add_argument("--against", default=".venv/bin/python", help="the other interpreter (default: .venv's, scripts/main.sh's release build)")
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    if not Path(args.wheel).is_file() or not Path(args.against).exists():
        ap.error(f"--wheel {args.wheel} and --against {args.against} must exist")
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([sys.executable, "-m", "venv", f"{tmp}/venv"], check=True)
        wheel_python = f"{tmp}/venv/bin/python"
        subprocess.run([wheel_python, "-m", "pip", "install", "-q", "--disable-pip-version-check", args.wheel], check=True)
        runs: dict[str, list[dict[str, float]]] = {"wheel": [], "local": []}
        for r in range(args.rounds):
            for name, python in (("wheel", wheel_python), ("local", args.against)) if r % 2 == 0 else (("local", args.against), ("wheel", wheel_python)):
                runs[name].append(probe(python))
                print(f"round {r + 1} {name}: {runs[name][-1]}", file=sys.stderr)
    print(f"| measure (median of {args.rounds} rounds) | wheel ({Path(args.wheel).name}) | local build ({args.against}) | wheel / local |")
    print("|---|---:|---:|---:|")
    for key, label in KEYS:
        w, loc = (float(np.median([run[key] for run in runs[n]])) for n in ("wheel", "local"))
        print(f"| {label} | {w:,.1f} | {loc:,.1f} | {w / loc:.2f} |")
    print(f"| SIMD kernel | {runs['wheel'][0]['simd']} | {runs['local'][0]['simd']} | |")


if __name__ == "__main__":
    main()
