"""A sweep of the shield's science that the paper leaves open.

Five experiments, each varying one thing around the paper's defaults (γ = 0.9, κ = 8, a
1024-column planar ring, control at 50 Hz, LIDAR at 10 Hz) with the scripted inspection agent
under the composite shield, on the paper's three scenarios and procedural office sites:

* ``conservatism``: no episodes. ``H`` of the Rust shield for a corridor scan of N points
  (N up to 20,000) and κ, against the soft-min bound ``γ tanh(h_min/γ) − (γ/κ) ln N``: the
  composite turns conservative like ln(N)/κ.
* ``kappa`` and ``gamma``: deadlock rate, success, intervention and smallest true clearance.
* ``points``: the LIDAR's density (1 to 32 channels, 512 to 2048 columns: up to ~20,000
  points in the crop) with and without down-sampling (``voxel_size``), against the same.
* ``rates``: the control rate (10–100 Hz) and the LIDAR rate (10–20 Hz) against the smallest
  true clearance and contacts (the guarantee is continuous-time; sampling can break it).

    python -m agents.sweep                    # everything (about 10 minutes on 2 cores)
    python -m agents.sweep --quick            # one seed (unless --seeds), fewer values
    python -m agents.sweep --experiments kappa points --seeds 5 --backend ray

Writes ``sweep.json`` (every episode and the aggregate), ``sweep.csv`` and one figure per
experiment to ``--out``. Interrupting keeps and reports the episodes that finished. Options
are checked before anything runs (as ``agents.benchmark`` does).
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import sys
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np
from shieldnav.registration import ENV_IDS

from agents import benchmark, report

EXPERIMENTS = ["conservatism", "kappa", "gamma", "points", "rates"]
SCENARIOS = benchmark.PAPER + ["shieldnav/CorridorInspection-v0"]

#: experiment → [(label, env kwargs)]; the full grid, then the --quick one.
GRID: dict[str, list[tuple[str, dict[str, Any]]]] = {
    "kappa": [(f"κ={k:g}", {"kappa": k}) for k in (2, 4, 8, 16, 32, 64)],
    "gamma": [(f"γ={g:g}", {"gamma": g}) for g in (0.3, 0.6, 0.9, 1.5, 3.0)],
    "points": [
        (f"{ch}×{col}{' voxel 0.1 m' if vox else ''}", {"lidar_channels": ch, "lidar_columns": col, "voxel_size": vox})
        for ch, col in ((1, 512), (1, 1024), (1, 2048), (16, 1024), (32, 1024))
        for vox in (None, 0.1)
    ],
    "rates": [(f"control {1 / dt:g} Hz", {"dt": dt}) for dt in (0.01, 0.02, 0.04, 0.1)]
    + [(f"LIDAR {hz:g} Hz", {"lidar_rate_hz": hz}) for hz in (10.0, 15.0, 20.0)],
}
QUICK = {
    "kappa": ["κ=2", "κ=8", "κ=32"],
    "gamma": ["γ=0.3", "γ=0.9", "γ=3"],
    "points": ["1×1024", "32×1024", "32×1024 voxel 0.1 m"],
    "rates": ["control 50 Hz", "control 10 Hz", "LIDAR 20 Hz"],
}


def tasks(experiments: list[str], scenarios: list[str], seeds: int, quick: bool, steps: int | None = None) -> list[dict[str, Any]]:
    """One episode task per (experiment, setting, scenario, seed). Episode time limits are
    the registered ones in seconds, so a slower control rate gets fewer steps."""
    out = []
    for exp in experiments:
        for label, kwargs in GRID.get(exp, []):
            if quick and label not in QUICK[exp]:
                continue
            dt = kwargs.get("dt", 0.02)
            for env_id in scenarios:
                limit = steps if steps is not None else math.ceil(ENV_IDS[env_id][1] * 0.02 / dt)
                for seed in range(seeds):
                    kw = {k: v for k, v in kwargs.items() if v is not None} | {
                        "truncate_on_deadlock": True, "time_limit": limit, "max_episode_steps": limit,
                    }
                    out.append({"env_id": env_id, "shield": "composite", "seed": seed, "policy": "scripted",
                                "kwargs": kw, "experiment": exp, "setting": label})
    return out


def aggregate(results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per (experiment, setting, scenario) and per (experiment, setting) over all scenarios."""
    groups: dict[tuple[str, str, str], list[dict[str, Any]]] = defaultdict(list)
    for r in results:
        t = r["task"]
        groups[(t["experiment"], t["setting"], t["env_id"])].append(r)
        groups[(t["experiment"], t["setting"], "all")].append(r)
    order = {(e, label): i for e in GRID for i, (label, _) in enumerate(GRID[e])}
    rows = []
    for (exp, setting, scenario), rs in sorted(groups.items(), key=lambda kv: (kv[0][0], order[kv[0][:2]], kv[0][2])):
        s = [r["summary"] for r in rs]
        rows.append({
            "experiment": exp, "setting": setting, "scenario": scenario, "episodes": len(rs),
            "deadlock_rate": float(np.mean([x["deadlock"] for x in s])),
            "success_rate": float(np.mean([x["success"] for x in s])),
            "with_contact": int(sum(x["collisions"] > 0 for x in s)),
            "contact_rate": float(np.mean([x["collisions"] > 0 for x in s])),
            "min_clearance": float(min(x["min_clearance"] for x in s)),
            "mean_min_clearance": float(np.mean([x["min_clearance"] for x in s])),
            "intervention": float(np.mean([x["intervention_mean"] for x in s])),
            "coverage": float(np.mean([x["coverage"] for x in s])),
            "points_mean": float(np.mean(np.concatenate([r["num_points"] for r in rs]))),
            "shield_us_mean": float(np.mean(np.concatenate([r["solve_time_ns"] for r in rs])) / 1e3),
        })
    return rows


def conservatism(kappas: tuple[float, ...] = (2, 4, 8, 16, 32), counts: tuple[int, ...] = (25, 50, 100, 200, 400, 800, 1600, 3200, 6400, 12800, 20000)) -> list[dict[str, Any]]:
    """``H`` of the Rust composite shield for a 2 m corridor scanned with N points (robot on
    the centre line, facing along it), per κ; with the soft-min bounds
    ``γ tanh(h_min/γ) − (γ/κ) ln N ≤ H ≤ γ tanh(h_min/γ)``."""
    from shieldnav import SHIELD_DEFAULTS, Shield

    gamma = float(SHIELD_DEFAULTS["gamma"])
    rows = []
    for n in counts:
        # N points evenly along both walls (y = ±1 m) within the 3.5 m crop
        x = np.linspace(-3.3, 3.3, n // 2)
        pts = np.concatenate([np.stack([x, np.full_like(x, s)], 1) for s in (-1.0, 1.0)])
        for kappa in kappas:
            out = Shield(kappa=kappa).filter(pts, np.zeros(2), yaw=0.0, omega=0.0)
            top = gamma * math.tanh(out.h_min / gamma)
            rows.append({"kappa": kappa, "gamma": gamma, "points": int(out.num_points), "H": out.H, "h_min": out.h_min,
                         "upper": top, "lower": top - gamma / kappa * math.log(out.num_points)})
    return rows


def plot(rows: list[dict[str, Any]], cons: list[dict[str, Any]], out: Path) -> list[Path]:
    """One figure per experiment; returns the files written."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    written = []
    if cons:
        fig, ax = plt.subplots(1, 2, figsize=(12, 4.5), constrained_layout=True)
        for kappa in dict.fromkeys(r["kappa"] for r in cons):
            rs = [r for r in cons if r["kappa"] == kappa]
            n = [r["points"] for r in rs]
            line = ax[0].plot(n, [r["H"] for r in rs], "o-", ms=3, label=f"κ={kappa:g}")[0]
            ax[0].plot(n, [r["lower"] for r in rs], ":", color=line.get_color())
            ax[1].plot(n, [r["upper"] - r["H"] for r in rs], "o-", ms=3, color=line.get_color(), label=f"κ={kappa:g}")
            ax[1].plot(n, [r["gamma"] / kappa * math.log(r["points"]) for r in rs], ":", color=line.get_color())
        ax[0].axhline(0, color="k", lw=0.6)
        ax[0].set(xscale="log", xlabel="points N", ylabel="H", title="composite H, robot centred in a 2 m corridor (dotted: lower bound)")
        ax[1].set(xscale="log", xlabel="points N", ylabel="γ tanh(h_min/γ) − H",
                  title="conservatism of the soft-min vs (γ/κ) ln N (dotted)")
        for a in ax:
            a.legend(fontsize=8)
        written.append(out / "conservatism.png")
        fig.savefig(written[-1], dpi=90)
        plt.close(fig)
    metrics = [("deadlock_rate", "deadlock rate"), ("intervention", "mean ‖u* − u_nom‖ (m/s)"),
               ("mean_min_clearance", "smallest true clearance (m), mean"), ("contact_rate", "episodes with contact")]
    for exp in dict.fromkeys(r["experiment"] for r in rows):
        rs = [r for r in rows if r["experiment"] == exp]
        settings = list(dict.fromkeys(r["setting"] for r in rs))
        scenarios = list(dict.fromkeys(r["scenario"] for r in rs))
        fig, ax = plt.subplots(1, len(metrics), figsize=(5 * len(metrics), 4.5), constrained_layout=True)
        xs = np.arange(len(settings))
        for j, (key, title) in enumerate(metrics):
            width = 0.8 / len(scenarios)
            for i, sc in enumerate(scenarios):
                ys = [next((r[key] for r in rs if r["setting"] == s and r["scenario"] == sc), np.nan) for s in settings]
                ax[j].bar(xs + (i - (len(scenarios) - 1) / 2) * width, ys, width, label=sc.split("/")[-1].removesuffix("-v0"))
            ax[j].set_xticks(xs, settings, rotation=35, ha="right", fontsize=8)
            ax[j].set_title(title, fontsize=10)
        ax[0].legend(fontsize=7)
        if exp == "points":
            for i, s in enumerate(settings):
                n = next(r["points_mean"] for r in rs if r["setting"] == s and r["scenario"] == "all")
                ax[0].annotate(f"N̄={n:.0f}", (i, 0), xytext=(0, 2), textcoords="offset points", ha="center", fontsize=7, rotation=90)
        fig.suptitle(f"sweep: {exp} (composite shield, scripted agent)")
        written.append(out / f"{exp}.png")
        fig.savefig(written[-1], dpi=90)
        plt.close(fig)
    return written


def table(rows: list[dict[str, Any]]) -> str:
    cols = ["deadlock_rate", "success_rate", "with_contact", "min_clearance", "intervention", "coverage", "points_mean"]
    lines = []
    for exp in dict.fromkeys(r["experiment"] for r in rows):
        lines.append(f"\n{exp} (all scenarios)")
        lines.append(f"  {'setting':22s} " + " ".join(f"{c:>14s}" for c in cols))
        for r in rows:
            if r["experiment"] == exp and r["scenario"] == "all":
                lines.append(f"  {r['setting']:22s} " + " ".join(f"{r[c]:>14.3f}" if isinstance(r[c], float) else f"{r[c]:>14d}" for c in cols))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> list[dict[str, Any]]:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--experiments", nargs="+", default=EXPERIMENTS, choices=EXPERIMENTS)
    ap.add_argument("--scenarios", nargs="+", type=benchmark.env_id, default=SCENARIOS, help="environment ids")
    ap.add_argument("--seeds", type=benchmark.positive_int, default=None, help="seeds per setting and scenario (default 3; --quick: 1)")
    ap.add_argument("--quick", action="store_true", help="one seed (unless --seeds), three values per experiment")
    ap.add_argument("--max-steps", type=benchmark.positive_int, default=None, help="override every episode's step limit")
    ap.add_argument("--backend", default="local", choices=["local", "ray"])
    ap.add_argument("--ray-address", default=None)
    ap.add_argument("--workers", type=benchmark.positive_int, default=os.cpu_count() or 1)
    ap.add_argument("--out", default="results/sweep")
    ap.add_argument("--no-plots", action="store_true")
    args = ap.parse_args(argv)
    benchmark.check_options(ap, args, "experiments", "scenarios")
    seeds = args.seeds or (1 if args.quick else 3)
    out = benchmark.output_folder(ap, args.out)
    cons = conservatism() if "conservatism" in args.experiments else []
    results = benchmark.run(tasks(args.experiments, args.scenarios, seeds, args.quick, args.max_steps), args.backend, args.workers, args.ray_address)
    rows = aggregate(results)
    print(table(rows))
    episodes = [{"task": r["task"], "summary": r["summary"]} for r in results]
    (out / "sweep.json").write_text(report.to_json({"aggregate": rows, "conservatism": cons, "episodes": episodes}))
    with open(out / "sweep.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]) if rows else ["experiment"])
        w.writeheader()
        w.writerows(rows)
    written = [out / "sweep.json", out / "sweep.csv"]
    if not args.no_plots:
        written += plot(rows, cons, out)
    print("\nwrote " + ", ".join(str(p) for p in written), file=sys.stderr)
    return rows


if __name__ == "__main__":
    main()
