"""The paper's inspection stack as a policy: the reactive view planner (Sec. IV-A, Eq. flip)
and the P controller ``u_nom = K_p (p_d − p̂)``, both in Rust, on what the robot observes
(the LIDAR returns in its body frame and the odometry estimate).

Two missions:

- ``"inspect"``: the reference is the view planner's (nearest surface at ``d_view``, sideways
  by ``d_hov``, facing the wall), held until reached.
- ``"goal"``: transit to the scenario's goal, as in the paper's three experiments where the
  robot is sent through a doorway, down a tunnel and along a corridor: the mission line runs
  from the start to the goal, and the reference is a carrot ``lookahead`` metres ahead of the
  estimate's projection on it, facing along the line. The line is fixed in the odometry frame
  at reset, so an odometry fault moves it exactly as in the paper's Scenario 2 (the
  controller then "directs the robot to the wall").

``mission="auto"`` (default) transits on the paper's presets and inspects elsewhere.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np

from shieldnav import NominalController, ViewPlanner
from shieldnav.env import CorridorInspectionEnv
from shieldnav.exceptions import InvalidArgumentError


class InspectionAgent:
    """``act(obs, info) -> action`` for any shieldnav environment and action mode.

    Reads the Dict observation (``points``, ``valid``, ``pose``) when the env gives one, else
    the same data from the env's episode. Planner and controller take their parameters from
    the env's configuration (the paper's values by default). Call ``reset()`` at every
    episode start.
    """

    def __init__(self, env: gym.Env[Any, Any], *, mission: str = "auto", lookahead: float = 1.0) -> None:
        if mission not in ("auto", "inspect", "goal"):
            raise InvalidArgumentError(f"invalid `mission`: expected 'auto', 'inspect' or 'goal', got {mission!r}")
        if not (math.isfinite(lookahead) and lookahead > 0):
            raise InvalidArgumentError(f"invalid `lookahead`: must be finite and > 0 m, got {lookahead}")
        inner = env.unwrapped
        if not isinstance(inner, CorridorInspectionEnv):
            raise InvalidArgumentError(f"invalid `env`: expected a shieldnav environment, got {type(inner).__name__}")
        self._env = inner
        c = inner.config
        self.planner = ViewPlanner(
            d_view=c["d_view"],
            gamma_h=c["gamma_h"],
            fov_h_deg=math.degrees(c["fov_h"]),
            fov_v_deg=math.degrees(c["fov_v"]),
            gamma_v=c["gamma_v"],
            horizon=c["horizon"],
            reach_threshold=c["reach_threshold"],
        )
        self.controller = NominalController(
            kp=c["kp"], k_yaw=c["k_yaw"], u_max=tuple(c["controller_u_max"]), omega_max=c["omega_max"]
        )
        self._mode = c["action_mode"]
        self._v_max = np.asarray(c["v_max"], dtype=np.float64)
        self._w_max = float(c["w_max"])
        self._u_max = np.asarray(c["controller_u_max"], dtype=np.float64)
        self._reach = float(c["waypoint_reach"])
        self._mission = mission
        self._lookahead = float(lookahead)
        self._goal: np.ndarray | None = None
        self._origin = np.zeros(2)
        #: The reference ``(p_d, ψ_d)`` of the last call, in the odometry's world frame.
        self.reference: tuple[np.ndarray, float] | None = None

    def reset(self) -> None:
        """Forgets the held reference and reads the scenario's goal (call after ``env.reset``)."""
        self.planner.reset()
        self.reference = None
        goal = self._env.episode.goal
        transit = self._mission == "goal" or (self._mission == "auto" and self._env.preset is not None)
        if self._mission == "goal" and goal is None:
            raise InvalidArgumentError("invalid `mission`: 'goal' needs a scenario with a goal")
        self._goal = np.array(goal[:2]) if transit and goal is not None else None
        self._origin = np.array(self._env.episode.estimated_pose[:2])

    def _transit(self, x: float, y: float) -> tuple[np.ndarray, float]:
        assert self._goal is not None
        line = self._goal - self._origin
        length = float(np.hypot(line[0], line[1]))
        if length == 0.0:
            return self._goal.copy(), 0.0
        t = line / length
        s = float(np.clip(np.dot((x, y) - self._origin, t) + self._lookahead, 0.0, length))
        return self._origin + s * t, math.atan2(t[1], t[0])

    def _observe(self, obs: Any) -> tuple[np.ndarray, np.ndarray]:
        if isinstance(obs, dict) and "points" in obs:
            points = np.ascontiguousarray(obs["points"][obs["valid"].astype(bool)], dtype=np.float64)
            return points, np.asarray(obs["pose"], dtype=np.float64)
        ep = self._env.episode
        return ep.valid_points(), np.asarray(ep.estimated_pose, dtype=np.float64)

    def act(self, obs: Any, info: dict[str, Any] | None = None) -> np.ndarray:
        """The action that makes the env's ``u_nom`` the paper's nominal command."""
        points, pose = self._observe(obs)
        x, y, yaw = (float(v) for v in pose)
        ref = self._transit(x, y) if self._goal is not None else self.planner.update(points, (x, y), yaw)
        self.reference = ref
        self._env.reference = None if ref is None else (float(ref[0][0]), float(ref[0][1]), float(ref[1]))
        if ref is None:
            return np.zeros(3, dtype=np.float32)
        goal, goal_yaw = ref
        u, w = self.controller.command((float(goal[0]), float(goal[1])), float(goal_yaw), (x, y), yaw)
        c, s = math.cos(yaw), math.sin(yaw)
        if self._mode == "body":
            a = [(c * u[0] + s * u[1]) / self._v_max[0], (-s * u[0] + c * u[1]) / self._v_max[1], w / self._w_max]
        elif self._mode == "world":
            a = [u[0] / self._u_max[0], u[1] / self._u_max[1], w / self._w_max]
        else:
            dx, dy = float(goal[0]) - x, float(goal[1]) - y
            dyaw = math.remainder(float(goal_yaw) - yaw, math.tau)
            a = [(c * dx + s * dy) / self._reach, (-s * dx + c * dy) / self._reach, dyaw / math.pi]
        return np.clip(np.asarray(a, dtype=np.float32), -1.0, 1.0)
