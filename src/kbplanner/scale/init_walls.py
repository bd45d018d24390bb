"""``kbplanner init`` (issue 10), step 1: which walls of an IFC model get stud-frame panels, and where.

Reads any IFC file that ifcopenshell opens (the import's opener and units,
:mod:`kbplanner.model.ifc_open`), in the site frame of the import (:mod:`kbplanner.model.ifc_geometry`):

- the storeys (name, elevation) and the walls contained in each;
- a wall qualifies for the framing task when it is interior (``Pset_WallCommon.IsExternal`` not true),
  not load-bearing (``LoadBearing`` not true), straight and thin (its footprint's minimum rectangle
  at most :data:`MAX_THICKNESS_M` thick), at least :data:`MIN_WALL_M` long and high enough for a
  panel; every other wall gets its reason (:class:`WallChoice`);
- the panels of a chosen wall stand on its axis, on the floor, cut around its openings (doors), around
  every other element of the storey whose footprint crosses the axis (a wall that stays, a column) and
  around the panels of walls chosen before, each at most :data:`MAX_PANEL_M` long (the generator's
  panels, :mod:`kbplanner.model.stud_frames`); free pieces shorter than :data:`MIN_PANEL_M` are left.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import ifcopenshell
import ifcopenshell.util.element
import numpy as np
import trimesh
from shapely.geometry import MultiPoint, Polygon

from kbplanner.core.errors import KbplannerError
from kbplanner.model.stud_frames import PANEL_HEIGHT, STUD_DEPTH
from kbplanner.scale.building_plan import MAX_PANEL_LENGTH, segments

MAX_THICKNESS_M = 0.3  # thicker walls are structural or external in practice
MIN_WALL_M = 1.0
MIN_PANEL_M = 0.3
MIN_HEIGHT_M = 2.0
MAX_PANEL_M = MAX_PANEL_LENGTH
GAP_M = 0.02  # between a panel and what it is cut around
OPENING_MARGIN_M = 0.05


class InitError(KbplannerError):
    """Bad input for ``kbplanner init``: the IFC, a selector, an option or the output folder."""


@dataclass(frozen=True)
class StoreyRef:
    """A storey of the IFC file: GlobalId, name, elevation (site frame, metres)."""

    global_id: str
    name: str
    elevation: float


@dataclass(frozen=True)
class WallAxis:
    """A straight wall's axis in the site frame (metres): from (x0, y0) to (x1, y1) at ``base_z``."""

    x0: float
    y0: float
    x1: float
    y1: float
    base_z: float
    height: float
    thickness: float

    @property
    def length(self) -> float:
        return math.hypot(self.x1 - self.x0, self.y1 - self.y0)

    @property
    def yaw(self) -> float:
        return math.atan2(self.y1 - self.y0, self.x1 - self.x0)

    def along(self, points: np.ndarray) -> np.ndarray:
        """Distance along the axis from its start of xy ``points`` (n, 2)."""
        d = np.array([math.cos(self.yaw), math.sin(self.yaw)])
        return (points - np.array([self.x0, self.y0])) @ d

    def point(self, s: float) -> tuple[float, float]:
        return (self.x0 + math.cos(self.yaw) * s, self.y0 + math.sin(self.yaw) * s)

    def band(self, width: float) -> Polygon:
        """The rectangle of ``width`` centred on the axis."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        n = (-s * width / 2, c * width / 2)
        return Polygon(
            [
                (self.x0 + n[0], self.y0 + n[1]),
                (self.x1 + n[0], self.y1 + n[1]),
                (self.x1 - n[0], self.y1 - n[1]),
                (self.x0 - n[0], self.y0 - n[1]),
            ]
        )


@dataclass(frozen=True)
class PanelSpot:
    """Where one panel stands: its centre on the axis at floor level, yaw along the wall, length."""

    wall: str  # GlobalId of the host wall
    index: int  # 1-based along the wall
    x: float
    y: float
    z: float
    yaw: float
    length: float
    height: float

    def footprint(self) -> Polygon:
        half = self.length / 2
        axis = WallAxis(
            self.x - math.cos(self.yaw) * half,
            self.y - math.sin(self.yaw) * half,
            self.x + math.cos(self.yaw) * half,
            self.y + math.sin(self.yaw) * half,
            self.z,
            self.height,
            STUD_DEPTH,
        )
        return axis.band(STUD_DEPTH)


@dataclass
class WallChoice:
    """A wall of the model and whether it gets panels: ``reason`` says why not (empty when chosen)."""

    global_id: str
    name: str
    storey: str
    ifc_class: str
    reason: str = ""
    axis: WallAxis | None = None
    panels: list[PanelSpot] = field(default_factory=list)
    lost_m: float = 0.0  # free axis length in pieces too short for a panel
    parts: list[str] = field(default_factory=list)  # GlobalIds of the parts that are its body, if any

    @property
    def chosen(self) -> bool:
        return not self.reason and bool(self.panels)


# ---------------------------------------------------------------------------------------------
# Reading the IFC


def storey_of(product: Any) -> Any | None:
    """The storey that contains ``product`` (through a space or an element it is part of).

    An element contained in the IfcBuilding itself gets the building: a building without storeys is
    one storey for init, as for the import (:func:`kbplanner.model.ifc_graph.implicit_storey_label`).
    """
    seen = 0
    node = ifcopenshell.util.element.get_container(product) or ifcopenshell.util.element.get_aggregate(
        product
    )
    while node is not None and seen < 10:
        if node.is_a("IfcBuildingStorey") or node.is_a("IfcBuilding"):
            return node
        node = ifcopenshell.util.element.get_container(node) or ifcopenshell.util.element.get_aggregate(node)
        seen += 1
    return None


def body_from_parts(wall: Any, meshes: dict[str, Any]) -> list[str]:
    """A wall without a body of its own whose parts (IfcBuildingElementPart ...) have meshes: their
    meshes are merged into the wall's (and leave ``meshes``); returns the parts' GlobalIds."""
    gid = str(wall.GlobalId)
    if gid in meshes:
        return []
    parts = sorted(str(p.GlobalId) for p in ifcopenshell.util.element.get_decomposition(wall)
                   if str(p.GlobalId) in meshes)
    if parts:
        meshes[gid] = trimesh.util.concatenate([meshes.pop(p) for p in parts])
    return parts


def storeys(f: ifcopenshell.file, site: np.ndarray, length_m: float) -> list[StoreyRef]:
    """The storeys by elevation (site frame), as the import has them (``storey_elevation``)."""
    from kbplanner.model.ifc_geometry import placement_matrix, storey_elevation
    from kbplanner.model.ifc_graph import has_storeys, implicit_storey_label

    inv = np.linalg.inv(site)
    out = []
    for st in f.by_type("IfcBuildingStorey"):
        z = storey_elevation(st, inv, length_m).elevation_m
        out.append(StoreyRef(str(st.GlobalId), str(st.Name or st.LongName or st.GlobalId), round(z, 4)))
    for building in f.by_type("IfcBuilding"):  # a building without storeys is one, at its 0.00 level
        if not has_storeys(building):
            m = placement_matrix(building, length_m)
            z = float((inv @ m)[2, 3]) if m is not None else 0.0
            out.append(StoreyRef(str(building.GlobalId), implicit_storey_label(building), round(z, 4)))
    return sorted(out, key=lambda s: (s.elevation, s.name, s.global_id))


def wall_property(wall: Any, name: str) -> bool | None:
    """``Pset_WallCommon.<name>`` of the wall or its type (``None`` when absent or unreadable)."""
    try:
        psets = ifcopenshell.util.element.get_psets(wall, psets_only=True)
    except Exception:  # a malformed property set: the import notes it; here it is just unknown
        return None
    value = (psets.get("Pset_WallCommon") or {}).get(name)
    return value if isinstance(value, bool) else None


def property_reason(wall: Any) -> str:
    """Why the wall's properties rule it out ('' when they do not)."""
    if wall_property(wall, "IsExternal") is True:
        return "external wall (Pset_WallCommon.IsExternal = true)"
    if wall_property(wall, "LoadBearing") is True:
        return "load-bearing (Pset_WallCommon.LoadBearing = true)"
    return ""


def footprint(mesh: trimesh.Trimesh) -> Polygon:
    """The convex hull of a mesh's vertices in plan."""
    hull = MultiPoint([tuple(p) for p in np.asarray(mesh.vertices)[:, :2]]).convex_hull
    return hull if isinstance(hull, Polygon) else hull.buffer(0.001)


def wall_axis(mesh: trimesh.Trimesh, floor_z: float) -> WallAxis:
    """The axis of a straight wall: the long centre line of its footprint's minimum rectangle."""
    rect = footprint(mesh).minimum_rotated_rectangle
    pts = np.asarray(rect.exterior.coords)[:4] if isinstance(rect, Polygon) else np.zeros((4, 2))
    e1, e2 = pts[1] - pts[0], pts[2] - pts[1]
    if np.linalg.norm(e1) < np.linalg.norm(e2):
        pts = np.roll(pts, -1, axis=0)
        e1, e2 = e2, e1
    start = (pts[0] + pts[3]) / 2
    end = (pts[1] + pts[2]) / 2
    if (end[0], end[1]) < (start[0], start[1]):  # a stable direction, whatever the rectangle's corner order
        start, end = end, start
    z0, z1 = float(mesh.bounds[0][2]), float(mesh.bounds[1][2])
    base = max(z0, floor_z) if z0 < floor_z + 0.5 else z0
    return WallAxis(
        round(float(start[0]), 4),
        round(float(start[1]), 4),
        round(float(end[0]), 4),
        round(float(end[1]), 4),
        round(base, 4),
        round(z1 - base, 4),
        round(float(np.linalg.norm(e2)), 4),
    )


def opening_products(wall: Any) -> list[Any]:
    """The openings that void a wall and the doors and windows that fill them."""
    out: list[Any] = []
    for rel in getattr(wall, "HasOpenings", ()) or ():
        opening = rel.RelatedOpeningElement
        out.append(opening)
        for fill in getattr(opening, "HasFillings", ()) or ():
            out.append(fill.RelatedBuildingElement)
    return out


# ---------------------------------------------------------------------------------------------
# Panels on a wall


def _overlaps_z(mesh: trimesh.Trimesh, z0: float, z1: float) -> bool:
    return float(mesh.bounds[0][2]) < z1 and float(mesh.bounds[1][2]) > z0


def _interval(axis: WallAxis, poly: Any) -> tuple[float, float] | None:
    if poly.is_empty:
        return None
    coords: list[tuple[float, float]] = []
    for part in getattr(poly, "geoms", [poly]):
        if hasattr(part, "exterior"):
            coords += list(part.exterior.coords)
    if not coords:
        return None
    s = axis.along(np.asarray(coords, dtype=float)[:, :2])
    return (float(s.min()) - GAP_M, float(s.max()) + GAP_M)


def panel_spots(
    choice: WallChoice,
    openings: Sequence[trimesh.Trimesh],
    obstacles: Sequence[trimesh.Trimesh],
    placed: Sequence[PanelSpot],
) -> None:
    """Fill ``choice.panels`` (or its reason): the axis cut around openings, obstacles and ``placed``."""
    axis = choice.axis
    assert axis is not None
    height = min(PANEL_HEIGHT, axis.height)
    z0, z1 = axis.base_z + 0.05, axis.base_z + height
    band = axis.band(STUD_DEPTH + 2 * GAP_M)
    cuts: list[tuple[float, float]] = []
    for m in openings:
        s = axis.along(np.asarray(m.vertices)[:, :2])
        cuts.append((float(s.min()) - OPENING_MARGIN_M, float(s.max()) + OPENING_MARGIN_M))
    for m in obstacles:
        if _overlaps_z(m, z0, z1):
            hull = footprint(m)
            if hull.intersects(band):
                iv = _interval(axis, hull.intersection(band))
                if iv is not None:
                    cuts.append(iv)
    for p in placed:
        fp = p.footprint()
        if fp.intersects(band):
            iv = _interval(axis, fp.intersection(band))
            if iv is not None:
                cuts.append(iv)
    pieces = segments(
        axis.length, [(max(0.0, a), min(axis.length, b)) for a, b in cuts if b > 0 and a < axis.length]
    )
    n = 0
    for a, b in pieces:
        if b - a < MIN_PANEL_M:
            choice.lost_m += b - a
            continue
        count = max(1, math.ceil((b - a) / MAX_PANEL_M - 1e-9))
        length = (b - a) / count
        for i in range(count):
            n += 1
            x, y = axis.point(a + (i + 0.5) * length)
            choice.panels.append(
                PanelSpot(
                    choice.global_id,
                    n,
                    round(x, 4),
                    round(y, 4),
                    axis.base_z,
                    axis.yaw,
                    round(length, 4),
                    round(height, 4),
                )
            )
    if not choice.panels:
        choice.reason = (
            f"no free piece of its axis is {MIN_PANEL_M} m long (openings, crossing walls or "
            "other elements take it)"
        )


def axis_reason(axis: WallAxis) -> str:
    """Why a wall's shape rules it out ('' when it does not)."""
    if axis.thickness > MAX_THICKNESS_M:
        return (
            f"not a straight partition: its footprint is {axis.thickness:.2f} m thick "
            f"(at most {MAX_THICKNESS_M} m)"
        )
    if axis.length < MIN_WALL_M:
        return f"shorter than {MIN_WALL_M} m ({axis.length:.2f} m)"
    if axis.height < MIN_HEIGHT_M:
        return f"lower than {MIN_HEIGHT_M} m ({axis.height:.2f} m)"
    return ""


# ---------------------------------------------------------------------------------------------
# Room doors (the robot selection's door rule, applied before the panels are written)


@dataclass(frozen=True)
class RoomDoors:
    """Spaces (plan boxes) of the task storey with the width and name of their widest door."""

    spaces: list[tuple[tuple[float, float, float, float], float, str]]

    def widest_near(self, x: float, y: float, margin: float) -> tuple[float, str] | None:
        """The best door of the spaces whose box comes within ``margin`` of (x, y) (None: no such space)."""
        near = [
            (w, d)
            for (x0, y0, x1, y1), w, d in self.spaces
            if x0 - margin <= x <= x1 + margin and y0 - margin <= y <= y1 + margin
        ]
        return max(near) if near else None


def room_doors(
    spaces: Sequence[trimesh.Trimesh], doors: Sequence[tuple[trimesh.Trimesh, float, str]], tolerance: float
) -> RoomDoors:
    """Each space with its widest door (a door belongs to a space when their boxes overlap within
    ``tolerance``, as in :mod:`kbplanner.knowledge.robot_selection`); spaces without a door are left out."""
    out = []
    for s in spaces:
        (sx0, sy0, _sz0), (sx1, sy1, _sz1) = s.bounds
        best: tuple[float, str] | None = None
        for m, width, name in doors:
            (dx0, dy0, _a), (dx1, dy1, _b) = m.bounds
            if (
                sx0 - tolerance <= dx1
                and dx0 <= sx1 + tolerance
                and sy0 - tolerance <= dy1
                and dy0 <= sy1 + tolerance
            ):
                best = max(best or (width, name), (width, name))
        if best is not None:
            out.append(((float(sx0), float(sy0), float(sx1), float(sy1)), best[0], best[1]))
    return RoomDoors(out)


def door_reason(choice: WallChoice, rooms: RoomDoors, need: float, margin: float, robot: str) -> str:
    """Why the robot cannot reach the wall's panels through the rooms' doors ('' when it can)."""
    worst: tuple[float, str] | None = None
    for p in choice.panels:
        best = rooms.widest_near(p.x, p.y, margin)
        if best is not None and best[0] < need and (worst is None or best < worst):
            worst = best
    if worst is None:
        return ""
    return (
        f"in a room whose widest door is {worst[0]:.3f} m ({worst[1]}): the robot needs {need:.2f} m "
        f"({robot})"
    )
