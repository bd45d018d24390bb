"""IFC import (the pipeline's entry, before A1): an IFC file becomes the model graph and element meshes.

Takes an IFC2X3, IFC4 or IFC4X3_ADD2 file and returns an :class:`ImportResult`: an RDF graph (BOT
spatial tree + kbplanner element classes, poses, bounds, sizes, materials, masses; IRIs keyed by
GlobalId) and one triangle mesh per element with geometry. :func:`import_ifc` also writes them into a
directory as ``model.ttl`` and ``meshes/<GlobalId>.glb``, atomically.

Everything comes out in metres, radians, kilograms and cubic metres, in the site frame (the
placement frame of the IfcSite; the IFC world frame when there is none), whatever units the file
uses. Geometry that cannot be built is reported in ``ImportResult.skipped``, never fatal; a file
that cannot be read raises :class:`kbplanner.core.errors.IfcError`.
"""

from __future__ import annotations

import logging
import os
import shutil
import time
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

import ifcopenshell
import ifcopenshell.util.element
import ifcopenshell.util.unit
import numpy as np
import trimesh
from rdflib import RDF, RDFS, XSD, Graph, Literal, URIRef

from kbplanner.core.errors import IfcError
from kbplanner.core.iris import element_iri
from kbplanner.core.rdf_io import new_graph
from kbplanner.core.vocab import BOT, KBP
from kbplanner.model import ifc_geometry as geo
from kbplanner.model import ifc_semantics as sem
from kbplanner.model import ifc_turtle

log = logging.getLogger(__name__)

ProgressCallback = Callable[[int, int], None]

_NOT_COUNTED = frozenset({KBP.Element, BOT.Element, KBP.Pose, KBP.Box})

# ifcopenshell reads these; IFC4X3_ADD2 geometry was checked on files written by ifcopenshell.api.
SUPPORTED_SCHEMAS: tuple[str, ...] = ("IFC2X3", "IFC4", "IFC4X3_ADD2")
# Bump when the graph or meshes written for the same IFC change (the project loader caches imports).
IMPORTER_VERSION = "1"
MODEL_FILE = "model.ttl"
MESH_DIR = "meshes"

_EXPORT_FIX = "export the model again from the BIM authoring tool as IFC4 or IFC2X3 (.ifc, STEP format)"


@dataclass(frozen=True)
class SkippedElement:
    """An element (or part of one) the import could not use, and why."""

    global_id: str
    ifc_class: str
    name: str
    reason: str


@dataclass(frozen=True)
class StoreyInfo:
    """A storey as imported: GlobalId, name and elevation (m)."""

    global_id: str
    name: str
    elevation_m: float


@dataclass(frozen=True)
class ImportResult:
    """What an IFC import produced.

    ``counts`` maps CURIEs of the classes given (``"kbp:Wall"``, ``"bot:Storey"``, ...) to numbers of
    instances; ``meshes`` holds the site-frame meshes by GlobalId; ``length_unit_m`` is the size of
    the file's length unit in metres (0.001 for millimetres).
    """

    graph: Graph
    counts: dict[str, int]
    skipped: tuple[SkippedElement, ...]
    schema: str
    length_unit_m: float
    seconds: float
    source: Path
    storeys: tuple[StoreyInfo, ...]
    meshes: dict[str, trimesh.Trimesh] = field(repr=False)
    out_dir: Path | None = None


# ---------------------------------------------------------------------------------------------
# Opening the file


def open_ifc(ifc_path: Path) -> ifcopenshell.file:
    """Open an IFC file, or raise :class:`IfcError` saying what is wrong with it and what to do.

    Example:
        >>> open_ifc(Path("/work/shared/data/ifc/Duplex_A_20110907.ifc")).schema
        'IFC2X3'
    """
    path = Path(ifc_path)
    if not path.exists():
        raise IfcError("IFC file not found", file=path,
                       fix="check the path of the IFC model (relative paths start in the current directory)")
    if not path.is_file():
        raise IfcError("not a file", file=path, fix="give the path of an .ifc file, not of a directory")
    try:
        with path.open("rb") as stream:
            head = stream.read(512)
            stream.seek(0, os.SEEK_END)
            size = stream.tell()
            stream.seek(max(0, size - 4096))
            tail = stream.read()
    except OSError as exc:
        raise IfcError(f"cannot read the file ({exc.strerror})", file=path,
                       fix="check the file's permissions") from None
    start = head.lstrip(b"\xef\xbb\xbf \t\r\n")
    if start.startswith(b"PK"):
        raise IfcError("this is a ZIP archive (ifcZIP), which is not read", file=path,
                       fix="unzip it and import the .ifc file inside")
    if start.startswith(b"<"):
        raise IfcError("this is XML (ifcXML), which is not read", file=path, fix=_EXPORT_FIX)
    if not start.upper().startswith(b"ISO-10303-21"):
        raise IfcError("not an IFC file (it does not start with an ISO-10303-21 STEP header)", file=path,
                       fix=_EXPORT_FIX)
    if b"END-ISO-10303-21" not in tail.upper():
        raise IfcError("the IFC file is incomplete (no END-ISO-10303-21; at its end)", file=path,
                       fix="copy or export the file again; this copy was cut off")
    try:
        ifc_file = ifcopenshell.open(str(path))
    except ifcopenshell.SchemaError as exc:
        schema = str(exc).rsplit(":", 1)[-1].strip()
        raise IfcError(f"unsupported IFC schema {schema}", file=path, element=schema,
                       fix=f"{_EXPORT_FIX}; kbplanner reads {', '.join(SUPPORTED_SCHEMAS)}") from None
    except Exception as exc:  # ifcopenshell raises plain Error/OSError for unparsable files
        raise IfcError(f"ifcopenshell cannot parse the file: {exc}", file=path, fix=_EXPORT_FIX) from None
    schema = str(ifc_file.schema_identifier)
    if schema not in SUPPORTED_SCHEMAS:
        raise IfcError(f"unsupported IFC schema {schema}", file=path, element=schema,
                       fix=f"{_EXPORT_FIX}; kbplanner reads {', '.join(SUPPORTED_SCHEMAS)}")
    return ifc_file


# ---------------------------------------------------------------------------------------------
# Units


@dataclass(frozen=True)
class UnitScales:
    """Factors from the file's units to metres, cubic metres and kilograms."""

    length_m: float
    volume_m3: float
    mass_kg: float


def unit_scales(ifc_file: ifcopenshell.file) -> UnitScales:
    """The file's project units as SI factors (IFC's default mass unit is the kilogram)."""
    length = float(ifcopenshell.util.unit.calculate_unit_scale(ifc_file, "LENGTHUNIT"))
    volume = float(ifcopenshell.util.unit.calculate_unit_scale(ifc_file, "VOLUMEUNIT"))
    has_mass_unit = ifcopenshell.util.unit.get_project_unit(ifc_file, "MASSUNIT") is not None
    # ifcopenshell measures masses in grams.
    mass = float(ifcopenshell.util.unit.calculate_unit_scale(ifc_file, "MASSUNIT")) / 1000.0 \
        if has_mass_unit else 1.0
    return UnitScales(length, volume, mass)


# ---------------------------------------------------------------------------------------------
# Building the graph


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


class _GraphBuilder:
    """Holds the state of one import while its triples are added."""

    def __init__(self, ifc_file: ifcopenshell.file, base: str, source: Path) -> None:
        self.f = ifc_file
        self.base = base
        self.source = source
        self.g = new_graph("memory")
        self.units = unit_scales(ifc_file)
        self.site_m = geo.site_matrix(ifc_file, self.units.length_m)
        self.site_inv = np.linalg.inv(self.site_m)
        self.skipped: list[SkippedElement] = []
        self.dropped: list[Any] = []
        self.seen_ids: set[str] = set()
        self.boundaries = sem.space_boundary_index(ifc_file)

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
            self.skipped.append(SkippedElement(str(product.GlobalId), product.is_a(), str(product.Name or ""),
                                               f"could not read its data ({type(exc).__name__}: {exc})"))

    def unique(self, products: Iterable[Any]) -> list[Any]:
        """Products sorted by GlobalId; a repeated or empty GlobalId is skipped and reported."""
        out = []
        for p in sorted(products, key=lambda e: (str(e.GlobalId or ""), e.id())):
            gid = str(p.GlobalId or "")
            if not gid or gid in self.seen_ids:
                self.skipped.append(SkippedElement(gid, p.is_a(), str(p.Name or ""),
                                                   f"empty or duplicate GlobalId (#{p.id()})"))
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
        m = geo.placement_matrix(product, self.units.length_m)
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
        for storey in self.unique(self.f.by_type("IfcBuildingStorey")):
            node = self.identity(storey)
            self.typed(node, BOT.Storey)
            if storey.Elevation is not None:
                elevation = geo.round_length(float(storey.Elevation) * self.units.length_m)
            else:  # no Elevation attribute: the height of the storey's placement
                m = self.site_frame(storey)
                elevation = geo.round_length(m[2, 3]) if m is not None else 0.0
            self.g.add((node, KBP.elevation, _dbl(elevation)))
            building = _nearest(storey, "IfcBuilding")
            if building is not None:
                self.g.add((self.iri(building), BOT.hasStorey, node))
            storeys.append(StoreyInfo(str(storey.GlobalId), str(storey.Name or ""), elevation))
        return sorted(storeys, key=lambda s: (s.elevation_m, s.name, s.global_id))

    def add_space(self, space: Any, mesh: trimesh.Trimesh | None) -> None:
        node = self.identity(space, space.LongName or space.Name)
        self.typed(node, BOT.Space)
        self.add_type_attributes(node, space)
        parent = _nearest(space, "IfcBuildingStorey") or _nearest(space, "IfcBuilding")
        if parent is not None:
            self.g.add((self.iri(parent), BOT.hasSpace, node))
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
            return
        self.g.add((self.iri(container), BOT.containsElement, node))
        if container.is_a("IfcSpace"):
            storey = _nearest(container, "IfcBuildingStorey")
            if storey is not None:
                self.g.add((self.iri(storey), BOT.containsElement, node))

    def add_mesh_facts(
        self, node: URIRef, product: Any, mesh: trimesh.Trimesh, psets: dict[str, dict[str, Any]]
    ) -> float | None:
        """meshFile, bounds and volume of a product with a mesh; returns the volume (m3)."""
        self.g.add((node, KBP.meshFile, Literal(f"{MESH_DIR}/{product.GlobalId}.glb")))
        self.add_bounds(node, mesh.bounds)
        found = geo.mesh_volume(mesh)
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
        self.add_type_attributes(node, element)
        self.add_containment(node, element)
        psets = ifcopenshell.util.element.get_psets(element)

        decision: sem.ExternalDecision | None
        if cls == KBP.Wall:
            decision = sem.decide_wall_external(element, psets, self.boundaries)
        else:
            decision = sem.common_pset_external(element, psets)
        if decision is not None:
            self.g.add((node, KBP.isExternal, Literal(decision.is_external)))
            self.g.add((node, KBP.isExternalSource, Literal(decision.source)))

        placement = self.site_frame(element)
        if placement is not None:
            self.add_pose(node, placement)

        materials = sem.material_names(element)
        if materials:
            self.g.add((node, KBP.material, Literal("; ".join(materials))))

        volume = None
        if mesh is not None:
            volume = self.add_mesh_facts(node, element, mesh, psets)
        elif parts_bounds is not None:
            self.add_bounds(node, parts_bounds)
        self.add_mass(node, element, psets, volume)

        if cls in (KBP.Door, KBP.Window):
            self.add_door_window(node, element, mesh, placement)
        if element.is_a("IfcFeatureElementSubtraction"):
            for rel in getattr(element, "VoidsElements", None) or ():
                self.g.add((self.iri(rel.RelatingBuildingElement), KBP.hasOpening, node))

    def add_mass(
        self, node: URIRef, element: Any, psets: dict[str, dict[str, Any]], volume: float | None
    ) -> None:
        quantity = sem.quantity_mass(psets, self.units.mass_kg)
        if quantity is not None:
            mass, text = quantity[0], f"quantity set {quantity[1]}"
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
        for fill in getattr(element, "FillsVoids", None) or ():
            opening = fill.RelatingOpeningElement
            opening_node = self.iri(opening)
            self.g.add((node, KBP.fillsOpening, opening_node))
            for void in getattr(opening, "VoidsElements", None) or ():
                host = self.iri(void.RelatingBuildingElement)
                self.g.add((node, KBP.hostWall, host))
                self.g.add((host, BOT.hostsElement, node))


def import_ifc_graph(
    ifc_path: Path,
    *,
    base: str,
    progress: ProgressCallback | None = None,
    processes: int = 1,
) -> ImportResult:
    """Read an IFC file into a graph and meshes, without writing anything.

    ``base`` is the project's base IRI (``kbplanner.core.iris.base_iri(name)``); ``progress(done, total)``
    follows the geometry loop; ``processes`` is the number of geometry worker processes.

    Example:
        >>> from kbplanner.core.iris import base_iri
        >>> r = import_ifc_graph(Path("/work/shared/data/ifc/Duplex_A_20110907.ifc"),
        ...                      base=base_iri("duplex"))  # doctest: +SKIP
        >>> r.counts["kbp:Wall"]  # doctest: +SKIP
        57
    """
    started = time.perf_counter()
    source = Path(ifc_path)
    ifc_file = open_ifc(source)
    b = _GraphBuilder(ifc_file, base, source)
    log.info("importing %s (%s, %g m per length unit)", source, ifc_file.schema_identifier, b.units.length_m)

    b.add_project()
    storeys = b.add_spatial()
    spaces = b.unique(ifc_file.by_type("IfcSpace"))
    elements = b.unique(p for p in ifc_file.by_type("IfcElement") if sem.is_imported_element(p))

    # Openings keep their RDF but get no mesh: they are voids, already cut from their hosts.
    with_geometry = [p for p in (*elements, *spaces)
                     if p.Representation is not None and not p.is_a("IfcFeatureElementSubtraction")]
    result = geo.build_meshes(ifc_file, with_geometry, world_to_site=b.site_inv, processes=processes,
                             progress=progress)
    meshes = result.meshes
    by_guid = {str(p.GlobalId): p for p in with_geometry}
    for guid in sorted(result.failures):
        product = by_guid[guid]
        b.skipped.append(SkippedElement(guid, product.is_a(), str(product.Name or ""), result.failures[guid]))

    for space in spaces:
        b.guarded(space, partial(b.add_space, space, meshes.get(str(space.GlobalId))))
    for element in elements:
        guid = str(element.GlobalId)
        mesh = meshes.get(guid)
        parts_bounds = None
        if mesh is None and not element.is_a("IfcFeatureElementSubtraction"):
            parts = [meshes[str(p.GlobalId)] for p in ifcopenshell.util.element.get_decomposition(element)
                     if str(p.GlobalId) in meshes]
            if parts:
                stacked = np.vstack([m.bounds for m in parts])
                parts_bounds = np.array([stacked.min(axis=0), stacked.max(axis=0)])
        b.guarded(element, partial(b.add_element, element, mesh, parts_bounds))
    for product in b.dropped:  # links that products read later made to a dropped one
        b.drop(product)

    seconds = time.perf_counter() - started
    log.info("imported %d triples, %d meshes, %d skipped in %.1f s", len(b.g), len(meshes),
             len(b.skipped), seconds)
    return ImportResult(
        graph=b.g,
        counts=b.counts(),
        skipped=tuple(sorted(b.skipped, key=lambda s: (s.global_id, s.reason))),
        schema=str(ifc_file.schema_identifier),
        length_unit_m=b.units.length_m,
        seconds=seconds,
        source=source,
        storeys=tuple(storeys),
        meshes=dict(sorted(meshes.items())),
    )


# ---------------------------------------------------------------------------------------------
# Writing


def _atomic_write(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        with tmp.open("wb") as stream:
            stream.write(data)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def serialize_model(graph: Graph) -> bytes:
    """The graph as Turtle; the same graph always gives the same bytes (sorted, no blank nodes)."""
    return ifc_turtle.serialize(graph)


def write_import(result: ImportResult, out_dir: Path) -> None:
    """Write ``model.ttl`` and ``meshes/`` of an import into ``out_dir``, replacing earlier ones.

    The meshes are written to a temporary directory that then replaces ``meshes/``; ``model.ttl``
    is replaced last, so a crash leaves either the earlier import or the new one, never a half file.
    """
    out_dir = Path(out_dir)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise IfcError(f"cannot create the output directory ({exc.strerror})", file=out_dir,
                       fix="choose a directory you can write to") from None
    pid = os.getpid()
    staging = out_dir / f".{MESH_DIR}.tmp-{pid}"
    retired = out_dir / f".{MESH_DIR}.old-{pid}"
    final = out_dir / MESH_DIR
    model_bytes = serialize_model(result.graph)
    try:
        shutil.rmtree(staging, ignore_errors=True)
        staging.mkdir()
        for guid, mesh in result.meshes.items():
            (staging / f"{guid}.glb").write_bytes(geo.glb_bytes(mesh))
        if final.exists():
            os.replace(final, retired)
        os.replace(staging, final)
        _atomic_write(out_dir / MODEL_FILE, model_bytes)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
        shutil.rmtree(retired, ignore_errors=True)


def import_ifc(
    ifc_path: Path,
    out_dir: Path,
    *,
    base: str,
    progress: ProgressCallback | None = None,
    processes: int = 1,
) -> ImportResult:
    """Import an IFC file and write ``out_dir/model.ttl`` and ``out_dir/meshes/<GlobalId>.glb``.

    Example:
        >>> from kbplanner.core.iris import base_iri
        >>> r = import_ifc(Path("model.ifc"), Path("project"), base=base_iri("demo"))  # doctest: +SKIP
        >>> sorted(p.name for p in Path("project").iterdir())  # doctest: +SKIP
        ['meshes', 'model.ttl']
    """
    started = time.perf_counter()
    result = import_ifc_graph(ifc_path, base=base, progress=progress, processes=processes)
    write_import(result, out_dir)
    seconds = time.perf_counter() - started
    return ImportResult(
        graph=result.graph, counts=result.counts, skipped=result.skipped, schema=result.schema,
        length_unit_m=result.length_unit_m, seconds=seconds, source=result.source,
        storeys=result.storeys, meshes=result.meshes, out_dir=Path(out_dir),
    )
