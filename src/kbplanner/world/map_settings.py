"""How occupancy maps are built (A6): the settings alone, light enough for the command line's defaults.

:mod:`kbplanner.world.maps` builds the maps with them (and re-exports :class:`MapSettings`).
"""

from __future__ import annotations

from dataclasses import dataclass

from kbplanner.core.errors import KbplannerError


@dataclass(frozen=True)
class MapSettings:
    """How a storey's occupancy grid is built (metres).

    ``robot_height_m`` is the top of the band above the floor: the robot with its load. The default
    1.8 m covers a mobile manipulator (Husky + UR5: 0.95 m) carrying material, and stays under
    door heads (2.0-2.1 m), so open doorways stay free on the map.
    """

    resolution_m: float = 0.05
    robot_height_m: float = 1.8
    floor_clearance_m: float = 0.05
    no_go_occupied: bool = True

    def __post_init__(self) -> None:
        if not self.resolution_m > 0:
            raise KbplannerError(f"map resolution must be positive, got {self.resolution_m}",
                                 element="resolution", fix="give the cell size in metres, e.g. 0.05")
        if not self.robot_height_m > self.floor_clearance_m:
            raise KbplannerError(f"robot height {self.robot_height_m} m is not above the floor clearance "
                                 f"{self.floor_clearance_m} m", element="robot_height",
                                 fix="give the robot's height with its load in metres, e.g. 1.8")
