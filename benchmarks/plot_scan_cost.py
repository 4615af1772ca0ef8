"""Where on a map the LIDAR's scan is slow: the times of `lidar_maps --csv` drawn on the maps.

    cargo run --release -p shieldnav-core --example lidar_maps -- --places 32 --csv scan_cost.csv
    python benchmarks/plot_scan_cost.py scan_cost.csv --maps ../shared/maps [--only g4s_office ut_gdc_floor2] [--how walking] [--out docs/img/scan_cost.png]

One panel per map: its walls (default contours), each place timed as a dot coloured by the
least time per planar 1024-column scan there (a robot pacing 0.75 m), the start (the map's
most open place) as a star, and the issue's 15 µs target as the colour scale's middle.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

TARGET_US = 15.0


def read_times(path: Path) -> dict[str, list[tuple[str, float, float, float, float]]]:
    """Rows of `lidar_maps --csv` per map: (where, x, y, least µs, range m)."""
    out: dict[str, list[tuple[str, float, float, float, float]]] = {}
    with path.open(newline="") as f:
        rows = csv.DictReader(f)
        want = {"map", "range_m", "where", "x", "y", "least_us"}
        if rows.fieldnames is None or not want <= set(rows.fieldnames):
            raise SystemExit(f"{path}: expected the columns {sorted(want)} of `lidar_maps --csv`, got {rows.fieldnames}")
        for n, r in enumerate(rows, start=2):
            try:
                out.setdefault(r["map"], []).append((r["where"], float(r["x"]), float(r["y"]), float(r["least_us"]), float(r["range_m"])))
            except ValueError as e:
                raise SystemExit(f"{path}: line {n}: {e}") from None
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("csv", type=Path, help="the times, from `lidar_maps --csv`")
    ap.add_argument("--maps", type=Path, default=Path("../shared/maps"), help="the maps' directory (one sub-directory with a YAML per map)")
    ap.add_argument("--only", nargs="+", help="these maps (default: every map in the CSV)")
    ap.add_argument("--range", type=float, help="the range (m) whose times to draw, if the CSV has several")
    ap.add_argument("--out", type=Path, default=Path("docs/img/scan_cost.png"))
    ap.add_argument("--how", default="", help="how the scans were taken, for the titles (e.g. 'walking', for `lidar_maps --mesh`)")
    args = ap.parse_args()

    times = read_times(args.csv)
    ranges = sorted({t[4] for rows in times.values() for t in rows})
    if not ranges:
        raise SystemExit(f"{args.csv}: no times (only its header)")
    if args.range is None and len(ranges) > 1:
        raise SystemExit(f"{args.csv} holds times at ranges {ranges} m: pick one with --range")
    rng = args.range if args.range is not None else ranges[0]
    times = {n: [t for t in rows if t[4] == rng] for n, rows in times.items()}
    times = {n: rows for n, rows in times.items() if rows}
    if not times:
        raise SystemExit(f"{args.csv}: no times at range {rng:g} m (it has {ranges})")
    names = args.only or sorted(times)
    missing = [n for n in names if n not in times]
    if missing:
        raise SystemExit(f"{args.csv}: no times for {missing}; it has {sorted(times)}")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection
    from matplotlib.colors import TwoSlopeNorm
    from matplotlib.lines import Line2D
    from shieldnav import World

    all_us = [t[3] for n in names for t in times[n]]
    norm = TwoSlopeNorm(vcenter=TARGET_US, vmin=min(min(all_us), TARGET_US - 1.0), vmax=max(max(all_us), TARGET_US + 1.0))
    fig, axes = plt.subplots(1, len(names), figsize=(6.5 * len(names), 6.2), constrained_layout=True, squeeze=False)
    for ax, name in zip(axes[0], names):
        yamls = sorted((args.maps / name).glob("*.yaml"))
        if not yamls:
            raise SystemExit(f"{args.maps / name}: no map YAML")
        walls = np.asarray(World(ros_map=str(yamls[0])).walls)[:, :4]
        ax.add_collection(LineCollection(walls.reshape(-1, 2, 2), colors="0.35", linewidths=0.4))
        rows = times[name]
        places = np.array([t[1:4] for t in rows if t[0] == "place"]).reshape(-1, 3)
        start = [t for t in rows if t[0] == "start"]
        sc = ax.scatter(places[:, 0], places[:, 1], c=places[:, 2], cmap="RdYlGn_r", norm=norm, s=45, edgecolors="k", linewidths=0.4)
        for _, x, y, us, _ in start:
            ax.scatter([x], [y], c=[us], cmap="RdYlGn_r", norm=norm, s=260, marker="*", edgecolors="k", linewidths=0.6)
        ok = int((places[:, 2] <= TARGET_US).sum())
        ax.autoscale()
        ax.set_aspect("equal")
        how = f", {args.how}" if args.how else ""
        ax.set_title(f"{name}, {rows[0][4]:g} m range{how}: {ok} of {len(places)} places within {TARGET_US:g} µs")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.legend(
            handles=[
                Line2D([], [], marker="o", ls="", mfc="0.8", mec="k", label="a place (a robot pacing 0.75 m)"),
                Line2D([], [], marker="*", ms=13, ls="", mfc="0.8", mec="k", label="the start (the most open place)"),
            ],
            loc="lower right",
            fontsize=8,
        )
    fig.colorbar(sc, ax=axes[0].tolist(), shrink=0.8, label="least µs per scan (planar, 1024 columns)")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=80)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
