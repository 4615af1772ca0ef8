"""Learning curves and a table of final figures from an experiment grid's run folders.

    python -m agents.report_grid results/grid/safe_rl [results/grid/sac ...] --out docs/training

For each environment of the grid, ``<out>/<env>.png`` holds four panels against training env
steps: episode return, coverage, contact steps per episode (all three over the training episodes
that end in each step bin) and the run's cumulative training contact steps; a line per method is
the mean over seeds and its band the seeds' spread (min … max). The scripted agent
(``shieldnav.InspectionAgent``, default shield, the runs' episode length) is the dashed line on
the coverage panel. ``<out>/results.md`` is the table of final figures, mean ± std over seeds:
the last evaluation's coverage, the training episodes' coverage, return and contact steps in the
last fifth of the run, and the contact steps summed over every training step.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

#: How many step bins a learning curve has.
BINS = 12
#: The share of a run, at its end, whose training episodes give the final figures.
LAST = 0.2
COLOURS = {"ppo_braking": "tab:green", "ppo_composite": "tab:blue", "ppo_none": "tab:red", "ppo_penalty": "tab:orange",
           "ppo_lagrangian": "tab:purple", "sac_braking": "tab:olive", "sac_composite": "tab:cyan", "sac_none": "tab:brown"}


def load_runs(*grids: Path) -> dict[str, dict[str, list[dict[str, Any]]]]:
    """``{env: {method: [run.json, one per seed]}}`` of every finished run under the ``grids``."""
    out: dict[str, dict[str, list[dict[str, Any]]]] = {}
    for path in sorted(p for grid in grids for p in grid.glob("*/*/seed_*/run.json")):
        meta = json.loads(path.read_text())
        env, method = meta.get("grid", {}).get("env", path.parts[-4]), meta.get("grid", {}).get("method", path.parts[-3])
        out.setdefault(env, {}).setdefault(method, []).append(meta)
    order = list(COLOURS)
    for env, methods in out.items():
        for runs in methods.values():
            runs.sort(key=lambda m: m["seed"])
        out[env] = dict(sorted(methods.items(), key=lambda kv: (order.index(kv[0]) if kv[0] in order else len(order), kv[0])))
    return out


def scripted_coverage(env_id: str, episode_steps: int | None, seeds: int, cache: Path) -> dict[str, Any]:
    """The scripted agent's coverage (mean, std, per seed) under the default shield, episodes
    of ``episode_steps`` (the registered limit when None); kept in ``cache``."""
    known = json.loads(cache.read_text()) if cache.exists() else {}
    key = f"{env_id}|{episode_steps}|{seeds}"
    if key not in known:
        from agents.episodes import run_episode

        kwargs = {} if episode_steps is None else {"max_episode_steps": episode_steps, "time_limit": episode_steps}
        rows = [run_episode({"env_id": env_id, "shield": "braking", "seed": s, "policy": "scripted", "kwargs": kwargs})["summary"] for s in range(seeds)]
        cov = [float(r["coverage"]) for r in rows]
        known[key] = {"coverage": float(np.mean(cov)), "std": float(np.std(cov)), "per_seed": cov, "collisions": [int(r.get("collisions", 0)) for r in rows]}
        cache.write_text(json.dumps(known, indent=1))
    return known[key]


def binned(meta: dict[str, Any], key: str, edges: np.ndarray) -> np.ndarray:
    """The mean of ``key`` over the training episodes ending in each bin (NaN where none end)."""
    t = np.array([e["timesteps"] for e in meta["episodes"]], dtype=float)
    v = np.array([e[key] for e in meta["episodes"]], dtype=float)
    out = np.full(len(edges) - 1, np.nan)
    for b in range(len(edges) - 1):
        sel = (t > edges[b]) & (t <= edges[b + 1])
        if sel.any():
            out[b] = v[sel].mean()
    return out


def cumulative_contacts(meta: dict[str, Any], at: np.ndarray) -> np.ndarray:
    """The run's contact steps summed over every training step up to each step count in ``at``
    (known at each episode's end, and in total at the run's end)."""
    t = np.array([0] + [e["timesteps"] for e in meta["episodes"]] + [meta["training_safety"]["steps"]], dtype=float)
    c = np.array([0] + [e["run_contact_steps"] for e in meta["episodes"]] + [meta["training_safety"]["contact_steps"]], dtype=float)
    return c[np.searchsorted(t, at, side="right") - 1]


def final(meta: dict[str, Any], key: str) -> float:
    """The mean of ``key`` over the training episodes of the run's last fifth (or, when none
    ends there, the last episode of each environment)."""
    end = meta["training_safety"]["steps"]
    rows = [e[key] for e in meta["episodes"] if e["timesteps"] > (1 - LAST) * end] or [e[key] for e in meta["episodes"][-meta["num_envs"]:]]
    return float(np.mean(rows)) if rows else float("nan")


def spread(values: list[float], digits: int = 3) -> str:
    v = np.asarray(values, dtype=float)
    return f"{v.mean():.{digits}f} ± {v.std():.{digits}f}"


def table(runs: dict[str, dict[str, list[dict[str, Any]]]], scripted: dict[str, dict[str, Any]], grid_summaries: dict[str, dict[str, Any]]) -> str:
    lines = ["| env | method | seeds | steps | eval coverage | training coverage | training return | contact steps / episode | "
             "training contact steps (per seed) | episodes with contact | steps/s |", "|---|---|---:|---:|---:|---:|---:|---:|---|---:|---:|"]
    for env, methods in runs.items():
        for method, metas in methods.items():
            evals = [m["eval"][-1]["coverage"] for m in metas if m["eval"]]
            safety = [m["training_safety"] for m in metas]
            lines.append(
                f"| {env} | {method} | {len(metas)} | {metas[0]['timesteps']:,} | {spread(evals) if evals else '–'} | {spread([final(m, 'coverage') for m in metas])} | "
                f"{spread([final(m, 'return') for m in metas], 2)} | {spread([final(m, 'contact_steps') for m in metas], 1)} | "
                f"{spread([s['contact_steps'] for s in safety], 0)} ({', '.join(str(s['contact_steps']) for s in safety)}) | "
                f"{sum(s['episodes_with_contact'] for s in safety)} / {sum(s['episodes'] for s in safety)} | {np.mean([m['steps_per_s'] for m in metas]):.0f} |")
        if env in scripted:
            s = scripted[env]
            lines.append(f"| {env} | scripted agent (braking) | {len(s['per_seed'])} | – | {spread(s['per_seed'])} | – | – | – | – | – | – |")
    text = "\n".join(lines) + "\n"
    for name, g in grid_summaries.items():
        text += (f"\nThe last invocation of the grid `{name}`: {g['done']} runs in {g['wall_time_s'] / 60:.1f} min, "
                 f"{g['steps_per_s']:.0f} training env steps/s over {g['workers']} workers ({g['backend']}).\n")
    return text


def figure(env: str, methods: dict[str, list[dict[str, Any]]], scripted: dict[str, Any] | None, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    end = max(m["training_safety"]["steps"] for metas in methods.values() for m in metas)
    edges = np.linspace(0, end, BINS + 1)
    mid = (edges[:-1] + edges[1:]) / 2
    at = np.linspace(0, end, 100)
    fig, axes = plt.subplots(1, 4, figsize=(20, 4.4))
    panels = [("return", "episode return"), ("coverage", "coverage (share of the wall inspected)"), ("contact_steps", "contact steps per episode")]
    for method, metas in methods.items():
        colour = COLOURS.get(method)
        label = f"{method} ({len(metas)} seeds)"
        for ax, (key, _) in zip(axes, panels):
            y = np.array([binned(m, key, edges) for m in metas])
            ok = ~np.isnan(y).all(axis=0)
            mean = np.nanmean(y[:, ok], axis=0)
            ax.plot(mid[ok], mean, color=colour, label=label)
            ax.fill_between(mid[ok], np.nanmin(y[:, ok], axis=0), np.nanmax(y[:, ok], axis=0), color=colour, alpha=0.2)
        c = np.array([cumulative_contacts(m, at) for m in metas])
        axes[3].plot(at, c.mean(axis=0), color=colour, label=label)
        axes[3].fill_between(at, c.min(axis=0), c.max(axis=0), color=colour, alpha=0.2)
    if scripted is not None:
        axes[1].axhline(scripted["coverage"], color="black", linestyle="--", label="scripted agent (braking)")
    for ax, (_, title) in zip(axes, [*panels, (None, "contact steps over all training so far")]):
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("training env steps")
        ax.grid(alpha=0.3)
    axes[2].set_yscale("symlog", linthresh=1)
    axes[3].set_yscale("symlog", linthresh=1)
    for ax in axes[2:]:
        ax.set_ylim(bottom=0)
    handles, labels = axes[1].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize=9, frameon=False)
    fig.suptitle(f"{env}: {next(iter(methods.values()))[0]['env_id']}, mean over seeds, band: min … max", fontsize=11)
    fig.tight_layout(rect=(0, 0.07, 1, 0.95))
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main(argv: list[str] | None = None) -> Path:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("grids", nargs="+", help="the grids' folders (agents.grid --out); their runs are drawn together")
    ap.add_argument("--out", default="docs/training", help="where the pictures and results.md go")
    ap.add_argument("--scripted-seeds", type=int, default=3, help="episodes of the scripted agent per environment (0: no line)")
    args = ap.parse_args(argv)
    grids, out = [Path(g) for g in args.grids], Path(args.out)
    runs = load_runs(*grids)
    if not runs:
        ap.error(f"no finished run (run.json) under {', '.join(map(str, grids))}")
    out.mkdir(parents=True, exist_ok=True)
    scripted = {}
    for env, methods in runs.items():
        meta = next(iter(methods.values()))[0]
        if args.scripted_seeds > 0:
            scripted[env] = scripted_coverage(meta["env_id"], meta.get("max_episode_steps"), args.scripted_seeds, grids[0] / "scripted.json")
        figure(env, methods, scripted.get(env), out / f"{env}.png")
    summaries = {g.name: json.loads((g / "grid.json").read_text()) for g in grids if (g / "grid.json").exists()}
    (out / "results.md").write_text(table(runs, scripted, summaries))
    print(f"{out / 'results.md'} and {len(runs)} picture(s) in {out}")
    return out / "results.md"


if __name__ == "__main__":
    main()
