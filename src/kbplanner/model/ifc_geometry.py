"""IFC import, geometry: meshes and poses of IFC products in the model frame (helper of ``ifc_import``).

Takes an open IFC file and the products that should get a mesh; returns one ``trimesh.Trimesh`` per
product (metres, in the model frame of :func:`model_frame`: the IfcBuilding's placement, levelled)
and, for each product whose geometry cannot be built, the reason. Also converts IFC
placements to x, y, z, roll, pitch, yaw and writes meshes as byte-stable GLB.

The GLB files hold site-frame coordinates as they are (z up), not glTF's y-up convention.
"""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import ifcopenshell
import ifcopenshell.geom
import ifcopenshell.util.placement
import numpy as np
import trimesh

# The pose values live in a module without ifcopenshell (the world and the planner import them).
from kbplanner.model.mesh_volumes import mesh_volume  # noqa: F401  (re-exported: ifc_graph uses it from here)
from kbplanner.model.poses import (  # noqa: F401  (re-exported: ifc_graph and callers use them from here)
    ANGLE_DIGITS,
    LENGTH_DIGITS,
    Pose,
    matrix_to_pose,
    round_angle,
    round_length,
)

log = logging.getLogger(__name__)

ProgressCallback = Callable[[int, int], None]

def placement_matrix(product: Any, length_scale: float,
                     memo: dict[int, np.ndarray] | None = None) -> np.ndarray | None:
    """The product's absolute placement (IFC world frame) with the translation in metres.

    ``memo`` (one per open file) keeps the absolute placement of each IfcLocalPlacement read, so the
    storey's, building's and site's placements under every element are read once; the product is
    ifcopenshell's ``get_local_placement`` to the bit (the same products in the same order)."""
    placement = getattr(product, "ObjectPlacement", None)
    if placement is None:
        return None
    local = (ifcopenshell.util.placement.get_local_placement(placement) if memo is None
             else _local_placement(placement, memo))
    m = np.array(local, dtype=float)
    m[:3, 3] *= length_scale
    return m


def _local_placement(placement: Any, memo: dict[int, np.ndarray]) -> np.ndarray:
    """``ifcopenshell.util.placement.get_local_placement`` with each placement's result kept in ``memo``."""
    key = int(placement.id())
    kept = memo.get(key) if key else None
    if kept is not None:
        return kept
    rel_to = placement.PlacementRelTo
    parent = np.eye(4) if rel_to is None else _local_placement(rel_to, memo)
    axes = ifcopenshell.util.placement.get_axis2placement(placement.RelativePlacement)
    m: np.ndarray = np.dot(parent, axes)
    if key:
        memo[key] = m
    return m


# Walls farther than this from the building's origin move the model frame (see ``model_frame``).
FAR_M = 1000.0


def _first_placement(ifc_file: ifcopenshell.file, ifc_class: str, length_scale: float) -> np.ndarray | None:
    """The placement (metres) of the first ``ifc_class`` by GlobalId that has a readable one."""
    for product in sorted(ifc_file.by_type(ifc_class), key=lambda s: str(s.GlobalId or "")):
        try:
            m = placement_matrix(product, length_scale)
        except Exception:  # a broken placement chain: try the next one
            continue
        if m is not None and np.all(np.isfinite(m)):
            return m
    return None


def site_matrix(ifc_file: ifcopenshell.file, length_scale: float) -> np.ndarray:
    """The placement of the (first, by GlobalId) IfcSite in metres; identity when there is none."""
    m = _first_placement(ifc_file, "IfcSite", length_scale)
    return np.eye(4) if m is None else m


def model_frame(ifc_file: ifcopenshell.file, length_scale: float) -> np.ndarray:
    """The frame every pose, bound and mesh of the import is in (4x4, metres, frame -> IFC world).

    It is the placement of the (first, by GlobalId) IfcBuilding: its origin (the building's 0.00
    level, where storey elevations start) and its horizontal axes, with z kept vertical. So a
    georeferenced model (a site or building placed at easting 500 000 m, northing 5 400 000 m) comes
    out in local metres near the origin, without the float loss of large coordinates, and a building
    rotated against the site (or against true north) has its walls along the map axes. Without a
    building it is the IfcSite's placement, else the IFC world frame. When the walls stand more than
    ``FAR_M`` from that origin (storeys or elements placed at survey coordinates under a building at
    the origin), the origin moves to their median position (:func:`far_shift`). IfcMapConversion and
    TrueNorth only relate the file's frame to a map or to north, so they do not move it.

    Example:
        >>> f = ifcopenshell.file(schema="IFC4")
        >>> model_frame(f, 1.0).tolist() == np.eye(4).tolist()
        True
    """
    site = site_matrix(ifc_file, length_scale)
    building = _first_placement(ifc_file, "IfcBuilding", length_scale)
    frame: np.ndarray = site
    if building is not None:
        relative = np.linalg.inv(site) @ building
        yaw = math.atan2(relative[1, 0], relative[0, 0])  # the building's x axis in the site's plan
        c, s = math.cos(yaw), math.sin(yaw)
        level = np.eye(4)
        level[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
        level[:3, 3] = relative[:3, 3]
        frame = site @ level
    shift = far_shift(ifc_file, frame, length_scale)
    if shift is not None:
        moved = np.eye(4)
        moved[:2, 3] = shift
        frame = frame @ moved
    return frame


def far_shift(
    ifc_file: ifcopenshell.file, frame: np.ndarray, length_scale: float
) -> tuple[float, float] | None:
    """Where the walls stand when they stand more than ``FAR_M`` from ``frame``'s origin, else None.

    The median x, y (whole metres) of the walls' placements in ``frame`` (of every element's when
    there is no wall): a model whose building sits at the origin while its storeys or elements carry
    the survey coordinates. Walls only, so that elements init adds to a copy do not move the frame.
    """
    inverse = np.linalg.inv(frame)
    for ifc_class in ("IfcWall", "IfcElement"):
        points = []
        for product in ifc_file.by_type(ifc_class):
            try:
                m = placement_matrix(product, length_scale)
            except Exception:  # a broken placement chain: the import notes it
                continue
            if m is not None and np.all(np.isfinite(m)):
                points.append((inverse @ m)[:2, 3])
        if points:
            x, y = np.median(np.array(points), axis=0)
            if math.hypot(x, y) <= FAR_M:
                return None
            return float(round(x)), float(round(y))
    return None


# A storey's Elevation attribute and its placement's height may differ by this much without a note.
ELEVATION_TOLERANCE_M = 0.01


@dataclass(frozen=True)
class StoreyElevation:
    """A storey's floor height in the model frame (m), and why, when its two sources disagreed."""

    elevation_m: float
    note: str = ""


def _frame_z(product: Any, inverse_frame: np.ndarray, length_scale: float) -> float | None:
    try:
        m = placement_matrix(product, length_scale)
    except Exception:  # a broken placement chain: no height from it
        return None
    return None if m is None or not np.all(np.isfinite(m)) else float((inverse_frame @ m)[2, 3])


def storey_elevation(storey: Any, inverse_frame: np.ndarray, length_scale: float) -> StoreyElevation:
    """The height of a storey's floor in the model frame (``inverse_frame``: IFC world -> model frame).

    Its Elevation attribute (relative to the building's 0.00 level, by the standard), else its
    placement's height. When both are there and differ by more than ``ELEVATION_TOLERANCE_M`` (an
    Elevation written above sea level while the placements are relative, or storeys all placed at 0
    while the Elevation is right), the one nearer the median height of the placements of the elements
    it contains wins (the storey's placement when it contains none), with a note saying so.
    """
    attribute = float(storey.Elevation) * length_scale if storey.Elevation is not None else None
    placed = _frame_z(storey, inverse_frame, length_scale)
    if attribute is None or placed is None or abs(attribute - placed) <= ELEVATION_TOLERANCE_M:
        return StoreyElevation(attribute if attribute is not None else placed if placed is not None else 0.0)
    heights = [z for rel in getattr(storey, "ContainsElements", None) or () for e in rel.RelatedElements
               if (z := _frame_z(e, inverse_frame, length_scale)) is not None]
    reference = float(np.median(heights)) if heights else placed
    use_attribute = abs(attribute - reference) < abs(placed - reference)
    chosen = attribute if use_attribute else placed
    what = "its Elevation attribute" if use_attribute else "its placement's height"
    return StoreyElevation(chosen, (
        f"its Elevation attribute ({attribute:.3f} m) and its placement's height above the building's 0.00 "
        f"level ({placed:.3f} m) differ: {what} ({chosen:.3f} m) is used, nearer where its "
        f"{len(heights)} element(s) are placed (median {reference:.3f} m); correct the storey's Elevation "
        "or placement in the authoring tool"))


@dataclass(frozen=True)
class MeshResult:
    """Meshes by GlobalId, and the reasons for the products whose geometry failed."""

    meshes: dict[str, trimesh.Trimesh]
    failures: dict[str, str]
    processes: int


def _settings() -> Any:
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)  # vertices placed in the IFC world frame, in metres
    return settings


def _to_mesh(geometry: Any, world_to_site: np.ndarray) -> trimesh.Trimesh:
    vertices = np.asarray(geometry.verts, dtype=np.float64).reshape(-1, 3)
    # The same transform as for poses (not ifcopenshell's site-local-placement, which only strips
    # the site from placement chains that pass through it).
    vertices = trimesh.transform_points(vertices, world_to_site)
    faces = np.asarray(geometry.faces, dtype=np.int64).reshape(-1, 3)
    # process=True merges coincident vertices, which makes closed solids watertight.
    return trimesh.Trimesh(vertices=vertices, faces=faces, process=True)


_LOG_LINE = re.compile(r"^\[(\w+)\]\s*(?:\[[^\]]*\]\s*)*(.*)$")


def _log_errors(text: str) -> list[str]:
    """The error messages of an ifcopenshell log, without their level, code and timestamp."""
    errors: list[str] = []
    in_error = False
    for line in text.splitlines():
        m = _LOG_LINE.match(line)
        if m:
            in_error = m.group(1) == "error"
            if in_error:
                errors.append(m.group(2).strip())
        elif in_error and errors:
            errors[-1] = f"{errors[-1]} {line.strip()}".strip()
    return errors


def build_meshes(
    ifc_file: ifcopenshell.file,
    products: Sequence[Any],
    *,
    world_to_site: np.ndarray | None = None,
    processes: int = 1,
    progress: ProgressCallback | None = None,
    on_mesh: Callable[[str, trimesh.Trimesh], None] | None = None,
) -> MeshResult:
    """Triangulate ``products`` (their Body representation) with ifcopenshell's geometry iterator.

    ``world_to_site`` (4x4, metres) moves the IFC world frame to the site frame (default: identity).
    A product the iterator does not return is retried alone, to get the reason it fails (or a mesh
    from another representation); products without triangles are reported as failures too.
    ``progress(done, total)`` is called as shapes arrive, ``on_mesh(guid, mesh)`` with each mesh kept.
    """
    total = len(products)
    meshes: dict[str, trimesh.Trimesh] = {}
    failures: dict[str, str] = {}
    if total == 0:
        return MeshResult(meshes, failures, processes)
    settings = _settings()
    to_site = np.eye(4) if world_to_site is None else np.asarray(world_to_site, dtype=float)
    ifcopenshell.get_log()  # drop earlier messages
    iterator = ifcopenshell.geom.iterator(settings, ifc_file, max(1, processes), include=list(products))
    done = 0
    if iterator.initialize():
        while True:
            shape: Any = iterator.get()
            guid = str(shape.guid)
            mesh = _to_mesh(shape.geometry, to_site)
            if len(mesh.faces) > 0:
                meshes[guid] = mesh
                if on_mesh is not None:
                    on_mesh(guid, mesh)
            else:
                failures[guid] = "geometry has no triangles"
            done += 1
            if progress is not None:
                progress(min(done, total), total)
            if not iterator.next():
                break
    ifcopenshell.get_log()
    for product in products:
        guid = str(product.GlobalId)
        if guid in meshes or guid in failures:
            continue
        try:
            single: Any = ifcopenshell.geom.create_shape(settings, product)
        except RuntimeError as exc:
            errors = _log_errors(ifcopenshell.get_log())
            failures[guid] = "geometry failed: " + (errors[0] if errors else str(exc))
            continue
        mesh = _to_mesh(single.geometry, to_site)
        if len(mesh.faces) > 0:
            meshes[guid] = mesh
            if on_mesh is not None:
                on_mesh(guid, mesh)
        else:
            failures[guid] = "no body geometry (no triangles from any representation)"
    if progress is not None:
        progress(total, total)
    for guid in sorted(failures):
        log.warning("skipped geometry of %s: %s", guid, failures[guid])
    return MeshResult(meshes, failures, processes)


def glb_bytes(mesh: trimesh.Trimesh) -> bytes:
    """The mesh as binary glTF; equal meshes give equal bytes (no timestamps, ids or randomness)."""
    data = trimesh.exchange.gltf.export_glb(mesh, include_normals=False)
    return bytes(data)


def local_extent(mesh: trimesh.Trimesh, placement: np.ndarray) -> np.ndarray:
    """Size (m) of the mesh along the x, y, z axes of ``placement`` (a site-frame 4x4 transform)."""
    inverse = np.linalg.inv(placement)
    local = trimesh.transform_points(mesh.vertices, inverse)
    extent: np.ndarray = local.max(axis=0) - local.min(axis=0)
    return extent
