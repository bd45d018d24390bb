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
    key = _ground_key(world, ground)
    if key is not None and _kept and _kept[0][0] == key:
        return _fresh(_kept[0][1])
    from kbplanner.world.maps import storey_map

    grid = storey_map(world, ground.iri).grid
    _kept.clear()
    if key is not None:
        _kept.append((key, _fresh(grid)))
    return grid


# The ground storey's map of this process's last upper-storey task: the tasks of one scenario on other
# storeys (a building's storeys one after another) walk their workers on the same ground floor, whose
# map only depends on the parts of the world :func:`_ground_key` holds.
_kept: list[tuple[tuple[object, ...], OccupancyGrid]] = []

#: The map's height band is read from MapSettings; elements this much beyond it are in the key too.
_KEY_MARGIN_M = 0.5


def _ground_key(world: World, ground: StoreyInfo) -> tuple[object, ...] | None:
    """Everything ``storey_map(world, ground.iri).grid`` reads of ``world`` (a superset: the elements
    with a mesh near the storey's height band), or None when the map would read more (no site extent:
    the obstacles then make the extent)."""
    from kbplanner.world.map_settings import MapSettings

    if world.site_extent is None:
        return None
    settings = MapSettings()
    lo = ground.elevation_m + settings.floor_clearance_m - _KEY_MARGIN_M
    hi = ground.elevation_m + settings.robot_height_m + _KEY_MARGIN_M
    near = tuple(e for e in world.static if e.mesh_path is not None
                 and (e.bounds is None or (e.bounds.zmax >= lo and e.bounds.zmin <= hi)))
    return (ground, settings, world.storeys, world.ground_z, world.site_extent, world.site_objects, near)


def _fresh(grid: OccupancyGrid) -> OccupancyGrid:
    """A copy of ``grid`` of its own (its array and no derived arrays), so no task edits another's."""
    return OccupancyGrid(occupied=grid.occupied.copy(), origin=grid.origin, resolution=grid.resolution,
                         band=grid.band, notes=grid.notes)
