"""A6, site locations checked against the world: where the robot must stand is somewhere it can.

A material storage's ``kbp:pickupLocation`` is where the robot stands to pick (the NV-1 destination).
Before B4 uses it, :func:`check_pickup_locations` checks, for every storage that holds an element of
the task: inside the site extent, on a free cell of the task storey's occupancy map (not inside a wall,
the storage itself or a solid site object such as the office), and outside every no-go zone. A location
that fails is bad input: :class:`~kbplanner.core.errors.SiteLocationError` (exit 2) naming the storage,
the location, the reason and the fix, never silently replaced by another base pose. A location that
is valid ground but walled off from the robot (no free path) is not bad input but an infeasible plan:
B4 and the executor record each element it holds as failed with the reason "walled off" (exit 1).
"""

from __future__ import annotations

import math

from kbplanner.core.errors import SiteLocationError
from kbplanner.world.occupancy import OccupancyGrid
from kbplanner.world.world_types import SiteObject, World

SAME_STOREY_M = 1.0  # a pickup this close to the task storey's elevation stands on its map


def _inside_box(obj: SiteObject, x: float, y: float) -> bool:
    """Whether (x, y) lies in the footprint of a site object (its box, turned by its yaw)."""
    dx, dy = x - obj.pose.x, y - obj.pose.y
    c, s = math.cos(obj.pose.yaw), math.sin(obj.pose.yaw)
    u, v = c * dx + s * dy, -s * dx + c * dy
    return abs(u) <= obj.size[0] / 2 and abs(v) <= obj.size[1] / 2


def pickup_problem(world: World, grid: OccupancyGrid, storage: SiteObject) -> str | None:
    """Why the storage's pickup location cannot be used (``None``: it can)."""
    p = storage.pickup
    if p is None:
        return None
    where = f"({p.x:.2f}, {p.y:.2f})"
    ext = world.site_extent
    if ext is not None and not (ext.xmin <= p.x <= ext.xmax and ext.ymin <= p.y <= ext.ymax):
        return (f"pickup location {where} is off the site (extent x {ext.xmin:g}..{ext.xmax:g}, "
                f"y {ext.ymin:g}..{ext.ymax:g})")
    storey = world.storey(world.task_storey)
    if storey is not None and abs(p.z - storey.elevation_m) > SAME_STOREY_M:
        return None  # on another storey than the task's map (the robot arrives there by lift)
    for obj in world.site_objects:
        if obj.is_no_go and _inside_box(obj, p.x, p.y):
            return f"pickup location {where} is in the no-go zone {obj.label!r}"
    for obj in world.site_objects:
        if obj.obstructs and _inside_box(obj, p.x, p.y):
            return f"pickup location {where} is inside {obj.label!r} ({obj.kind})"
    if grid.is_occupied(p.x, p.y):
        return (f"pickup location {where} is on an occupied cell of the {grid.resolution:g} m map of the "
                "task storey (inside a wall or another element)")
    return None


def check_pickup_locations(world: World, grid: OccupancyGrid) -> None:
    """Raise :class:`SiteLocationError` for the first storage of a task element whose pickup location
    cannot be used (see :func:`pickup_problem`)."""
    used = {e.storage for e in world.task_elements if e.storage is not None}
    for obj in sorted(world.site_objects, key=lambda o: o.iri):
        if obj.iri not in used:
            continue
        problem = pickup_problem(world, grid, obj)
        if problem is not None:
            raise SiteLocationError(
                f"{obj.label}: {problem}", element=f"<{obj.iri}> kbp:pickupLocation",
                fix="move the storage's kbp:pickupLocation pose to free ground beside the storage, on the "
                    "site and outside no-go zones (the site layout or scenario Turtle), then run again")
