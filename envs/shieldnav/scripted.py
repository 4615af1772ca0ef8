"""The paper's inspection stack as a policy: the reactive view planner (Sec. IV-A, Eq. flip)
and the P controller ``u_nom = K_p (p_d − p̂)``, both in Rust, on what the robot observes
(the LIDAR returns in its body frame and the odometry estimate).

Two missions:

- ``"inspect"``: the reference is the view planner's (nearest surface at ``d_view``, sideways
  by ``d_hov``, facing the wall), held until reached. Three additions make the paper's
  reactive planner usable on whole sites rather than one tunnel; each can be switched off:

  * ``keep_side``: the planner sees only the returns on the side of the wall being inspected
    (ahead of the last view direction ν_x), so in a corridor it keeps following one wall
    instead of flipping to the opposite wall at every reference; corners turn it gradually.
  * ``fit_reference``: in corridors narrower than about 2 ``d_view`` the paper's reference
    lies where the robot cannot stand (its ellipse, facing the wall, spans the corridor);
    held until reached, it deadlocks the robot. Such a reference is moved across the
    corridor (then turned) as little as needed for the composite barrier ``H`` of the current
    scan, seen from there, to be at least ``fit_margin``.
  * ``stall_time``: a reference that the robot has come no closer to for this long (the
    shield blocks it) is replaced by a new one from where the robot stands; a second stall
    in a row turns the robot to the other side.
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
from gymnasium.error import ResetNeeded

from shieldnav import NominalController, Shield, ViewPlanner
from shieldnav.env import CorridorInspectionEnv
from shieldnav.exceptions import InvalidArgumentError

#: Yaw changes tried, in order, when the planned view pose does not fit (rad).
_TURNS = np.radians([0.0, 30.0, -30.0, 60.0, -60.0, 90.0, -90.0])


def _free_fraction(world: np.ndarray, start: np.ndarray, step: np.ndarray, half_width: float) -> float:
    """How much of the straight move ``start → start + step`` a body ``2 half_width`` wide can
    make before a return lies in its way (0 to 1), keeping ``half_width`` back."""
    length = float(np.hypot(*step))
    if length == 0.0 or len(world) == 0:
        return 1.0
    u = step / length
    rel = world - start
    s, lateral = rel @ u, rel @ np.array((-u[1], u[0]))
    blocking = s[(np.abs(lateral) < half_width) & (s > 0.0)]
    free = float(blocking.min()) - half_width if len(blocking) else math.inf
    return float(np.clip(free / length, 0.0, 1.0))


def _free_interval(world: np.ndarray, centre: np.ndarray, axis: np.ndarray, half_width: float) -> tuple[float, float]:
    """The offsets along ``axis`` through ``centre`` that a body ``2 half_width`` wide reaches
    without a return in its way (at most 2 m each way), ``half_width`` kept back."""
    rel = world - centre
    s, lateral = rel @ axis, rel @ np.array((-axis[1], axis[0]))
    inside = np.abs(lateral) < half_width
    ahead, behind = s[inside & (s > 0.0)], s[inside & (s <= 0.0)]
    hi = min(2.0, float(ahead.min()) - half_width) if len(ahead) else 2.0
    lo = max(-2.0, float(behind.max()) + half_width) if len(behind) else -2.0
    return lo, hi



def _number(name: str, value: Any) -> float:
    """``value`` as a float, or an ``InvalidArgumentError`` naming ``name``."""
    try:
        return float(value)
    except (TypeError, ValueError):
        raise InvalidArgumentError(f"invalid `{name}`: expected a number, got {value!r}") from None

class InspectionAgent:
    """``act(obs, info) -> action`` for any shieldnav environment and action mode.

    Reads the Dict observation (``points``, ``valid``, ``pose``) when the env gives one, else
    the same data from the env's episode. Planner and controller take their parameters from
    the env's configuration (the paper's values by default). Call ``reset()`` at every
    episode start.
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        *,
        mission: str = "auto",
        lookahead: float = 1.0,
        keep_side: bool = True,
        fit_reference: bool = True,
        fit_margin: float = 0.05,
        stall_time: float | None = 2.0,
    ) -> None:
        lookahead, fit_margin = _number("lookahead", lookahead), _number("fit_margin", fit_margin)
        stall_time = None if stall_time is None else _number("stall_time", stall_time)
        if mission not in ("auto", "inspect", "goal"):
            raise InvalidArgumentError(f"invalid `mission`: expected 'auto', 'inspect' or 'goal', got {mission!r}")
        if not (math.isfinite(lookahead) and lookahead > 0):
            raise InvalidArgumentError(f"invalid `lookahead`: must be finite and > 0 m, got {lookahead}")
        if not (math.isfinite(fit_margin) and fit_margin >= 0):
            raise InvalidArgumentError(f"invalid `fit_margin`: must be finite and >= 0 (a value of H), got {fit_margin}")
        if stall_time is not None and not (math.isfinite(stall_time) and stall_time > 0):
            raise InvalidArgumentError(f"invalid `stall_time`: must be None or finite and > 0 s, got {stall_time}")
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
        self._keep_side = keep_side
        self._fit = fit_reference
        self._stall_steps = None if stall_time is None else max(1, round(stall_time / c["dt"]))
        self._reach_threshold = float(c["reach_threshold"])
        self._half_width = 0.5 * float(c["robot_width"])
        # the env's composite barrier, to judge where the robot can stand
        self._shield = Shield(semi_axes=tuple(c["semi_axes"][:2]), gamma=c["gamma"], kappa=c["kappa"], crop_radius=c["crop_radius"], height_band=None)
        self._fit_margin = float(fit_margin)
        self._held: tuple[np.ndarray, float] | None = None
        self._side: np.ndarray | None = None
        self._closest = math.inf
        self._since_closer = 0
        self._stalls = 0
        self._goal: np.ndarray | None = None
        self._origin = np.zeros(2)
        #: The reference ``(p_d, ψ_d)`` of the last call, in the odometry's world frame.
        self.reference: tuple[np.ndarray, float] | None = None
        self._reset_with = -1  # the env's reset this agent was reset after

    def reset(self) -> None:
        """Forgets the held reference and reads the scenario's goal (call after ``env.reset``)."""
        self.planner.reset()
        self.reference = None
        self._held = None
        self._side = None
        self._stalls = 0
        goal = self._env.episode.goal
        transit = self._mission == "goal" or (self._mission == "auto" and self._env.preset is not None)
        if self._mission == "goal" and goal is None:
            raise InvalidArgumentError("invalid `mission`: 'goal' needs a scenario with a goal")
        self._goal = np.array(goal[:2]) if transit and goal is not None else None
        self._origin = np.array(self._env.episode.estimated_pose[:2])
        self._reset_with = self._env.resets

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

    def _inspect(self, points: np.ndarray, x: float, y: float, yaw: float) -> tuple[np.ndarray, float] | None:
        """The held view reference, replanned when reached or stalled (see the module doc)."""
        here = np.array((x, y))
        if self._held is not None:
            dist = float(np.hypot(*(self._held[0] - here)))
            # progress toward the reference: position, and yaw at 0.5 m per rad
            gap = dist + 0.5 * abs(math.remainder(self._held[1] - yaw, math.tau))
            if gap < self._closest - 0.05:
                self._closest, self._since_closer = gap, 0
            else:
                self._since_closer += 1
            stalled = self._stall_steps is not None and self._since_closer >= self._stall_steps
            if dist >= self._reach_threshold and not stalled:
                return self._held
            self._stalls = self._stalls + 1 if stalled else 0
            if self._stalls >= 2 and self._side is not None:
                self._side = -self._side
                self._stalls = 0
        c, s = math.cos(yaw), math.sin(yaw)
        world = here + points[:, :2] @ np.array([[c, s], [-s, c]])
        seen = points
        if self._keep_side and self._side is not None:
            ahead = (world - here) @ self._side > 0.0
            if ahead.any():
                seen = points[ahead]
        pose = self.planner.plan(np.ascontiguousarray(seen), (x, y), yaw)
        if pose is None:
            return self._held
        goal, goal_yaw = np.asarray(pose[0][:2], dtype=np.float64), float(pose[1])
        self._side = np.array((math.cos(goal_yaw), math.sin(goal_yaw)))
        if self._fit:
            goal, goal_yaw = self._fit_goal(world, here, goal, goal_yaw)
        self._held = (goal, goal_yaw)
        self._closest, self._since_closer = math.inf, 0
        return self._held

    def _fit_goal(self, world: np.ndarray, here: np.ndarray, goal: np.ndarray, goal_yaw: float) -> tuple[np.ndarray, float]:
        """A reference the robot can stand at: the planner's along-wall step kept (as far as
        the scan shows it free), then the distance to the wall (``d_insp``) and then the yaw
        changed as little as possible until the composite barrier of the scan seen from there
        (the env's ellipse, γ, κ and crop) is at least ``fit_margin``; the best candidate if
        none is."""
        view = np.array((math.cos(goal_yaw), math.sin(goal_yaw)))
        step = goal - here
        d_insp = float(step @ view)
        side = step - d_insp * view
        along = here + side * _free_fraction(world, here, side, self._half_width)
        lo, hi = _free_interval(world, along, view, self._half_width)
        offsets = np.arange(lo, hi, 0.05)
        if lo <= d_insp <= hi:
            offsets = np.append(offsets, d_insp)  # the planner's own distance, tried first
        if len(offsets) == 0:
            return along, goal_yaw
        offsets = offsets[np.argsort(np.abs(offsets - d_insp), kind="stable")]
        centres = along[None, :] + offsets[:, None] * view
        best = (-math.inf, centres[0], goal_yaw)
        zero = np.zeros(2)
        for turn in _TURNS:
            yaw = goal_yaw + turn
            rot = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
            for centre in centres:
                body = np.ascontiguousarray((world - centre) @ rot)
                barrier = self._shield.filter(body, zero, yaw=0.0, omega=0.0).H
                if barrier >= self._fit_margin:
                    return centre, yaw
                if barrier > best[0]:
                    best = (barrier, centre, yaw)
        return best[1], best[2]

    def act(self, obs: Any, info: dict[str, Any] | None = None) -> np.ndarray:
        """The action that makes the env's ``u_nom`` the paper's nominal command."""
        if self._reset_with != self._env.resets:
            # (else it would act on the last episode's goal and memory, or none)
            raise ResetNeeded("call agent.reset() after each env.reset(), before agent.act()")
        points, pose = self._observe(obs)
        x, y, yaw = (float(v) for v in pose)
        ref = self._transit(x, y) if self._goal is not None else self._inspect(points, x, y, yaw)
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
