"""``kbplanner init`` (issue 10), step 3a: the site plan read from the building's geometry.

The entrance (the widest external door of the task storey: ``Pset_DoorCommon.IsExternal``, else a
door on the footprint's edge) and its outward side, the robot start in front of it, the site objects
placed outside along the facade (entrance area, the carpenters' lumber storage, the site office),
the narrowest door the knowledge base's arm robots pass (the robot selection's door rule), the
``project.toml`` text, and the fallback when the start does not reach the inside on the map (the
robot is set down inside, with a note).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import ifcopenshell.util.element as ue
import numpy as np
from scipy import ndimage
from shapely import contains_xy
from shapely.geometry import Point, Polygon

from kbplanner.knowledge.knowledge_base import load_kb
from kbplanner.knowledge.robot_selection import load_robots
from kbplanner.scale import init_site as site
from kbplanner.scale.init_walls import footprint
from kbplanner.scale.project_toml import model_calendar_simulation

START_OUT_M = 4.0  # robot start in front of the entrance door
UPPER_STOREY_M = 1.0  # a task storey this far above the ground is reached by lift (a robot arrival)
PANEL_MAX_KG = 14.0  # panels of at most 0.75 m weigh about 9-14 kg


def is_external_door(door: Any, hull: Polygon, centre: tuple[float, float]) -> bool:
    try:
        psets = ue.get_psets(door, psets_only=True)
    except Exception:
        psets = {}
    ext = (psets.get("Pset_DoorCommon") or {}).get("IsExternal")
    if isinstance(ext, bool):
        return ext
    return hull.exterior.distance(Point(centre)) < 0.6


def door_width(door: Any, meshes: dict[str, Any], length_m: float) -> float:
    """OverallWidth in metres, else the long side of the door's footprint."""
    w = getattr(door, "OverallWidth", None)
    if isinstance(w, (int, float)) and w > 0:
        return round(float(w) * length_m, 4)
    rect = footprint(meshes[str(door.GlobalId)]).minimum_rotated_rectangle
    pts = np.asarray(rect.exterior.coords)[:3]
    return round(float(max(np.linalg.norm(pts[1] - pts[0]), np.linalg.norm(pts[2] - pts[1]))), 4)


def door_need() -> tuple[float, str]:
    """The narrowest door the narrowest KB robot with an arm passes (its width + the proposed clearance)."""
    arms = [r for r in load_robots(load_kb()) if r.payload_kg is not None and r.payload_kg >= PANEL_MAX_KG]
    if not arms:
        return (0.0, "no robot of the knowledge base lifts a panel")
    r = min(arms, key=lambda r: (r.width_m, r.label))
    return (
        round(r.width_m + 2 * site.DOOR_CLEARANCE, 4),
        f"{r.label}: {r.width_m:.2f} m + 2 x {site.DOOR_CLEARANCE} m door clearance",
    )


def entrance_door(
    doors: Sequence[Any], meshes: dict[str, Any], hull: Polygon
) -> tuple[tuple[float, float], tuple[float, float], str] | None:
    """(door centre, outward unit normal, label) of the widest external door of the storey."""
    best: tuple[float, str, tuple[float, float], tuple[float, float], str] | None = None
    for d in doors:
        mesh = meshes.get(str(d.GlobalId))
        if mesh is None:
            continue
        fp = footprint(mesh)
        c = (fp.centroid.x, fp.centroid.y)
        if not is_external_door(d, hull, c):
            continue
        rect = fp.minimum_rotated_rectangle
        pts = np.asarray(rect.exterior.coords)[:4]
        e1, e2 = pts[1] - pts[0], pts[2] - pts[1]
        long_ = e1 if np.linalg.norm(e1) >= np.linalg.norm(e2) else e2
        width = float(np.linalg.norm(long_))
        n = np.array([-long_[1], long_[0]]) / max(width, 1e-9)
        probe = Point(c[0] + n[0] * 2.0, c[1] + n[1] * 2.0)
        if hull.contains(probe):
            n = -n
        key = (-round(width, 3), str(d.GlobalId))
        if best is None or key < (best[0], best[1]):
            best = (key[0], key[1], c, (float(n[0]), float(n[1])), f"{d.Name or d.GlobalId} ({d.GlobalId})")
    return None if best is None else (best[2], best[3], best[4])


def site_plan(
    hull: Polygon,
    elevation: float,
    entrance: tuple[tuple[float, float], tuple[float, float], str] | None,
    ground: float,
) -> site.SitePlan:
    x0, y0, x1, y1 = hull.bounds
    extent = (
        round(x0 - 15, 3),
        round(y0 - 15, 3),
        ground - 2.0,
        round(x1 + 15, 3),
        round(y1 + 15, 3),
        elevation + 15.0,
    )
    if entrance is None:
        c = (x1 + 5.0, (y0 + y1) / 2)
        n = (1.0, 0.0)
        note = (
            "No external door was found: the robot start is east of the building; move it to where the "
            "robot enters, or add a door."
        )
        door = (x1, (y0 + y1) / 2)
    else:
        door, n, label = entrance
        c = (door[0] + n[0] * START_OUT_M, door[1] + n[1] * START_OUT_M)
        note = f"The robot starts {START_OUT_M} m in front of the entrance door {label}, facing it."
    t = (-n[1], n[0])  # along the facade

    def at(out_m: float, side_m: float) -> tuple[float, float]:
        return (
            round(door[0] + n[0] * out_m + t[0] * side_m, 3),
            round(door[1] + n[1] * out_m + t[1] * side_m, 3),
        )

    face = math.atan2(-n[1], -n[0])
    objs = []
    for key, cls, label, obstructs, size, (out_m, side) in (
        # the entrance area beside the doorway, not in it (a carpenter dwells there)
        ("entrance-area", "Workspace", "Entrance area", False, (2.0, 2.0, 2.0), (2.0, 2.5)),
        (
            "lumber-storage",
            "MaterialStorage",
            "Lumber storage (carpenters)",
            True,
            (3.6, 1.4, 1.0),
            (7.0, 6.0),
        ),
        ("office", "SiteOffice", "Site office", True, (6.0, 2.5, 2.7), (11.0, -8.0)),
    ):
        x, y = at(out_m, side)
        objs.append(site.PlacedObject(key, cls, label, obstructs, size, x, y, ground, round(face, 9)))
    start = (round(c[0], 3), round(c[1], 3), ground, round(face, 9))
    return site.SitePlan(extent, start, note, None, tuple(objs))


def project_toml(
    name: str,
    base: str,
    ifc_rel: str,
    seed: int,
    sim_date: str,
    source: Path,
    scenarios: dict[str, tuple[str, str]],
) -> str:
    lines = [
        f"# Written by `kbplanner init {source.name}`: every file here is a proposal to edit.",
        "",
        "[project]",
        f"name = {toml_str(name)}",
        f'description = "Robotized interior wall framing in {toml_esc(source.name)} (kbplanner init)"',
        f'base_iri = "{base}"',
        f"seed = {seed}",
        "",
        *model_calendar_simulation(
            ifc_rel, "[]  # the work sequence is in each scenario: it follows the storages",
            site.FRAME_TASK, sim_date,
        ),
    ]
    for key, (desc, file) in scenarios.items():
        lines += [
            f"[scenarios.{key}]",
            f"description = {toml_str(desc)}",
            f'overlays = ["{file}", "augmentation/grasp_points.ttl"]',
            "",
        ]
    return "\n".join(lines)


def toml_esc(s: str) -> str:
    return s.replace("\\", "\\\\").replace('"', '\\"')


def toml_str(s: str) -> str:
    return f'"{toml_esc(s)}"'


def reaches_inside(grid: Any, start: tuple[float, float], hull: Polygon) -> bool:
    """Whether the start's free region (4-connected) reaches the inside of the building on the map."""
    inner = hull.buffer(-0.5)
    if grid.is_occupied(*start) or inner.is_empty:
        return False
    labels, _n = ndimage.label(~grid.occupied)
    ix, iy = grid.cell_of(*start)
    ys, xs = np.nonzero(labels == labels[iy, ix])
    px = grid.origin[0] + (xs + 0.5) * grid.resolution
    py = grid.origin[1] + (ys + 0.5) * grid.resolution
    return bool(contains_xy(inner, px, py).any())


def inside_start(
    plan: site.SitePlan, grid: Any, hull: Polygon, z: float, notes: list[str], *, arrival: bool = False
) -> site.SitePlan:
    """A robot start (or, on an upper storey, arrival) inside: the free cell farthest from obstacles."""
    clearance = ndimage.distance_transform_edt(~grid.occupied)
    ys, xs = np.nonzero(~grid.occupied)
    px = grid.origin[0] + (xs + 0.5) * grid.resolution
    py = grid.origin[1] + (ys + 0.5) * grid.resolution
    inside = contains_xy(hull, px, py)
    if not inside.any():
        notes.append("no free floor inside the building on the task storey's map: robot start kept")
        return plan
    k = int(np.lexsort((px[inside], py[inside], -clearance[ys[inside], xs[inside]]))[0])
    x, y = round(float(px[inside][k]), 3), round(float(py[inside][k]), 3)
    if arrival:
        notes.append(
            f"the robot arrival on the task storey is proposed at ({x}, {y}), the most open free spot "
            "inside: move it to the lift landing or stair (kbp:robotArrival in site/site_layout.ttl)"
        )
        return site.SitePlan(plan.extent, plan.start, plan.start_note, (x, y, z, 0.0), plan.objects)
    notes.append(
        f"the robot start in front of the entrance does not reach the inside on the map: the "
        f"robot is set down inside at ({x}, {y}) instead (edit kbp:robotStart in "
        "site/site_layout.ttl)"
    )
    return site.SitePlan(
        plan.extent,
        (x, y, z, 0.0),
        "The robot is set down inside the building (no open entrance on the map).",
        plan.arrival,
        plan.objects,
    )
