"""Building maps shipped with shieldnav (ROS map_server YAML + image), each with its license."""

from pathlib import Path

#: Folder of the shipped maps.
MAPS_DIR = Path(__file__).parent

#: The map `shieldnav/MapInspection-v0` loads when no `map_path` is given (MIT Building 31,
#: MIT license, see `mit_building31/LICENSE.md`).
DEFAULT_MAP = MAPS_DIR / "mit_building31" / "building_31.yaml"
