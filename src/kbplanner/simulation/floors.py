"""B5 simulation, world set-up: on which map the workers walk when the robot works on another floor.

Workers walk on the site's ground (``World.ground_z``); the robot works on the task's storey. On the
ground floor both share the task storey's occupancy grid. When the robot works upstairs (or below
ground: more than :data:`FLOOR_GAP_M` from the ground), that grid is
the wrong one for people on the ground: an upper storey's map marks every cell without a floor slab
occupied (the site round the building), and its walls are not the ground floor's. The workers then
walk on the ground-level storey's map (:func:`walk_grid`); the robot keeps its own.
"""

from __future__ import annotations

import logging

from kbplanner.world.occupancy import OccupancyGrid
from kbplanner.world.world_types import GROUND_STOREY_TOLERANCE_M, StoreyInfo, World

log = logging.getLogger(__name__)

#: A worker whose floor is more than this above or below the robot's floor is out of its hazard scope:
#: half a storey of 3 m, well above a raised ground floor (``GROUND_STOREY_TOLERANCE_M`` 0.5 m).
FLOOR_GAP_M = 1.5


def robot_floor_z(world: World) -> float:
    """Elevation of the floor the robot works on: the task storey's, else the site's ground."""
    storey = world.storey(world.task_storey)
    return float(storey.elevation_m) if storey is not None else float(world.ground_z)


def ground_storey(world: World) -> StoreyInfo | None:
    """The storey at ground level (within GROUND_STOREY_TOLERANCE_M of ``World.ground_z``), if any."""
    near = [s for s in world.storeys if abs(s.elevation_m - world.ground_z) <= GROUND_STOREY_TOLERANCE_M]
    return min(near, key=lambda s: (abs(s.elevation_m - world.ground_z), s.elevation_m)) if near else None


def walk_grid(world: World, robot_grid: OccupancyGrid) -> OccupancyGrid:
    """The occupancy grid the workers walk on: ``robot_grid`` when the robot works within FLOOR_GAP_M of
    the ground, else the ground-level storey's map (the robot's grid, with a warning, when the model has
    no storey at ground level)."""
    if abs(robot_floor_z(world) - float(world.ground_z)) <= FLOOR_GAP_M:
        return robot_grid
    ground = ground_storey(world)
    if ground is None:
        log.warning("the robot works %.2f m above the ground but the model has no storey at ground level "
                    "(%.2f m): the workers walk on the robot's storey map",
                    robot_floor_z(world) - world.ground_z, world.ground_z)
        return robot_grid
    from kbplanner.world.maps import storey_map

    return storey_map(world, ground.iri).grid
