"""``kbplanner init`` (issue 10), step 5: what takes the floor around a frame no base pose can reach.

A frame whose install fails with "no base pose near the installed pose is free" (B4 found no place where
the robot, holding it, may stand within the arm's reach) gets, in init's report, what occupies the task
storey's map around its installed pose: the share of occupied cells within :data:`NEAR_M` and the nearest
elements and site objects there that reach into the robot's height band, each with its distance (a
split-level floor, a wall, a stair, a storage), and whether init's restack rounds already installed it
earlier. So the fix names what to change: that element in the model, the storage, or the wall's frames.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import shapely

from kbplanner.scale.init_plan_check import Failure
from kbplanner.world.maps import StoreyMap
from kbplanner.world.world_types import World

NEAR_M = 1.5  # the floor looked at around the installed pose (the robot's carry footprint is 2.4 m long)
NAMED = 3  # the nearest obstacles named

#: Added to the fix of such a frame: what to do when an element of the model takes the floor.
FLOOR_FIX = ("when an element named there takes the floor (a raised floor, a wall or a stair beside the "
             "wall to frame), no order frees it: leave that wall's frames out (`kbplanner init --walls` "
             "naming the other walls, or a lower `--max-walls`) or change that element in the model")


def floor_around(world: World, storey_map: StoreyMap, x: float, y: float) -> str:
    """``within 1.5 m of its installed pose (5.00, 0.54) 48 % of the floor is occupied: Split-level floor
    (raised floor, top +1.44 m) 0.08 m away, Exterior wall L1 south 0.22 m away``: the map's occupied
    share around (x, y) and the nearest obstacles reaching into its height band there."""
    grid = storey_map.grid
    r = grid.resolution
    ix0, iy0 = grid.cell_of(x - NEAR_M, y - NEAR_M)
    ix1, iy1 = grid.cell_of(x + NEAR_M, y + NEAR_M)
    cells = occupied = 0
    for iy in range(max(iy0, 0), min(iy1, grid.occupied.shape[0] - 1) + 1):
        for ix in range(max(ix0, 0), min(ix1, grid.occupied.shape[1] - 1) + 1):
            cx, cy = grid.origin[0] + (ix + 0.5) * r, grid.origin[1] + (iy + 0.5) * r
            if math.hypot(cx - x, cy - y) <= NEAR_M:
                cells += 1
                occupied += bool(grid.occupied[iy, ix])
    lo, hi = storey_map.band  # absolute heights, as the map's
    roles = {lv.iri: f"{lv.role}, top {lv.top_m:+.2f} m" for lv in storey_map.levels}
    here = shapely.Point(x, y)
    found: list[tuple[float, str]] = []
    for e in world.static:  # what stands in the robot's height band there (the frames are task elements)
        b = e.bounds
        if b is None or b.zmax < lo or b.zmin > hi:
            continue
        d = float(shapely.box(b.xmin, b.ymin, b.xmax, b.ymax).distance(here))
        if d <= NEAR_M:
            found.append((d, f"{e.label or e.global_id} ({roles.get(e.iri, e.kind)}) {d:.2f} m away"))
    for o in world.site_objects:  # storages, site offices, no-go zones: what the map holds
        if not (o.obstructs or o.is_no_go):
            continue
        c, s = math.cos(o.pose.yaw), math.sin(o.pose.yaw)
        hx, hy = o.size[0] / 2, o.size[1] / 2
        corners = [(o.pose.x + c * u - s * v, o.pose.y + s * u + c * v)
                   for u, v in ((-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy))]
        d = float(shapely.Polygon(corners).distance(here))
        if d <= NEAR_M:
            found.append((d, f"{o.label} ({o.kind}) {d:.2f} m away"))
    found.sort()
    named = ", ".join(text for _d, text in found[:NAMED]) or "no element or site object"
    share = 100.0 * occupied / cells if cells else 100.0
    return (f"within {NEAR_M} m of its installed pose ({x:.2f}, {y:.2f}) {share:.0f} % of the floor is "
            f"occupied; nearest there: {named}")


def with_floor(world: World, storey_map: StoreyMap, failures: Sequence[Failure],
               unbound: str) -> list[Failure]:
    """``failures`` with, for each frame whose reason says ``unbound`` (no free base pose), what takes the
    floor around its installed pose (:func:`floor_around`) added to the reason and :data:`FLOOR_FIX` to
    the fix."""
    out = []
    for f in failures:
        we = world.element(f.iri)
        pose = we.installed_pose if we is not None else None
        if unbound in f.reason and pose is not None:
            f = Failure(f.iri, f.label, f"{f.reason}; {floor_around(world, storey_map, pose.x, pose.y)}",
                        f"{f.fix}; {FLOOR_FIX}" if f.fix else FLOOR_FIX)
        out.append(f)
    return out
