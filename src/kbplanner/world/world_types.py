"""A6, the typed world: element states, poses and bounds, and the records of a :class:`World`
(elements, doors, omitted elements, site objects, workers, storeys)."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from kbplanner.core.vocab import KBP
from kbplanner.model.poses import Pose

if TYPE_CHECKING:
    pass

log = logging.getLogger(__name__)


Matrix = npt.NDArray[np.float64]


BUILT = "built"
IN_PROGRESS = "in progress"
NOT_STARTED = "not started"
STATE_NAMES = {str(KBP.Built): BUILT, str(KBP.InProgress): IN_PROGRESS, str(KBP.NotStarted): NOT_STARTED}

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
        return cls(*(round_um(v) for v in (*lo, *hi)))

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


def translation(x: float, y: float, z: float) -> Matrix:
    """The 4x4 transform of a pure translation."""
    m = np.eye(4)
    m[:3, 3] = [x, y, z]
    return m


def round_um(v: float) -> float:
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
        return pose_matrix(self.pose) @ translation(0.0, 0.0, self.size[2] / 2)

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
        """The storey with this IRI (or label; or GlobalId, the IRI's last segment, when no label has it)."""
        found = next((s for s in self.storeys if iri in (s.iri, s.label)), None)
        if found is None and iri:
            found = next((s for s in self.storeys if s.iri.rsplit("/", 1)[-1] == iri), None)
        return found

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

