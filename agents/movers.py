"""Moving-obstacle sites for the red team and the benchmark: pedestrians crossing the robot's
path, walking head-on at it and overtaking it, a chaser steering at it, and a chair pushed and
a door swung toward it (the paper's Scenario 3). Each is a JSON scenario (``docs/world.md``)
run by ``shieldnav/CorridorInspection-v0`` with ``scenario_path=``; the robot starts at the
origin facing +x.

Pedestrians are 0.5 m squares at 1.2–1.5 m/s, the chaser a 0.5 m square at 1.0 m/s (slower
than the robot's 1.6 m/s) in an open hall; each site's timing and offsets are drawn from
``seed``, so that the pedestrians meet the robot where a cruising or full-speed attacker takes it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from agents.tight import HEIGHT, _path

PEDESTRIAN = {"vertices": [[-0.25, -0.25], [0.25, -0.25], [0.25, 0.25], [-0.25, 0.25]], "height": 1.8}
#: The chaser's speed (m/s): slower than the robot's top speed.
CHASER_SPEED = 1.0


def _hall(length: float, width: float) -> list[dict[str, Any]]:
    """A hall ``[-10, length] × [-width/2, width/2]`` closed on every side."""
    h = width / 2
    return _path((-10, -h), (length, -h), (length, h), (-10, h), (-10, -h))


def _walker(name: str, waypoints: list[list[float]], speed: float, start_time: float = 0.0) -> dict[str, Any]:
    return {"name": name, "shape": PEDESTRIAN, "walk": {"waypoints": [[round(x, 4), round(y, 4)] for x, y in waypoints], "speed": speed, "start_time": round(start_time, 4)}}


def _site(name: str, walls: list[dict[str, Any]], obstacles: list[dict[str, Any]]) -> dict[str, Any]:
    scenario = {"name": name, "walls": walls, "start": {"x": 0.0, "y": 0.0, "yaw": 0.0}, "obstacles": obstacles}
    return {"site": name, "scenario": scenario}


def crossing(rng: np.random.Generator) -> dict[str, Any]:
    """Three pedestrians crossing a 6 m corridor ahead of the robot, from either side, timed to
    meet a robot at 0.8–1.6 m/s."""
    walkers = []
    for k in range(3):
        x = 2.0 + 3.0 * k + rng.uniform(-0.5, 0.5)
        side = rng.choice([-1.0, 1.0])
        speed = rng.uniform(1.2, 1.5)
        t_meet = x / rng.uniform(0.8, 1.6)
        walkers.append(_walker(f"crossing-{k}", [[x, side * 2.8], [x, -side * 2.8]], speed, max(0.0, t_meet - 2.8 / speed)))
    return _site("crossing", _hall(30.0, 6.0), walkers)


def head_on(rng: np.random.Generator) -> dict[str, Any]:
    """Two pedestrians walking down a 4 m corridor straight at the robot, one after the other."""
    first = _walker("head-on-0", [[rng.uniform(6.0, 10.0), rng.uniform(-0.3, 0.3)], [-9.5, 0.0]], rng.uniform(1.2, 1.5))
    second = _walker("head-on-1", [[rng.uniform(14.0, 18.0), rng.uniform(-0.6, 0.6)], [-9.5, rng.uniform(-0.6, 0.6)]], rng.uniform(1.2, 1.5), rng.uniform(0.0, 3.0))
    return _site("head-on", _hall(30.0, 4.0), [first, second])


def overtaking(rng: np.random.Generator) -> dict[str, Any]:
    """A pedestrian overtaking the robot from behind at 1.5 m/s, and one the robot overtakes."""
    fast = _walker("overtaking", [[-8.0, rng.uniform(-0.4, 0.4)], [28.0, rng.uniform(-0.4, 0.4)]], 1.5, rng.uniform(0.0, 2.0))
    slow = _walker("overtaken", [[rng.uniform(3.0, 5.0), rng.uniform(-0.3, 0.3)], [28.0, 0.0]], rng.uniform(0.5, 0.7))
    return _site("overtaking", _hall(30.0, 4.0), [fast, slow])


def chaser(rng: np.random.Generator) -> dict[str, Any]:
    """A chaser steering at the robot at 1.0 m/s in an open hall (30 × 30 m)."""
    a = rng.uniform(-np.pi, np.pi)
    r = rng.uniform(4.0, 7.0)
    start = [round(r * np.cos(a), 4), round(r * np.sin(a), 4)]
    obstacle = {"name": "chaser", "shape": PEDESTRIAN, "chase": {"start": start, "speed": CHASER_SPEED}}
    return _site("chaser", _path((-15, -15), (15, -15), (15, 15), (-15, 15), (-15, -15)), [obstacle])


def pushed(rng: np.random.Generator) -> dict[str, Any]:
    """A chair pushed toward the robot and a door swung into the corridor ahead of it
    (the paper's Scenario 3)."""
    t0 = rng.uniform(0.5, 3.0)
    chair = {"name": "chair", "shape": {"vertices": [[-0.3, -0.3], [0.3, -0.3], [0.3, 0.3], [-0.3, 0.3]], "height": 0.9},
             "trajectory": {"keys": [[t0, {"x": 7.0, "y": 1.2, "yaw": 0.0}], [t0 + 3.0, {"x": 2.5, "y": 0.1, "yaw": 0.6}]]}}
    t1 = rng.uniform(1.0, 4.0)
    door = {"name": "door", "shape": {"vertices": [[0.0, -0.03], [0.9, -0.03], [0.9, 0.03], [0.0, 0.03]], "height": HEIGHT},
            "trajectory": {"keys": [[t1, {"x": 5.0, "y": -1.5, "yaw": 0.0}], [t1 + 1.5, {"x": 5.0, "y": -1.5, "yaw": 1.5708}]]}}
    return _site("pushed", _hall(30.0, 3.0), [chair, door])


def mover_sites(seed: int = 0) -> list[dict[str, Any]]:
    """One of each site, drawn from ``seed``."""
    rng = np.random.default_rng(seed)
    return [f(rng) for f in (crossing, head_on, overtaking, chaser, pushed)]
