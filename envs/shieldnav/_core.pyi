"""Type stubs of the native module `shieldnav._core`."""

from typing import Any, Sequence, final

import numpy as np
import numpy.typing as npt

__version__: str
__all__ = [
    "__version__",
    "Shield",
    "ShieldOutcome",
    "shield_defaults",
    "ViewPlanner",
    "NominalController",
    "World",
    "Episode",
    "episode_defaults",
    "Batch",
    "Node",
]

_Vec = npt.ArrayLike
_Points = npt.NDArray[np.float32] | npt.NDArray[np.float64]

@final
class ShieldOutcome:
    """What one `Shield.filter` call produced."""

    @property
    def u(self) -> npt.NDArray[np.float64]: ...
    @property
    def H(self) -> float: ...
    @property
    def h_min(self) -> float: ...
    @property
    def grad_p(self) -> npt.NDArray[np.float64]: ...
    @property
    def dH_dt(self) -> float: ...
    @property
    def num_points(self) -> int: ...
    @property
    def active(self) -> bool: ...
    @property
    def feasible(self) -> bool: ...
    @property
    def solve_time_ns(self) -> int: ...
    @property
    def omega(self) -> float | npt.NDArray[np.float64]: ...
    @property
    def braked(self) -> bool: ...
    @property
    def recovering(self) -> bool: ...
    @property
    def sweep_h(self) -> float: ...
    @property
    def tight(self) -> bool: ...
    @property
    def clearance(self) -> float: ...

@final
class Shield:
    """The composite-CBF safety shield and its baselines."""

    def __new__(
        cls,
        semi_axes: Sequence[float] = ...,
        gamma: float = ...,
        kappa: float = ...,
        alpha: float = ...,
        crop_radius: float | None = ...,
        u_max: Sequence[float] | None = ...,
        method: str = ...,
        safety_distance: float = ...,
        height_band: tuple[float, float] | None = ...,
        voxel_size: float | None = ...,
        angular_bins: int | None = ...,
        grad_eps: float = ...,
        tracker_tau: float = ...,
        a_max: Sequence[float] = ...,
        w_max: float = ...,
        yaw_accel_max: float = ...,
        dt: float = ...,
        brake_margin: float = ...,
        rotation_weight: float = ...,
        footprint: tuple[float, float] | Sequence[Sequence[float]] | npt.ArrayLike | None = ...,
        lidar_noise_std: float = ...,
        tight_speed: float = ...,
        mover_accel: float = ...,
    ) -> Shield: ...
    def filter(
        self,
        points: _Points,
        u_nom: _Vec,
        yaw: float | None = None,
        omega: float | _Vec | None = None,
        rotation: npt.ArrayLike | None = None,
        extra_A: npt.NDArray[np.float64] | None = None,
        extra_b: _Vec | None = None,
        velocity: _Vec | None = None,
        movers: npt.NDArray[np.float64] | None = None,
    ) -> ShieldOutcome: ...
    def filter_world(
        self,
        points: _Points,
        u_nom: _Vec,
        position: _Vec,
        yaw: float | None = None,
        omega: float | _Vec | None = None,
        rotation: npt.ArrayLike | None = None,
        extra_A: npt.NDArray[np.float64] | None = None,
        extra_b: _Vec | None = None,
        velocity: _Vec | None = None,
        movers: npt.NDArray[np.float64] | None = None,
    ) -> ShieldOutcome: ...
    def reset(self) -> None: ...
    @property
    def config(self) -> dict[str, Any]: ...
    @property
    def dim(self) -> int: ...
    @property
    def method(self) -> str: ...
    @property
    def simd_level(self) -> str: ...

def shield_defaults() -> dict[str, Any]: ...

_Pose = tuple[npt.NDArray[np.float64], float]

@final
class ViewPlanner:
    """The reactive inspection (view) planner of the paper, Sec. IV-A."""

    def __new__(
        cls,
        d_view: float = ...,
        gamma_h: float = ...,
        fov_h_deg: float = ...,
        fov_v_deg: float = ...,
        gamma_v: float = ...,
        horizon: int = ...,
        reach_threshold: float = ...,
        planar: bool = ...,
    ) -> ViewPlanner: ...
    def plan(self, points: npt.NDArray[np.float64], position: _Vec, yaw: float) -> _Pose | None: ...
    def update(self, points: npt.NDArray[np.float64], position: _Vec, yaw: float) -> _Pose | None: ...
    def predict_path(
        self, points: npt.NDArray[np.float64], position: _Vec, yaw: float
    ) -> list[_Pose]: ...
    def reset(self) -> None: ...

@final
class NominalController:
    """u_nom = K_p (p_d - p_hat), saturated, with yaw tracking."""

    def __new__(
        cls, kp: float = ..., k_yaw: float = ..., u_max: tuple[float, float] = ..., omega_max: float = ...
    ) -> NominalController: ...
    def command(
        self, goal: _Vec, goal_yaw: float, position: _Vec, yaw: float
    ) -> tuple[npt.NDArray[np.float64], float]: ...

@final
class World:
    """A simulated corridor world: walls, obstacles, the robot's body, LIDAR and odometry.

    `ranges`, `points`, the poses and `contacts` are live read-only views of the world's own
    buffers (no copy); they follow the world as it steps, `.copy()` keeps one.

    Scans are taken at control steps (the first step at or after each is due; `scan_time`
    reports when): `rate_hz` above the control rate `1 / dt` is an `InvalidArgumentError`
    naming `rate_hz` and `dt`. `channels`, `columns`, `seed`, `mount` and `vertical_fov` of
    the wrong type, sign or length are `InvalidArgumentError`s naming them.
    """

    def __new__(
        cls,
        *,
        preset: str | None = None,
        procedural: int | None = None,
        kind: str = "office",
        ros_map: str | None = None,
        scenario: str | None = None,
        seed: int | None = None,
        dt: float = 0.02,
        channels: int = 1,
        columns: int = 1024,
        min_range: float = 0.1,
        max_range: float = 20.0,
        range_noise_std: float = 0.01,
        dropout: float = 0.0,
        rate_hz: float = 10.0,
        vertical_fov: tuple[float, float] = ...,
        mount: tuple[float, float, float, float] = ...,
        robot_length: float = 1.1,
        robot_width: float = 0.5,
        corner_radius: float = 0.0,
        unknown_is_wall: bool = True,
        unreachable_walls: bool = False,
        simplify: float | None = None,
    ) -> World: ...
    def step(self, vx: float, vy: float, wz: float) -> dict[str, Any]: ...
    @property
    def time(self) -> float: ...
    @property
    def ranges(self) -> npt.NDArray[np.float64]: ...
    @property
    def points(self) -> npt.NDArray[np.float64]: ...
    @property
    def scan_time(self) -> float: ...
    @property
    def sensor_pose(self) -> npt.NDArray[np.float64]: ...
    @property
    def true_pose(self) -> npt.NDArray[np.float64]: ...
    @property
    def estimated_pose(self) -> npt.NDArray[np.float64]: ...
    @property
    def contacts(self) -> npt.NDArray[np.float64]: ...
    @property
    def walls(self) -> npt.NDArray[np.float64]: ...
    @property
    def name(self) -> str: ...

_Pose3 = tuple[float, float, float]

@final
class Episode:
    """One corridor-inspection episode in Rust: world, shield, coverage, reward, metrics.

    `step` and `observe` release the GIL. An action is three real numbers: bool or complex
    ones (arrays of those dtypes included) are refused, as are bools for the numeric
    configuration keys (`gamma=True`); a seed that is not an integer from 0 to 2**64 - 1 is an
    `InvalidArgumentError` naming `seed`.
    """

    def __new__(
        cls,
        *,
        preset: str | None = None,
        procedural: bool = False,
        ros_map: str | None = None,
        scenario: str | None = None,
        seed: int = 0,
        **kwargs: Any,
    ) -> Episode: ...
    def reset(self, seed: int) -> None: ...
    def step(
        self, action: npt.ArrayLike
    ) -> tuple[npt.NDArray[np.float32], float, bool, bool, dict[str, Any]]: ...
    def observe(self) -> npt.NDArray[np.float32]: ...
    def scan_points(self) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.int8]]: ...
    def scan_ranges(self) -> tuple[npt.NDArray[np.float64], float, tuple[float, float, float, float]]: ...
    def observation_bounds(self) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]: ...
    def valid_points(self) -> npt.NDArray[np.float64]: ...
    def shield_points(self) -> npt.NDArray[np.float32]: ...
    def summary(self) -> dict[str, Any]: ...
    def render_data(self) -> dict[str, Any]: ...
    @property
    def observation_len(self) -> int: ...
    @property
    def lidar_shape(self) -> tuple[int, int, float]: ...
    @property
    def time(self) -> float: ...
    @property
    def true_pose(self) -> _Pose3: ...
    @property
    def velocity(self) -> _Pose3: ...
    @property
    def estimated_pose(self) -> _Pose3: ...
    @property
    def goal(self) -> _Pose3 | None: ...
    @property
    def name(self) -> str: ...
    @property
    def geometry(self) -> tuple[tuple[float, float], list[float], float | None]: ...
    @property
    def dt(self) -> float: ...

def episode_defaults() -> dict[str, Any]: ...

@final
class Batch:
    """N corridor-inspection episodes stepped together in Rust.

    `step` checks every row of `actions` it will step (not those of episodes about to reset)
    before stepping any: a bad row is an `InvalidArgumentError` naming it (`actions[2]`) and
    no episode moves. Bool or complex `actions` are refused.
    """

    def __new__(
        cls,
        num_envs: int,
        seeds: npt.ArrayLike,
        *,
        preset: str | None = None,
        procedural: bool = False,
        ros_map: str | None = None,
        scenario: str | None = None,
        autoreset_mode: str = "next_step",
        threads: int = 2,
        **kwargs: Any,
    ) -> Batch: ...
    def reset(self, seeds: npt.ArrayLike) -> npt.NDArray[np.float32]: ...
    def step(
        self, actions: npt.ArrayLike, next_seeds: npt.ArrayLike
    ) -> tuple[
        npt.NDArray[np.float32],
        npt.NDArray[np.float64],
        npt.NDArray[np.bool_],
        npt.NDArray[np.bool_],
        dict[str, Any],
        npt.NDArray[np.float32],
        npt.NDArray[np.bool_],
    ]: ...
    def summary(self, i: int) -> dict[str, Any]: ...
    def site_name(self, i: int) -> str: ...
    def __len__(self) -> int: ...
    @property
    def observation_len(self) -> int: ...

@final
class Node:
    """The ROS 2 node's decisions without the network (``shieldnav.replay``): each ``on_*``
    takes the message's arrival time ``t`` (s, ≥ 0)."""

    def __new__(cls, args: Sequence[str] = ...) -> Node: ...
    def topics(self) -> dict[str, Any]: ...
    @property
    def method(self) -> str: ...
    def timeouts(self) -> dict[str, Any]: ...
    def body(self) -> dict[str, Any]: ...
    def points(self) -> npt.NDArray[np.float64]: ...
    def on_scan(
        self,
        t: float,
        frame_id: str,
        angle_min: float,
        angle_max: float,
        angle_increment: float,
        range_min: float,
        range_max: float,
        ranges: npt.NDArray[np.float32],
        intensities: npt.NDArray[np.float32] | None = None,
        time_increment: float = 0.0,
        scan_time: float = 0.0,
    ) -> str | None: ...
    def on_cloud(
        self,
        t: float,
        frame_id: str,
        height: int,
        width: int,
        fields: Sequence[tuple[str, int, int, int]],
        is_bigendian: bool,
        point_step: int,
        row_step: int,
        data: bytes,
        is_dense: bool = True,
    ) -> str | None: ...
    def reject_scan(self, reason: str) -> None: ...
    def on_odometry(self, t: float, linear: Sequence[float], angular: Sequence[float]) -> str | None: ...
    def on_imu(self, t: float, angular_velocity: Sequence[float]) -> str | None: ...
    def reject_motion(self, reason: str) -> None: ...
    def on_nominal(self, t: float, linear: Sequence[float], angular: Sequence[float]) -> tuple[list[float], str]: ...
    def reject_nominal(self, t: float, reason: str) -> tuple[list[float], str]: ...
    def tick(self, t: float) -> tuple[list[float], str] | None: ...
    def command(self, t: float) -> tuple[list[float], str]: ...
