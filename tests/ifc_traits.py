"""IFC fixtures with the traits of real exports (test helper of the import and world steps).

Each ``write_*`` function writes the test building of :mod:`ifc_factory` and then changes it with
ifcopenshell the way a real authoring tool's export differs from it, and returns what the file
holds. Traits: property and quantity sets without a Name (IFC2X3, ArchiCAD) plus windows; mass
units (gram, pound); length units (millimetre, inch, foot); a split-level slab at +1.44 m; stairs;
a door without a host wall; a storey without spaces; a wall whose body is two overlapping, partly
self-intersecting solids; elements without geometry.

Example:
    >>> from pathlib import Path
    >>> import tempfile
    >>> t = write_traits(Path(tempfile.mkdtemp()) / "t.ifc")
    >>> sorted(t.extra)[:3]
    ['door_no_host', 'empty_storey', 'empty_storey_slab']
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import ifcopenshell
import ifcopenshell.api.aggregate
import ifcopenshell.api.geometry
import ifcopenshell.api.spatial
import ifcopenshell.api.unit
import ifcopenshell.util.unit

from ifc_factory import TestBuilding, _gid, _matrix, write_test_building

SPLIT_LEVEL_M = 1.44


@dataclass
class TraitBuilding:
    """A written trait fixture: the base building and the GlobalIds of what was added, by key."""

    __test__ = False

    path: Path
    base: TestBuilding
    windows: list[str] = field(default_factory=list)
    extra: dict[str, str] = field(default_factory=dict)


def _body(f: ifcopenshell.file) -> Any:
    return next(c for c in f.by_type("IfcGeometricRepresentationSubContext") if c.ContextIdentifier == "Body")


def _rooted(f: ifcopenshell.file, ifc_class: str, name: str, key: str, **attributes: Any) -> Any:
    """A rooted entity with a derived GlobalId (and the file's owner history: IFC2X3 needs one)."""
    owners = f.by_type("IfcOwnerHistory")
    entity = f.create_entity(ifc_class, GlobalId=_gid(key), Name=name, **attributes)
    if owners:
        entity.OwnerHistory = owners[0]
    return entity


def _contain(f: ifcopenshell.file, product: Any, storey: Any, key: str) -> None:
    _rooted(f, "IfcRelContainedInSpatialStructure", "", f"contain-{key}", RelatedElements=[product],
            RelatingStructure=storey).Name = None


def _box(f: ifcopenshell.file, product: Any, x: float, y: float, z: float, dx: float, dy: float,
         dz: float) -> None:
    """Place ``product`` at (x, y, z) m and give it a dx x dy x dz m box body: ``ifcopenshell.api`` takes
    metres and writes the file's length unit (dividing by the unit here too made the millimetre
    fixture's windows 1000 times too large and kilometres away)."""
    ifcopenshell.api.geometry.edit_object_placement(f, product=product, matrix=_matrix(x, y, z))
    rep = ifcopenshell.api.geometry.add_slab_representation(
        f, context=_body(f), depth=dz, polyline=[(0.0, 0.0), (dx, 0.0), (dx, dy), (0.0, dy)])
    ifcopenshell.api.geometry.assign_representation(f, product=product, representation=rep)


def _storey(f: ifcopenshell.file, index: int) -> Any:
    return f.by_guid(_gid(f"storey-{index}"))


def _unname_sets(f: ifcopenshell.file, keep: tuple[str, ...]) -> int:
    """Remove the Name of the property and quantity sets not named in ``keep`` (as ArchiCAD's IFC2X3 does)."""
    n = 0
    for definition in (*f.by_type("IfcPropertySet"), *f.by_type("IfcElementQuantity")):
        if definition.Name not in keep:
            definition.Name = None
            n += 1
    return n


def _window(f: ifcopenshell.file, key: str, storey: Any, x: float, scale: float) -> Any:
    window = _rooted(f, "IfcWindow", f"Window {key}", f"window-{key}")
    _contain(f, window, storey, f"window-{key}")
    _box(f, window, x, 0.1, 0.9, 1.2, 0.1, 1.2)
    window.OverallWidth, window.OverallHeight = 1.2 / scale, 1.2 / scale
    return window


def _unnamed_weight(f: ifcopenshell.file, product: Any, kg: float) -> None:
    quantity = f.create_entity("IfcQuantityWeight", Name="NetWeight", WeightValue=kg)
    qto = _rooted(f, "IfcElementQuantity", "", f"qto-unnamed-{product.GlobalId}", Quantities=[quantity])
    qto.Name = None
    _rooted(f, "IfcRelDefinesByProperties", "", f"rel-unnamed-{product.GlobalId}", RelatedObjects=[product],
            RelatingPropertyDefinition=qto).Name = None


def write_unnamed_sets(path: Path, schema: Literal["IFC2X3", "IFC4"] = "IFC2X3") -> TraitBuilding:
    """The test building with two windows; unnamed property/quantity sets (all but Pset_WallCommon).

    Doors, windows and walls get an unnamed quantity set with a NetWeight (35, 20, 400 kg), so
    walls carry a named and an unnamed set, doors and windows unnamed ones only.
    """
    base = write_test_building(path, schema=schema, unit_mm=True)
    f = ifcopenshell.open(str(path))
    out = TraitBuilding(path, base)
    for k, x in ((0, 6.0), (1, 7.5)):
        out.windows.append(_window(f, f"w{k}", _storey(f, k), x, 0.001).GlobalId)
    for gid in base.doors:
        _unnamed_weight(f, f.by_guid(gid), 35.0)
    for gid in out.windows:
        _unnamed_weight(f, f.by_guid(gid), 20.0)
    for gid in base.walls:
        _unnamed_weight(f, f.by_guid(gid), 400.0)
    out.extra["unnamed_sets"] = str(_unname_sets(f, keep=("Pset_WallCommon",)))
    f.write(str(path))
    return out


def write_mass_unit(path: Path, unit: Literal["gram", "pound"], slab_weight: float) -> TraitBuilding:
    """The test building whose MASSUNIT is the gram or the pound and whose slabs weigh ``slab_weight``."""
    base = write_test_building(path, schema="IFC4", slab_net_weight_kg=slab_weight)
    f = ifcopenshell.open(str(path))
    if unit == "gram":
        mass = ifcopenshell.api.unit.add_si_unit(f, unit_type="MASSUNIT")
    else:
        mass = ifcopenshell.api.unit.add_conversion_based_unit(f, name="pound")
    assignment = f.by_type("IfcUnitAssignment")[0]
    assignment.Units = [*assignment.Units, mass]
    f.write(str(path))
    return TraitBuilding(path, base)


def write_length_unit(path: Path, unit: Literal["MILLIMETER", "INCH", "FOOT"]) -> TraitBuilding:
    """The test building converted to another length unit by ifcopenshell (every length rewritten)."""
    base = write_test_building(path, schema="IFC4")
    f = ifcopenshell.util.unit.convert_file_length_units(ifcopenshell.open(str(path)), unit)
    f.write(str(path))
    return TraitBuilding(path, base)


def write_traits(path: Path) -> TraitBuilding:
    """One IFC4 building (metres) with every geometric trait (keys of ``extra``).

    - ``split_slab``: a slab over x 5.1-9.7, y 0.3-3.0 of Level 1 whose top is at +1.44 m;
    - ``stair``: an IfcStair of two IfcStairFlight boxes in bay 1 of Level 1 (x 1-2, y 3.5-5.5);
    - ``door_no_host``: a door contained in Level 1 that fills no opening;
    - ``empty_storey``: "Level 3" at +6 m with one slab and no spaces (``empty_storey_slab``);
    - ``overlapping_wall``: a wall on Level 2 whose body is two overlapping extrusions, one with a
      self-intersecting (bow-tie) profile;
    - ``no_geometry_wall`` and ``no_geometry_proxy``: a wall and a proxy without any representation.
    """
    base = write_test_building(path, schema="IFC4")
    f = ifcopenshell.open(str(path))
    out = TraitBuilding(path, base)
    level1, level2 = _storey(f, 0), _storey(f, 1)

    slab = _rooted(f, "IfcSlab", "Split-level floor", "split-slab", PredefinedType="FLOOR")
    _contain(f, slab, level1, "split-slab")
    _box(f, slab, 5.1, 0.3, SPLIT_LEVEL_M - 0.2, 4.6, 2.7, 0.2)
    out.extra["split_slab"] = slab.GlobalId

    stair = _rooted(f, "IfcStair", "Stair", "stair")
    _contain(f, stair, level1, "stair")
    ifcopenshell.api.geometry.edit_object_placement(f, product=stair, matrix=_matrix(1.0, 3.5, 0.0))
    flights = []
    for n in range(2):
        flight = _rooted(f, "IfcStairFlight", f"Flight {n + 1}", f"flight-{n}")
        _box(f, flight, 1.0, 3.5 + n * 1.0, 0.0, 1.0, 1.0, 0.6 * (n + 1))
        flights.append(flight)
    ifcopenshell.api.aggregate.assign_object(f, products=flights, relating_object=stair)
    out.extra["stair"] = stair.GlobalId

    door = _rooted(f, "IfcDoor", "Door without host", "door-no-host")
    _contain(f, door, level1, "door-no-host")
    _box(f, door, 3.0, 5.6, 0.0, 0.9, 0.05, 2.1)
    out.extra["door_no_host"] = door.GlobalId

    building = f.by_guid(_gid("building"))
    empty = _rooted(f, "IfcBuildingStorey", "Level 3", "storey-empty", Elevation=6.0)
    ifcopenshell.api.aggregate.assign_object(f, products=[empty], relating_object=building)
    ifcopenshell.api.geometry.edit_object_placement(f, product=empty, matrix=_matrix(0.0, 0.0, 6.0))
    roof_slab = _rooted(f, "IfcSlab", "Level 3 floor", "storey-empty-slab", PredefinedType="FLOOR")
    _contain(f, roof_slab, empty, "storey-empty-slab")
    _box(f, roof_slab, 0.0, 0.0, 5.8, 10.0, 6.0, 0.2)
    out.extra["empty_storey"] = empty.GlobalId
    out.extra["empty_storey_slab"] = roof_slab.GlobalId

    wall = _rooted(f, "IfcWall", "Overlapping wall", "overlapping-wall")
    _contain(f, wall, level2, "overlapping-wall")
    ifcopenshell.api.geometry.edit_object_placement(f, product=wall, matrix=_matrix(2.0, 2.0, 3.0))
    body = _body(f)
    box = ifcopenshell.api.geometry.add_slab_representation(
        f, context=body, depth=2.5, polyline=[(0.0, 0.0), (2.0, 0.0), (2.0, 0.2), (0.0, 0.2)])
    bowtie = f.create_entity("IfcArbitraryClosedProfileDef", ProfileType="AREA", OuterCurve=f.create_entity(
        "IfcPolyline", Points=[f.create_entity("IfcCartesianPoint", Coordinates=c)
                               for c in ((1.0, 0.0), (3.0, 0.6), (3.0, 0.0), (1.0, 0.6), (1.0, 0.0))]))
    solid = f.create_entity(
        "IfcExtrudedAreaSolid", SweptArea=bowtie,
        Position=f.create_entity("IfcAxis2Placement3D", Location=f.create_entity(
            "IfcCartesianPoint", Coordinates=(0.0, 0.0, 0.0))),
        ExtrudedDirection=f.create_entity("IfcDirection", DirectionRatios=(0.0, 0.0, 1.0)), Depth=2.5)
    box.Items = [*box.Items, solid]
    ifcopenshell.api.geometry.assign_representation(f, product=wall, representation=box)
    out.extra["overlapping_wall"] = wall.GlobalId

    bare_wall = _rooted(f, "IfcWall", "Wall without geometry", "no-geometry-wall")
    _contain(f, bare_wall, level2, "no-geometry-wall")
    ifcopenshell.api.geometry.edit_object_placement(f, product=bare_wall, matrix=_matrix(1.0, 1.0, 3.0))
    out.extra["no_geometry_wall"] = bare_wall.GlobalId
    proxy = _rooted(f, "IfcBuildingElementProxy", "Proxy without geometry", "no-geometry-proxy")
    _contain(f, proxy, level2, "no-geometry-proxy")
    out.extra["no_geometry_proxy"] = proxy.GlobalId

    f.write(str(path))
    return out
