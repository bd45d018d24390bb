"""IFC import (the pipeline's entry, before A1): an IFC file becomes the model graph and element meshes.

Takes an IFC2X3, IFC4 or IFC4X3_ADD2 file and returns an :class:`ImportResult`: an RDF graph (BOT
spatial tree + kbplanner element classes, poses, bounds, sizes, materials, masses; IRIs keyed by
GlobalId) and one triangle mesh per element with geometry. :func:`import_ifc` also writes them into a
directory as ``model.ttl`` and ``meshes/<GlobalId>.glb``, atomically.

Everything comes out in metres, radians, kilograms and cubic metres, in the site frame of the
project, which is the model frame of :func:`kbplanner.model.ifc_geometry.model_frame` (the
IfcBuilding's placement with z vertical: local metres even for a georeferenced model; the IfcSite's
placement, or the IFC world frame, when there is no building), whatever units the file uses.
Geometry that cannot be built is reported in ``ImportResult.skipped``, never fatal; a file
that cannot be read raises :class:`kbplanner.core.errors.IfcError`.
"""

from __future__ import annotations

import logging
import os
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

import ifcopenshell.util.element
import numpy as np
import trimesh
from rdflib import Graph

from kbplanner.core.errors import IfcError
from kbplanner.model import ifc_geometry as geo
from kbplanner.model import ifc_semantics as sem
from kbplanner.model import ifc_turtle
from kbplanner.model.ifc_graph import MESH_DIR, GraphBuilder, StoreyInfo
from kbplanner.model.ifc_open import SUPPORTED_SCHEMAS, UnitScales, open_ifc, unit_scales
from kbplanner.model.ifc_report import (
    SKIPPED_CSV,
    SKIPPED_JSON,
    ImportNote,
    SkippedElement,
    blocking,
    note_of,
    skipped_csv,
    skipped_json,
    skipped_of,
)
from kbplanner.model.import_version import IMPORTER_VERSION
from kbplanner.model.mesh_volumes import VolumePool

__all__ = [
    "IMPORTER_VERSION", "MESH_DIR", "MODEL_FILE", "SUPPORTED_SCHEMAS", "ImportNote", "ImportResult",
    "SkippedElement", "StoreyInfo", "UnitScales", "import_ifc", "import_ifc_graph", "open_ifc",
    "serialize_model", "unit_scales", "write_import",
]

log = logging.getLogger(__name__)

ProgressCallback = Callable[[int, int], None]

MODEL_FILE = "model.ttl"
#: Fewer meshes than this: their volumes are computed here (a spawned process costs about a second).
MIN_POOLED = 400
NO_GEOMETRY = ("no geometry: no body representation and no parts with one (in the graph without bounds, "
               "so it is no obstacle on maps)")


@dataclass(frozen=True)
class ImportResult:
    """What an IFC import produced.

    ``counts`` maps CURIEs of the classes given (``"kbp:Wall"``, ``"bot:Storey"``, ...) to numbers of
    instances; ``meshes`` holds the site-frame meshes by GlobalId; ``length_unit_m`` is the size of
    the file's length unit in metres (0.001 for millimetres); ``notes`` are elements imported with a
    doubt (unreadable optional data, implausible masses); ``units`` the file's units.
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
    notes: tuple[ImportNote, ...] = ()
    units: UnitScales | None = None

    @property
    def blocking(self) -> list[SkippedElement]:
        """Skipped elements of classes tasks use: they make ``import-ifc`` a negative result (exit 1)."""
        return blocking(self.skipped)


def import_ifc_graph(
    ifc_path: Path,
    *,
    base: str,
    progress: ProgressCallback | None = None,
    processes: int = 1,
    volume_processes: int = 0,
) -> ImportResult:
    """Read an IFC file into a graph and meshes, without writing anything.

    ``base`` is the project's base IRI (``kbplanner.core.iris.base_iri(name)``); ``progress(done, total)``
    follows the geometry loop; ``processes`` is the number of geometry worker processes;
    ``volume_processes`` spawned processes compute the meshes' volumes while the geometry loop runs
    (:class:`~kbplanner.model.mesh_volumes.VolumePool`; the same volumes as computed here).

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
    b = GraphBuilder(ifc_file, base, source)
    log.info("importing %s (%s, %g m per length unit)", source, ifc_file.schema_identifier, b.units.length_m)

    b.add_project()
    storeys = b.add_spatial()
    spaces = b.unique(ifc_file.by_type("IfcSpace"))
    elements = b.unique(p for p in ifc_file.by_type("IfcElement") if sem.is_imported_element(p))

    # Openings keep their RDF but get no mesh: they are voids, already cut from their hosts.
    with_geometry = [p for p in (*elements, *spaces)
                     if p.Representation is not None and not p.is_a("IfcFeatureElementSubtraction")]
    with VolumePool(volume_processes if len(with_geometry) >= MIN_POOLED else 0) as pool:
        result = geo.build_meshes(ifc_file, with_geometry, world_to_site=b.site_inv, processes=processes,
                                 progress=progress, on_mesh=pool.add)
        b.volumes = pool.volumes()
    meshes = result.meshes
    by_guid = {str(p.GlobalId): p for p in with_geometry}
    for guid in sorted(result.failures):
        product = by_guid[guid]
        b.skipped.append(skipped_of(product, result.failures[guid], in_graph=True))
    for guid in sorted(meshes):  # placements near the origin, coordinates far away: noted, not moved
        distance = float(np.hypot(*meshes[guid].bounds.mean(axis=0)[:2]))
        if distance > geo.FAR_M:
            b.notes.append(note_of(by_guid[guid], "far", (
                f"its geometry lies {distance / 1000:.1f} km from the model frame's origin (the building's "
                "0.00 point): its shape's own coordinates carry survey coordinates, so maps that include "
                "it are large and its mesh loses precision; export with coordinates relative to the "
                "element's placement, or place the building there")))

    for space in spaces:
        if str(space.GlobalId) not in meshes and str(space.GlobalId) not in result.failures:
            b.skipped.append(skipped_of(space, NO_GEOMETRY, in_graph=True))
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
            elif guid not in result.failures:
                b.skipped.append(skipped_of(element, NO_GEOMETRY, in_graph=True))
        b.guarded(element, partial(b.add_element, element, mesh, parts_bounds))
    for product in b.dropped:  # links that products read later made to a dropped one
        b.drop(product)

    seconds = time.perf_counter() - started
    log.info("imported %d triples, %d meshes, %d skipped in %.1f s", len(b.g), len(meshes),
             len(b.skipped), seconds)
    if b.notes:
        log.warning("%s: %d element(s) imported with a note (unreadable optional data, implausible mass, "
                    "no host, no storey or containment); they are listed in %s", source.name, len(b.notes),
                    SKIPPED_CSV)
    return ImportResult(
        graph=b.g,
        counts=b.counts(),
        skipped=tuple(sorted(b.skipped, key=lambda s: (s.global_id, s.reason))),
        notes=tuple(sorted(b.notes, key=lambda n: (n.global_id, n.kind, n.message))),
        units=b.units,
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
    """Write ``model.ttl``, ``meshes/``, ``skipped.json`` and ``skipped.csv`` into ``out_dir``.

    Earlier files of an import there are replaced.

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
        _atomic_write(out_dir / SKIPPED_JSON, skipped_json(result.skipped, result.notes))
        _atomic_write(out_dir / SKIPPED_CSV, skipped_csv(result.skipped, result.notes))
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
    volume_processes: int = 0,
) -> ImportResult:
    """Import an IFC file and write ``out_dir/model.ttl`` and ``out_dir/meshes/<GlobalId>.glb``.

    Example:
        >>> from kbplanner.core.iris import base_iri
        >>> r = import_ifc(Path("model.ifc"), Path("project"), base=base_iri("demo"))  # doctest: +SKIP
        >>> sorted(p.name for p in Path("project").iterdir())  # doctest: +SKIP
        ['meshes', 'model.ttl']
    """
    started = time.perf_counter()
    result = import_ifc_graph(ifc_path, base=base, progress=progress, processes=processes,
                              volume_processes=volume_processes)
    write_import(result, out_dir)
    seconds = time.perf_counter() - started
    return ImportResult(
        graph=result.graph, counts=result.counts, skipped=result.skipped, schema=result.schema,
        length_unit_m=result.length_unit_m, seconds=seconds, source=result.source,
        storeys=result.storeys, meshes=result.meshes, out_dir=Path(out_dir), notes=result.notes,
        units=result.units,
    )
