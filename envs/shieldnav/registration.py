"""The registered environment ids and their time limits."""

from gymnasium.envs.registration import register, registry

from shieldnav.env import SITE_KEYS
from shieldnav.maps import DEFAULT_MAP

_ENTRY = "shieldnav.env:CorridorInspectionEnv"

#: id → (keyword arguments, time limit in steps at the default 50 Hz).
ENV_IDS: dict[str, tuple[dict[str, object], int]] = {
    # a new procedural office site every reset
    "shieldnav/CorridorInspection-v0": ({"procedural": True}, 3000),
    # the paper's Scenario 1: a doorway narrowed by a misplaced cabinet
    "shieldnav/ConstrictedPassage-v0": ({"preset": "constricted_passage", "terminate_at_goal": True}, 1500),
    # Scenario 2: a self-similar corridor, the odometry jumps 100 m (and 1.5 m across) at 20 s; the paper widens
    # the ellipse to a_y = 0.6 m there
    "shieldnav/OdometryJump-v0": ({"preset": "odometry_jump", "semi_axes": [0.9, 0.6], "terminate_at_goal": True}, 2500),
    # Scenario 3: a chair pushed toward the robot at 9 s, a door swinging open at 20 s
    "shieldnav/DynamicObstacles-v0": ({"preset": "dynamic_obstacles", "terminate_at_goal": True}, 2000),
    # any ROS map_server map (`map_path=...`); MIT Building 31 by default
    "shieldnav/MapInspection-v0": ({"map_path": str(DEFAULT_MAP)}, 6000),
}


def register_envs() -> None:
    """Registers every id of `ENV_IDS` (once)."""
    for env_id, (kwargs, steps) in ENV_IDS.items():
        if env_id not in registry:
            # the id's site is registered as `default_site`, not as site keywords: Gymnasium merges
            # the registered keywords with the user's, and a site the user gives (say scenario_path=)
            # must replace the id's (procedural=True), not join it
            site = {k: v for k, v in kwargs.items() if k in SITE_KEYS}
            rest = {k: v for k, v in kwargs.items() if k not in SITE_KEYS}
            # the episode applies its time limit itself (its last step carries the summary), so no
            # TimeLimit wrapper is registered; gym.make(..., max_episode_steps=N) still adds one
            register(
                id=env_id,
                entry_point=_ENTRY,
                vector_entry_point="shieldnav.vector:make_vector",
                kwargs={"default_site": site, **rest, "time_limit": steps},
            )
