"""IFC import, graph (middle step of ``ifc_import``): the RDF triples of an IFC file's products.

Takes an open IFC file and the meshes built for its products; adds to an rdflib graph the spatial
tree (BOT site, building, storeys, spaces), and per element its kbplanner class, containment, pose,
bounds, volume, materials, mass, door/window sizes and hosts. An element whose optional data cannot
be read (a malformed property set, an odd material) keeps its class, pose and bounds and gets an
:class:`~kbplanner.model.ifc_report.ImportNote`; only an element whose identity or placement cannot be read
is left out, as a :class:`~kbplanner.model.ifc_report.SkippedElement`.
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import ifcopenshell
import ifcopenshell.util.element
import numpy as np
import trimesh
from rdflib import RDF, RDFS, XSD, Literal, URIRef

from kbplanner.core.iris import element_iri
from kbplanner.core.rdf_io import new_graph
from kbplanner.core.vocab import BOT, KBP
from kbplanner.model import ifc_geometry as geo
from kbplanner.model import ifc_semantics as sem
from kbplanner.model.ifc_open import unit_scales
from kbplanner.model.ifc_report import ImportNote, SkippedElement, mass_doubt, note_of, skipped_of

log = logging.getLogger(__name__)

MESH_DIR = "meshes"
_NOT_COUNTED = frozenset({KBP.Element, BOT.Element, KBP.Pose, KBP.Box})


@dataclass(frozen=True)
class StoreyInfo:
    """A storey as imported: GlobalId, name and elevation (m)."""

    global_id: str
    name: str
    elevation_m: float


def _dbl(value: float) -> Literal:
    return Literal(value, datatype=XSD.double)


def _nearest(product: Any, ifc_class: str) -> Any | None:
    """The nearest ancestor of ``product`` (by aggregation) that is an ``ifc_class``."""
    seen: set[int] = set()
    parent = ifcopenshell.util.element.get_aggregate(product)
    while parent is not None and parent.id() not in seen:
        if parent.is_a(ifc_class):
            return parent
        seen.add(parent.id())
        parent = ifcopenshell.util.element.get_aggregate(parent)
    return None


def _container(product: Any) -> Any | None:
    """The spatial structure element containing the product, or containing its aggregate whole."""
    seen: set[int] = set()
    current: Any | None = product
    while current is not None and current.id() not in seen:
        seen.add(current.id())
        container = ifcopenshell.util.element.get_container(current)
        if container is not None:
            return container
        current = ifcopenshell.util.element.get_aggregate(current)
    return None


def implicit_storey_label(building: Any) -> str:
    """The label of the storey a building without IfcBuildingStorey gets: "<its name> (no storey)"."""
    return f"{building.Name or building.LongName or building.GlobalId} (no storey)"


def has_storeys(building: Any) -> bool:
    """Whether an IfcBuilding aggregates (directly or further down) an IfcBuildingStorey."""
    return any(_nearest(st, "IfcBuilding") == building for st in building.file.by_type("IfcBuildingStorey"))


class GraphBuilder:
    """Holds the state of one import while its triples are added."""

    def __init__(self, ifc_file: ifcopenshell.file, base: str, source: Path) -> None:
        self.f = ifc_file
        self.base = base
        self.source = source
        self.g = new_graph("memory")
        self.units = unit_scales(ifc_file, source)
        self.site_m = geo.model_frame(ifc_file, self.units.length_m)
        self.site_inv = np.linalg.inv(self.site_m)
        self.skipped: list[SkippedElement] = []
        self.notes: list[ImportNote] = []
        self.dropped: list[Any] = []
        self.seen_ids: set[str] = set()
        self.boundaries = sem.space_boundary_index(ifc_file)
        self.implicit_storeys: dict[int, URIRef] = {}  # building entity id -> its implicit storey
        self.volumes: dict[str, tuple[float, str] | None] = {}  # mesh volumes computed ahead, by GlobalId
        self.placements: dict[int, np.ndarray] = {}  # absolute placement by IfcLocalPlacement id

    # --- helpers -----------------------------------------------------------------------------

    def iri(self, product: Any) -> URIRef:
        return element_iri(self.base, str(product.GlobalId))

    def typed(self, node: URIRef, cls: URIRef) -> None:
        self.g.add((node, RDF.type, cls))

    def counts(self) -> dict[str, int]:
        """Instances per kbp/BOT class given by the import (not the materialised supertypes)."""
        found: Counter[str] = Counter()
        for cls in self.g.objects(None, RDF.type):
            if cls in _NOT_COUNTED:
                continue
            for prefix, ns in (("kbp", str(KBP._NS)), ("bot", str(BOT._NS))):
                if str(cls).startswith(ns):
                    found[f"{prefix}:{str(cls)[len(ns):]}"] += 1
        return dict(sorted(found.items()))

    def drop(self, product: Any) -> None:
        """Remove every triple about a product (after its data could not be read)."""
        node = self.iri(product)
        for subject in (node, URIRef(f"{node}/installed-pose"), URIRef(f"{node}/bounds")):
            self.g.remove((subject, None, None))
        self.g.remove((None, None, node))

    def guarded(self, product: Any, add: Callable[[], None]) -> None:
        """Run ``add``; a product whose data cannot be read is dropped and reported, not fatal."""
        try:
            add()
        except Exception as exc:  # malformed IFC data of one product must not stop the import
            log.debug("cannot read %s", product, exc_info=True)
            self.drop(product)
            self.dropped.append(product)
            reason = f"could not read its data ({type(exc).__name__}: {exc})"
            self.skipped.append(skipped_of(product, reason, in_graph=False))

    def optional(self, product: Any, what: str, add: Callable[[], None]) -> None:
        """Run ``add`` for optional data; if it fails the element stays, with a note of what is missing."""
        try:
            add()
        except Exception as exc:  # optional data of one product must not drop the product
            log.debug("cannot read %s of %s", what, product, exc_info=True)
            text = f"{what} not imported: {type(exc).__name__}: {exc}"
            self.notes.append(note_of(product, "unreadable", text))

    def unique(self, products: Iterable[Any]) -> list[Any]:
        """Products sorted by GlobalId; a repeated or empty GlobalId is skipped and reported."""
        out = []
        for p in sorted(products, key=lambda e: (str(e.GlobalId or ""), e.id())):
            gid = str(p.GlobalId or "")
            if not gid or gid in self.seen_ids:
                self.skipped.append(skipped_of(p, f"empty or duplicate GlobalId (#{p.id()})", in_graph=False))
                continue
            self.seen_ids.add(gid)
            out.append(p)
        return out

    def identity(self, product: Any, label: str | None = None) -> URIRef:
        node = self.iri(product)
        self.g.add((node, KBP.globalId, Literal(str(product.GlobalId))))
        self.g.add((node, KBP.ifcClass, Literal(product.is_a())))
        text = label if label is not None else product.Name
        if text:
            self.g.add((node, RDFS.label, Literal(str(text))))
        return node

    def site_frame(self, product: Any) -> np.ndarray | None:
        """The product's placement in the site frame; None (with a note) when it cannot be read."""
        try:
            m = geo.placement_matrix(product, self.units.length_m, self.placements)
        except Exception as exc:  # e.g. an IfcGridPlacement or a broken placement chain
            text = (f"placement not imported ({type(exc).__name__}: {exc}); the element has no pose, "
                    "its bounds come from its geometry")
            self.notes.append(note_of(product, "unreadable", text))
            return None
        return None if m is None else self.site_inv @ m

    def add_pose(self, node: URIRef, matrix: np.ndarray) -> None:
        pose = geo.matrix_to_pose(matrix)
        pose_node = URIRef(f"{node}/installed-pose")
        self.g.add((node, KBP.installedPose, pose_node))
        self.g.add((pose_node, RDF.type, KBP.Pose))
        for prop, value in ((KBP.x, pose.x), (KBP.y, pose.y), (KBP.z, pose.z),
                            (KBP.roll, pose.roll), (KBP.pitch, pose.pitch), (KBP.yaw, pose.yaw)):
            self.g.add((pose_node, prop, _dbl(value)))

    def add_bounds(self, node: URIRef, bounds: np.ndarray) -> None:
        box = URIRef(f"{node}/bounds")
        self.g.add((node, KBP.bounds, box))
        self.g.add((box, RDF.type, KBP.Box))
        (x0, y0, z0), (x1, y1, z1) = bounds
        for prop, value in ((KBP.minX, x0), (KBP.minY, y0), (KBP.minZ, z0),
                            (KBP.maxX, x1), (KBP.maxY, y1), (KBP.maxZ, z1)):
            self.g.add((box, prop, _dbl(geo.round_length(value))))

    # --- the spatial tree ---------------------------------------------------------------------

    def add_project(self) -> None:
        for project in self.unique(self.f.by_type("IfcProject")):
            node = self.identity(project, project.LongName or project.Name)
            self.g.add((node, KBP.ifcSchema, Literal(str(self.f.schema_identifier))))
            self.g.add((node, KBP.sourceFile, Literal(self.source.name)))

    def add_spatial(self) -> list[StoreyInfo]:
        for site in self.unique(self.f.by_type("IfcSite")):
            self.typed(self.identity(site), BOT.Site)
        for building in self.unique(self.f.by_type("IfcBuilding")):
            node = self.identity(building)
            self.typed(node, BOT.Building)
            site = _nearest(building, "IfcSite")
            if site is not None:
                self.g.add((self.iri(site), BOT.hasBuilding, node))
        storeys: list[StoreyInfo] = []
        entities = self.unique(self.f.by_type("IfcBuildingStorey"))
        for storey in entities:
            node = self.identity(storey)
            self.typed(node, BOT.Storey)
            found = geo.storey_elevation(storey, self.site_inv, self.units.length_m)
            elevation = geo.round_length(found.elevation_m)
            if found.note:
                self.notes.append(note_of(storey, "storey", found.note))
            self.g.add((node, KBP.elevation, _dbl(elevation)))
            building = _nearest(storey, "IfcBuilding")
            if building is not None:
                self.g.add((self.iri(building), BOT.hasStorey, node))
            storeys.append(StoreyInfo(str(storey.GlobalId), str(storey.Name or ""), elevation))
        named = Counter(s.name for s in storeys if s.name)
        for storey in entities:
            if named[str(storey.Name or "")] > 1:
                self.notes.append(note_of(storey, "storey", (
                    f"{named[str(storey.Name)]} storeys are named {storey.Name!r}: a storey name chooses the "
                    f"lowest of them; choose this one by its GlobalId (--storey {storey.GlobalId}) or rename "
                    "the storeys in the authoring tool")))
        storeys += self.add_implicit_storeys()
        return sorted(storeys, key=lambda s: (s.elevation_m, s.name, s.global_id))

    def add_implicit_storeys(self) -> list[StoreyInfo]:
        """One storey per building that has no IfcBuildingStorey (elements contained in the building).

        The storey is ``<building IRI>/storey``, labelled "<building name> (no storey)", at the
        building's 0.00 level; it contains what the building contains. The building gets a note.
        """
        out = []
        for building in sorted(self.f.by_type("IfcBuilding"), key=lambda b: str(b.GlobalId or "")):
            if has_storeys(building) or str(building.GlobalId or "") not in self.seen_ids:
                continue
            node = URIRef(f"{self.iri(building)}/storey")
            label = implicit_storey_label(building)
            self.typed(node, BOT.Storey)
            self.g.add((node, RDFS.label, Literal(label)))
            self.g.add((node, KBP.elevation, _dbl(0.0)))
            self.g.add((self.iri(building), BOT.hasStorey, node))
            self.implicit_storeys[building.id()] = node
            self.notes.append(note_of(building, "storey", (
                f"the building has no IfcBuildingStorey: what it contains is one storey {label!r} at its "
                "0.00 level (maps and tasks use it); export the model with its storeys (levels) to have "
                "them")))
            out.append(StoreyInfo(f"{building.GlobalId}/storey", label, 0.0))
        return out

    def add_space(self, space: Any, mesh: trimesh.Trimesh | None) -> None:
        node = self.identity(space, space.LongName or space.Name)
        self.typed(node, BOT.Space)
        self.optional(space, "PredefinedType/ObjectType", lambda: self.add_type_attributes(node, space))
        parent = _nearest(space, "IfcBuildingStorey") or _nearest(space, "IfcBuilding")
        if parent is not None:
            self.g.add((self.implicit_storeys.get(parent.id(), self.iri(parent)), BOT.hasSpace, node))
        placement = self.site_frame(space)
        if placement is not None:
            self.add_pose(node, placement)
        if mesh is not None:
            self.add_mesh_facts(node, space, mesh, {})


    # --- elements -----------------------------------------------------------------------------

    def add_type_attributes(self, node: URIRef, product: Any) -> None:
        predefined = getattr(product, "PredefinedType", None)
        if predefined and predefined != "NOTDEFINED":
            self.g.add((node, KBP.predefinedType, Literal(str(predefined))))
        object_type = getattr(product, "ObjectType", None)
        if object_type:
            self.g.add((node, KBP.objectType, Literal(str(object_type))))

    def add_containment(self, node: URIRef, element: Any) -> None:
        if element.is_a("IfcFeatureElementSubtraction"):
            return  # openings hang off their host (kbp:hasOpening), not off a storey
        container = _container(element)
        if container is None:
            self.notes.append(note_of(element, "containment", (
                "contained in no spatial structure (no IfcRelContainedInSpatialStructure, also not "
                "through an aggregate): it is on no storey, so tasks and storey counts miss it; maps "
                "still show it by its height")))
            return
        self.g.add((self.iri(container), BOT.containsElement, node))
        if container.id() in self.implicit_storeys:
            self.g.add((self.implicit_storeys[container.id()], BOT.containsElement, node))
        if container.is_a("IfcSpace"):
            storey = _nearest(container, "IfcBuildingStorey")
            building = _nearest(container, "IfcBuilding")
            if storey is not None:
                self.g.add((self.iri(storey), BOT.containsElement, node))
            elif building is not None and building.id() in self.implicit_storeys:
                self.g.add((self.implicit_storeys[building.id()], BOT.containsElement, node))

    def add_mesh_facts(
        self, node: URIRef, product: Any, mesh: trimesh.Trimesh, psets: dict[str, dict[str, Any]]
    ) -> float | None:
        """meshFile, bounds and volume of a product with a mesh; returns the volume (m3)."""
        self.g.add((node, KBP.meshFile, Literal(f"{MESH_DIR}/{product.GlobalId}.glb")))
        self.add_bounds(node, mesh.bounds)
        guid = str(product.GlobalId)
        found = self.volumes[guid] if guid in self.volumes else geo.mesh_volume(mesh)
        if found is None:
            found = sem.quantity_volume(psets, self.units.volume_m3)
        if found is None:
            return None
        volume = round(found[0], 9)
        self.g.add((node, KBP.volume, _dbl(volume)))
        return volume

    def add_element(
        self, element: Any, mesh: trimesh.Trimesh | None, parts_bounds: np.ndarray | None
    ) -> None:
        node = self.identity(element)
        cls = sem.kbp_class(element)
        self.typed(node, cls)
        self.g.add((node, RDF.type, KBP.Element))
        self.g.add((node, RDF.type, BOT.Element))
        placement = self.site_frame(element)
        if placement is not None:
            self.add_pose(node, placement)
        self.add_containment(node, element)
        # Everything below is optional data: what cannot be read is noted, the element stays.
        self.optional(element, "PredefinedType/ObjectType", lambda: self.add_type_attributes(node, element))
        found = sem.PropertySets({}, ())
        try:
            found = sem.property_sets(element)
        except Exception as exc:  # the relationships themselves are malformed
            text = f"property sets not imported: {type(exc).__name__}: {exc}"
            self.notes.append(note_of(element, "unreadable", text))
        for problem in found.problems:
            self.notes.append(note_of(element, "unreadable", problem))
        psets = found.sets
        self.optional(element, "IsExternal", lambda: self.add_external(node, element, cls, psets))
        self.optional(element, "materials", lambda: self.add_materials(node, element))

        volume: list[float | None] = [None]

        def mesh_facts() -> None:
            if mesh is not None:
                volume[0] = self.add_mesh_facts(node, element, mesh, psets)
            elif parts_bounds is not None:
                self.add_bounds(node, parts_bounds)

        self.optional(element, "bounds and volume", mesh_facts)
        self.optional(element, "mass", lambda: self.add_mass(node, element, psets, volume[0]))
        if cls in (KBP.Door, KBP.Window):
            self.optional(element, "door/window size and host",
                          lambda: self.add_door_window(node, element, mesh, placement))
        if element.is_a("IfcFeatureElementSubtraction"):
            for rel in getattr(element, "VoidsElements", None) or ():
                self.g.add((self.iri(rel.RelatingBuildingElement), KBP.hasOpening, node))

    def add_external(
        self, node: URIRef, element: Any, cls: URIRef, psets: dict[str, dict[str, Any]]
    ) -> None:
        decision: sem.ExternalDecision | None
        if cls == KBP.Wall:
            decision = sem.decide_wall_external(element, psets, self.boundaries)
        else:
            decision = sem.common_pset_external(element, psets)
        if decision is not None:
            self.g.add((node, KBP.isExternal, Literal(decision.is_external)))
            self.g.add((node, KBP.isExternalSource, Literal(decision.source)))

    def add_materials(self, node: URIRef, element: Any) -> None:
        materials = sem.material_names(element)
        if materials:
            self.g.add((node, KBP.material, Literal("; ".join(materials))))

    def add_mass(
        self, node: URIRef, element: Any, psets: dict[str, dict[str, Any]], volume: float | None
    ) -> None:
        quantity = sem.quantity_mass(psets, self.units.mass_kg)
        if quantity is not None:
            mass, text = quantity[0], f"quantity set {quantity[1]}"
            doubt = mass_doubt(mass, volume, self.units.mass_name)
            if doubt is not None:
                self.notes.append(note_of(element, "mass", f"{quantity[1]}: {doubt}"))
        elif volume is not None and volume > 0:
            density = sem.assumed_density(element, self.units.length_m)
            if density is None:
                return
            mass = volume * density.density
            text = f"volume {volume:.4f} m3 x {density.density:.0f} kg/m3 ({density.text})"
        else:
            return
        self.g.add((node, KBP.mass, _dbl(round(mass, 3))))
        self.g.add((node, KBP.massAssumption, Literal(text)))

    def add_door_window(
        self, node: URIRef, element: Any, mesh: trimesh.Trimesh | None, placement: np.ndarray | None
    ) -> None:
        width = getattr(element, "OverallWidth", None)
        height = getattr(element, "OverallHeight", None)
        extent = geo.local_extent(mesh, placement) if mesh is not None and placement is not None else None
        if width:
            self.g.add((node, KBP.overallWidth, _dbl(geo.round_length(float(width) * self.units.length_m))))
        elif extent is not None:  # no OverallWidth: the leaf's size along its own x axis
            self.g.add((node, KBP.overallWidth, _dbl(geo.round_length(extent[0]))))
        if height:
            self.g.add((node, KBP.overallHeight, _dbl(geo.round_length(float(height) * self.units.length_m))))
        elif extent is not None:
            self.g.add((node, KBP.overallHeight, _dbl(geo.round_length(extent[2]))))
        fills = list(getattr(element, "FillsVoids", None) or ())
        if not fills:
            text = ("fills no opening (no IfcRelFillsElement), so it has no host wall: tasks that need "
                    "the host (kbp:hostWall) skip it")
            self.notes.append(note_of(element, "host", text))
        for fill in fills:
            opening = fill.RelatingOpeningElement
            opening_node = self.iri(opening)
            self.g.add((node, KBP.fillsOpening, opening_node))
            for void in getattr(opening, "VoidsElements", None) or ():
                host = self.iri(void.RelatingBuildingElement)
                self.g.add((node, KBP.hostWall, host))
                self.g.add((host, BOT.hostsElement, node))


