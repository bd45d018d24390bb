"""An office building written with ``ifcopenshell.api`` (test helper of the init and run steps, issue 10).

``write_office(path, schema=..., rooms_per_side=..., storeys=...)`` writes a rectangular office floor
plate per storey: a central corridor along x (``CORRIDOR_M`` wide) between two corridor walls, and
``rooms_per_side`` offices on each side, split by partitions that run from the facade to the corridor
wall; every office has a door into the corridor (``DOOR_M`` wide) and a window in the facade; the
ground floor has an entrance door (``ENTRANCE_M``) at the west end of the corridor. Spaces (offices
and corridor), a floor slab per storey, ``Pset_WallCommon`` (``IsExternal``, ``LoadBearing``: the
facades are external and load-bearing, corridor walls and partitions neither). Nothing of the frames,
site or schedule: that is what ``kbplanner init`` proposes.

IFC2X3 is written as ArchiCAD writes it: millimetres, ``IfcWallStandardCase``, and every property and
quantity set but ``Pset_WallCommon`` without a Name (an unnamed set with the element's NetWeight and an
unnamed "ArchiCAD" property set on walls, doors and windows).

Layout (site frame, metres): x in [0, ROOM_W_M * rooms_per_side], y in [0, 2 * ROOM_D_M + CORRIDOR_M];
the corridor is y in [ROOM_D_M, ROOM_D_M + CORRIDOR_M]; storey k at elevation 3.2 k.

Example:
    >>> from pathlib import Path
    >>> import tempfile
    >>> o = write_office(Path(tempfile.mkdtemp()) / "o.ifc", rooms_per_side=3, storeys=1)
    >>> o.walls, o.doors, o.windows
    (10, 7, 6)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import ifcopenshell
import ifcopenshell.api.aggregate
import ifcopenshell.api.feature
import ifcopenshell.api.geometry
import ifcopenshell.api.pset
import ifcopenshell.api.spatial

from ifc_factory import _door, _matrix, _placement_matrix, _Writer
from ifc_traits import _unname_sets, _unnamed_weight

ROOM_W_M = 4.0
ROOM_D_M = 5.0
CORRIDOR_M = 2.2
EXT_M = 0.3
CORRIDOR_WALL_M = 0.15
PARTITION_M = 0.1
STOREY_M = 3.2
DOOR_M = 1.0
ENTRANCE_M = 1.2


@dataclass(frozen=True)
class Office:
    """What a written office holds: counts, and the GlobalIds of the walls by kind."""

    path: Path
    schema: str
    walls: int
    doors: int
    windows: int
    partitions: tuple[str, ...]  # GlobalIds of the office partitions (ground floor first)
    corridor_walls: tuple[str, ...]


def write_office(path: Path, *, schema: Literal["IFC2X3", "IFC4"] = "IFC4", rooms_per_side: int = 6,
                 storeys: int = 2) -> Office:
    """Write the office (module docstring) and return what it holds."""
    archicad = schema == "IFC2X3"
    w = _Writer(schema, unit_mm=archicad)
    f = w.f
    site = w.create("IfcSite", "Office site", "office-site")
    w.place(site, _matrix(0.0, 0.0, 0.0))
    building = w.create("IfcBuilding", "Office building", "office-building")
    w.place(building, _matrix(0.0, 0.0, 0.0))
    ifcopenshell.api.aggregate.assign_object(f, products=[site], relating_object=w.project)
    ifcopenshell.api.aggregate.assign_object(f, products=[building], relating_object=site)
    wall_class = "IfcWallStandardCase" if archicad else "IfcWall"
    length = ROOM_W_M * rooms_per_side
    depth = 2 * ROOM_D_M + CORRIDOR_M
    y_corr = (ROOM_D_M, ROOM_D_M + CORRIDOR_M)
    walls: list[Any] = []
    doors: list[Any] = []
    windows: list[Any] = []
    partitions: list[str] = []
    corridor_walls: list[str] = []

    for k in range(storeys):
        elev = k * STOREY_M
        storey = w.create("IfcBuildingStorey", f"Floor {k}", f"office-storey-{k}")
        storey.Elevation = w.units(elev)
        ifcopenshell.api.aggregate.assign_object(f, products=[storey], relating_object=building)
        w.place(storey, _matrix(0.0, 0.0, elev))

        def wall(key: str, kind: str, x: float, y: float, yaw: float, wall_length: float,
                 k: int = k, storey: Any = storey, elev: float = elev) -> Any:
            external = kind == "facade"
            thickness = {"facade": EXT_M, "corridor": CORRIDOR_WALL_M, "partition": PARTITION_M}[kind]
            element = w.create(wall_class, f"{kind.capitalize()} wall {k}.{key}", f"office-wall-{k}-{key}")
            ifcopenshell.api.spatial.assign_container(f, products=[element], relating_structure=storey)
            w.place(element, _matrix(x, y, elev, yaw))
            rep = ifcopenshell.api.geometry.add_wall_representation(
                f, context=w.body, length=wall_length, height=STOREY_M - 0.2,
                thickness=thickness, offset=0.0 if external else -thickness / 2)
            ifcopenshell.api.geometry.assign_representation(f, product=element, representation=rep)
            pset = ifcopenshell.api.pset.add_pset(f, product=element, name="Pset_WallCommon")
            ifcopenshell.api.pset.edit_pset(f, pset=pset, properties={"IsExternal": external,
                                                                      "LoadBearing": external})
            walls.append(element)
            return element

        south = wall("south", "facade", 0.0, 0.0, 0.0, length)
        wall("east", "facade", length, 0.0, math.pi / 2, depth)
        north = wall("north", "facade", length, depth, math.pi, length)
        west = wall("west", "facade", 0.0, depth, -math.pi / 2, depth)
        corridor = [wall(f"corridor-{s}", "corridor", EXT_M, y, 0.0, length - 2 * EXT_M)
                    for s, y in zip(("s", "n"), y_corr, strict=True)]
        corridor_walls += [c.GlobalId for c in corridor]
        half = CORRIDOR_WALL_M / 2
        for i in range(1, rooms_per_side):
            x = ROOM_W_M * i
            partitions.append(wall(f"p{i}s", "partition", x, EXT_M, math.pi / 2,
                                   ROOM_D_M - half - EXT_M).GlobalId)
            partitions.append(wall(f"p{i}n", "partition", x, y_corr[1] + half, math.pi / 2,
                                   ROOM_D_M - half - EXT_M).GlobalId)
        for i in range(rooms_per_side):
            along = ROOM_W_M * i + 1.2 - EXT_M  # from the corridor wall's start at x = EXT_M
            for side, host in zip(("s", "n"), corridor, strict=True):
                doors += map(f.by_guid, _door(w, storey, k, elev, f"r{i}{side}", host, along, DOOR_M, 2.1,
                                              CORRIDOR_WALL_M, True, wall_is_external=False))
            windows.append(_window(w, storey, f"{k}-{i}s", south, ROOM_W_M * i + 1.4, elev))
            windows.append(_window(w, storey, f"{k}-{i}n", north, length - ROOM_W_M * i - 2.6, elev))
        if k == 0:
            along = depth - (y_corr[0] + CORRIDOR_M / 2) - ENTRANCE_M / 2
            doors += map(f.by_guid, _door(w, storey, k, elev, "entrance", west, along, ENTRANCE_M, 2.1, EXT_M,
                                          True, wall_is_external=True))

        slab = w.create("IfcSlab", f"Floor slab {k}", f"office-slab-{k}", predefined_type="FLOOR")
        ifcopenshell.api.spatial.assign_container(f, products=[slab], relating_structure=storey)
        w.place(slab, _matrix(0.0, 0.0, elev - 0.2))
        rep = ifcopenshell.api.geometry.add_slab_representation(
            f, context=w.body, depth=0.2, polyline=[(0.0, 0.0), (length, 0.0), (length, depth), (0.0, depth)])
        ifcopenshell.api.geometry.assign_representation(f, product=slab, representation=rep)
        rooms = [(f"{k}{i:02d}S", ROOM_W_M * i, 0.0, ROOM_D_M) for i in range(rooms_per_side)]
        rooms += [(f"{k}{i:02d}N", ROOM_W_M * i, y_corr[1], depth) for i in range(rooms_per_side)]
        for name, x0, y0, y1 in [*rooms, (f"{k}-corridor", 0.0, y_corr[0], y_corr[1])]:
            x1 = length if name.endswith("corridor") else x0 + ROOM_W_M
            space = w.create("IfcSpace", name, f"office-space-{k}-{name}")
            space.LongName = "Corridor" if name.endswith("corridor") else f"Office {name}"
            ifcopenshell.api.aggregate.assign_object(f, products=[space], relating_object=storey)
            w.place(space, _matrix(0.0, 0.0, elev))
            m = 0.1  # inside the walls
            rep = ifcopenshell.api.geometry.add_slab_representation(
                f, context=w.body, depth=STOREY_M - 0.2,
                polyline=[(x0 + m, y0 + m), (x1 - m, y0 + m), (x1 - m, y1 - m), (x0 + m, y1 - m)])
            ifcopenshell.api.geometry.assign_representation(f, product=space, representation=rep)

    if archicad:
        for element in walls + doors + windows:
            _unnamed_weight(f, element, 35.0 if element in doors else 20.0 if element in windows else 400.0)
            pset = ifcopenshell.api.pset.add_pset(f, product=element, name="ArchiCAD")
            ifcopenshell.api.pset.edit_pset(f, pset=pset, properties={"Renovation Status": "New"})
        _unname_sets(f, keep=("Pset_WallCommon",))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    f.write(str(path))
    return Office(path, f.schema, len(walls), len(doors), len(windows), tuple(partitions),
                  tuple(corridor_walls))


def _window(w: _Writer, storey: Any, key: str, host: Any, along: float, elev: float) -> Any:
    """A 1.2 x 1.2 m window at 0.9 m filling an opening of ``host`` (a facade, body on its +y side)."""
    f = w.f
    host_matrix = _placement_matrix(host, w.scale)
    opening = w.create("IfcOpeningElement", f"Window opening {key}", f"office-wopening-{key}", "OPENING")
    w.place(opening, host_matrix @ _matrix(along, -0.05, 0.9), absolute=True)
    rep = ifcopenshell.api.geometry.add_wall_representation(
        f, context=w.body, length=1.2, height=1.2, thickness=EXT_M + 0.1)
    ifcopenshell.api.geometry.assign_representation(f, product=opening, representation=rep)
    ifcopenshell.api.feature.add_feature(f, feature=opening, element=host)
    window = w.create("IfcWindow", f"Window {key}", f"office-window-{key}")
    ifcopenshell.api.spatial.assign_container(f, products=[window], relating_structure=storey)
    w.place(window, host_matrix @ _matrix(along, 0.0, 0.9), absolute=True)
    rep = ifcopenshell.api.geometry.add_wall_representation(
        f, context=w.body, length=1.2, height=1.2, thickness=0.05,
        offset=EXT_M / 2 - 0.025)
    ifcopenshell.api.geometry.assign_representation(f, product=window, representation=rep)
    window.OverallWidth, window.OverallHeight = w.units(1.2), w.units(1.2)
    ifcopenshell.api.feature.add_filling(f, opening=opening, element=window)
    del elev
    return window
