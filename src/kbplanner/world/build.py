"""A6, the world at a date: from the augmented 4D model to a typed description of the simulation world.

Takes a loaded :class:`~kbplanner.model.project_data.ProjectData` (model graph of one scenario), a date
and the
robotized task to simulate; returns a :class:`World`: what stands on site at that date and where.

- **Static elements**: building elements that are built at the date, and elements of *other* tasks
  that are in progress (partly built, so present as obstacles; their state says ``in progress``).
  Elements that no task builds count as built (``kbplanner.model.schedule.element_states``).
- **Doors are open**: a built door's panel is no obstacle and its opening stays free, so doors are
  listed in :attr:`World.open_doors`, never as static geometry. Openings (voids) are never elements
  of the world.
- **Task elements**: the elements of the robotized task (``task_id``, default the manifest's
  ``[simulation] task``) are separate movable bodies at their material storage (``kbp:storedIn``),
  whatever their state at the date. Layout, deterministic: each element lies flat on the storage
  top: its longest side along the storage's local x, its middle side along local y, its thinnest
  side (its thickness) vertical; elements of one storage are stacked in ``kbp:stackIndex`` order
  (0 = bottom; elements without an index follow, by IRI), each resting on the one below (heights
  add up, so elements of different thickness never overlap), centred on the storage footprint.
  Sizes are the element's extents in its own frame (its mesh seen from its installed pose).
  A task element with no storage or no geometry cannot be placed: it is reported in
  :attr:`World.omitted` with the reason and the fix (an expected outcome on a bare model).
- **Absent**: elements of tasks that have not started at the date (:attr:`World.omitted`).
- **Site objects** with pose and box size: solid ones (``kbp:obstructs`` true or unset) become
  boxes; areas (``kbp:obstructs false``: workspaces, no-go zones) stay areas, not bodies.
- **Workers**: positions only (the first stop of their route, and the route), their motion is B5's.
- **Storeys** with elevations; the storey of the task (where most task elements are installed).
- **Read once**: what does not depend on the date or the task (elements, storeys, site objects,
  workers, each scheduled element's deciding finish and start) is read by :func:`world_tables`;
  :func:`build_world` takes those tables to build many worlds of one project (every robotized task,
  several dates) without reading the whole building again, and gives the same worlds. The states
  follow the rule of the named query ``element_state_at``, judged in Python from the table (by the
  query itself when a schedule time has a time zone).

Example:
    >>> from datetime import datetime
    >>> from kbplanner import Project
    >>> p = Project.load("data/case_study", scenario="storage-outside")  # doctest: +SKIP
    >>> w = build_world(p, datetime(2022, 5, 10, 7))  # doctest: +SKIP
    >>> len(w.task_elements), w.storey(w.task_storey).label  # doctest: +SKIP
    (11, 'Level 1')
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import numpy.typing as npt
import trimesh

from kbplanner.core.errors import InputFileError, WorldError
from kbplanner.core.iris import slug
from kbplanner.core.named_queries import run_named
from kbplanner.core.vocab import KBP
from kbplanner.model.dates import parse_date
from kbplanner.model.ifc_geometry import Pose, matrix_to_pose

if TYPE_CHECKING:
    from kbplanner.model.project_data import ProjectData

log = logging.getLogger(__name__)

Matrix = npt.NDArray[np.float64]

BUILT = "built"
IN_PROGRESS = "in progress"
NOT_STARTED = "not started"
_STATE_NAMES = {str(KBP.Built): BUILT, str(KBP.InProgress): IN_PROGRESS, str(KBP.NotStarted): NOT_STARTED}

NO_STOREY = "site"  # group of static elements that no storey contains
GROUND_STOREY_TOLERANCE_M = 0.5  # a storey this close to the ground level is at ground level
UNPLACED_PREFIXES = ("task element", "its storage")  # reasons of Omitted task elements
ASSUMED_MASS_KG = 10.0  # a task element body without kbp:mass (said in its mass_assumption)


# --------------------------------------------------------------------------------------------
# Small geometry helpers
# --------------------------------------------------------------------------------------------


def pose_matrix(pose: Pose) -> Matrix:
    """The 4x4 transform of a pose: R = Rz(yaw) Ry(pitch) Rx(roll), then the translation.

    Example:
        >>> pose_matrix(Pose(1.0, 2.0, 3.0, 0.0, 0.0, math.pi / 2)).round(6)[:3, 3].tolist()
        [1.0, 2.0, 3.0]
    """
    cr, sr = math.cos(pose.roll), math.sin(pose.roll)
    cp, sp = math.cos(pose.pitch), math.sin(pose.pitch)
    cy, sy = math.cos(pose.yaw), math.sin(pose.yaw)
    m = np.eye(4)
    m[:3, :3] = [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
    m[:3, 3] = [pose.x, pose.y, pose.z]
    return m


@dataclass(frozen=True)
class Bounds:
    """An axis-aligned box (m); in the site frame unless said otherwise."""

    xmin: float
    ymin: float
    zmin: float
    xmax: float
    ymax: float
    zmax: float

    @classmethod
    def of_points(cls, points: npt.ArrayLike) -> Bounds:
        """The box around some points (N, 3)."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        lo, hi = p.min(axis=0), p.max(axis=0)
        return cls(*(_r(v) for v in (*lo, *hi)))

    @property
    def size(self) -> tuple[float, float, float]:
        """Extent along x, y, z."""
        return (self.xmax - self.xmin, self.ymax - self.ymin, self.zmax - self.zmin)

    @property
    def center(self) -> tuple[float, float, float]:
        """Centre point."""
        return ((self.xmin + self.xmax) / 2, (self.ymin + self.ymax) / 2, (self.zmin + self.zmax) / 2)

    def corners(self) -> Matrix:
        """The 8 corners (8, 3)."""
        xs, ys, zs = (self.xmin, self.xmax), (self.ymin, self.ymax), (self.zmin, self.zmax)
        return np.array([[x, y, z] for x in xs for y in ys for z in zs], dtype=np.float64)

    def overlap_volume(self, other: Bounds) -> float:
        """Volume (m3) shared with another box (0 when they only touch)."""
        dx = min(self.xmax, other.xmax) - max(self.xmin, other.xmin)
        dy = min(self.ymax, other.ymax) - max(self.ymin, other.ymin)
        dz = min(self.zmax, other.zmax) - max(self.zmin, other.zmin)
        return max(dx, 0.0) * max(dy, 0.0) * max(dz, 0.0)

    def as_list(self) -> list[float]:
        """[xmin, ymin, zmin, xmax, ymax, zmax]."""
        return [self.xmin, self.ymin, self.zmin, self.xmax, self.ymax, self.zmax]


def _r(v: float) -> float:
    """Round a length to 1 µm (without negative zero) so that written files are byte-stable."""
    return round(float(v), 6) + 0.0


def pose_dict(pose: Pose | None) -> dict[str, float] | None:
    """A pose as a JSON object (x, y, z in m; roll, pitch, yaw in rad)."""
    if pose is None:
        return None
    return {"x": pose.x, "y": pose.y, "z": pose.z, "roll": pose.roll, "pitch": pose.pitch, "yaw": pose.yaw}


# --------------------------------------------------------------------------------------------
# The typed world
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class StoreyInfo:
    """A storey: IRI, label and floor elevation (m)."""

    iri: str
    label: str
    elevation_m: float


@dataclass(frozen=True)
class WorldElement:
    """A building element present in the world, static or (for the robotized task) movable.

    ``pose`` is where the element's own frame is now (the installed pose for static elements, the
    storage placement for task elements); ``bounds`` is its box in the site frame there.
    ``local_bounds`` is its box in its own frame. ``mesh_path`` is the site-frame mesh at the
    installed pose (the import's GLB); :func:`element_mesh` gives it at ``pose``.
    """

    iri: str
    global_id: str
    label: str
    ifc_class: str
    kind: str  # kbp class local name: Wall, Slab, Member, ...
    storey: str | None  # IRI of the storey that contains it
    state: str  # built | in progress | not started
    mesh_file: str | None
    mesh_path: Path | None
    installed_pose: Pose | None
    pose: Pose | None
    bounds: Bounds | None
    local_bounds: Bounds | None
    mass_kg: float | None
    mass_assumption: str | None
    group: str = ""  # merged static body it belongs to ("" for task elements)
    storage: str | None = None  # task elements: IRI of the material storage
    stack_index: int | None = None  # task elements: position in the stack (0 = bottom)

    @property
    def is_movable(self) -> bool:
        """Whether the element is a task element (a separate dynamic body)."""
        return self.storage is not None

    @property
    def body_mass_kg(self) -> float:
        """Mass of its simulated body: ``kbp:mass``, else :data:`ASSUMED_MASS_KG`."""
        return self.mass_kg if self.mass_kg is not None and self.mass_kg > 0 else ASSUMED_MASS_KG

    @property
    def placement(self) -> Matrix:
        """Transform from the element's installed site-frame mesh to where it is now."""
        if self.pose is None:
            return np.eye(4)
        now = pose_matrix(self.pose)
        if self.installed_pose is None:
            return now
        return now @ np.linalg.inv(pose_matrix(self.installed_pose))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields (paths relative to the import directory)."""
        return {
            "iri": self.iri, "global_id": self.global_id, "label": self.label, "ifc_class": self.ifc_class,
            "kind": self.kind, "storey": self.storey, "state": self.state, "mesh_file": self.mesh_file,
            "installed_pose": pose_dict(self.installed_pose), "pose": pose_dict(self.pose),
            "bounds": self.bounds.as_list() if self.bounds else None,
            "local_bounds": self.local_bounds.as_list() if self.local_bounds else None,
            "mass_kg": self.mass_kg, "mass_assumption": self.mass_assumption, "group": self.group,
            "storage": self.storage, "stack_index": self.stack_index,
        }


@dataclass(frozen=True)
class OpenDoor:
    """A built door: present, open, so neither its panel nor its opening is an obstacle."""

    iri: str
    global_id: str
    label: str
    storey: str | None
    bounds: Bounds | None


@dataclass(frozen=True)
class Omitted:
    """An element that is not in the world, and why (with how to change that when it is a gap)."""

    iri: str
    global_id: str
    label: str
    kind: str
    state: str
    reason: str


@dataclass(frozen=True)
class SiteObject:
    """A site object: pose of its footprint centre at its base, box size along its own axes (m)."""

    iri: str
    kind: str  # kbp class local name: SiteOffice, MaterialStorage, NoGoZone, ...
    label: str
    pose: Pose
    size: tuple[float, float, float]
    obstructs: bool
    pickup: Pose | None = None  # material storages: where the robot stands to pick

    @property
    def is_no_go(self) -> bool:
        """Whether this is a no-go zone."""
        return self.kind == "NoGoZone"

    @property
    def box_center(self) -> Matrix:
        """4x4 transform of the box centre (the pose raised by half the height)."""
        return pose_matrix(self.pose) @ _translation(0.0, 0.0, self.size[2] / 2)

    @property
    def top_z(self) -> float:
        """Height of the top face (m), for an upright box."""
        return self.pose.z + self.size[2]


@dataclass(frozen=True)
class RouteStop:
    """A stop of a worker's route: order, location IRI, position (m), dwell time (s)."""

    order: int
    location: str | None
    position: tuple[float, float, float] | None
    dwell_s: float | None


@dataclass(frozen=True)
class Worker:
    """A worker: role, speed, start position (first route stop) and route."""

    iri: str
    label: str
    role: str
    speed_mps: float | None
    position: tuple[float, float, float] | None
    route: tuple[RouteStop, ...]


@dataclass(frozen=True)
class World:
    """The simulation world of one scenario at one date (see module docstring)."""

    project: str
    scenario: str | None
    at: datetime
    task_id: str | None
    task_iri: str | None
    task_label: str | None
    storeys: tuple[StoreyInfo, ...]
    static: tuple[WorldElement, ...]
    task_elements: tuple[WorldElement, ...]
    open_doors: tuple[OpenDoor, ...]
    omitted: tuple[Omitted, ...]
    site_objects: tuple[SiteObject, ...]
    workers: tuple[Worker, ...]
    site_extent: Bounds | None
    robot_start: Pose | None
    task_storey: str | None
    ground_z: float
    import_dir: Path = field(compare=False)

    def storey(self, iri: str | None) -> StoreyInfo | None:
        """The storey with this IRI (or label)."""
        return next((s for s in self.storeys if iri in (s.iri, s.label)), None)

    def element(self, iri: str) -> WorldElement | None:
        """A present element (static or task) by IRI."""
        return next((e for e in (*self.static, *self.task_elements) if e.iri == iri), None)

    def static_groups(self) -> dict[str, list[WorldElement]]:
        """Static elements with geometry by merge group (storey + class), groups and members sorted."""
        out: dict[str, list[WorldElement]] = {}
        for e in self.static:
            if e.mesh_path is not None:
                out.setdefault(e.group, []).append(e)
        return {k: sorted(out[k], key=lambda e: e.iri) for k in sorted(out)}

    @property
    def solid_site_objects(self) -> tuple[SiteObject, ...]:
        """Site objects that are bodies."""
        return tuple(o for o in self.site_objects if o.obstructs)

    @property
    def areas(self) -> tuple[SiteObject, ...]:
        """Site objects that are marked areas (workspaces, no-go zones), not bodies."""
        return tuple(o for o in self.site_objects if not o.obstructs)

    @property
    def storages(self) -> tuple[SiteObject, ...]:
        """Material storages."""
        return tuple(o for o in self.site_objects if o.kind == "MaterialStorage")

    def unplaced(self) -> tuple[Omitted, ...]:
        """Elements of the robotized task that could not be placed at a storage (with reasons)."""
        return tuple(o for o in self.omitted if o.reason.startswith(UNPLACED_PREFIXES))

    def summary(self) -> dict[str, int]:
        """Counts for the command line and world.json."""
        return {
            "static_elements": len(self.static),
            "static_groups": len(self.static_groups()),
            "task_elements_at_storage": len(self.task_elements),
            "open_doors": len(self.open_doors),
            "absent_not_started": sum(1 for o in self.omitted if o.reason.startswith("not started")),
            "task_elements_not_placed": len(self.unplaced()),
            "omitted": len(self.omitted),
            "site_objects": len(self.site_objects),
            "solid_site_objects": len(self.solid_site_objects),
            "areas": len(self.areas),
            "workers": len(self.workers),
            "in_progress_static": sum(1 for e in self.static if e.state == IN_PROGRESS),
        }

    def to_dict(self) -> dict[str, Any]:
        """The world as JSON-ready data (sorted, rounded: byte-stable when written)."""
        def obj(o: SiteObject) -> dict[str, Any]:
            return {"iri": o.iri, "kind": o.kind, "label": o.label, "pose": pose_dict(o.pose),
                    "size": list(o.size), "obstructs": o.obstructs, "pickup": pose_dict(o.pickup)}

        return {
            "project": self.project,
            "scenario": self.scenario,
            "date": self.at.isoformat(),
            "task": {"id": self.task_id, "iri": self.task_iri, "label": self.task_label,
                     "storey": self.task_storey},
            "counts": self.summary(),
            "ground_z": self.ground_z,
            "site_extent": self.site_extent.as_list() if self.site_extent else None,
            "robot_start": pose_dict(self.robot_start),
            "storeys": [{"iri": s.iri, "label": s.label, "elevation_m": s.elevation_m} for s in self.storeys],
            "static_elements": [e.to_dict() for e in self.static],
            "task_elements": [e.to_dict() for e in self.task_elements],
            "open_doors": [{"iri": d.iri, "global_id": d.global_id, "label": d.label, "storey": d.storey,
                            "bounds": d.bounds.as_list() if d.bounds else None} for d in self.open_doors],
            "omitted": [{"iri": o.iri, "global_id": o.global_id, "label": o.label, "kind": o.kind,
                         "state": o.state, "reason": o.reason} for o in self.omitted],
            "site_objects": [obj(o) for o in self.site_objects],
            "workers": [{"iri": w.iri, "label": w.label, "role": w.role, "speed_mps": w.speed_mps,
                         "position": list(w.position) if w.position else None,
                         "route": [{"order": s.order, "location": s.location,
                                    "position": list(s.position) if s.position else None,
                                    "dwell_s": s.dwell_s} for s in w.route]} for w in self.workers],
        }


# --------------------------------------------------------------------------------------------
# Meshes
# --------------------------------------------------------------------------------------------


@lru_cache(maxsize=4096)
def _read_mesh(path: str, mtime_ns: int) -> trimesh.Trimesh:
    del mtime_ns  # part of the cache key only: a rewritten file is read again
    mesh = trimesh.load(path, force="mesh", process=False)
    if not isinstance(mesh, trimesh.Trimesh):  # pragma: no cover - force="mesh" gives a Trimesh
        raise InputFileError("not a triangle mesh", file=path, fix="re-run the IFC import")
    return mesh


def load_mesh(path: Path) -> trimesh.Trimesh:
    """A copy of a mesh file's triangles (cached by path and modification time).

    Raises:
        InputFileError: the file is missing or not a mesh.
    """
    try:
        stat = Path(path).stat()
    except OSError:
        raise InputFileError("mesh file not found", file=path,
                             fix="delete the project's .kbplanner-cache directory to import the IFC again"
                             ) from None
    try:
        mesh = _read_mesh(str(path), stat.st_mtime_ns)
    except (ValueError, KeyError, OSError) as exc:
        raise InputFileError(f"cannot read mesh: {exc}", file=path,
                             fix="delete the project's .kbplanner-cache directory to import the IFC again"
                             ) from None
    return mesh.copy()


def element_mesh(element: WorldElement) -> trimesh.Trimesh | None:
    """The element's mesh in the site frame at its current pose (None without geometry)."""
    if element.mesh_path is None:
        return None
    mesh = load_mesh(element.mesh_path)
    if element.is_movable:
        mesh.apply_transform(element.placement)
    return mesh


def element_local_mesh(element: WorldElement) -> trimesh.Trimesh | None:
    """The element's mesh in its own frame (origin at its pose), e.g. for a body or an SDF model."""
    if element.mesh_path is None:
        return None
    mesh = load_mesh(element.mesh_path)
    if element.installed_pose is not None:
        mesh.apply_transform(np.linalg.inv(pose_matrix(element.installed_pose)))
    return mesh


def group_mesh(elements: Sequence[WorldElement]) -> trimesh.Trimesh:
    """The meshes of some static elements merged into one (site frame), in the order given."""
    meshes = [m for m in (element_mesh(e) for e in elements) if m is not None]
    if not meshes:
        return trimesh.Trimesh()
    return cast(trimesh.Trimesh, trimesh.util.concatenate(meshes))


def site_object_mesh(obj: SiteObject) -> trimesh.Trimesh:
    """A site object's box as a mesh in the site frame."""
    return trimesh.creation.box(extents=obj.size, transform=obj.box_center)


# --------------------------------------------------------------------------------------------
# Building the world
# --------------------------------------------------------------------------------------------


def _translation(x: float, y: float, z: float) -> Matrix:
    m = np.eye(4)
    m[:3, 3] = [x, y, z]
    return m


def _local(iri: str) -> str:
    return iri.rsplit("#", 1)[-1].rsplit("/", 1)[-1]


def _opt_float(v: Any) -> float | None:
    return None if v is None else float(v)


def _first_rows(rows: Iterable[tuple[Any, ...]]) -> dict[str, tuple[Any, ...]]:
    out: dict[str, tuple[Any, ...]] = {}
    for row in rows:
        out.setdefault(str(row[0]), row)
    return out


@dataclass(frozen=True)
class _TaskInfo:
    iri: str
    task_id: str
    label: str
    elements: dict[str, tuple[str | None, int | None]]  # element IRI -> (storage, stack index)


def _resolve_task(project: ProjectData, task_id: str | None,
                  tasks: Sequence[tuple[Any, ...]] | None = None) -> _TaskInfo | None:
    if tasks is None:
        tasks = run_named(project.model, "world_tasks").rows
    known = sorted({str(r[1]) for r in tasks})
    if task_id is None:
        task_id = project.manifest.simulation.get("task")
        if task_id is None:
            robotized = sorted(str(r[1]) for r in tasks if r[5])
            if len(robotized) == 1:
                task_id = robotized[0]
            elif not robotized:
                log.info("no robotized task: the world has no task elements")
                return None
            else:
                raise WorldError("several robotized tasks and no [simulation] task in project.toml",
                                 file=project.manifest.path, element=", ".join(robotized),
                                 fix="choose one with --task ID or set [simulation] task = \"ID\"")
    task_id = str(task_id)
    if task_id not in known:
        raise WorldError(f"unknown task {task_id!r}", file=project.manifest.path, element=task_id,
                         fix="choose one of the schedule's tasks: " + (", ".join(known) or "none"))
    row = next(r for r in tasks if str(r[1]) == task_id)
    elements: dict[str, tuple[str | None, int | None]] = {}
    rows = run_named(project.model, "world_task_elements", taskId=task_id).rows
    for _task, _tid, el, storage, index in rows:
        prev = elements.get(str(el))
        if prev is not None and prev[0] is not None:
            continue  # several storages: the first (by IRI) wins, deterministically
        elements[str(el)] = (str(storage) if storage is not None else None,
                             int(index) if index is not None else None)
    return _TaskInfo(str(row[0]), task_id, str(row[2] or task_id), elements)


def _storeys(project: ProjectData) -> tuple[tuple[StoreyInfo, ...], dict[str, str]]:
    storeys: dict[str, StoreyInfo] = {}
    of_element: dict[str, str] = {}
    for storey, label, elevation, element in run_named(project.model, "world_storeys").rows:
        s = str(storey)
        if s not in storeys:
            storeys[s] = StoreyInfo(s, str(label or _local(s)), float(elevation or 0.0))
        if element is not None:
            # An element in two storeys (rare; e.g. through a space) keeps the lower one.
            of_element.setdefault(str(element), s)
    ordered = tuple(sorted(storeys.values(), key=lambda s: (s.elevation_m, s.label, s.iri)))
    return ordered, of_element


def _site_objects(project: ProjectData) -> tuple[SiteObject, ...]:
    out: dict[str, SiteObject] = {}
    for row in run_named(project.graph, "world_site_objects").rows:
        (obj, cls, label, obstructs, x, y, z, roll, pitch, yaw, sx, sy, sz, px, py, pz, pyaw) = row
        iri = str(obj)
        if iri in out:  # several classes or pickups: the first row (by class IRI) wins
            continue
        if x is None or sx is None or sy is None or sz is None:
            log.warning("site object %s has no pose or no size: left out of the world", iri)
            continue
        kind = _local(str(cls))
        pose = Pose(float(x), float(y), float(z), float(roll or 0.0), float(pitch or 0.0), float(yaw or 0.0))
        pickup = (Pose(float(px), float(py), float(pz), 0.0, 0.0, float(pyaw or 0.0))
                  if px is not None else None)
        # kbp:obstructs unset: areas by class (workspaces, no-go zones), every other object is solid.
        solid = bool(obstructs) if obstructs is not None else kind not in ("NoGoZone", "Workspace")
        out[iri] = SiteObject(iri, kind, str(label or _local(iri)), pose, (float(sx), float(sy), float(sz)),
                              solid, pickup)
    return tuple(out[k] for k in sorted(out))


def _workers(project: ProjectData) -> tuple[Worker, ...]:
    rows = run_named(project.model, "world_workers").rows
    by_worker: dict[str, list[tuple[Any, ...]]] = {}
    for row in rows:
        by_worker.setdefault(str(row[0]), []).append(row)
    out: list[Worker] = []
    for iri in sorted(by_worker):
        rs = by_worker[iri]
        first = rs[0]
        stops: dict[str, RouteStop] = {}
        for _w, _l, _r, _s, stop, order, loc, x, y, z, dwell in rs:
            if stop is None or str(stop) in stops:
                continue
            pos = (float(x), float(y), float(z)) if x is not None else None
            stops[str(stop)] = RouteStop(int(order) if order is not None else 0,
                                         str(loc) if loc is not None else None, pos, _opt_float(dwell))
        route = tuple(sorted(stops.values(), key=lambda s: (s.order, s.location or "")))
        position = next((s.position for s in route if s.position is not None), None)
        out.append(Worker(iri, str(first[1] or _local(iri)), str(first[2] or ""), _opt_float(first[3]),
                          position, route))
    return tuple(out)


def _layout_rows(project: ProjectData) -> tuple[int, Bounds | None, Pose | None]:
    rows = run_named(project.model, "world_layout").rows
    extent: Bounds | None = None
    start: Pose | None = None
    for _layout_iri, x0, y0, z0, x1, y1, z1, sx, sy, sz, syaw in rows:
        if extent is None and x0 is not None:
            extent = Bounds(float(x0), float(y0), float(z0), float(x1), float(y1), float(z1))
        if start is None and sx is not None:
            start = Pose(float(sx), float(sy), float(sz), 0.0, 0.0, float(syaw or 0.0))
    return len(rows), extent, start


def _align_to_storage(local: Bounds) -> Matrix:
    """Rotation (4x4) that lays a box flat: longest side along x, middle along y, thinnest up."""
    size = local.size
    order = sorted(range(3), key=lambda i: (-size[i], i))
    p = np.zeros((3, 3))
    for row, axis in enumerate(order):
        p[row, axis] = 1.0
    if np.linalg.det(p) < 0:
        p[2] *= -1.0
    m = np.eye(4)
    m[:3, :3] = p
    return m


def _stack(
    storage: SiteObject, members: list[tuple[WorldElement, Bounds]]
) -> list[tuple[WorldElement, Pose, Bounds]]:
    """Place the elements of one storage (sorted bottom first) flat on its top, one on the other."""
    placed: list[tuple[WorldElement, Pose, Bounds]] = []
    z = storage.size[2]  # in the storage frame: its top face
    top = pose_matrix(storage.pose)
    for element, local in members:
        align = _align_to_storage(local)
        cx, cy, cz = local.center
        centred = align @ _translation(-cx, -cy, -cz)  # element box centre at the origin, laid flat
        thickness = float(sorted(local.size)[0])
        place = top @ _translation(0.0, 0.0, z + thickness / 2) @ centred
        pose = matrix_to_pose(place)
        bounds = Bounds.of_points((np.c_[local.corners(), np.ones(8)] @ pose_matrix(pose).T)[:, :3])
        placed.append((element, pose, bounds))
        z += thickness
    return placed


@dataclass(frozen=True)
class _ElementRecord:
    """One building element as read from ``world_elements``: everything that does not depend on the date."""

    iri: str
    global_id: str
    name: str
    ifc_class: str
    kind: str
    storey: str | None
    mesh_file: str | None
    mesh_path: Path | None
    installed: Pose | None
    bounds: Bounds | None
    mass_kg: float | None
    mass_text: str | None
    is_door: bool
    static: WorldElement | None  # the static body (state built) when it has geometry


@dataclass(frozen=True)
class WorldTables:
    """The date-independent part of a project's worlds (A6), read from the model once.

    :func:`build_world` reads these tables from the graph every time it is called without them;
    building many worlds of one project (e.g. planning every robotized task,
    :func:`kbplanner.planning.planner.plan_tasks`) with one ``WorldTables`` reads the whole building once
    instead of once per world, and gives the same worlds. Made by :func:`world_tables`; valid while
    the project's model is not changed (build them again after editing the graph).
    """

    model_id: int  # id() of the project's model graph the tables were read from
    tasks: tuple[tuple[Any, ...], ...]  # rows of world_tasks
    storeys: tuple[StoreyInfo, ...]
    storey_of: dict[str, str]
    site_objects: tuple[SiteObject, ...]
    elements: tuple[_ElementRecord, ...]  # sorted by IRI
    workers: tuple[Worker, ...]
    layout_rows: int
    extent: Bounds | None
    robot_start: Pose | None
    schedule: dict[str, tuple[datetime, datetime]] | None  # element -> (finish, start); None: SPARQL per date
    arrivals: tuple[Pose, ...] = ()  # kbp:robotArrival poses of the first site layout, by elevation


def world_tables(project: ProjectData) -> WorldTables:
    """Read the date-independent tables of ``project``'s worlds (storeys, elements, site, workers, schedule).

    Example:
        >>> from kbplanner import Project
        >>> p = Project.load("data/case_study", scenario="storage-outside")  # doctest: +SKIP
        >>> tables = world_tables(p)  # doctest: +SKIP
        >>> build_world(p, datetime(2022, 5, 10, 7), tables=tables).task_id  # doctest: +SKIP
        'T-FRAME'
    """
    storeys, storey_of = _storeys(project)
    kinds: dict[str, list[str]] = {}
    for el, cls in run_named(project.model, "world_element_kinds").rows:
        kinds.setdefault(str(el), []).append(_local(str(cls)))
    storey_label = {s.iri: s.label for s in storeys}
    records: list[_ElementRecord] = []
    for iri, row in sorted(_first_rows(run_named(project.model, "world_elements").rows).items()):
        (_el, gid, label, ifc_class, mesh_file, x, y, z, roll, pitch, yaw,
         x0, y0, z0, x1, y1, z1, mass, mass_text, is_door) = row
        kind = sorted(kinds.get(iri) or ["Element"])[0]
        installed = (Pose(float(x), float(y), float(z), float(roll), float(pitch), float(yaw))
                     if x is not None else None)
        bounds = (Bounds(float(x0), float(y0), float(z0), float(x1), float(y1), float(z1))
                  if x0 is not None else None)
        storey = storey_of.get(iri)
        mesh_path = project.mesh_path(str(mesh_file)) if mesh_file else None
        name = str(label or gid)
        static: WorldElement | None = None
        if mesh_path is not None:
            group = f"{slug(storey_label.get(storey or '', NO_STOREY))}_{kind.lower()}"
            local_bounds = None
            if bounds is not None and installed is not None:
                local_bounds = Bounds.of_points(
                    (np.c_[bounds.corners(), np.ones(8)] @ np.linalg.inv(pose_matrix(installed)).T)[:, :3])
            static = WorldElement(
                iri=iri, global_id=str(gid), label=name, ifc_class=str(ifc_class or ""), kind=kind,
                storey=storey, state=BUILT, mesh_file=str(mesh_file), mesh_path=mesh_path,
                installed_pose=installed, pose=installed, bounds=bounds, local_bounds=local_bounds,
                mass_kg=_opt_float(mass), mass_assumption=str(mass_text) if mass_text else None, group=group,
            )
        records.append(_ElementRecord(
            iri=iri, global_id=str(gid), name=name, ifc_class=str(ifc_class or ""), kind=kind, storey=storey,
            mesh_file=str(mesh_file) if mesh_file else None, mesh_path=mesh_path, installed=installed,
            bounds=bounds, mass_kg=_opt_float(mass), mass_text=str(mass_text) if mass_text else None,
            is_door=bool(is_door), static=static))
    layout_rows, extent, start = _layout_rows(project)
    return WorldTables(
        model_id=id(project.model), tasks=tuple(run_named(project.model, "world_tasks").rows),
        storeys=storeys, storey_of=storey_of, site_objects=_site_objects(project), elements=tuple(records),
        workers=_workers(project), layout_rows=layout_rows, extent=extent, robot_start=start,
        schedule=_schedule_table(project), arrivals=_arrivals(project))


def _arrivals(project: ProjectData) -> tuple[Pose, ...]:
    """Where the robot is set down on other floors (``kbp:robotArrival`` of the first site layout)."""
    rows = run_named(project.model, "robot_arrivals").rows
    first = rows[0][0] if rows else None
    return tuple(Pose(float(x), float(y), float(z), 0.0, 0.0, float(yaw or 0.0))
                 for layout, _a, x, y, z, yaw in rows if layout == first)


def _schedule_table(project: ProjectData) -> dict[str, tuple[datetime, datetime]] | None:
    """Finish and start that decide each scheduled element's state (``world_element_schedule``).

    None when a finish or start is not a local date-time (e.g. one with a time zone): the states are
    then computed by ``element_state_at`` for each date, as SPARQL compares such values.
    """
    table: dict[str, tuple[datetime, datetime]] = {}
    for el, finish, start in run_named(project.model, "world_element_schedule").rows:
        if not (isinstance(finish, datetime) and isinstance(start, datetime)
                and finish.tzinfo is None and start.tzinfo is None):
            return None
        table.setdefault(str(el), (finish, start))
    return table


def _states_at(project: ProjectData, tables: WorldTables, at: datetime) -> dict[str, str]:
    """Every scheduled element's state at ``at`` (the rule of ``element_state_at``); others are built."""
    if at.tzinfo is not None or tables.schedule is None:
        from kbplanner.model.schedule import element_states  # raises QueryError for a date with a time zone

        rows = element_states(project.model, at)
        return {str(k): _STATE_NAMES.get(str(v), str(v)) for k, v in rows.items()}
    return {el: BUILT if finish < at else NOT_STARTED if start > at else IN_PROGRESS
            for el, (finish, start) in tables.schedule.items()}


def build_world(
    project: ProjectData,
    at: datetime,
    task_id: str | None = None,
    *,
    tables: WorldTables | None = None,
) -> World:
    """Build the world of ``project`` (its scenario) at ``at`` for the robotized task ``task_id``.

    ``task_id`` defaults to the manifest's ``[simulation] task`` (or the only robotized task).
    ``tables`` (:func:`world_tables` of the same project) saves reading the building again when
    several worlds are built; without them they are read here.

    Raises:
        WorldError: an unknown task id, or several robotized tasks and none chosen; tables read from
            another model.
        InputFileError: a mesh file of a task element is missing.
        QueryError: ``at`` has a time zone (schedule times are local site time).
    """
    if tables is None:
        tables = world_tables(project)
    elif tables.model_id != id(project.model):
        raise WorldError("the world tables given were read from another model", element=project.name,
                         fix="make them with world_tables(project) of this project")
    states = _states_at(project, tables, at)
    task = _resolve_task(project, task_id, tables.tasks)
    storeys, storey_of = tables.storeys, tables.storey_of
    site_objects = tables.site_objects
    storage_by_iri = {o.iri: o for o in site_objects}

    static: list[WorldElement] = []
    doors: list[OpenDoor] = []
    omitted: list[Omitted] = []
    task_members: dict[str, list[tuple[WorldElement, Bounds]]] = {}
    task_elements = task.elements if task else {}

    for rec in tables.elements:
        iri, kind, storey, mesh_path, name = rec.iri, rec.kind, rec.storey, rec.mesh_path, rec.name
        state = states.get(iri, BUILT)
        if iri in task_elements:
            storage_iri, index = task_elements[iri]
            storage = storage_by_iri.get(storage_iri) if storage_iri else None
            reason = ""
            if storage_iri is None:
                reason = ("task element without material storage: add kbp:storedIn (and kbp:stackIndex) "
                          "to the model, e.g. by loading a scenario that places the material")
            elif storage is None:
                reason = (f"its storage {storage_iri} has no pose or size: give it kbp:installedPose "
                          "and kbp:sizeX/Y/Z")
            elif mesh_path is None:
                reason = "task element without geometry (kbp:meshFile): it cannot be a body"
            if reason:
                omitted.append(Omitted(iri, rec.global_id, name, kind, state, reason))
                continue
            local_mesh_bounds = _local_bounds(mesh_path, rec.installed)  # type: ignore[arg-type]
            element = WorldElement(
                iri=iri, global_id=rec.global_id, label=name, ifc_class=rec.ifc_class, kind=kind,
                storey=storey, state=state, mesh_file=rec.mesh_file, mesh_path=mesh_path,
                installed_pose=rec.installed, pose=None, bounds=None, local_bounds=local_mesh_bounds,
                mass_kg=rec.mass_kg, mass_assumption=rec.mass_text,
                storage=storage_iri, stack_index=index,
            )
            if element.mass_kg is None:
                log.warning("task element %s has no kbp:mass: its body weighs an assumed %.0f kg",
                            name, ASSUMED_MASS_KG)
                element = _with(element, mass_assumption=f"assumed {ASSUMED_MASS_KG:g} kg: no kbp:mass")
            task_members.setdefault(str(storage_iri), []).append((element, local_mesh_bounds))
            continue
        if state == NOT_STARTED:
            omitted.append(Omitted(iri, rec.global_id, name, kind, state,
                                   "not started at the date: built by a later task"))
            continue
        if rec.is_door:
            doors.append(OpenDoor(iri, rec.global_id, name, storey, rec.bounds))
            continue
        if rec.static is None:
            omitted.append(Omitted(iri, rec.global_id, name, kind, state,
                                   "no geometry of its own (e.g. an aggregate whose parts are elements)"))
            continue
        static.append(rec.static if state == BUILT else _with(rec.static, state=state))

    placed: list[WorldElement] = []
    for storage_iri in sorted(task_members):
        members = sorted(task_members[storage_iri],
                         key=lambda m: (m[0].stack_index is None, m[0].stack_index or 0, m[0].iri))
        for element, pose, bounds in _stack(storage_by_iri[storage_iri], members):
            placed.append(_with(element, pose=pose, bounds=bounds))
    placed.sort(key=lambda e: (e.storage or "", e.stack_index is None, e.stack_index or 0, e.iri))

    extent, start = tables.extent, tables.robot_start
    if tables.layout_rows > 1:
        log.warning("%d site layouts in the model: using the first extent and robot start",
                    tables.layout_rows)
    ground_z = start.z if start is not None else 0.0
    task_storey = _task_storey(task, storey_of, storeys, ground_z)
    start = _start_on_storey(start, tables.arrivals, next((s for s in storeys if s.iri == task_storey), None),
                             ground_z)
    unplaced = [o for o in omitted if o.iri in task_elements]
    if unplaced:
        log.warning("%d of %d task elements not placed (first: %s): %s", len(unplaced), len(task_elements),
                    unplaced[0].label, unplaced[0].reason)
    world = World(
        project=project.name,
        scenario=project.scenario,
        at=at,
        task_id=task.task_id if task else None,
        task_iri=task.iri if task else None,
        task_label=task.label if task else None,
        storeys=storeys,
        static=tuple(static),
        task_elements=tuple(placed),
        open_doors=tuple(doors),
        omitted=tuple(sorted(omitted, key=lambda o: o.iri)),
        site_objects=site_objects,
        workers=tables.workers,
        site_extent=extent,
        robot_start=start,
        task_storey=task_storey,
        ground_z=ground_z,
        import_dir=project.import_dir,
    )
    log.info("world at %s: %s", at.isoformat(), world.summary())
    return world


def _with(element: WorldElement, **changes: Any) -> WorldElement:
    from dataclasses import replace

    return replace(element, **changes)


def _local_bounds(mesh_path: Path, installed: Pose | None) -> Bounds:
    mesh = load_mesh(mesh_path)
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    if installed is not None:
        vertices = trimesh.transform_points(vertices, np.linalg.inv(pose_matrix(installed)))
    return Bounds.of_points(vertices)


def _start_on_storey(start: Pose | None, arrivals: Sequence[Pose], storey: StoreyInfo | None,
                     ground_z: float) -> Pose | None:
    """The robot's start for a task on ``storey``: its arrival there (a lift landing), else the site start."""
    if storey is None or abs(storey.elevation_m - ground_z) <= GROUND_STOREY_TOLERANCE_M:
        return start
    here = [a for a in arrivals if abs(a.z - storey.elevation_m) <= GROUND_STOREY_TOLERANCE_M]
    if here:
        return here[0]
    log.warning("the task is on %s (%.2f m) but the site layout has no kbp:robotArrival at that elevation: "
                "the robot starts at the site's robot start; add a kbp:robotArrival pose (e.g. the lift "
                "landing) with z = %.2f", storey.label, storey.elevation_m, storey.elevation_m)
    return start


def _task_storey(
    task: _TaskInfo | None, storey_of: dict[str, str], storeys: Sequence[StoreyInfo], ground_z: float
) -> str | None:
    """The storey that contains most task elements (ties: the lower); else the ground storey."""
    if not storeys:
        return None
    if task is not None:
        counts = Counter(storey_of[e] for e in task.elements if e in storey_of)
        if counts:
            rank = {s.iri: i for i, s in enumerate(storeys)}
            return sorted(counts, key=lambda s: (-counts[s], rank.get(s, 0)))[0]
    return min(storeys, key=lambda s: (abs(s.elevation_m - ground_z), s.elevation_m)).iri


def ground_level_storey(world: World, storey: StoreyInfo) -> bool:
    """Whether a storey's floor is at ground level (outside the building is free ground there)."""
    return abs(storey.elevation_m - world.ground_z) <= GROUND_STOREY_TOLERANCE_M


def world_of(project: ProjectData, at: datetime | str | None = None, task_id: str | None = None) -> World:
    """A6: the world of a task at a date (default: the task's :meth:`ProjectData.world_date`)."""
    when = at if at is not None else project.world_date(task_id)
    if isinstance(when, str):
        when = parse_date(when)
    return build_world(project, when, task_id=task_id)
