"""Tables, files and pictures of a benchmark run."""

from __future__ import annotations

import csv
import json
import math
import sys
from collections import defaultdict
from pathlib import Path
from typing import Any, Iterable

import numpy as np

#: Columns of the per (scenario, shield) table, in order.
COLUMNS = [
    ("episodes", "{:d}"),
    ("with_contact", "{:d}"),
    ("contact_time_s", "{:.2f}"),
    ("deadlock_rate", "{:.2f}"),
    ("success_rate", "{:.2f}"),
    ("coverage", "{:.3f}"),
    ("intervention", "{:.3f}"),
    ("shield_us_mean", "{:.1f}"),
    ("shield_us_p99_6", "{:.1f}"),
    ("shield_us_max", "{:.1f}"),
    ("steps_per_s", "{:.0f}"),
]


def aggregate(results: Iterable[dict[str, Any]]) -> dict[tuple[str, str], dict[str, Any]]:
    """Per (scenario, shield): the table's columns over the episodes."""
    groups: dict[tuple[str, str], list[dict[str, Any]]] = defaultdict(list)
    for r in results:
        groups[(r["task"]["env_id"], r["task"]["shield"])].append(r)
    rows = {}
    for key, rs in sorted(groups.items()):
        s = [r["summary"] for r in rs]
        us = np.concatenate([r["solve_time_ns"] for r in rs]) / 1e3
        rows[key] = {
            "episodes": len(rs),
            "with_contact": sum(x["collisions"] > 0 for x in s),
            "contact_time_s": float(np.mean([x["contact_time"] for x in s])),
            "deadlock_rate": float(np.mean([x["deadlock"] for x in s])),
            "success_rate": float(np.mean([x["success"] for x in s])),
            "coverage": float(np.mean([x["coverage"] for x in s])),
            "intervention": float(np.mean([x["intervention_mean"] for x in s])),
            "shield_us_mean": float(us.mean()),
            "shield_us_p99_6": float(np.percentile(us, 99.6)),
            "shield_us_max": float(us.max()),
            "steps_per_s": float(np.mean([r["steps_per_s"] for r in rs])),
        }
    return rows


def table(rows: dict[tuple[str, str], dict[str, Any]]) -> str:
    """The aggregate as one text table per scenario."""
    out = []
    for scenario in dict.fromkeys(k[0] for k in rows):
        out.append(f"\n{scenario}")
        out.append(f"  {'shield':10s} " + " ".join(f"{name:>15s}" for name, _ in COLUMNS))
        for (sc, shield), row in rows.items():
            if sc == scenario:
                out.append(f"  {shield:10s} " + " ".join(f"{fmt.format(row[name]):>15s}" for name, fmt in COLUMNS))
    return "\n".join(out)


def write_files(results: list[dict[str, Any]], rows: dict[tuple[str, str], dict[str, Any]], out: Path) -> None:
    """``benchmark.json`` (every episode and the aggregate) and ``benchmark.csv`` (the aggregate)."""
    out.mkdir(parents=True, exist_ok=True)
    episodes = [{"task": r["task"], "summary": r["summary"], "steps_per_s": r["steps_per_s"]} for r in results]
    aggregate_list = [{"scenario": k[0], "shield": k[1], **v} for k, v in rows.items()]
    (out / "benchmark.json").write_text(to_json({"aggregate": aggregate_list, "episodes": episodes}))
    with open(out / "benchmark.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["scenario", "shield"] + [c for c, _ in COLUMNS])
        w.writeheader()
        w.writerows(aggregate_list)


def to_json(data: Any) -> str:
    """Valid JSON of ``data``: numpy values as Python ones, NaN and ±inf (e.g. the
    ``deadlock_time`` of an episode without a deadlock) as ``null``."""
    return json.dumps(_finite(data), indent=1, allow_nan=False)


def _finite(v: Any) -> Any:
    if isinstance(v, dict):
        return {k: _finite(x) for k, x in v.items()}
    if isinstance(v, (list, tuple, np.ndarray)):
        return [_finite(x) for x in v]
    if isinstance(v, np.generic):
        v = v.item()
    return None if isinstance(v, float) and not math.isfinite(v) else v


def plot_scenario(scenario: str, traces: dict[str, dict[str, Any]], timing: dict[str, tuple[np.ndarray, np.ndarray]], path: Path) -> None:
    """The paper's pictures for one scenario: u_nom against u* over time, H and min h_i over
    time (Figs. u_values, h_func), shield time over time and against the number of points
    (Fig. solver_time). ``traces`` and ``timing`` are keyed by shield."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(2, 3, figsize=(16, 8), constrained_layout=True)
    for shield, tr in traces.items():
        t = np.asarray(tr["t"])
        un, us = np.asarray(tr["u_nom"]), np.asarray(tr["u_star"])
        if shield == "composite":
            for k, name in enumerate(("x", "y")):
                ax[0, k].plot(t, un[:, k], color="m", lw=1.2, label="u_nom")
                ax[0, k].plot(t, us[:, k], color="purple", lw=1.2, ls="--", label="u*")
                ax[0, k].set(title=f"body-frame u_{name} (composite)", xlabel="t (s)", ylabel="m/s")
                ax[0, k].legend()
        # the shield reports f64::MAX for a scan with no point in the crop: not plotted
        H = np.asarray(tr["H"], dtype=np.float64)
        H[H >= 1e300] = np.nan
        ax[0, 2].plot(t, H, lw=1, label=f"H ({shield})")
        h_min = np.asarray(tr["h_min"], dtype=np.float64)
        h_min[h_min >= 1e300] = np.nan
        ax[1, 0].plot(t, h_min, lw=1, label=f"min h_i ({shield})")
    ax[0, 2].axhline(0, color="k", lw=0.5)
    ax[0, 2].set(title="composite barrier H", xlabel="t (s)")
    ax[0, 2].legend(fontsize=8)
    ax[1, 0].axhline(0, color="k", lw=0.5)
    ax[1, 0].set(title="smallest individual barrier", xlabel="t (s)", ylim=(-1, 3))
    ax[1, 0].legend(fontsize=8)
    for shield, (us, n) in timing.items():
        us = np.asarray(us, dtype=np.float64)
        us = np.where(us > 0, us, np.nan)  # log axes: a call timed at 0 µs is not drawn
        ax[1, 1].plot(np.arange(len(us)) * 0.02, us, lw=0.6, label=shield)
        ax[1, 2].scatter(n, us, s=2, alpha=0.4, label=shield)
    ax[1, 1].set(title="shield time per call", xlabel="t (s)", ylabel="µs", yscale="log")
    ax[1, 1].legend(fontsize=8)
    ax[1, 2].set(title="shield time vs points", xlabel="points used", ylabel="µs", yscale="log")
    ax[1, 2].legend(fontsize=8)
    fig.suptitle(scenario)
    fig.savefig(path, dpi=90)
    plt.close(fig)


if __name__ == "__main__":  # a library module: say which modules are command lines
    print("agents.report is not a command line; the command lines are python -m agents.train, agents.benchmark "
          "and agents.sweep (each with --help)", file=sys.stderr)
    sys.exit(2)
