"""Tight-space sites for the red team: the robot started inside aisles, L-shaped aisles and
doorways narrower than the shield's ellipse (semi-axes 0.9 × 0.45 m: 0.9 m wide), beside a
wall, facing one and in a corner. Each is a JSON scenario (``docs/world.md``) run by
``shieldnav/CorridorInspection-v0`` with ``scenario_path=``.

The body is the environment's default 1.1 × 0.5 m rectangle, centred on the start pose. Each
site's ``gap`` is the body's clearance at the start and ``width`` the free width of its aisle
or doorway (None elsewhere). Aisles are closed at both ends, so the robot stays in them; the
aisles' start takes a small lateral offset and yaw drawn from ``seed`` (a scenario's start is
fixed: one draw per site).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

HALF_LENGTH, HALF_WIDTH = 0.55, 0.25  # the body's half extents (robot_length, robot_width)
HEIGHT = 2.0  # walls' height (m)
AISLES = (0.60, 0.65, 0.70, 0.75, 0.80, 0.85, 0.90)
L_AISLES = (0.65, 0.70, 0.75, 0.80, 0.85, 0.90)
DOORS = (0.70, 0.75, 0.80, 0.90)
BESIDE, FACING, CORNER = (0.05, 0.10), (0.10, 0.20), (0.15, 0.20)
#: The least body clearance an aisle's jittered start keeps (m).
MARGIN = 0.02


def _wall(a: tuple[float, float], b: tuple[float, float]) -> dict[str, Any]:
    return {"a": [round(a[0], 6), round(a[1], 6)], "b": [round(b[0], 6), round(b[1], 6)], "height": HEIGHT}


def _path(*points: tuple[float, float]) -> list[dict[str, Any]]:
    """Walls joining ``points`` in turn (closed when the last equals the first)."""
    return [_wall(a, b) for a, b in zip(points, points[1:])]


def _block(x0: float, y0: float, x1: float, y1: float) -> dict[str, Any]:
    return {"vertices": [[x0, y0], [x1, y0], [x1, y1], [x0, y1]], "height": HEIGHT}


def _site(name: str, walls: list[dict[str, Any]], start: tuple[float, float, float], gap: float,
          width: float | None = None, polygons: tuple[dict[str, Any], ...] = ()) -> dict[str, Any]:
    x, y, yaw = start
    scenario = {"name": name, "walls": walls, "polygons": list(polygons), "start": {"x": round(x, 6), "y": round(y, 6), "yaw": round(yaw, 6)}}
    return {"site": name, "scenario": scenario, "gap": gap, "width": width}


def _jitter(width: float, rng: np.random.Generator) -> tuple[float, float, float]:
    """A lateral offset and a yaw for a start aligned with an aisle of ``width``, and the gap
    they leave: the body's half extent across, ``0.55 |sin ψ| + 0.25 cos ψ``, keeps ``MARGIN``."""
    dy = rng.uniform(-0.3, 0.3) * (width / 2 - HALF_WIDTH)
    room = width / 2 - abs(dy) - MARGIN  # the largest half extent allowed
    r, phi = math.hypot(HALF_LENGTH, HALF_WIDTH), math.atan2(HALF_WIDTH, HALF_LENGTH)
    yaw = rng.uniform(-1.0, 1.0) * min(0.1, 0.5 * (math.asin(min(room / r, 1.0)) - phi))
    return dy, yaw, width / 2 - abs(dy) - (HALF_LENGTH * abs(math.sin(yaw)) + HALF_WIDTH * math.cos(yaw))


def aisle(width: float, rng: np.random.Generator, length: float = 6.0) -> dict[str, Any]:
    """A closed straight aisle along x, the robot in its middle."""
    h = width / 2
    dy, yaw, gap = _jitter(width, rng)
    return _site(f"aisle-{width:.2f}", _path((0, -h), (length, -h), (length, h), (0, h), (0, -h)), (length / 2, dy, yaw), gap, width)


def l_aisle(width: float, rng: np.random.Generator, leg: float = 4.0) -> dict[str, Any]:
    """A closed L: along x from 0 to ``leg``, then up y by ``leg``; the robot in the first leg,
    its nose 0.6 m before the corner's opening."""
    h = width / 2
    walls = _path((0, -h), (leg, -h), (leg, h + leg), (leg - width, h + leg), (leg - width, h), (0, h), (0, -h))
    dy, yaw, gap = _jitter(width, rng)
    return _site(f"L-{width:.2f}", walls, (leg - width - 0.6 - HALF_LENGTH, dy, yaw), gap, width)


def doorway(width: float, inside: bool) -> dict[str, Any]:
    """Two 3 × 4 m rooms joined through a 0.15 m thick wall by a doorway of ``width``; the
    robot faces it, its nose 0.15 m before it, or stands in it."""
    h, t = width / 2, 0.15
    jambs = (_block(0, h, t, 2), _block(0, -2, t, -h))
    if inside:
        start, gap = (t / 2, 0.0, 0.0), h - HALF_WIDTH
    else:
        start, gap = (-0.15 - HALF_LENGTH, 0.0, 0.0), math.hypot(0.15, h - HALF_WIDTH)
    name = f"door-{width:.2f}-{'inside' if inside else 'front'}"
    return _site(name, _path((-3, -2), (3 + t, -2), (3 + t, 2), (-3, 2), (-3, -2)), start, gap, width, jambs)


def room_start(kind: str, gap: float) -> dict[str, Any]:
    """In a 5 × 4 m room, facing +x: ``beside`` the wall y = 0, ``facing`` the wall x = 5, or
    in the ``corner`` of both, ``gap`` from each."""
    x = {"beside": 2.5, "facing": 5 - HALF_LENGTH - gap, "corner": 5 - HALF_LENGTH - gap}[kind]
    y = 2.0 if kind == "facing" else HALF_WIDTH + gap
    return _site(f"{kind}-{gap:.2f}", _path((0, 0), (5, 0), (5, 4), (0, 4), (0, 0)), (x, y, 0.0), gap)


def tight_sites(seed: int = 0) -> list[dict[str, Any]]:
    """Every tight site: ``site`` (its name), ``scenario`` (the JSON object), ``gap``, ``width``."""
    rng = np.random.default_rng(seed)
    return (
        [aisle(w, rng) for w in AISLES]
        + [l_aisle(w, rng) for w in L_AISLES]
        + [doorway(w, inside) for w in DOORS for inside in (False, True)]
        + [room_start(kind, g) for kind, gaps in (("beside", BESIDE), ("facing", FACING), ("corner", CORNER)) for g in gaps]
    )


def scenario_file(scenario: dict[str, Any], folder: str | os.PathLike[str] | None = None) -> str:
    """``scenario`` written as a JSON file named by its content (under the temporary folder by
    default: a worker on another machine writes its own), for ``scenario_path=``."""
    text = json.dumps(scenario, sort_keys=True)
    base = Path(folder) if folder is not None else Path(tempfile.gettempdir()) / "shieldnav-tight"
    path = base / f"{scenario['name']}-{hashlib.sha1(text.encode()).hexdigest()[:12]}.json"
    if not path.exists():
        base.mkdir(parents=True, exist_ok=True)
        part = path.with_suffix(f".{os.getpid()}.part")
        part.write_text(text)
        os.replace(part, path)
    return str(path)
