"""``kbplanner init`` (issue 10), step 4: where the frame storages and their pickup locations go.

Works on the occupancy grid of the task storey at the framing date (:mod:`kbplanner.world.maps`,
the real map the planner uses): a storage is a 2.6 x 0.8 m box turned 0 or 90 degrees whose cells and a
margin around them are free, away from the panels' install locations; its pickup location is
:data:`PICKUP_STANDOFF` beside the stack's centre line, facing it, on a cell with room for the robot
and in the free region of the robot start (4-connected, as :mod:`kbplanner.world.site_checks` checks).
``inside`` takes the candidate inside the building's footprint nearest the panels (short carries),
``outside`` the one outside it nearest the entrance, but not in the entrance's approach: the stack (with
its margin) stays :data:`ENTRANCE_KEEP` from the entrance and off the straight line from its pickup to
the entrance, so that the robot turning in with a frame does not meet it; no stack stands within
:data:`START_KEEP` of the robot start. Each placed storage is marked
occupied before the next is placed. Deterministic: candidates are scanned in a fixed order and ties
broken by position.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from shapely import contains_xy
from shapely.geometry import LineString, Point, Polygon, box

from kbplanner.world.occupancy import OccupancyGrid

PICKUP_STANDOFF = 1.15  # m from the stack's centre line: the Husky's half length + a cell of margin
STORAGE = (2.6, 0.8)
MARGIN = 0.2  # free ground around a storage
ROBOT_ROOM = 0.5  # clearance of the pickup cell (the robot's half width + margin)
PANEL_KEEP = 0.9  # a storage at least this far from an install location
PICKUP_KEEP = 0.9  # a pickup at least this far from an install location (the last tier)
STEP = 0.2
ENTRANCE_KEEP = 2.0  # m from the entrance door to an outside stack: room to turn in with a 2.4 m frame
# (pickup clearance, pickup distance to install locations): first room for the robot to turn with a
# 2.4 m frame (its half length + margin), else the least that still fits the robot
TIERS = ((1.3, 1.6), (ROBOT_ROOM, PICKUP_KEEP))
START_KEEP = 1.5  # m from the robot start to a stack (with its margin): the robot's half length + margin
AVOID_M = 1.5  # a further proposal's stacks stand this far from the stacks of the ones before


@dataclass(frozen=True)
class Spot:
    x: float
    y: float
    yaw: float  # of the storage (its long side along local x)
    pickup: tuple[float, float, float]  # x, y, yaw facing the stack


def _rect_cells(grid: OccupancyGrid, x: float, y: float, hx: float, hy: float) -> tuple[slice, slice] | None:
    ix0, iy0 = grid.cell_of(x - hx, y - hy)
    ix1, iy1 = grid.cell_of(x + hx, y + hy)
    ny, nx = grid.shape
    if ix0 < 0 or iy0 < 0 or ix1 >= nx or iy1 >= ny:
        return None
    return (slice(iy0, iy1 + 1), slice(ix0, ix1 + 1))


def place_storages(
    grid: OccupancyGrid,
    count: int,
    *,
    start: tuple[float, float],
    panels: Sequence[tuple[float, float]],
    footprint: Polygon,
    inside: bool,
    near: tuple[float, float],
    entrance: tuple[float, float] | None = None,
    entrance_keep: float = ENTRANCE_KEEP,
    avoid: Sequence[tuple[float, float]] = (),
) -> list[Spot]:
    """Up to ``count`` storage spots (fewer when the map has no more room; the caller reports it).

    ``entrance``: the door the robot enters by, whose approach the stacks leave free, ``entrance_keep``
    from it (module docstring); ``avoid``: stack centres of proposals tried before (kbplanner init's
    next proposal), which a stack keeps :data:`AVOID_M` from.
    """
    occupied = grid.occupied.copy()
    res = grid.resolution
    panel_mask = np.zeros_like(occupied)
    for px, py in panels:
        ix, iy = grid.cell_of(px, py)
        if 0 <= iy < occupied.shape[0] and 0 <= ix < occupied.shape[1]:
            panel_mask[iy, ix] = True
    panel_dist = (
        ndimage.distance_transform_edt(~panel_mask) * res
        if panel_mask.any()
        else np.full(occupied.shape, np.inf)
    )
    sx, sy = grid.cell_of(*start)
    out: list[Spot] = []
    inner = footprint.buffer(-0.3)
    outer = footprint.buffer(1.5)
    for _ in range(count):
        clearance = ndimage.distance_transform_edt(~occupied) * res
        labels, _n = ndimage.label(~occupied)
        if not (0 <= sy < occupied.shape[0] and 0 <= sx < occupied.shape[1]) or occupied[sy, sx]:
            return out
        region = labels[sy, sx]
        x0, y0 = grid.origin
        ny, nx = occupied.shape
        mx, my = np.meshgrid(
            np.arange(x0 + 1.5, x0 + nx * res - 1.5, STEP), np.arange(y0 + 1.5, y0 + ny * res - 1.5, STEP)
        )
        fx, fy = mx.ravel(), my.ravel()
        keep = contains_xy(inner, fx, fy) if inside else ~contains_xy(outer, fx, fy)
        for ax, ay in avoid:
            keep &= np.hypot(fx - ax, fy - ay) >= AVOID_M
        gx, gy = fx[keep], fy[keep]
        dist = np.hypot(gx - near[0], gy - near[1])
        best: Spot | None = None
        ranked = np.lexsort((np.round(gx, 6), np.round(gy, 6), np.round(dist, 6)))
        for room, keep in TIERS:  # room to turn with a frame at the pickup first, else the least room
            for k in ranked:
                for yaw in (0.0, math.pi / 2):
                    best = _try(
                        grid,
                        occupied,
                        clearance,
                        labels,
                        region,
                        panel_dist,
                        float(gx[k]),
                        float(gy[k]),
                        yaw,
                        room,
                        keep,
                        entrance,
                        entrance_keep,
                        start,
                    )
                    if best is not None:
                        break
                if best is not None:
                    break
            if best is not None:
                break
        if best is None:
            return out
        spot = best
        out.append(spot)
        hx, hy = (STORAGE[0] / 2, STORAGE[1] / 2) if spot.yaw == 0.0 else (STORAGE[1] / 2, STORAGE[0] / 2)
        cells = _rect_cells(grid, spot.x, spot.y, hx + MARGIN, hy + MARGIN)
        if cells is not None:
            occupied[cells] = True
        cells = _rect_cells(grid, spot.pickup[0], spot.pickup[1], ROBOT_ROOM, ROBOT_ROOM)
        if cells is not None:  # the next storage leaves this pickup free
            occupied[cells] = True
            ix, iy = grid.cell_of(spot.pickup[0], spot.pickup[1])
            occupied[iy, ix] = False
    return out


def _try(
    grid: OccupancyGrid,
    occupied: np.ndarray,
    clearance: np.ndarray,
    labels: np.ndarray,
    region: int,
    panel_dist: np.ndarray,
    x: float,
    y: float,
    yaw: float,
    room: float = ROBOT_ROOM,
    keep: float = PICKUP_KEEP,
    entrance: tuple[float, float] | None = None,
    entrance_keep: float = ENTRANCE_KEEP,
    start: tuple[float, float] | None = None,
) -> Spot | None:
    hx, hy = (STORAGE[0] / 2, STORAGE[1] / 2) if yaw == 0.0 else (STORAGE[1] / 2, STORAGE[0] / 2)
    cells = _rect_cells(grid, x, y, hx + MARGIN, hy + MARGIN)
    if cells is None or occupied[cells].any() or float(panel_dist[cells].min()) < PANEL_KEEP:
        return None
    stack = box(x - hx - MARGIN, y - hy - MARGIN, x + hx + MARGIN, y + hy + MARGIN)
    if entrance is not None and stack.distance(Point(entrance)) < entrance_keep:
        return None
    if start is not None and stack.distance(Point(start)) < START_KEEP:
        return None  # the robot starts there
    # the pickup side: across the stack (local +y or -y)
    nxv, nyv = -math.sin(yaw), math.cos(yaw)
    for side in (1.0, -1.0):
        px, py = x + side * nxv * PICKUP_STANDOFF, y + side * nyv * PICKUP_STANDOFF
        ix, iy = grid.cell_of(px, py)
        if not (0 <= iy < occupied.shape[0] and 0 <= ix < occupied.shape[1]):
            continue
        if occupied[iy, ix] or clearance[iy, ix] < room or labels[iy, ix] != region:
            continue
        if panel_dist[iy, ix] < keep:
            continue
        if entrance is not None and LineString([(px, py), entrance]).intersects(stack):
            continue  # the stack stands between its pickup and the entrance
        # the storage must not cut the pickup off from the start: its box lies away from the pickup
        facing = math.atan2(y - py, x - px)
        return Spot(round(x, 4), round(y, 4), yaw, (round(px, 4), round(py, 4), round(facing, 9)))
    return None
