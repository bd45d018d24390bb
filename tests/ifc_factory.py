"""Small IFC test buildings written with ``ifcopenshell.api`` (test helper for the import step and others).

``write_test_building(path, schema=..., unit_mm=...)`` writes a rectangular building of ``storeys``
storeys and ``bays`` rooms per storey: four exterior walls and ``bays - 1`` interior partitions per
storey, a floor slab per storey, one space per bay, a door in every partition (and a front door in the
south wall of the ground floor), optional furniture inside the spaces. It returns a
:class:`TestBuilding` that says, in metres, what the file holds, so tests can compare the import with
it. GlobalIds are derived from element names, so the same arguments give the same GlobalIds.

Layout (site frame, metres): the building spans x in [0, 5 * bays], y in [0, 6] (plus ``site_origin``);
exterior walls are 0.3 m thick inside that rectangle, partitions 0.1 m thick centred on x = 5 * i;
storey k (0-based) is at elevation ``k * storey_height_m``.

Example:
    >>> from pathlib import Path
    >>> import tempfile
    >>> b = write_test_building(Path(tempfile.mkdtemp()) / "t.ifc", schema="IFC4", unit_mm=True)
    >>> len(b.storeys), len(b.walls), len(b.doors)
    (2, 10, 3)
"""

from __future__ import annotations

import math
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import ifcopenshell
import ifcopenshell.api.aggregate
import ifcopenshell.api.context
import ifcopenshell.api.feature
import ifcopenshell.api.geometry
import ifcopenshell.api.material
import ifcopenshell.api.owner
import ifcopenshell.api.project
import ifcopenshell.api.pset
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.api.type
import ifcopenshell.api.unit
import ifcopenshell.guid
import numpy as np

Schema = Literal["IFC2X3", "IFC4", "IFC4X3"]
_GUID_NS = uuid.UUID("6f1c1d52-5a43-4b8e-9d0a-2f3a4b5c6d7e")

BAY_M = 5.0
DEPTH_M = 6.0
EXT_THICK_M = 0.3
INT_THICK_M = 0.1


@dataclass(frozen=True)
class WallInfo:
    name: str
    storey: str  # GlobalId of the storey
    is_external: bool
    ifc_class: str


@dataclass(frozen=True)
class DoorInfo:
    name: str
    storey: str
    width_m: float
    height_m: float
    host_wall: str  # GlobalId
    opening: str  # GlobalId


@dataclass(frozen=True)
class TestBuilding:
    """What a written test building holds (metres); keys are GlobalIds."""

    __test__ = False  # not a pytest test class

    path: Path
    schema: str
    metres_per_unit: float
    site: str
    building: str
    storeys: dict[str, tuple[str, float]]  # GlobalId -> (name, elevation in metres)
    walls: dict[str, WallInfo]
    doors: dict[str, DoorInfo]
    slabs: dict[str, str]  # GlobalId -> storey GlobalId
    spaces: dict[str, str]  # GlobalId -> storey GlobalId
    furniture: dict[str, str] = field(default_factory=dict)  # GlobalId -> space GlobalId
    broken: str | None = None  # GlobalId of the element whose geometry cannot be built


def _gid(key: str) -> str:
    return str(ifcopenshell.guid.compress(uuid.uuid5(_GUID_NS, key).hex))


def _matrix(x: float, y: float, z: float, yaw: float = 0.0) -> np.ndarray:
    m = np.eye(4)
    c, s = math.cos(yaw), math.sin(yaw)
    m[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    m[:3, 3] = [x, y, z]
    return m


class _Writer:
    def __init__(self, schema: Schema, unit_mm: bool) -> None:
        self.f = ifcopenshell.api.project.create_file(version=schema)
        self.schema = schema
        self.scale = 0.001 if unit_mm else 1.0
        self.frame = np.eye(4)  # building frame -> IFC world frame (metres)
        if schema == "IFC2X3":  # IFC2X3 requires an owner history on every rooted entity
            person = ifcopenshell.api.owner.add_person(self.f, identification="kbp", family_name="Test",
                                                       given_name="Factory")
            org = ifcopenshell.api.owner.add_organisation(self.f, identification="KBP", name="kbplanner")
            ifcopenshell.api.owner.add_person_and_organisation(self.f, person=person, organisation=org)
            ifcopenshell.api.owner.add_application(self.f, application_developer=org,
                                                   application_full_name="kbplanner test factory",
                                                   application_identifier="kbplanner")
        self.project = self.create("IfcProject", "Test project", "project")
        if unit_mm:
            ifcopenshell.api.unit.assign_unit(self.f)  # no arguments: millimetres
        else:
            ifcopenshell.api.unit.assign_unit(
                self.f,
                length={"is_metric": True, "raw": "METERS"},
                area={"is_metric": True, "raw": "METERS"},
                volume={"is_metric": True, "raw": "METERS"},
            )
        model = ifcopenshell.api.context.add_context(self.f, context_type="Model")
        self.body = ifcopenshell.api.context.add_context(
            self.f, context_type="Model", context_identifier="Body", target_view="MODEL_VIEW",
            parent=model,
        )

    def create(self, ifc_class: str, name: str, key: str, predefined_type: str | None = None) -> Any:
        entity = ifcopenshell.api.root.create_entity(
            self.f, ifc_class=ifc_class, name=name, predefined_type=predefined_type
        )
        entity.GlobalId = _gid(key)
        return entity

    def place(self, product: Any, matrix: np.ndarray, *, absolute: bool = False) -> None:
        """Place ``product`` at ``matrix`` (metres) in the building frame, or in the IFC world frame."""
        world = matrix if absolute else self.frame @ matrix
        ifcopenshell.api.geometry.edit_object_placement(self.f, product=product, matrix=world)

    def units(self, metres: float) -> float:
        return metres / self.scale


def write_test_building(
    path: Path,
    *,
    schema: Schema = "IFC4",
    unit_mm: bool = False,
    storeys: int = 2,
    bays: int = 2,
    storey_height_m: float = 3.0,
    wall_psets: bool = True,
    wall_names: Literal["descriptive", "plain"] = "descriptive",
    space_boundaries: bool = False,
    door_width_m: float = 0.9,
    front_door_width_m: float = 1.0,
    door_height_m: float = 2.1,
    door_size_attributes: bool = True,
    furniture_per_space: int = 0,
    slab_net_weight_kg: float | None = None,
    broken_element: bool = False,
    site_origin: tuple[float, float, float] = (0.0, 0.0, 0.0),
    building_placement: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0),
) -> TestBuilding:
    """Write a small building as an IFC file and return what it holds (see module docstring).

    ``wall_psets`` writes ``Pset_WallCommon.IsExternal`` on every wall; ``wall_names`` "descriptive"
    names walls "Exterior wall ..." / "Interior partition ...", "plain" names them "Wall n";
    ``space_boundaries`` adds an IfcRelSpaceBoundary (INTERNAL/EXTERNAL) for every wall-space pair;
    ``door_size_attributes`` False leaves the doors' OverallWidth/OverallHeight unset;
    ``broken_element`` adds an IfcBuildingElementProxy whose body is an extrusion of depth zero;
    ``building_placement`` (x, y, z in metres, yaw in radians) places the building, and everything in
    it, at that pose relative to the site (georeferenced or rotated buildings); the layout above is
    then in the building's frame.
    """
    w = _Writer(schema, unit_mm)
    f = w.f
    ox, oy, oz = site_origin
    site = w.create("IfcSite", "Test site", "site")
    w.place(site, _matrix(ox, oy, oz))
    w.frame = _matrix(*building_placement)
    building = w.create("IfcBuilding", "Test building", "building")
    ifcopenshell.api.aggregate.assign_object(f, products=[site], relating_object=w.project)
    ifcopenshell.api.aggregate.assign_object(f, products=[building], relating_object=site)
    w.place(building, _matrix(ox, oy, oz))

    length = BAY_M * bays
    wall_class = "IfcWallStandardCase" if schema == "IFC2X3" else "IfcWall"
    furniture_class = "IfcFurnishingElement" if schema == "IFC2X3" else "IfcFurniture"

    type_name = "Exterior - Brick on Block" if wall_names == "descriptive" else "Wall type A"
    ext_type = _layered_wall_type(w, type_name, [("Masonry - Brick", 0.1),
                                                                  ("Masonry - Concrete Block", 0.2)])
    wood = ifcopenshell.api.material.add_material(f, name="Wood - Stud")
    concrete = ifcopenshell.api.material.add_material(f, name="Concrete - Cast In Situ")
    timber = ifcopenshell.api.material.add_material(f, name="Wood - Timber")

    storey_info: dict[str, tuple[str, float]] = {}
    walls: dict[str, WallInfo] = {}
    doors: dict[str, DoorInfo] = {}
    slabs: dict[str, str] = {}
    spaces: dict[str, str] = {}
    furniture: dict[str, str] = {}
    boundaries: list[tuple[Any, Any, bool]] = []
    wall_counter = 0

    for k in range(storeys):
        elev = k * storey_height_m
        name = f"Level {k + 1}"
        storey = w.create("IfcBuildingStorey", name, f"storey-{k}")
        storey.Elevation = w.units(elev)
        ifcopenshell.api.aggregate.assign_object(f, products=[storey], relating_object=building)
        w.place(storey, _matrix(ox, oy, oz + elev))
        storey_info[storey.GlobalId] = (name, elev)

        def wall(
            key: str, external: bool, x: float, y: float, yaw: float, wall_length: float,
            k: int = k, storey: Any = storey, elev: float = elev,
        ) -> Any:
            nonlocal wall_counter
            wall_counter += 1
            if wall_names == "descriptive":
                label = (f"Exterior wall L{k + 1} {key}" if external
                         else f"Interior partition L{k + 1} {key}")
            else:
                label = f"Wall {wall_counter}"
            element = w.create(wall_class, label, f"wall-{k}-{key}")
            ifcopenshell.api.spatial.assign_container(f, products=[element], relating_structure=storey)
            w.place(element, _matrix(ox + x, oy + y, oz + elev, yaw))
            thickness = EXT_THICK_M if external else INT_THICK_M
            rep = ifcopenshell.api.geometry.add_wall_representation(
                f, context=w.body, length=wall_length, height=storey_height_m, thickness=thickness,
                offset=0.0 if external else -thickness / 2,
            )
            ifcopenshell.api.geometry.assign_representation(f, product=element, representation=rep)
            if external:
                ifcopenshell.api.type.assign_type(f, related_objects=[element], relating_type=ext_type)
                ifcopenshell.api.material.assign_material(
                    f, products=[element], type="IfcMaterialLayerSetUsage"
                )
            else:
                ifcopenshell.api.material.assign_material(f, products=[element], material=wood)
            if wall_psets:
                pset = ifcopenshell.api.pset.add_pset(f, product=element, name="Pset_WallCommon")
                ifcopenshell.api.pset.edit_pset(f, pset=pset, properties={"IsExternal": external})
            walls[element.GlobalId] = WallInfo(label, storey.GlobalId, external, wall_class)
            return element

        south = wall("south", True, 0.0, 0.0, 0.0, length)
        wall("east", True, length, 0.0, math.pi / 2, DEPTH_M)
        north = wall("north", True, length, DEPTH_M, math.pi, length)
        west = wall("west", True, 0.0, DEPTH_M, -math.pi / 2, DEPTH_M)
        partitions = [
            wall(f"p{i}", False, BAY_M * i, EXT_THICK_M, math.pi / 2, DEPTH_M - 2 * EXT_THICK_M)
            for i in range(1, bays)
        ]

        # Doors: the partition door opens 1.0 m from the partition's start; the front door is
        # centred in the first bay of the ground-floor south wall.
        door_specs: list[tuple[str, Any, float, float, float]] = [
            (f"p{i}", p, 1.0, door_width_m, INT_THICK_M) for i, p in enumerate(partitions, start=1)
        ]
        if k == 0:
            door_specs.append(("front", south, BAY_M / 2 - front_door_width_m / 2,
                               front_door_width_m, EXT_THICK_M))
        for key, host, along, width, thick in door_specs:
            doors.update(_door(w, storey, k, elev, key, host, along, width, door_height_m, thick,
                               door_size_attributes, wall_is_external=host is south))

        slab = w.create("IfcSlab", f"Floor L{k + 1}", f"slab-{k}", predefined_type="FLOOR")
        ifcopenshell.api.spatial.assign_container(f, products=[slab], relating_structure=storey)
        w.place(slab, _matrix(ox, oy, oz + elev - 0.2))
        rep = ifcopenshell.api.geometry.add_slab_representation(
            f, context=w.body, depth=0.2, polyline=[(0.0, 0.0), (length, 0.0), (length, DEPTH_M),
                                                    (0.0, DEPTH_M)],
        )
        ifcopenshell.api.geometry.assign_representation(f, product=slab, representation=rep)
        ifcopenshell.api.material.assign_material(f, products=[slab], material=concrete)
        if slab_net_weight_kg is not None:
            _weight_qto(w, slab, "Qto_SlabBaseQuantities", slab_net_weight_kg)
        slabs[slab.GlobalId] = storey.GlobalId

        for b in range(bays):
            x0 = BAY_M * b + (EXT_THICK_M if b == 0 else INT_THICK_M / 2)
            x1 = BAY_M * (b + 1) - (EXT_THICK_M if b == bays - 1 else INT_THICK_M / 2)
            y0, y1 = EXT_THICK_M, DEPTH_M - EXT_THICK_M
            space = w.create("IfcSpace", f"{k + 1}{b + 1:02d}", f"space-{k}-{b}")
            space.LongName = f"Room {k + 1}.{b + 1}"
            ifcopenshell.api.aggregate.assign_object(f, products=[space], relating_object=storey)
            w.place(space, _matrix(ox, oy, oz + elev))
            rep = ifcopenshell.api.geometry.add_slab_representation(
                f, context=w.body, depth=storey_height_m,
                polyline=[(x0, y0), (x1, y0), (x1, y1), (x0, y1)],
            )
            ifcopenshell.api.geometry.assign_representation(f, product=space, representation=rep)
            spaces[space.GlobalId] = storey.GlobalId
            for n in range(furniture_per_space):
                item = w.create(furniture_class, f"Table {k + 1}.{b + 1}.{n + 1}", f"furn-{k}-{b}-{n}")
                ifcopenshell.api.spatial.assign_container(f, products=[item], relating_structure=space)
                fx = x0 + 0.5 + (n % 3) * 1.2
                fy = y0 + 0.5 + (n // 3) * 1.0
                w.place(item, _matrix(ox + fx, oy + fy, oz + elev))
                rep = ifcopenshell.api.geometry.add_slab_representation(
                    f, context=w.body, depth=0.75, polyline=[(0.0, 0.0), (0.8, 0.0), (0.8, 0.6),
                                                             (0.0, 0.6)],
                )
                ifcopenshell.api.geometry.assign_representation(f, product=item, representation=rep)
                ifcopenshell.api.material.assign_material(f, products=[item], material=timber)
                furniture[item.GlobalId] = space.GlobalId
            if space_boundaries:
                sides = [(south, True), (north, True)]
                if b == 0:
                    sides.append((west, True))
                if b == bays - 1:
                    sides.append((f.by_guid(_gid(f"wall-{k}-east")), True))
                if b > 0:
                    sides.append((partitions[b - 1], False))
                if b < bays - 1:
                    sides.append((partitions[b], False))
                boundaries.extend((space, el, ext) for el, ext in sides)

    for n, (space, element, external) in enumerate(boundaries):
        f.create_entity(
            "IfcRelSpaceBoundary", GlobalId=_gid(f"boundary-{n}"), Name="1stLevel",
            RelatingSpace=space, RelatedBuildingElement=element,
            PhysicalOrVirtualBoundary="PHYSICAL",
            InternalOrExternalBoundary="EXTERNAL" if external else "INTERNAL",
        )

    broken = None
    if broken_element:
        first_storey = f.by_guid(_gid("storey-0"))
        proxy = w.create("IfcBuildingElementProxy", "Broken proxy", "broken")
        ifcopenshell.api.spatial.assign_container(f, products=[proxy], relating_structure=first_storey)
        w.place(proxy, _matrix(ox + 1.0, oy + 1.0, oz))
        profile = f.create_entity("IfcRectangleProfileDef", ProfileType="AREA", XDim=w.units(1.0),
                                  YDim=w.units(1.0))
        solid = f.create_entity(
            "IfcExtrudedAreaSolid", SweptArea=profile,
            Position=f.create_entity("IfcAxis2Placement3D",
                                     Location=f.create_entity("IfcCartesianPoint",
                                                              Coordinates=(0.0, 0.0, 0.0))),
            ExtrudedDirection=f.create_entity("IfcDirection", DirectionRatios=(0.0, 0.0, 1.0)),
            Depth=0.0,
        )
        rep = f.create_entity("IfcShapeRepresentation", ContextOfItems=w.body,
                              RepresentationIdentifier="Body", RepresentationType="SweptSolid",
                              Items=[solid])
        ifcopenshell.api.geometry.assign_representation(f, product=proxy, representation=rep)
        broken = proxy.GlobalId

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    f.write(str(path))
    return TestBuilding(
        path=path, schema=f.schema, metres_per_unit=w.scale, site=site.GlobalId,
        building=building.GlobalId, storeys=storey_info, walls=walls, doors=doors, slabs=slabs,
        spaces=spaces, furniture=furniture, broken=broken,
    )


def _layered_wall_type(w: _Writer, name: str, layers: list[tuple[str, float]]) -> Any:
    f = w.f
    wall_type = w.create("IfcWallType", name, f"type-{name}", predefined_type="STANDARD")
    layer_set = ifcopenshell.api.material.add_material_set(f, name=name, set_type="IfcMaterialLayerSet")
    for material_name, thickness in layers:
        material = ifcopenshell.api.material.add_material(f, name=material_name)
        layer = ifcopenshell.api.material.add_layer(f, layer_set=layer_set, material=material)
        ifcopenshell.api.material.edit_layer(f, layer=layer,
                                             attributes={"LayerThickness": w.units(thickness)})
    ifcopenshell.api.material.assign_material(f, products=[wall_type], type="IfcMaterialLayerSet",
                                              material=layer_set)
    return wall_type


def _door(
    w: _Writer, storey: Any, k: int, elev: float, key: str, host: Any, along: float, width: float,
    height: float, wall_thickness: float, size_attributes: bool, *, wall_is_external: bool,
) -> dict[str, DoorInfo]:
    f = w.f
    host_matrix = _placement_matrix(host, w.scale)
    # The opening is a box slightly thicker than the wall, placed in the wall's frame.
    centre_offset = 0.0 if wall_is_external else -wall_thickness / 2
    local = _matrix(along, centre_offset - 0.05, 0.0)
    world = host_matrix @ local
    opening = w.create("IfcOpeningElement", f"Opening {key} L{k + 1}", f"opening-{k}-{key}", "OPENING")
    w.place(opening, world, absolute=True)
    rep = ifcopenshell.api.geometry.add_wall_representation(
        f, context=w.body, length=width, height=height, thickness=wall_thickness + 0.1,
    )
    ifcopenshell.api.geometry.assign_representation(f, product=opening, representation=rep)
    ifcopenshell.api.feature.add_feature(f, feature=opening, element=host)

    door = w.create("IfcDoor", f"Door {key} L{k + 1}", f"door-{k}-{key}")
    ifcopenshell.api.spatial.assign_container(f, products=[door], relating_structure=storey)
    w.place(door, host_matrix @ _matrix(along, centre_offset, 0.0), absolute=True)
    # A plain 50 mm leaf box, so that its geometry width equals the door width exactly.
    rep = ifcopenshell.api.geometry.add_wall_representation(
        f, context=w.body, length=width, height=height, thickness=0.05, offset=wall_thickness / 2 - 0.025,
    )
    ifcopenshell.api.geometry.assign_representation(f, product=door, representation=rep)
    if size_attributes:
        door.OverallWidth = w.units(width)
        door.OverallHeight = w.units(height)
    pset = ifcopenshell.api.pset.add_pset(f, product=door, name="Pset_DoorCommon")
    ifcopenshell.api.pset.edit_pset(f, pset=pset, properties={"IsExternal": wall_is_external})
    ifcopenshell.api.feature.add_filling(f, opening=opening, element=door)
    del elev
    return {door.GlobalId: DoorInfo(door.Name, storey.GlobalId, width, height, host.GlobalId,
                                    opening.GlobalId)}


def _placement_matrix(product: Any, metres_per_unit: float) -> np.ndarray:
    import ifcopenshell.util.placement

    m = np.array(ifcopenshell.util.placement.get_local_placement(product.ObjectPlacement), dtype=float)
    m[:3, 3] *= metres_per_unit
    return m


def _weight_qto(w: _Writer, product: Any, name: str, kg: float) -> None:
    f = w.f
    quantity = f.create_entity("IfcQuantityWeight", Name="NetWeight", WeightValue=kg)
    f.create_entity(
        "IfcRelDefinesByProperties", GlobalId=_gid(f"qto-{product.GlobalId}"),
        RelatedObjects=[product],
        RelatingPropertyDefinition=f.create_entity(
            "IfcElementQuantity", GlobalId=_gid(f"qto-set-{product.GlobalId}"), Name=name,
            Quantities=[quantity],
        ),
    )
