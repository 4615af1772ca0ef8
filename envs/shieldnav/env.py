"""The corridor-inspection Gymnasium environment: an adapter over the Rust ``Episode``."""

from __future__ import annotations

import os
from types import MappingProxyType
from typing import Any, Mapping

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from shieldnav._core import Episode, episode_defaults
from shieldnav.exceptions import InvalidArgumentError

#: Every configuration keyword of the environments with its default (the paper's values;
#: read-only, vectors as tuples).
ENV_DEFAULTS: Mapping[str, Any] = MappingProxyType({k: tuple(v) if isinstance(v, list) else v for k, v in episode_defaults().items()})

_OBSERVATIONS = ("flat", "dict")
#: The keywords that choose the site (exactly one is given).
SITE_KEYS = ("preset", "procedural", "map_path", "scenario_path")
#: Bound (m) of odometry quantities in the observation spaces: far beyond any site (walls lie
#: within 1e5 m of the origin), finite so that checkers accept the space.
_POSE_BOUND = 1.0e9


def site_args(preset: str | None, procedural: bool | None, map_path: Any, scenario_path: Any, default_site: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The site keywords of the Rust ``Episode`` and ``Batch`` (a path may start with ``~``),
    checked as the environments name them. ``default_site`` (a registered id's own site, e.g.
    ``{"procedural": True}``) applies when none of the four chooses a site; a site given
    replaces it, so that ``scenario_path=`` on a procedural id is that scenario."""
    if default_site is not None and (not isinstance(default_site, Mapping) or not set(default_site) <= set(SITE_KEYS)):
        raise InvalidArgumentError(f"invalid `default_site`: expected a mapping of {', '.join(SITE_KEYS)}, got {default_site!r}")
    given = {k: v for k, v in zip(SITE_KEYS, (preset, procedural, map_path, scenario_path)) if v is not None}
    # (procedural=False chooses no site: the id's applies, under it)
    if default_site and not any(k != "procedural" or not isinstance(v, (bool, np.bool_)) or v for k, v in given.items()):
        given = {**default_site, **given}
    preset, procedural, map_path, scenario_path = (given.get(k) for k in SITE_KEYS)
    procedural = False if procedural is None else procedural
    if not isinstance(procedural, (bool, np.bool_)):
        raise InvalidArgumentError(f"invalid `procedural`: expected True or False, got {procedural!r}")
    if preset is not None and not isinstance(preset, str):
        raise InvalidArgumentError(f"invalid `preset`: expected a preset name (str), got {preset!r}")
    for name, value in (("map_path", map_path), ("scenario_path", scenario_path)):
        if value is not None and not isinstance(value, (str, os.PathLike)):
            raise InvalidArgumentError(f"invalid `{name}`: expected a file path (str or os.PathLike), got {value!r}")
    chosen = [k for k, v in (("preset", preset), ("procedural=True", procedural or None), ("map_path", map_path), ("scenario_path", scenario_path)) if v is not None]
    if len(chosen) != 1:
        raise InvalidArgumentError(f"invalid site: give exactly one of preset, procedural=True, map_path, scenario_path (got {', '.join(chosen) or 'none'})")
    path = lambda p: None if p is None else os.path.expanduser(p)  # noqa: E731
    return dict(preset=preset, procedural=bool(procedural), ros_map=path(map_path), scenario=path(scenario_path))


def check_flag(name: str, value: Any) -> bool:
    """``value`` if it is a bool, else an error naming ``name``."""
    if not isinstance(value, (bool, np.bool_)):
        raise InvalidArgumentError(f"invalid `{name}`: expected True or False, got {value!r}")
    return bool(value)


#: The wall-clock entries of an episode's totals (shown with ``report_timing`` only).
TIMING_TOTALS = ("solve_time_mean_ns", "solve_time_max_ns")


def episode_totals(summary: dict[str, Any], report_timing: bool) -> dict[str, Any]:
    """An episode's totals as ``info["shieldnav_episode"]`` gives them: without the wall-clock
    entries unless ``report_timing``."""
    return summary if report_timing else {k: v for k, v in summary.items() if k not in TIMING_TOTALS}


class CorridorInspectionEnv(gym.Env[Any, np.ndarray]):
    """Inspect the walls of a building with a legged robot whose commands pass a safety shield.

    ## Description
    A 1.1 × 0.5 m robot (Spot-like) carries a LIDAR and a camera. The mission is visual
    inspection: every wall piece should pass through the camera's field of view (α = 69.4°
    wide, within ``d_view`` + margin). Each step the agent's nominal velocity command goes
    through the composite control-barrier-function shield of the paper (or a baseline), then
    a low-level tracker and rapier physics. The LIDAR sees the true world; the odometry the
    agent sees may drift and jump.

    ## Action Space
    ``Box(-1, 1, (3,), float32)``, read by ``action_mode``:

    | mode | meaning |
    |---|---|
    | ``"body"`` (default) | ``(v_x, v_y, ω)`` over the robot's limits ``v_max = (1.6, 0.8)`` m/s, ``w_max = 1.5`` rad/s |
    | ``"world"`` | ``(v_x, v_y)`` over ``controller_u_max`` in the odometry's world frame, ``ω`` as above |
    | ``"waypoint"`` | reference offset ``a₀₁ · waypoint_reach`` (m, body frame) and yaw offset ``a₂ π``; the P controller ``K_p = 4`` makes ``u_nom`` |

    Entries outside ``[-1, 1]`` (beyond 1e-6) or NaN raise ``InvalidArgumentError``.

    ## Observation Space
    ``observation="flat"`` (default): ``Box(float32, (lidar_bins + 9,))``, usable by SB3's
    ``MlpPolicy``:

    | index | observation |
    |---|---|
    | ``0 .. lidar_bins-1`` | nearest return per azimuth bin / ``lidar_max_range`` (bin 0 ahead, counter-clockwise; 1 = no return) |
    | ``+0 .. +2`` | odometry estimate change over the last step (Δx, Δy m in the previous estimate's frame, Δψ rad) |
    | ``+3 .. +5`` | body velocity over its limits |
    | ``+6 .. +8`` | last command sent to the tracker, over the limits |

    ``observation="dict"``: ``{"flat": the above, "points": (channels·columns, 3) float32
    returns of the latest scan in the current body frame (0 where none), "valid": (channels·columns,)
    int8 mask, "pose": (3,) float64 odometry estimate (x, y, ψ)}``: what the scripted agent reads.

    ## Rewards
    ``coverage_reward`` per metre of newly inspected wall, minus ``collision_penalty`` per step
    in contact, minus ``intervention_penalty`` · ‖u* − u_nom‖.

    ## Starting State
    The scenario's start (presets, maps) or a new procedural site per reset, at rest.

    ## Episode End
    Terminated when ``coverage_goal`` of the inspectable wall length is inspected, or at the
    first contact with ``terminate_on_contact=True``; truncated by the registered time limit,
    or at a deadlock with ``truncate_on_deadlock=True``. Contacts do not end the episode by
    default: ``info["cost"]`` counts them (safe-RL convention).

    ``info`` on every step: ``cost``, ``collision``, ``contacts``, ``clearance``, ``H``,
    ``h_min``, ``shield_active``, ``shield_feasible``, ``intervention``, ``u_nom``,
    ``u_filtered`` (body frame, ``(v_x, v_y, ω)``), ``coverage``, ``new_coverage``,
    ``deadlock``, ``odometry_error``, ``num_points``, ``time`` (and ``solve_time_ns`` with ``report_timing``); on the last
    step of an episode also ``shieldnav_episode``: collisions, contact time, deadlock,
    coverage, path length, time, mean intervention, shield statistics (``episode`` is left to
    Gymnasium's ``RecordEpisodeStatistics`` and SB3's ``Monitor``, which write their own). It
    comes with the episode's own ends: its ``time_limit`` (the id's registered steps, applied
    by the episode itself: no ``TimeLimit`` wrapper is registered), the goal, a deadlock; to
    shorten episodes pass ``time_limit=N`` (``gym.make(..., max_episode_steps=N)`` adds a
    ``TimeLimit`` wrapper the environment cannot see). ``env.unwrapped.episode.summary()`` gives the totals at any step.

    ## Arguments
    ``preset`` / ``procedural`` / ``map_path`` / ``scenario_path``: the site (exactly one).
    ``default_site``: the site when none of those is given (each registered id sets its own,
    e.g. ``{"procedural": True}``); a site keyword given replaces it, so
    ``gym.make("shieldnav/CorridorInspection-v0", scenario_path="my.json")`` runs that file.
    ``observation``: ``"flat"`` or ``"dict"``. ``render_mode``: ``"rgb_array"`` or ``"human"``.
    ``report_timing``: put the shield's wall time in ``info["solve_time_ns"]`` and its mean and
    maximum in ``info["shieldnav_episode"]`` (``solve_time_mean_ns``, ``solve_time_max_ns``;
    off by default: they are the only entries of ``info`` that differ between two runs with the
    same seed, and Gymnasium's checker asks for equal ones; the benchmark turns it on). A bool.
    Every other keyword is a configuration key of ``ENV_DEFAULTS`` (shield, its parameters,
    robot, tracker, LIDAR, rates, reward weights, coverage, deadlock), e.g.
    ``gymnasium.make("shieldnav/ConstrictedPassage-v0", shield="distance", kappa=12)``.

    ## Vectorized environment
    See ``shieldnav.vector``.

    ## Version History
    * v0: initial release.
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 50}

    def __init__(
        self,
        *,
        preset: str | None = None,
        procedural: bool | None = None,
        map_path: str | None = None,
        scenario_path: str | None = None,
        default_site: Mapping[str, Any] | None = None,
        observation: str = "flat",
        render_mode: str | None = None,
        report_timing: bool = False,
        **config: Any,
    ) -> None:
        # (`in` on an array compares element-wise: a bare ValueError)
        if not isinstance(observation, str) or observation not in _OBSERVATIONS:
            raise InvalidArgumentError(f"invalid `observation`: expected one of {_OBSERVATIONS}, got {observation!r}")
        if render_mode is not None and (not isinstance(render_mode, str) or render_mode not in self.metadata["render_modes"]):
            raise InvalidArgumentError(
                f"invalid `render_mode`: expected one of {self.metadata['render_modes']} or None, got {render_mode!r}"
            )
        if "seed" in config:
            raise InvalidArgumentError("invalid `seed`: not an environment keyword; seed the episodes with reset(seed=...)")
        self._site = site_args(preset, procedural, map_path, scenario_path, default_site)
        self._episode = Episode(**self._site, seed=0, **config)
        self.config = {**ENV_DEFAULTS, **config}
        self.observation_mode = observation
        self._report_timing = check_flag("report_timing", report_timing)
        self.render_mode = render_mode
        # frames at the control rate (human mode shows every step; video tools read this)
        self.metadata = {**type(self).metadata, "render_fps": 1.0 / float(self.config["dt"])}
        #: How many times the env has been reset (agents check that they were reset with it).
        self.resets = 0
        # the bounds the core derives from its validated configuration
        low, high = self._episode.observation_bounds()
        flat = spaces.Box(low, high, dtype=np.float32)
        if observation == "flat":
            self.observation_space: spaces.Space[Any] = flat
        else:
            channels, columns, max_range = self._episode.lidar_shape
            m = channels * columns
            # body-frame points: the range from the sensor, which sits at the mount's offset
            reach = np.float32(max_range + np.linalg.norm(np.asarray(self.config["lidar_mount"], float)[:3]))
            self.observation_space = spaces.Dict(
                {
                    "flat": flat,
                    "points": spaces.Box(-reach, reach, (m, 3), dtype=np.float32),
                    "valid": spaces.MultiBinary(m),
                    "pose": spaces.Box(-_POSE_BOUND, _POSE_BOUND, (3,), dtype=np.float64),
                }
            )
        self.action_space = spaces.Box(-1.0, 1.0, (3,), dtype=np.float32)
        #: A reference pose ``(x, y, ψ)`` in the odometry frame to draw (agents may set it).
        self.reference: Any = None
        self._renderer: Any = None
        self._window: Any = None

    @property
    def preset(self) -> str | None:
        """The paper preset this env runs, if any."""
        return self._site["preset"]

    @property
    def episode(self) -> Episode:
        """The Rust episode (poses, points, summary, render data)."""
        return self._episode

    def _obs(self, flat: np.ndarray) -> Any:
        if self.observation_mode == "flat":
            return flat
        points, valid = self._episode.scan_points()
        return {"flat": flat, "points": points, "valid": valid, "pose": np.array(self._episode.estimated_pose)}

    def _info(self) -> dict[str, Any]:
        # (the first scan, at reset, may already inspect walls)
        summary = self._episode.summary()
        return {"coverage": summary["coverage"], "time": summary["time"], "seed": self._episode_seed, "site": self._episode.name}

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        super().reset(seed=seed)
        if options:
            raise InvalidArgumentError(f"invalid `options`: reset takes no options, got {sorted(options)}")
        self._episode_seed = int(self.np_random.integers(0, 2**63))
        self._episode.reset(self._episode_seed)
        self.resets += 1
        if self.render_mode == "human":
            self.render()
        return self._obs(self._episode.observe()), self._info()

    def step(self, action: np.ndarray) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        flat, reward, terminated, truncated, info = self._episode.step(action)
        if not self._report_timing:
            del info["solve_time_ns"]
        if terminated or truncated:
            info["shieldnav_episode"] = episode_totals(self._episode.summary(), self._report_timing)
        if self.render_mode == "human":
            self.render()
        return self._obs(flat), reward, terminated, truncated, info

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' or 'human'")
            return None
        from shieldnav import rendering

        if self._renderer is None:
            self._renderer = rendering.TopDownRenderer()
        rgb = self._renderer.draw(self.render_frame())
        if self.render_mode == "human":
            if self._window is None:
                self._window = rendering.HumanWindow(rgb.shape[1], rgb.shape[0], self.metadata["render_fps"])
            self._window.show(rgb)
            return None
        return rgb

    def render_frame(self) -> Any:
        """The top-down picture's content now (a ``shieldnav.rendering.RenderFrame``)."""
        from shieldnav.rendering import RenderFrame

        d = self._episode.render_data()
        pose, est = d["pose"], d["estimated_pose"]
        reference = None
        if self.reference is not None:
            # from the odometry frame into the true one: where the robot is really sent
            rx, ry, ryaw = (float(v) for v in self.reference)
            c, s = np.cos(est[2]), np.sin(est[2])
            bx, by = c * (rx - est[0]) + s * (ry - est[1]), -s * (rx - est[0]) + c * (ry - est[1])
            c, s = np.cos(pose[2]), np.sin(pose[2])
            reference = np.array([pose[0] + c * bx - s * by, pose[1] + s * bx + c * by, ryaw - est[2] + pose[2]])
        (length, width), semi_axes, crop = self._episode.geometry
        text = (
            f"{self._episode.name}  t = {d['time']:.2f} s",
            # (no shield call before the first step: no H yet)
            f"coverage {100 * d['coverage']:.1f} %   H = " + (f"{d['H']:.3f}" if np.isfinite(d["H"]) else "n/a"),
            f"odometry error {np.hypot(est[0] - pose[0], est[1] - pose[1]):.2f} m",
        )
        return RenderFrame(
            walls=d["walls"], pieces=d["pieces"], inspected=d["inspected"], obstacles=d["obstacles"],
            pose=pose, footprint=(length, width), semi_axes=tuple(semi_axes), points=d["points"],
            crop_radius=crop, u_nom=d["u_nom"], u_star=d["u_star"], reference=reference,
            ghost_pose=est, text=text, contact=d["contact"],
        )

    def close(self) -> None:
        if self._window is not None:
            self._window.close()
            self._window = None
