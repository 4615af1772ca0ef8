"""A ROS map's walls as cell edges and as simplified contours, side by side, with a scan.

    python benchmarks/plot_map_walls.py ../shared/maps/g4s_office/g4s_y2.yaml [--out docs/img/map_walls.png]

Left: `simplify=0`, every wall a run of cell edges (a wall drawn at an angle is a staircase of
5 cm pieces). Right: the default, each contour simplified within one cell. Both with the wall
count and the 1024-column scan from the map's start (10 m range, no noise).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("map", help="ROS map_server YAML")
    ap.add_argument("--out", default="docs/img/map_walls.png")
    ap.add_argument("--half", type=float, default=7.0, help="half the side of the square shown (m)")
    args = ap.parse_args()

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection
    from shieldnav import World

    fig, axes = plt.subplots(1, 2, figsize=(12, 6.2), constrained_layout=True)
    for ax, simplify, title in ((axes[0], 0.0, "cell edges (simplify=0)"), (axes[1], None, "simplified within 1 cell (default)")):
        kw = {} if simplify is None else {"simplify": simplify}
        w = World(ros_map=args.map, range_noise_std=0.0, max_range=10.0, **kw)
        walls = np.asarray(w.walls)[:, :4]
        x, y, yaw = w.sensor_pose
        pts = np.asarray(w.points)[:, :2]
        pts = pts[np.isfinite(pts).all(axis=1)]
        c, s = np.cos(yaw), np.sin(yaw)
        world = pts @ np.array([[c, s], [-s, c]]) + [x, y]
        ax.add_collection(LineCollection(walls.reshape(-1, 2, 2), colors="k", linewidths=0.7))
        ax.plot(world[:, 0], world[:, 1], ".", color="tab:red", ms=2.5, label="LIDAR returns (1024 columns)")
        ax.plot([x], [y], "o", color="tab:blue", ms=6, label="sensor (map start)")
        ax.set_xlim(x - args.half, x + args.half)
        ax.set_ylim(y - args.half, y + args.half)
        ax.set_aspect("equal")
        ax.set_title(f"{title}: {len(walls)} walls")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.legend(loc="lower right", fontsize=8)
    fig.suptitle(f"{Path(args.map).parent.name}: map walls")
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=90)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
