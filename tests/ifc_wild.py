"""IFC fixtures with the geometry kinds, spatial trees and names of real exports (test helper of the import
and world steps, next to :mod:`ifc_traits`).

Each ``write_*`` function writes the test building of :mod:`ifc_factory` and then changes it with
ifcopenshell the way real authoring tools' exports differ from it, and returns what the file holds.

- :func:`write_geometry_kinds`: a faceted Brep column, furniture whose body is an IfcMappedItem of its
  type's representation map, a wall clipped by a half space (IfcBooleanClippingResult), an
  IfcElementAssembly of two plates, a wall made of two IfcBuildingElementPart (no body of its own), an
  IfcWallStandardCase (IFC4), and names that are empty, missing, non-ASCII or full of quotes;
- :func:`write_without_storeys`: no IfcBuildingStorey (every element contained directly in the
  building) and one element contained nowhere;
- :func:`write_placed`: georeferenced (a site at easting 500 000 m in millimetres, IFC2X3; a building
  placed at easting 512 345.6 m and turned 30 degrees, with an IfcMapConversion and TrueNorth, IFC4)
  and rotated (30 degrees about the site origin) buildings.

Example:
    >>> from pathlib import Path
    >>> import tempfile
    >>> w = write_geometry_kinds(Path(tempfile.mkdtemp()) / "g.ifc")
    >>> sorted(w.extra)[:3]
    ['assembly', 'assembly_part_0', 'assembly_part_1']
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Literal

import ifcopenshell
import ifcopenshell.api.aggregate
import ifcopenshell.api.geometry
import ifcopenshell.api.type

from ifc_factory import _gid, _matrix, write_test_building
from ifc_traits import TraitBuilding, _body, _box, _contain, _rooted, _storey

NON_ASCII_NAME = "Wand Küche Ø 10 – 東京 «A»"
QUOTED_NAME = 'Wall "A";\n\t<tab> \\ end'
CLIP_HEIGHT_M = 2.0


def _point(f: ifcopenshell.file, *c: float) -> Any:
    return f.create_entity("IfcCartesianPoint", Coordinates=tuple(float(v) for v in c))


def _axis(f: ifcopenshell.file, x: float = 0.0, y: float = 0.0, z: float = 0.0) -> Any:
    return f.create_entity("IfcAxis2Placement3D", Location=_point(f, x, y, z))


def _faceted_box(f: ifcopenshell.file, dx: float, dy: float, dz: float, x0: float = 0.0,
                 y0: float = 0.0) -> Any:
    """An IfcFacetedBrep box of dx x dy x dz from (x0, y0, 0) (six quad faces, outward loops)."""
    corners = {(i, j, k): _point(f, x0 + i * dx, y0 + j * dy, k * dz)
               for i in (0, 1) for j in (0, 1) for k in (0, 1)}
    quads = [
        [(0, 0, 0), (0, 1, 0), (1, 1, 0), (1, 0, 0)], [(0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)],
        [(0, 0, 0), (1, 0, 0), (1, 0, 1), (0, 0, 1)], [(0, 1, 0), (0, 1, 1), (1, 1, 1), (1, 1, 0)],
        [(0, 0, 0), (0, 0, 1), (0, 1, 1), (0, 1, 0)], [(1, 0, 0), (1, 1, 0), (1, 1, 1), (1, 0, 1)],
    ]
    faces = [f.create_entity("IfcFace", Bounds=[f.create_entity(
        "IfcFaceOuterBound", Bound=f.create_entity("IfcPolyLoop", Polygon=[corners[c] for c in q]),
        Orientation=True)]) for q in quads]
    return f.create_entity("IfcFacetedBrep", Outer=f.create_entity("IfcClosedShell", CfsFaces=faces))


def _shape(f: ifcopenshell.file, items: list[Any], kind: str) -> Any:
    return f.create_entity("IfcShapeRepresentation", ContextOfItems=_body(f), RepresentationIdentifier="Body",
                           RepresentationType=kind, Items=items)


def _extrusion(f: ifcopenshell.file, dx: float, dy: float, dz: float) -> Any:
    centre = f.create_entity("IfcCartesianPoint", Coordinates=(dx / 2, dy / 2))
    profile = f.create_entity("IfcRectangleProfileDef", ProfileType="AREA", XDim=dx, YDim=dy,
                              Position=f.create_entity("IfcAxis2Placement2D", Location=centre))
    return f.create_entity("IfcExtrudedAreaSolid", SweptArea=profile, Position=_axis(f),
                           ExtrudedDirection=f.create_entity("IfcDirection", DirectionRatios=(0.0, 0.0, 1.0)),
                           Depth=dz)


def _product(f: ifcopenshell.file, ifc_class: str, name: str | None, key: str, storey: Any,
             at: tuple[float, float, float], rep: Any | None) -> Any:
    product = _rooted(f, ifc_class, name or "", key)
    product.Name = name
    if storey is not None:
        _contain(f, product, storey, key)
    ifcopenshell.api.geometry.edit_object_placement(f, product=product, matrix=_matrix(*at))
    if rep is not None:
        ifcopenshell.api.geometry.assign_representation(f, product=product, representation=rep)
    return product


def write_geometry_kinds(path: Path, schema: Literal["IFC2X3", "IFC4", "IFC4X3"] = "IFC4") -> TraitBuilding:
    """The test building (metres) with one element of each geometry kind on Level 1 (keys of ``extra``).

    - ``brep_column``: IfcColumn, faceted Brep 0.4 x 0.4 x 2.5 m at (2, 2);
    - ``mapped_furniture`` (IfcFurniture; IfcFurnishingElement in IFC2X3): an IfcMappedItem of a 1.0 x
      0.5 x 0.75 m box, at (3, 4) and yawed 90 degrees by its mapping target;
    - ``clipped_wall``: 3 m high IfcWall along x from (6, 2), 2 m x 0.1 m, clipped at
      ``CLIP_HEIGHT_M`` by a half space;
    - ``assembly`` (IfcElementAssembly, no body) of two 1 x 0.1 x 1.5 m IfcPlate ``assembly_part_<n>``
      at (6, 4) and (7, 4);
    - ``wall_with_parts``: IfcWall without a body, aggregating two IfcBuildingElementPart
      ``wall_part_<n>`` (0.05 m leaves of a 1.5 m wall along y at x = 8.5, from y = 1);
    - ``standard_case``: an IfcWallStandardCase (IFC2X3/IFC4 only) along y at x = 1.0 from y = 4, 1.5 m;
    - ``round_column``: IfcColumn, a circle profile (r 0.2 m) extruded 2.5 m at (3.5, 1);
    - ``railing``: IfcRailing, an IfcSweptDiskSolid tube (r 0.03 m) from (6.5, 5, 1) to (8.5, 5, 1);
    - ``tessellated`` (IFC4 and later): a proxy whose body is an IfcTriangulatedFaceSet, a 0.5 x 0.5 x
      1 m box at (1.5, 1);
    - names: the brep column is named ``NON_ASCII_NAME``, the clipped wall ``QUOTED_NAME``, the
      assembly has no Name ($) and the wall with parts an empty one; Level 2 is renamed "".
    """
    base = write_test_building(path, schema=schema)
    f = ifcopenshell.open(str(path))
    out = TraitBuilding(path, base)
    level1 = _storey(f, 0)

    column = _product(f, "IfcColumn", NON_ASCII_NAME, "brep-column", level1, (2.0, 2.0, 0.0),
                      _shape(f, [_faceted_box(f, 0.4, 0.4, 2.5)], "Brep"))
    out.extra["brep_column"] = column.GlobalId

    furniture_class = "IfcFurnishingElement" if schema == "IFC2X3" else "IfcFurniture"
    furniture_type = _rooted(f, "IfcFurnitureType", "Desk type", "desk-type")
    if schema != "IFC2X3":
        furniture_type.PredefinedType = "DESK"
    else:
        furniture_type.AssemblyPlace = "FACTORY"
    source = _shape(f, [_extrusion(f, 1.0, 0.5, 0.75)], "SweptSolid")
    rep_map = f.create_entity("IfcRepresentationMap", MappingOrigin=_axis(f), MappedRepresentation=source)
    furniture_type.RepresentationMaps = [rep_map]
    target = f.create_entity("IfcCartesianTransformationOperator3D", LocalOrigin=_point(f, 0.0, 0.0, 0.0),
                             Axis1=f.create_entity("IfcDirection", DirectionRatios=(0.0, 1.0, 0.0)),
                             Axis2=f.create_entity("IfcDirection", DirectionRatios=(-1.0, 0.0, 0.0)))
    mapped = f.create_entity("IfcMappedItem", MappingSource=rep_map, MappingTarget=target)
    furniture = _product(f, furniture_class, "Desk", "mapped-furniture", level1, (3.0, 4.0, 0.0),
                         _shape(f, [mapped], "MappedRepresentation"))
    _rooted(f, "IfcRelDefinesByType", "", "desk-type-rel", RelatedObjects=[furniture],
            RelatingType=furniture_type).Name = None
    out.extra["mapped_furniture"] = furniture.GlobalId

    plane = f.create_entity("IfcPlane", Position=_axis(f, 0.0, 0.0, CLIP_HEIGHT_M))
    half = f.create_entity("IfcHalfSpaceSolid", BaseSurface=plane, AgreementFlag=False)
    clipped = f.create_entity("IfcBooleanClippingResult", Operator="DIFFERENCE",
                              FirstOperand=_extrusion(f, 2.0, 0.1, 3.0), SecondOperand=half)
    wall = _product(f, "IfcWall", QUOTED_NAME, "clipped-wall", level1, (6.0, 2.0, 0.0),
                    _shape(f, [clipped], "Clipping"))
    out.extra["clipped_wall"] = wall.GlobalId

    assembly = _product(f, "IfcElementAssembly", None, "assembly", level1, (6.0, 4.0, 0.0), None)
    plates = []
    for n in range(2):
        plate = _rooted(f, "IfcPlate", f"Assembly plate {n + 1}", f"assembly-part-{n}")
        _box(f, plate, 6.0 + n, 4.0, 0.0, 1.0, 0.1, 1.5)
        plates.append(plate)
        out.extra[f"assembly_part_{n}"] = plate.GlobalId
    ifcopenshell.api.aggregate.assign_object(f, products=plates, relating_object=assembly)
    out.extra["assembly"] = assembly.GlobalId

    parted = _product(f, "IfcWall", "", "wall-with-parts", level1, (8.5, 1.0, 0.0), None)
    parts = []
    for n in range(2):
        part = _rooted(f, "IfcBuildingElementPart", f"Leaf {n + 1}", f"wall-part-{n}")
        _box(f, part, 8.45 + 0.05 * n, 1.0, 0.0, 0.05, 1.5, 2.5)
        parts.append(part)
        out.extra[f"wall_part_{n}"] = part.GlobalId
    ifcopenshell.api.aggregate.assign_object(f, products=parts, relating_object=parted)
    out.extra["wall_with_parts"] = parted.GlobalId

    if schema != "IFC4X3":
        standard = _product(f, "IfcWallStandardCase", "Standard case wall", "standard-case", level1,
                            (1.0, 4.0, 0.0), None)
        _box(f, standard, 1.0, 4.0, 0.0, 0.1, 1.5, 3.0)
        out.extra["standard_case"] = standard.GlobalId

    circle = f.create_entity("IfcCircleProfileDef", ProfileType="AREA", Radius=0.2, Position=f.create_entity(
        "IfcAxis2Placement2D", Location=f.create_entity("IfcCartesianPoint", Coordinates=(0.0, 0.0))))
    rod = f.create_entity("IfcExtrudedAreaSolid", SweptArea=circle, Position=_axis(f), Depth=2.5,
                          ExtrudedDirection=f.create_entity("IfcDirection", DirectionRatios=(0.0, 0.0, 1.0)))
    round_column = _product(f, "IfcColumn", "Round column", "round-column", level1, (3.5, 1.0, 0.0),
                            _shape(f, [rod], "SweptSolid"))
    out.extra["round_column"] = round_column.GlobalId

    path_curve = f.create_entity("IfcPolyline", Points=[_point(f, 0.0, 0.0, 0.0), _point(f, 2.0, 0.0, 0.0)])
    tube = f.create_entity("IfcSweptDiskSolid", Directrix=path_curve, Radius=0.03)
    railing = _product(f, "IfcRailing", "Handrail", "railing", level1, (6.5, 5.0, 1.0),
                       _shape(f, [tube], "AdvancedSweptSolid"))
    out.extra["railing"] = railing.GlobalId

    if schema != "IFC2X3":  # tessellation is IFC4 and later
        corners = [(x, y, z) for z in (0.0, 1.0) for y in (0.0, 0.5) for x in (0.0, 0.5)]
        triangles = [(1, 3, 2), (2, 3, 4), (5, 6, 8), (5, 8, 7), (1, 2, 6), (1, 6, 5), (3, 7, 8), (3, 8, 4),
                     (1, 5, 7), (1, 7, 3), (2, 4, 8), (2, 8, 6)]
        faces = f.create_entity("IfcTriangulatedFaceSet", Closed=True, CoordIndex=triangles,
                                Coordinates=f.create_entity("IfcCartesianPointList3D", CoordList=corners))
        tessellated = _product(f, "IfcBuildingElementProxy", "Tessellated box", "tessellated", level1,
                               (1.5, 1.0, 0.0), _shape(f, [faces], "Tessellation"))
        out.extra["tessellated"] = tessellated.GlobalId

    _storey(f, 1).Name = ""
    f.write(str(path))
    return out


def write_without_storeys(path: Path, schema: Literal["IFC2X3", "IFC4"] = "IFC4") -> TraitBuilding:
    """A one-storey test building whose storey is removed: walls, doors, the slab and the spaces hang
    directly off the IfcBuilding; plus ``uncontained`` (an IfcColumn 0.3 x 0.3 x 2.5 m at (2, 2) in no
    spatial structure at all)."""
    base = write_test_building(path, schema=schema, storeys=1)
    f = ifcopenshell.open(str(path))
    out = TraitBuilding(path, base)
    storey = _storey(f, 0)
    building = f.by_guid(_gid("building"))
    for rel in list(storey.ContainsElements or ()):
        rel.RelatingStructure = building
    for rel in list(storey.IsDecomposedBy or ()):
        rel.RelatingObject = building
    for rel in list(storey.Decomposes or ()):
        others = [o for o in rel.RelatedObjects if o != storey]
        if others:
            rel.RelatedObjects = others
        else:
            f.remove(rel)
    placement = storey.ObjectPlacement
    storey.ObjectPlacement = None
    f.remove(storey)
    del placement  # still the placement the storey's elements are placed relative to
    column = _rooted(f, "IfcColumn", "Uncontained column", "uncontained")
    _box(f, column, 2.0, 2.0, 0.0, 0.3, 0.3, 2.5)
    out.extra["uncontained"] = column.GlobalId
    f.write(str(path))
    return out



EASTING_M, NORTHING_M = 512_345.6, 5_403_210.9
ROTATION_DEG = 30.0


Placed = Literal["site-far", "georeferenced", "rotated", "storeys-far"]


def write_placed(path: Path, kind: Placed) -> TraitBuilding:
    """The test building, placed the way georeferenced or rotated exports place it.

    - ``site-far``: IFC2X3 in millimetres whose IfcSite (and everything in it) is placed at easting
      500 000 m, northing 5 400 000 m, 400 m up;
    - ``georeferenced``: IFC4 whose IfcSite is at the origin and whose IfcBuilding is placed at
      (``EASTING_M``, ``NORTHING_M``) and turned ``ROTATION_DEG`` about z, with an IfcMapConversion
      (EPSG:25832, 500 000 / 5 400 000) and a TrueNorth of ``ROTATION_DEG``;
    - ``rotated``: IFC4, the building turned ``ROTATION_DEG`` about the site's origin;
    - ``storeys-far``: IFC4, site and building at the origin, the storeys (and all in them) placed at
      (``EASTING_M``, ``NORTHING_M``): the import's frame moves to the walls' median position.

    In the building's own frame each is the plain test building (``write_test_building``).
    """
    turn = math.radians(ROTATION_DEG)
    if kind == "site-far":
        base = write_test_building(path, schema="IFC2X3", unit_mm=True,
                                   site_origin=(500_000.0, 5_400_000.0, 400.0))
        return TraitBuilding(path, base)
    if kind == "rotated":
        return TraitBuilding(path, write_test_building(path, schema="IFC4",
                                                       building_placement=(0.0, 0.0, 0.0, turn)))
    if kind == "storeys-far":
        base = write_test_building(path, schema="IFC4", building_placement=(EASTING_M, NORTHING_M, 0.0, 0.0))
        f = ifcopenshell.open(str(path))
        building = f.by_type("IfcBuilding")[0]  # back to the origin; what it holds keeps its place
        ifcopenshell.api.geometry.edit_object_placement(f, product=building, should_transform_children=False)
        f.write(str(path))
        return TraitBuilding(path, base)
    base = write_test_building(path, schema="IFC4", building_placement=(EASTING_M, NORTHING_M, 0.0, turn))
    f = ifcopenshell.open(str(path))
    context = next(c for c in f.by_type("IfcGeometricRepresentationContext")
                   if not c.is_a("IfcGeometricRepresentationSubContext"))
    context.TrueNorth = f.create_entity("IfcDirection", DirectionRatios=(-math.sin(turn), math.cos(turn)))
    crs = f.create_entity("IfcProjectedCRS", Name="EPSG:25832", Description="ETRS89 / UTM zone 32N")
    f.create_entity("IfcMapConversion", SourceCRS=context, TargetCRS=crs, Eastings=500_000.0,
                    Northings=5_400_000.0, OrthogonalHeight=0.0, XAxisAbscissa=1.0, XAxisOrdinate=0.0,
                    Scale=1.0)
    f.write(str(path))
    return TraitBuilding(path, base)


def write_far_geometry(path: Path) -> TraitBuilding:
    """The test building (IFC4) plus ``far_column``: an IfcColumn placed at the origin whose faceted
    Brep's own coordinates are at (``EASTING_M``, ``NORTHING_M``) (survey coordinates in the shape)."""
    base = write_test_building(path, schema="IFC4")
    f = ifcopenshell.open(str(path))
    out = TraitBuilding(path, base)
    column = _product(f, "IfcColumn", "Far column", "far-column", _storey(f, 0), (0.0, 0.0, 0.0),
                      _shape(f, [_faceted_box(f, 0.4, 0.4, 2.5, EASTING_M, NORTHING_M)], "Brep"))
    out.extra["far_column"] = column.GlobalId
    f.write(str(path))
    return out


def write_storey_heights(path: Path, kind: Literal["absolute-elevation", "storeys-at-zero"]
                         ) -> TraitBuilding:
    """The test building whose storeys' Elevation attribute and placement disagree.

    - ``absolute-elevation``: the ``site-far`` building (IFC2X3, millimetres, site 400 m up) whose
      storeys' Elevation is written above sea level (400 m, 403 m) while their placements are
      relative (0 m, 3 m above the building);
    - ``storeys-at-zero``: IFC4, every storey placed at height 0 (what it holds keeps its place),
      the Elevation attribute right (0 m, 3 m).
    """
    if kind == "absolute-elevation":
        out = write_placed(path, "site-far")
        f = ifcopenshell.open(str(path))
        for storey in f.by_type("IfcBuildingStorey"):
            storey.Elevation = storey.Elevation + 400_000.0
    else:
        out = TraitBuilding(path, write_test_building(path, schema="IFC4"))
        f = ifcopenshell.open(str(path))
        for storey in f.by_type("IfcBuildingStorey"):
            ifcopenshell.api.geometry.edit_object_placement(f, product=storey,
                                                            should_transform_children=False)
    f.write(str(path))
    return out
