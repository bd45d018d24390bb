"""A6, occupancy maps of the world: one storey's grid over the robot's height band.

The map of a storey (default: the task's) holds what lies within the robot's height band above that
storey's floor (``floor + floor_clearance_m`` to ``floor + robot_height_m``): the static element meshes
(doors are open), the solid site objects and the no-go zones (occupied: the robot must not enter);
task elements at their storage are left out. The grid covers the site extent (``kbp:siteExtent``;
without one, the obstacles' box plus a margin). On a storey at ground level the site outside the
building is free ground; on any other storey a cell is free only where a built floor is under it.
Slabs and stairs at other heights than the floor are obstacles where they reach into the band and are
reported (:mod:`kbplanner.world.levels`). :func:`write_map` writes ``map.pgm`` + ``map.yaml`` (ROS).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from kbplanner.core.errors import KbplannerError
from kbplanner.world import map_store
from kbplanner.world.build import ground_level_storey
from kbplanner.world.levels import STAIR, SUPPORT_DEPTH_M, LevelRegion, level_regions, levels_summary
from kbplanner.world.map_settings import MapSettings
from kbplanner.world.meshes import element_mesh, site_object_mesh
from kbplanner.world.occupancy import Box, OccupancyGrid, occupancy_from_meshes
from kbplanner.world.world_types import StoreyInfo, World

log = logging.getLogger(__name__)

EXTENT_MARGIN_M = 2.0  # grid margin around the obstacles when the site layout has no extent
STRAY_M = 1000.0  # without a site extent, obstacles this far from the others' median are left off the map
MAX_CELLS = 400_000_000  # a bigger grid (400 MB) is refused as bad input


# --------------------------------------------------------------------------------------------
# Occupancy maps
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class StoreyMap:
    """The occupancy grid of one storey and how it was made."""

    storey: StoreyInfo
    grid: OccupancyGrid
    band: tuple[float, float]
    ground_level: bool
    obstacles: int  # meshes rasterised (elements, site objects, no-go zones)
    seconds: float
    levels: tuple[LevelRegion, ...] = ()  # slabs and stairs at other heights than the floor

    @property
    def notes(self) -> tuple[str, ...]:
        """Meshes the grid could not use fully (and what was done instead); a storey without any floor."""
        return self.grid.notes

    def to_dict(self) -> dict[str, Any]:
        """Figures for world.json."""
        ny, nx = self.grid.shape
        data: dict[str, Any] = {
            "storey": self.storey.iri, "storey_label": self.storey.label,
            "elevation_m": self.storey.elevation_m, "band_m": [_round(v) for v in self.band],
            "ground_level": self.ground_level, "resolution_m": self.grid.resolution,
            "origin": [_round(v) for v in self.grid.origin], "width_cells": nx, "height_cells": ny,
            "occupied_fraction": round(1.0 - self.grid.free_fraction, 6), "obstacles": self.obstacles,
        }
        # Only when there are some, so that maps without them keep their world.json.
        if self.levels:
            data["levels"] = [r.to_dict() for r in self.levels]
        if self.notes:
            data["notes"] = list(self.notes)
        return data


def _round(v: float) -> float:
    return round(float(v), 6) + 0.0


def _within(lo: float, hi: float, band: tuple[float, float]) -> bool:
    return hi >= band[0] and lo <= band[1]


def map_extent(world: World, meshes: Sequence[trimesh.Trimesh]) -> Box:
    """The grid's extent: the site extent, else the obstacles' box, else the building's box, plus a margin."""
    if world.site_extent is not None:
        e = world.site_extent
        return Box(e.xmin, e.ymin, e.xmax, e.ymax)
    if meshes:
        return Box.around(meshes, margin_m=EXTENT_MARGIN_M)
    # Nothing in this storey's band (a storey without walls, spaces or furniture): the building's box.
    boxes = [e.bounds for e in world.static if e.bounds is not None]
    if not boxes:
        raise KbplannerError("nothing to map: no site extent and no element with a position",
                             element=world.project,
                             fix="add a kbp:SiteLayout with kbp:siteExtent to the site layout Turtle")
    m = EXTENT_MARGIN_M
    return Box(min(b.xmin for b in boxes) - m, min(b.ymin for b in boxes) - m,
               max(b.xmax for b in boxes) + m, max(b.ymax for b in boxes) + m)


def storey_map(world: World, storey: str | None = None, settings: MapSettings | None = None) -> StoreyMap:
    """The occupancy grid of a storey (IRI or label; default the task's storey) for a robot.

    Example:
        >>> m = storey_map(world)  # doctest: +SKIP
        >>> m.grid.is_occupied(2.0, 1.0)  # doctest: +SKIP
    """
    started = time.perf_counter()
    settings = settings or MapSettings()
    chosen = world.storey(storey or world.task_storey)
    if chosen is None and not world.storeys:
        raise KbplannerError("the model has no storey to map (no IfcBuildingStorey and no IfcBuilding)",
                             element="IfcBuildingStorey",
                             fix="export the model with its building and storeys (levels)")
    if chosen is None:
        known = ", ".join(s.label for s in world.storeys)
        raise KbplannerError(f"unknown storey {storey!r}", element=str(storey), fix=f"choose one of: {known}")
    floor = chosen.elevation_m
    band = (floor + settings.floor_clearance_m, floor + settings.robot_height_m)
    levels = tuple(level_regions(world.static, chosen.iri, floor, band))
    ground = ground_level_storey(world, chosen)
    kept = map_store.read(world, chosen, settings)  # a grid an earlier command made of the same world
    if kept is not None:
        grid, obstacles = kept
        for note in grid.notes:
            log.warning("map: %s", note)
    else:
        grid, obstacles = _grid_of_meshes(world, chosen, settings, band, ground)
        map_store.write(world, chosen, settings, grid, obstacles)
    seconds = time.perf_counter() - started
    log.info("map of %s: %d x %d cells, %.1f %% occupied, %.2f s", chosen.label, grid.shape[1],
             grid.shape[0], 100.0 * (1.0 - grid.free_fraction), seconds)
    for region in levels:  # stairs are expected obstacles; other floor heights deserve a look
        (log.info if region.role == STAIR else log.warning)("map of %s: %s", chosen.label, region.text())
    return StoreyMap(chosen, grid, band, ground, obstacles, seconds, levels)


def _grid_of_meshes(world: World, chosen: StoreyInfo, settings: MapSettings, band: tuple[float, float],
                    ground: bool) -> tuple[OccupancyGrid, int]:
    """The storey's grid made of its meshes, and how many meshes it holds."""
    floor = chosen.elevation_m
    meshes: list[trimesh.Trimesh] = []
    names: list[str] = []
    for e in world.static:
        if e.mesh_path is None or (e.bounds is not None and not _within(e.bounds.zmin, e.bounds.zmax, band)):
            continue
        mesh = element_mesh(e)
        if mesh is not None and len(mesh.faces):
            meshes.append(mesh)
            names.append(f"{e.label} ({e.ifc_class} {e.global_id})")
    for obj in world.site_objects:
        if not (obj.obstructs or (obj.is_no_go and settings.no_go_occupied)):
            continue
        if _within(obj.pose.z, obj.top_z, band):
            meshes.append(site_object_mesh(obj))
            names.append(f"{obj.label} ({obj.kind})")
    strays: tuple[str, ...] = ()
    if world.site_extent is None:  # the obstacles make the extent: one far away must not stretch it
        meshes, names, strays = _without_strays(meshes, names)
    extent = map_extent(world, meshes)
    _check_size(extent, settings.resolution_m, chosen)
    grid = occupancy_from_meshes(meshes, band, extent, settings.resolution_m, names=names)
    if strays:
        grid = replace(grid, notes=strays + grid.notes)
    if not ground:
        support_band = (floor - SUPPORT_DEPTH_M, floor + 0.01)
        floors = [m for m in (element_mesh(e) for e in world.static
                              if e.bounds is not None and _within(e.bounds.zmin, e.bounds.zmax, support_band))
                  if m is not None and len(m.faces)]
        support = occupancy_from_meshes(floors, support_band, extent, settings.resolution_m)
        occupied = grid.occupied | ~support.occupied
        notes = grid.notes + support.notes
        if occupied.all():
            notes += (f"no floor: every cell is occupied; no floor (a slab's top within {SUPPORT_DEPTH_M:g} "
                      f"m below this storey's level, {floor:+.2f} m) is free of obstacles",)
        grid = OccupancyGrid(occupied=occupied, origin=grid.origin, resolution=grid.resolution, band=band,
                             notes=notes)
    return grid, len(meshes)


def _without_strays(
    meshes: list[trimesh.Trimesh], names: list[str]
) -> tuple[list[trimesh.Trimesh], list[str], tuple[str, ...]]:
    """The meshes within ``STRAY_M`` of the median of their centres, and a note for each other one."""
    if len(meshes) < 2:
        return meshes, names, ()
    centres = np.array([m.bounds.mean(axis=0)[:2] for m in meshes])
    middle = np.median(centres, axis=0)
    distance = np.hypot(*(centres - middle).T)
    keep = distance <= STRAY_M
    if keep.all():
        return meshes, names, ()
    notes = tuple(f"{name}: lies {d / 1000:.1f} km from the rest of the storey's obstacles: left off the map "
                  "(check its placement or coordinates in the IFC, or give the site layout a kbp:siteExtent)"
                  for name, d, k in zip(names, distance, keep, strict=True) if not k)
    for note in notes:
        log.warning("map: %s", note)
    kept = [i for i, k in enumerate(keep) if k]
    return [meshes[i] for i in kept], [names[i] for i in kept], notes


def _check_size(extent: Box, resolution_m: float, storey: StoreyInfo) -> None:
    """Refuse a grid too large to hold (bad input: an extent kilometres wide at centimetre cells)."""
    width, depth = extent.xmax - extent.xmin, extent.ymax - extent.ymin
    cells = (width / resolution_m) * (depth / resolution_m)
    if cells > MAX_CELLS:
        raise KbplannerError(
            f"the map of {storey.label} would be {width:,.0f} x {depth:,.0f} m, {cells:,.0f} cells of "
            f"{resolution_m:g} m (at most {MAX_CELLS:,.0f})", element=storey.label,
            fix="give the site layout a smaller kbp:siteExtent around the building, or check the IFC's "
                "coordinates (elements far from the building)")


def write_map(storey_map_: StoreyMap, directory: Path, name: str = "map") -> tuple[Path, Path]:
    """Write ``{name}.pgm`` and ``{name}.yaml`` (ROS map_server format)."""
    return storey_map_.grid.to_pgm_yaml(Path(directory), name)



def map_summary(m: StoreyMap) -> str:
    """One line about a map for the command line."""
    ny, nx = m.grid.shape
    occupied = 100 * (1 - m.grid.free_fraction)
    text = (f"{m.storey.label} (floor {m.storey.elevation_m:+.2f} m, band {m.band[0]:.2f}-{m.band[1]:.2f} m):"
            f" {nx} x {ny} cells of {m.grid.resolution:g} m, {occupied:.1f} % occupied")
    if m.levels:
        text += f"; at other heights than the floor: {levels_summary(m.levels)}"
    if m.notes:
        text += f"; {len(m.notes)} map note(s) (world.json map.notes)"
    return text

