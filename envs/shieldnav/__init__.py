"""shieldnav: corridor-inspection worlds and the composite-CBF safety shield."""

from shieldnav._core import World

__all__ = ["World"]
