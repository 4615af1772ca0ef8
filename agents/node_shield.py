"""The ROS 2 node's decisions in the loop of the simulated body.

``NodeShield(env)`` puts ``shieldnav._core.Node`` (the node's own code, without the network)
where the environment's shield would be: at each step the agent's action becomes the nominal
``Twist``, the node gets the body's LIDAR as a ``LaserScan`` when a new scan is taken and its
velocity as ``Odometry``, each at the episode's time, and the command it answers drives the
body. The environment must run without its own shield (``shield="none"``) in the ``body``
action mode with a planar LIDAR; the node's braking model is the environment's body
(``tracker_tau``, ``a_max``, ``w_max``, ``yaw_accel_max``, ``dt``, ``v_max``, the footprint and the
LIDAR's mount). ``info["node_state"]`` holds the node's state for the step.

    env = NodeShield(gym.make("shieldnav/CorridorInspection-v0", shield="none"))
    python -m agents.redteam --shields node --tight     # the red team against the node
"""

from __future__ import annotations

import json
import math
from typing import Any, Sequence

import gymnasium as gym
import numpy as np
from shieldnav._core import Node
from shieldnav.exceptions import InvalidArgumentError

#: The node's shield parameters the environment's configuration holds under the same names.
SHARED = ("semi_axes", "gamma", "kappa", "alpha", "crop_radius", "safety_distance", "height_band", "voxel_size", "angular_bins", "grad_eps",
          "tracker_tau", "a_max", "w_max", "yaw_accel_max", "dt", "brake_margin", "lidar_noise_std", "tight_speed", "rotation_weight",
          "stop_when_infeasible", "track_movers", "mover_min_speed", "mover_max_size", "mover_max_range", "mover_accel")


def _yaml(v: Any) -> str:
    """A value as a ROS 2 command line writes it (``name:=value``, read as YAML)."""
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_yaml(x) for x in v) + "]"
    return repr(float(v)) if isinstance(v, float) else repr(v)


def body_parameters(config: dict[str, Any]) -> list[str]:
    """The node's ``-p`` arguments that make its shield the environment's: every shared
    parameter, the speed box (``u_max``, else the tracker's ``v_max``), the footprint (else
    the body's rectangle) and the LIDAR's mount."""
    length, width = config["robot_length"], config["robot_width"]
    footprint = config["footprint"] or [[length / 2, width / 2], [-length / 2, width / 2], [-length / 2, -width / 2], [length / 2, -width / 2]]
    mount = config["lidar_mount"]
    values = {name: config[name] for name in SHARED}
    values.update({"u_max": config["u_max"] or config["v_max"], "footprint": footprint,
                   "mount_x": mount[0], "mount_y": mount[1], "mount_z": mount[2], "mount_yaw": mount[3]})
    return [a for name, v in values.items() for a in ("-p", f"{name}:={_yaml(v)}")]


class NodeShield(gym.Wrapper):
    """See the module's text. ``node_args``: more of the node's command line (over the body's)."""

    def __init__(self, env: gym.Env, node_args: Sequence[str] = ()) -> None:
        super().__init__(env)
        config = env.unwrapped.config
        if config["shield"] != "none" or config["action_mode"] != "body":
            raise InvalidArgumentError(f"invalid `env`: NodeShield needs shield='none' and action_mode='body', got {config['shield']!r} and {config['action_mode']!r}")
        channels, self._columns, self._max_range = env.unwrapped.episode.lidar_shape
        if channels != 1:
            raise InvalidArgumentError(f"invalid `env`: NodeShield feeds a LaserScan, the LIDAR has {channels} channels")
        self._args = ["-p", "method:=braking", *body_parameters(config), *map(str, node_args)]
        self._limits = np.array([*config["v_max"], config["w_max"]], float)
        self._increment = float(np.float32(2 * math.pi / self._columns))
        self._angle_max = float(np.float32((self._columns - 1) * self._increment))
        self.node = Node(self._args)
        self._scan_time: float | None = None

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        self.node = Node(self._args)
        self._scan_time = None
        return obs, info

    def step(self, action: np.ndarray) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        episode = self.env.unwrapped.episode
        t = episode.time
        ranges, stamp, _ = episode.scan_ranges()
        if stamp != self._scan_time:
            self._scan_time = stamp
            self.node.on_scan(t, "laser", 0.0, self._angle_max, self._increment, 0.0, float(self._max_range), ranges[0].astype(np.float32))
        v = episode.velocity
        self.node.on_odometry(t, [v[0], v[1], 0.0], [0.0, 0.0, v[2]])
        nominal = np.clip(np.asarray(action, float), -1.0, 1.0) * self._limits
        command, state = self.node.on_nominal(t, [nominal[0], nominal[1], 0.0], [0.0, 0.0, nominal[2]])
        # (the command is within the limits; the division's last bit is rounding)
        act = np.clip(np.array([command[0], command[1], command[5]]) / self._limits, -1.0, 1.0).astype(np.float32)
        obs, reward, terminated, truncated, info = self.env.step(act)
        info["node_state"] = json.loads(state)
        return obs, reward, terminated, truncated, info
