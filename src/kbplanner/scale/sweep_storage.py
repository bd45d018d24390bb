"""Scenario sweeps (analysis, after B5), step 2: the storage to move, its overlay and free-space checks.

``find_storage`` finds the one material storage the task's elements are stored in; a moved candidate
is an in-memory :class:`Overlay` on the loaded model (``storage_overlay``, ``apply_overlay``) that
replaces the poses of the storage and of its pickup location (moved with it, the same pose relative
to it); the user's files are never edited. ``site_check`` says why a storage cannot stand somewhere
(footprint off the map or on an obstacle, too little room around the pickup location);
``grid_candidates`` gives the free positions of a ``grid:STEP`` candidate.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from rdflib import Graph, Literal, URIRef

from kbplanner.core.vocab import KBP
from kbplanner.scale.sweep_axes import StorageCandidate, SweepError

if TYPE_CHECKING:
    from kbplanner.world.occupancy import OccupancyGrid
    from kbplanner.world.world_types import World

log = logging.getLogger(__name__)

PICKUP_CLEARANCE_M = 0.4  # the robot's half width, about: free space needed around the pickup location
SAMPLE_STEP_M = 0.05  # spacing of the points checked inside the storage footprint


@dataclass(frozen=True)
class StorageInfo:
    """The material storage of the task elements: IRIs, pose, size and pickup pose (m, rad)."""

    iri: str
    pose_iri: str
    pickup_iri: str
    x: float
    y: float
    yaw: float
    size: tuple[float, float]
    pickup: tuple[float, float, float]


def _num(g: Graph, s: URIRef, p: URIRef, file: Any, fix: str) -> float:
    v = g.value(s, p)
    if not isinstance(v, Literal):
        raise SweepError(f"{s} has no numeric {p}", file=file, element=str(s), fix=fix)
    return float(v.toPython())


def find_storage(model: Graph, *, file: Any = None) -> StorageInfo:
    """The one material storage the model's elements are stored in (``kbp:storedIn``)."""
    storages = sorted({str(o) for o in model.objects(None, KBP.storedIn)})
    fix = ("sweep from a scenario with one kbp:MaterialStorage "
           "(see data/case_study/scenarios/storage_outside.ttl)")
    if len(storages) != 1:
        raise SweepError(f"{len(storages)} material storages hold elements; "
                         "a moved candidate needs exactly one",
                         file=file, element=", ".join(storages) or "kbp:storedIn", fix=fix)
    s = URIRef(storages[0])
    pose, pickup = model.value(s, KBP.installedPose), model.value(s, KBP.pickupLocation)
    if not isinstance(pose, URIRef) or not isinstance(pickup, URIRef):
        raise SweepError("the storage has no kbp:installedPose or kbp:pickupLocation (as IRIs)",
                         file=file, element=str(s), fix="give both poses as named kbp:Pose nodes")
    return StorageInfo(
        iri=str(s), pose_iri=str(pose), pickup_iri=str(pickup),
        x=_num(model, pose, KBP.x, file, fix), y=_num(model, pose, KBP.y, file, fix),
        yaw=_num(model, pose, KBP.yaw, file, fix) if model.value(pose, KBP.yaw) is not None else 0.0,
        size=(_num(model, s, KBP.sizeX, file, fix), _num(model, s, KBP.sizeY, file, fix)),
        pickup=(_num(model, pickup, KBP.x, file, fix), _num(model, pickup, KBP.y, file, fix),
                _num(model, pickup, KBP.yaw, file, fix) if model.value(pickup, KBP.yaw) is not None else 0.0),
    )


def _wrap(a: float) -> float:
    return math.atan2(math.sin(a), math.cos(a))


def moved_pickup(st: StorageInfo, x: float, y: float, yaw: float) -> tuple[float, float, float]:
    """The pickup pose after moving the storage to (x, y, yaw): same pose relative to the storage."""
    px, py, pyaw = st.pickup
    c, s = math.cos(-st.yaw), math.sin(-st.yaw)
    rx, ry = c * (px - st.x) - s * (py - st.y), s * (px - st.x) + c * (py - st.y)
    c2, s2 = math.cos(yaw), math.sin(yaw)
    return (round(x + c2 * rx - s2 * ry, 6), round(y + s2 * rx + c2 * ry, 6),
            round(_wrap(yaw + pyaw - st.yaw), 6))


@dataclass
class Overlay:
    """An in-memory change of the model: the (subject, predicate) pairs it replaces and what it adds."""

    clear: list[tuple[URIRef, URIRef]]
    add: Graph

    def turtle(self) -> str:
        """The added triples as Turtle (for the record)."""
        return str(self.add.serialize(format="turtle"))


def storage_overlay(st: StorageInfo, x: float, y: float, yaw: float) -> Overlay:
    """The overlay moving the storage to (x, y, yaw) and its pickup location with it."""
    clear: list[tuple[URIRef, URIRef]] = []
    add = Graph()
    add.bind("kbp", str(KBP))
    for iri, (nx, ny, nyaw) in ((st.pose_iri, (x, y, yaw)), (st.pickup_iri, moved_pickup(st, x, y, yaw))):
        node = URIRef(iri)
        for p, v in ((KBP.x, nx), (KBP.y, ny), (KBP.yaw, nyaw)):
            clear.append((node, p))
            add.add((node, p, Literal(float(v))))
    return Overlay(clear, add)


def apply_overlay(model: Graph, overlay: Overlay) -> None:
    """Apply an overlay to a loaded model in memory (never to the user's files)."""
    for s, p in overlay.clear:
        model.remove((s, p, None))
    for t in overlay.add:
        model.add(t)


# ---- free-space checks ---------------------------------------------------------------------------
def free_ground_grid(world: World, storage_iri: str) -> OccupancyGrid:
    """The task storey's occupancy grid with the storage itself left out (where could it stand?)."""
    from kbplanner.world.maps import storey_map

    others = tuple(o for o in world.site_objects if o.iri != storage_iri)
    return storey_map(replace(world, site_objects=others)).grid


def site_check(grid: OccupancyGrid, st: StorageInfo, x: float, y: float, yaw: float, *,
               clearance_m: float = PICKUP_CLEARANCE_M) -> str | None:
    """Why the storage cannot stand at (x, y, yaw), or None when its footprint and pickup pose are free."""
    hx, hy = st.size[0] / 2, st.size[1] / 2
    us = np.linspace(-hx, hx, max(2, math.ceil(2 * hx / SAMPLE_STEP_M) + 1))
    vs = np.linspace(-hy, hy, max(2, math.ceil(2 * hy / SAMPLE_STEP_M) + 1))
    c, s = math.cos(yaw), math.sin(yaw)
    for u in us:
        for v in vs:
            px, py = x + c * u - s * v, y + s * u + c * v
            if not grid.contains(px, py):
                return f"storage footprint leaves the site map at ({px:.2f}, {py:.2f})"
            if grid.is_occupied(px, py):
                return f"storage footprint overlaps an obstacle at ({px:.2f}, {py:.2f})"
    kx, ky, _ = moved_pickup(st, x, y, yaw)
    if not grid.contains(kx, ky):
        return f"pickup location ({kx:.2f}, {ky:.2f}) is outside the site map"
    free = grid.clearance_at(kx, ky)
    if free < clearance_m:
        return (f"pickup location ({kx:.2f}, {ky:.2f}) has {free:.2f} m free around it, "
                f"needs {clearance_m:.2f} m")
    return None


def grid_candidates(grid: OccupancyGrid, st: StorageInfo, step_m: float, *,
                    clearance_m: float = PICKUP_CLEARANCE_M) -> list[StorageCandidate]:
    """Storage positions on a ``step_m`` grid over the map where storage and pickup pose are free."""
    ext = grid.extent
    out = []
    for y in np.arange(ext.ymin + step_m / 2, ext.ymax, step_m):
        for x in np.arange(ext.xmin + step_m / 2, ext.xmax, step_m):
            fx, fy = round(float(x), 3), round(float(y), 3)
            if site_check(grid, st, fx, fy, st.yaw, clearance_m=clearance_m) is None:
                out.append(StorageCandidate(label=f"x{fx:.2f}y{fy:.2f}", x=fx, y=fy))
    log.info("grid:%s gives %d free storage positions", step_m, len(out))
    return out
