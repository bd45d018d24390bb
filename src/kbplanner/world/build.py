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
  ``[simulation] task``) are separate movable bodies at their material storage (the path of the task
  specification's ``kbp:materialStoragePath``, :mod:`kbplanner.knowledge.material_flow`), whatever
  their state at the date. A specification that picks nothing handles no material: its elements
  are targets and stand (or not) by their state like any other element. Layout, deterministic:
  each element lies flat on the storage top: its longest side along the storage's local x, its
  middle side along local y, its thinnest side (its thickness) vertical; elements of one storage
  are stacked in ``kbp:stackIndex`` order (0 = bottom; elements without an index follow, by IRI),
  each resting on the one below (heights add up, so elements of different thickness never
  overlap), centred on the storage footprint.
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
from collections import Counter
from collections.abc import Sequence
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import trimesh

from kbplanner.core.errors import WorldError
from kbplanner.model.dates import parse_date
from kbplanner.model.poses import Pose
from kbplanner.world.meshes import (
    load_mesh,
)
from kbplanner.world.tables import (
    TaskInfo,
    WorldTables,
    resolve_task,
    stack,
    states_at,
    world_tables,
)
from kbplanner.world.world_types import (
    ASSUMED_MASS_KG,
    BUILT,
    GROUND_STOREY_TOLERANCE_M,
    NOT_STARTED,
    Bounds,
    Omitted,
    OpenDoor,
    StoreyInfo,
    World,
    WorldElement,
    pose_matrix,
)

if TYPE_CHECKING:
    from kbplanner.model.project_data import ProjectData

log = logging.getLogger(__name__)


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
    states = states_at(project, tables, at)
    task = resolve_task(project, task_id, tables.tasks)
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
                reason = task.storage_note if task is not None and task.storage_note else (
                    "task element without material storage: the path of the task specification's "
                    "kbp:materialStoragePath (e.g. kbp:storedIn) reaches no storage; add it to the model, "
                    "e.g. by loading a scenario that places the material")
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
        for element, pose, bounds in stack(storage_by_iri[storage_iri], members):
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
    task: TaskInfo | None, storey_of: dict[str, str], storeys: Sequence[StoreyInfo], ground_z: float
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


def world_of(project: ProjectData, at: datetime | str | None = None, task_id: str | None = None, *,
             tables: WorldTables | None = None) -> World:
    """A6: the world of a task at a date (default: the task's :meth:`ProjectData.world_date`); ``tables``
    (:func:`world_tables` of the same project) saves reading the building again (several tasks)."""
    when = at if at is not None else project.world_date(task_id)
    if isinstance(when, str):
        when = parse_date(when)
    return build_world(project, when, task_id=task_id, tables=tables)

