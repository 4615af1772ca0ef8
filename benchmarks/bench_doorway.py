"""Doorway benchmark: can a go-to-goal controller drive the robot through a doorway narrower
than the shield's 0.9 m ellipse, and how much slower does the shield make it?

A 8 x 5 m room split across by a 0.15 m thick wall with a centred doorway (0.70, 0.72, 0.75,
0.80, 0.90 m wide by default; the body is 1.1 x 0.5 m), the robot started 2.5 m before the wall
facing it, the goal 2.5 m beyond it: JSON scenarios built with ``agents.tight``'s helpers and
run by ``shieldnav/CorridorInspection-v0`` with ``scenario_path=``. The controller reads the
true pose (``env.unwrapped.episode.true_pose``) and commands the body-frame action
(``action_mode="body"``: ``(v_x, v_y, omega)`` over ``v_max``, ``w_max``): full speed toward
the goal, turning toward it, slowing within 0.5 m of it. An episode ends when the robot is
within 0.3 m of the goal, or after 60 s (3000 steps at 50 Hz). Each seed draws its own LIDAR
noise.

Per door and shield: episodes that reached the goal, the mean time to it (over those that
did), the steps in contact, the least true clearance, the steps the braking shield spent in
its tight-space mode, and the time over the unshielded one (ratio of the means).

    python benchmarks/bench_doorway.py                       # 5 doors x 3 shields x 3 seeds
    python benchmarks/bench_doorway.py --doors 0.75 --shields braking none --seeds 1
    python benchmarks/bench_doorway.py --out results/bench_doorway.json
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # agents.tight, run as a script

import gymnasium as gym
import numpy as np
import shieldnav

from agents.tight import HALF_LENGTH, _block, _path, _site, scenario_file

ENV_ID = "shieldnav/CorridorInspection-v0"
DOORS = (0.70, 0.72, 0.75, 0.80, 0.90)
SHIELDS = ("none", "braking", "composite")
THICKNESS = 0.15  # the dividing wall's (m), spanning x = 0 .. THICKNESS
RUN_UP = 2.5  # the start's centre before the wall and the goal beyond it (m)
ROOM = (-4.0, 4.0 + THICKNESS, -2.5, 2.5)  # x0, x1, y0, y1
REACH = 0.3  # the goal counts as reached within this distance (m)
SLOW = 0.5  # the controller slows down within this distance of the goal (m)
K_YAW = 2.0  # rad/s per rad of heading error
STEPS = 3000  # 60 s at 50 Hz


def door_site(width: float) -> dict[str, Any]:
    """The room with the doorway of ``width``: ``site``, ``scenario`` (the JSON object), ``gap``
    (the body's clearance to the wall at the start), ``width`` and ``goal`` (x, y)."""
    x0, x1, y0, y1 = ROOM
    h = width / 2
    jambs = (_block(0, h, THICKNESS, y1), _block(0, y0, THICKNESS, -h))
    site = _site(f"doorway-{width:.2f}", _path((x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)), (-RUN_UP, 0.0, 0.0),
                 RUN_UP - HALF_LENGTH, width, jambs)
    return {**site, "goal": (THICKNESS + RUN_UP, 0.0)}


def go_to_goal(pose: tuple[float, float, float], goal: tuple[float, float], v_max: tuple[float, float], w_max: float) -> np.ndarray:
    """The body-frame action in [-1, 1]^3: full speed toward ``goal`` (slowing within ``SLOW``),
    the heading turned toward it."""
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    dx, dy = goal[0] - x, goal[1] - y
    bx, by = c * dx + s * dy, -s * dx + c * dy  # the goal in the body frame
    d = math.hypot(bx, by)
    if d < 1e-9:
        return np.zeros(3, dtype=np.float32)
    speed = v_max[0] * min(1.0, d / SLOW)
    a = np.array([speed * bx / d / v_max[0], speed * by / d / v_max[1]])
    a /= max(1.0, float(np.abs(a).max()))  # inside the box, the direction kept
    w = float(np.clip(K_YAW * math.atan2(by, bx) / w_max, -1.0, 1.0))
    return np.array([a[0], a[1], w], dtype=np.float32)


def run_episode(width: float, shield: str, seed: int, steps: int = STEPS, **kwargs: Any) -> dict[str, Any]:
    """One episode through the doorway of ``width`` under ``shield``; ``kwargs`` go to ``gym.make``."""
    site = door_site(width)
    env = gym.make(ENV_ID, scenario_path=scenario_file(site["scenario"]), shield=shield, time_limit=steps, **kwargs)
    cfg = env.unwrapped.config
    v_max, w_max = tuple(cfg["v_max"]), float(cfg["w_max"])
    episode = env.unwrapped.episode
    env.reset(seed=seed)
    goal = site["goal"]
    reached, t_goal = False, None
    for _ in range(steps):
        _, _, terminated, truncated, info = env.step(go_to_goal(episode.true_pose, goal, v_max, w_max))
        x, y, _ = episode.true_pose
        if math.hypot(goal[0] - x, goal[1] - y) < REACH:
            reached, t_goal = True, float(info["time"])
            break
        if terminated or truncated:
            break
    summary = episode.summary()
    x, y, _ = episode.true_pose
    env.close()
    return {
        "door": width, "shield": shield, "seed": seed, "reached": reached, "time": t_goal, "steps": int(summary["steps"]),
        "contact_steps": int(summary["contact_steps"]), "min_clearance": float(summary["min_clearance"]),
        "tight_steps": int(summary["shield_tight_steps"]), "braked_steps": int(summary["shield_braked_steps"]),
        "distance_left": math.hypot(goal[0] - x, goal[1] - y), "deadlock": bool(summary["deadlock"]),
    }


def aggregate(episodes: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per door and shield: ``reached`` and ``episodes``, ``time`` (mean over the episodes that
    reached the goal), ``contact_steps`` (total), ``least_clearance``, ``tight_steps`` (mean),
    ``ratio`` (the mean time over the unshielded one on the same door, None without both)."""
    rows = []
    for door in sorted({e["door"] for e in episodes}):
        for shield in dict.fromkeys(e["shield"] for e in episodes if e["door"] == door):
            es = [e for e in episodes if (e["door"], e["shield"]) == (door, shield)]
            times = [e["time"] for e in es if e["reached"]]
            rows.append({
                "door": door, "shield": shield, "episodes": len(es), "reached": len(times),
                "time": float(np.mean(times)) if times else None,
                "contact_steps": sum(e["contact_steps"] for e in es),
                "least_clearance": min(e["min_clearance"] for e in es),
                "tight_steps": float(np.mean([e["tight_steps"] for e in es])),
            })
    for r in rows:
        base = next((b for b in rows if b["door"] == r["door"] and b["shield"] == "none"), None)
        r["ratio"] = r["time"] / base["time"] if base and base["time"] and r["time"] is not None else None
    return rows


def _num(v: float | None, fmt: str = ".2f") -> str:
    return "-" if v is None else format(v, fmt)


def table(rows: list[dict[str, Any]]) -> str:
    out = ["| door (m) | shield | reached | time to goal (s) | x unshielded | contact steps | least clearance (m) | tight steps |",
           "|---:|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        out.append(f"| {r['door']:.2f} | {r['shield']} | {r['reached']}/{r['episodes']} | {_num(r['time'])} | {_num(r['ratio'])} | "
                   f"{r['contact_steps']} | {r['least_clearance']:.3f} | {r['tight_steps']:.0f} |")
    return "\n".join(out)


def verdict(rows: list[dict[str, Any]], factor: float = 2.0) -> list[str]:
    """The doors the braking shield does not pass: not every episode reached, a contact, or
    more than ``factor`` times the unshielded time."""
    bad = []
    for r in rows:
        if r["shield"] != "braking":
            continue
        why = [w for w, fails in (
            (f"reached {r['reached']}/{r['episodes']}", r["reached"] < r["episodes"]),
            (f"{r['contact_steps']} contact steps", r["contact_steps"] > 0),
            (f"{_num(r['ratio'])} x the unshielded time", r["ratio"] is not None and r["ratio"] > factor),
        ) if fails]
        if why:
            bad.append(f"door {r['door']:.2f}: " + ", ".join(why))
    return bad


def main(argv: list[str] | None = None) -> list[dict[str, Any]]:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--doors", nargs="+", type=float, default=list(DOORS), help="doorway widths (m)")
    ap.add_argument("--shields", nargs="+", default=list(SHIELDS), choices=["none", "braking", "composite", "distance", "hardmin"])
    ap.add_argument("--seeds", type=int, default=3, help="seeds 0 .. N-1 per door and shield")
    ap.add_argument("--steps", type=int, default=STEPS, help="steps per episode at most (50 Hz)")
    ap.add_argument("--out", default=None, help="write the episodes and the table's rows as JSON here")
    args = ap.parse_args(argv)
    if args.seeds < 1 or args.steps < 1:
        ap.error("--seeds and --steps must be at least 1")
    if any(not 2 * 0.25 < d < ROOM[3] - ROOM[2] for d in args.doors):
        ap.error(f"argument --doors: each width must be wider than the body (0.5 m) and narrower than the room ({ROOM[3] - ROOM[2]:g} m)")
    episodes = [run_episode(d, s, seed, args.steps) for d in args.doors for s in args.shields for seed in range(args.seeds)]
    rows = aggregate(episodes)
    print(table(rows))
    if "braking" in args.shields:
        bad = verdict(rows)
        print("\nbraking: every door passed without contact within 2x the unshielded time" if not bad else "\nbraking falls short: " + "; ".join(bad))
    if args.out:
        out = Path(args.out)
        out.parent.mkdir(parents=True, exist_ok=True)
        meta = {"shieldnav": shieldnav.__version__, "python": platform.python_version(), "env_id": ENV_ID, "seeds": args.seeds,
                "steps": args.steps, "reach": REACH, "slow": SLOW, "run_up": RUN_UP}
        out.write_text(json.dumps({"meta": meta, "rows": rows, "episodes": episodes}, indent=1))
        print(f"wrote {out}")
    return rows


if __name__ == "__main__":
    main()
