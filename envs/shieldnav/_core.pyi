"""Type stubs of the native module `shieldnav._core`."""

from typing import Any, Sequence, final

import numpy as np
import numpy.typing as npt

__version__: str

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
    ) -> Shield: ...
    def filter(
        self,
        points: _Points,
        u_nom: _Vec,
        yaw: float | None = None,
        omega: float | _Vec | None = None,
        rotation: npt.NDArray[np.float64] | None = None,
        extra_A: npt.NDArray[np.float64] | None = None,
        extra_b: _Vec | None = None,
    ) -> ShieldOutcome: ...
    def filter_world(
        self,
        points: _Points,
        u_nom: _Vec,
        position: _Vec,
        yaw: float | None = None,
        omega: float | _Vec | None = None,
        rotation: npt.NDArray[np.float64] | None = None,
        extra_A: npt.NDArray[np.float64] | None = None,
        extra_b: _Vec | None = None,
    ) -> ShieldOutcome: ...
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
    ) -> ViewPlanner: ...
    def plan(self, points: npt.NDArray[np.float64], position: tuple[float, float], yaw: float) -> _Pose | None: ...
    def update(self, points: npt.NDArray[np.float64], position: tuple[float, float], yaw: float) -> _Pose | None: ...
    def predict_path(
        self, points: npt.NDArray[np.float64], position: tuple[float, float], yaw: float
    ) -> list[_Pose]: ...
    def reset(self) -> None: ...

@final
class NominalController:
    """u_nom = K_p (p_d - p_hat), saturated, with yaw tracking."""

    def __new__(
        cls, kp: float = ..., k_yaw: float = ..., u_max: tuple[float, float] = ..., omega_max: float = ...
    ) -> NominalController: ...
    def command(
        self, goal: tuple[float, float], goal_yaw: float, position: tuple[float, float], yaw: float
    ) -> tuple[npt.NDArray[np.float64], float]: ...
