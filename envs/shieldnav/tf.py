"""Static transforms (``tf2_msgs/TFMessage`` on ``/tf_static``): a sensor's mount on the body.

The node's mount is planar (``mount_x``, ``mount_y``, ``mount_z``, ``mount_yaw``): a chain of
static transforms from the body's frame to the sensor's is composed and read as that, and a
sensor tilted out of the body's plane (an upside-down or pitched LIDAR) is refused with its
angles, as the node could not use its scans as they are.
"""

from __future__ import annotations

import math
from typing import Any, Iterable

import numpy as np

from shieldnav.exceptions import ShieldnavError

#: Largest tilt (rad) of the sensor's z axis from the body's that is still read as planar.
MAX_TILT = math.radians(1.0)


class TransformError(ShieldnavError, ValueError):
    """No usable mount: the frames are not connected, or the sensor is tilted."""


def rotation(q: Any) -> np.ndarray:
    """The rotation matrix of a quaternion with fields ``x, y, z, w`` (normalised here)."""
    x, y, z, w = (float(q.x), float(q.y), float(q.z), float(q.w))
    n = math.sqrt(x * x + y * y + z * z + w * w)
    if not (math.isfinite(n) and n > 0.0):
        raise TransformError(f"a rotation quaternion is not finite or zero: ({x}, {y}, {z}, {w})")
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def static_tree(messages: Iterable[Any]) -> dict[str, tuple[str, np.ndarray, np.ndarray]]:
    """``child → (parent, R, t)`` from ``TFMessage``s (a later transform of a child wins);
    frame names without a leading ``/``."""
    tree: dict[str, tuple[str, np.ndarray, np.ndarray]] = {}
    for msg in messages:
        for tr in msg.transforms:
            v = tr.transform.translation
            t = np.array([float(v.x), float(v.y), float(v.z)])
            if not np.isfinite(t).all():
                raise TransformError(f"the transform {tr.header.frame_id} → {tr.child_frame_id} has a non-finite translation {t.tolist()}")
            tree[tr.child_frame_id.lstrip("/")] = (tr.header.frame_id.lstrip("/"), rotation(tr.transform.rotation), t)
    return tree


def mount(tree: dict[str, tuple[str, np.ndarray, np.ndarray]], base: str, sensor: str) -> tuple[float, float, float, float] | None:
    """The sensor frame's pose in the base frame as the node's mount ``(x, y, z, yaw)``;
    ``None`` when the tree does not lead from ``sensor`` up to ``base``."""
    base, frame = base.lstrip("/"), sensor.lstrip("/")
    r, t = np.eye(3), np.zeros(3)
    seen = {frame}
    while frame != base:
        if frame not in tree:
            return None
        parent, rp, tp = tree[frame]
        r, t = rp @ r, rp @ t + tp
        if parent in seen:
            raise TransformError(f"/tf_static holds a loop through {parent!r}")
        seen.add(parent)
        frame = parent
    tilt = math.acos(max(-1.0, min(1.0, r[2, 2])))
    if tilt > MAX_TILT:
        roll, pitch = math.atan2(r[2, 1], r[2, 2]), math.asin(max(-1.0, min(1.0, -r[2, 0])))
        raise TransformError(f"the sensor frame {sensor!r} is tilted {math.degrees(tilt):.1f}° from {base!r} (roll {roll:.3f}, pitch {pitch:.3f} rad) "
                             "in /tf_static; the node's mount is planar (mount_x, mount_y, mount_z, mount_yaw)")
    return float(t[0]), float(t[1]), float(t[2]), math.atan2(r[1, 0], r[0, 0])
