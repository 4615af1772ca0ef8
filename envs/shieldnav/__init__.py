"""shieldnav: corridor-inspection navigation and the composite-CBF safety shield.

The shield (paper Sec. III) filters a nominal velocity against a LIDAR scan::

    from shieldnav import Shield
    shield = Shield(semi_axes=(0.9, 0.45), method="composite")
    out = shield.filter(points, u_nom, yaw=0.0, omega=0.0)
    out.u, out.H, out.feasible
"""

from shieldnav import exceptions
from shieldnav._core import Episode, NominalController, Shield, ShieldOutcome, ViewPlanner, World, __version__
from shieldnav.config import SHIELD_DEFAULTS
from shieldnav.env import ENV_DEFAULTS, CorridorInspectionEnv
from shieldnav.exceptions import InvalidArgumentError, MapFileError, ShieldnavError, SolverError
from shieldnav.registration import ENV_IDS, register_envs
from shieldnav.scripted import InspectionAgent

register_envs()


__all__ = [
    "ENV_DEFAULTS",
    "ENV_IDS",
    "CorridorInspectionEnv",
    "Episode",
    "InspectionAgent",
    "SHIELD_DEFAULTS",
    "InvalidArgumentError",
    "MapFileError",
    "NominalController",
    "Shield",
    "ShieldOutcome",
    "ShieldnavError",
    "SolverError",
    "ViewPlanner",
    "World",
    "__version__",
    "exceptions",
]
