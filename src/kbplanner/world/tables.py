"""A6, the world's tables: what does not depend on the date or the task (elements, storeys, site
objects, workers, schedule windows), read from the model by named SPARQL queries, once per project;
the robotized task resolved, task elements stacked at their storage."""

from __future__ import annotations

import logging
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from rdflib import URIRef

from kbplanner.core.errors import WorldError
from kbplanner.core.iris import slug
from kbplanner.core.named_queries import QueryResult, run_named
from kbplanner.knowledge.material_flow import MaterialFlow, material_flow
from kbplanner.knowledge.task_specs import robotized_tasks, task_specification
from kbplanner.model.poses import Pose, matrix_to_pose
from kbplanner.world.world_types import (
    BUILT,
    IN_PROGRESS,
    NO_STOREY,
    NOT_STARTED,
    STATE_NAMES,
    Bounds,
    Matrix,
    RouteStop,
    SiteObject,
    StoreyInfo,
    Worker,
    WorldElement,
    pose_matrix,
    translation,
)

if TYPE_CHECKING:
    from kbplanner.model.project_data import ProjectData

log = logging.getLogger(__name__)

# The queries the tables are read from, (name, on the model + knowledge base); unbound, so their rows
# are kept in the project cache (ProjectData.pristine_rows).
TABLE_QUERIES: tuple[tuple[str, bool], ...] = (
    ("world_storeys", False), ("world_element_kinds", False), ("world_elements", False),
    ("world_layout", False), ("world_tasks", False), ("world_site_objects", True), ("world_workers", False),
    ("world_element_schedule", False), ("robot_arrivals", False),
)


# --------------------------------------------------------------------------------------------
# Tables read from the model
# --------------------------------------------------------------------------------------------


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
class TaskInfo:
    iri: str
    task_id: str
    label: str
    elements: dict[str, tuple[str | None, int | None]]  # element IRI -> (storage, stack index)
    material: bool = True  # False: the specification picks nothing, its elements are targets, not material
    storage_note: str = ""  # why an element has no storage (for World.omitted)


def resolve_task(project: ProjectData, task_id: str | None,
                  tasks: Sequence[tuple[Any, ...]] | None = None) -> TaskInfo | None:
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
    flow, note = _material_flow(project, task_id)
    if flow is not None and not flow.handles_material:
        return TaskInfo(str(row[0]), task_id, str(row[2] or task_id), {}, material=False)
    rows = run_named(project.model, "world_task_elements", taskId=task_id).rows
    for _task, _tid, el, index in rows:
        storages = flow.storages(project.model, URIRef(str(el))) if flow is not None else []
        # several storages: the first (by IRI) wins, deterministically
        elements[str(el)] = (str(storages[0]) if storages else None,
                             int(index) if index is not None else None)
    return TaskInfo(str(row[0]), task_id, str(row[2] or task_id), elements, storage_note=note)


def _material_flow(project: ProjectData, task_id: str) -> tuple[MaterialFlow | None, str]:
    """The material flow of the task's specification (None, with why, when the task has none)."""
    found = [t for t in robotized_tasks(project.model, task_id) if t.task_id == task_id]
    spec_id = found[0].spec_id if found else None
    if spec_id is None:
        return None, ("task element without material storage: the task has no task specification "
                      "(kbp:taskSpecificationId) to say where its material waits (kbp:materialStoragePath)")
    return material_flow(project.kb, task_specification(project.kb, spec_id, task=task_id)), ""


def _storeys(rows: dict[str, QueryResult]) -> tuple[tuple[StoreyInfo, ...], dict[str, str]]:
    storeys: dict[str, StoreyInfo] = {}
    of_element: dict[str, str] = {}
    for storey, label, elevation, element in rows["world_storeys"].rows:
        s = str(storey)
        if s not in storeys:
            storeys[s] = StoreyInfo(s, str(label or _local(s)), float(elevation or 0.0))
        if element is not None:
            # An element in two storeys (rare; e.g. through a space) keeps the lower one.
            of_element.setdefault(str(element), s)
    ordered = tuple(sorted(storeys.values(), key=lambda s: (s.elevation_m, s.label, s.iri)))
    return ordered, of_element


def _site_objects(rows: dict[str, QueryResult]) -> tuple[SiteObject, ...]:
    out: dict[str, SiteObject] = {}
    for row in rows["world_site_objects"].rows:
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


def _workers(tables: dict[str, QueryResult]) -> tuple[Worker, ...]:
    rows = tables["world_workers"].rows
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


def _layout_rows(tables: dict[str, QueryResult]) -> tuple[int, Bounds | None, Pose | None]:
    rows = tables["world_layout"].rows
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


def stack(
    storage: SiteObject, members: list[tuple[WorldElement, Bounds]]
) -> list[tuple[WorldElement, Pose, Bounds]]:
    """Place the elements of one storage (sorted bottom first) flat on its top, one on the other."""
    placed: list[tuple[WorldElement, Pose, Bounds]] = []
    z = storage.size[2]  # in the storage frame: its top face
    top = pose_matrix(storage.pose)
    for element, local in members:
        align = _align_to_storage(local)
        cx, cy, cz = local.center
        centred = align @ translation(-cx, -cy, -cz)  # element box centre at the origin, laid flat
        thickness = float(sorted(local.size)[0])
        place = top @ translation(0.0, 0.0, z + thickness / 2) @ centred
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
    rows = project.pristine_rows(TABLE_QUERIES)  # from the project cache when the graphs are as loaded
    storeys, storey_of = _storeys(rows)
    kinds: dict[str, list[str]] = {}
    for el, cls in rows["world_element_kinds"].rows:
        kinds.setdefault(str(el), []).append(_local(str(cls)))
    storey_label = {s.iri: s.label for s in storeys}
    records: list[_ElementRecord] = []
    for iri, row in sorted(_first_rows(rows["world_elements"].rows).items()):
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
    layout_rows, extent, start = _layout_rows(rows)
    return WorldTables(
        model_id=id(project.model), tasks=tuple(rows["world_tasks"].rows),
        storeys=storeys, storey_of=storey_of, site_objects=_site_objects(rows), elements=tuple(records),
        workers=_workers(rows), layout_rows=layout_rows, extent=extent, robot_start=start,
        schedule=_schedule_table(rows), arrivals=_arrivals(rows))


def _arrivals(tables: dict[str, QueryResult]) -> tuple[Pose, ...]:
    """Where the robot is set down on other floors (``kbp:robotArrival`` of the first site layout)."""
    rows = tables["robot_arrivals"].rows
    first = rows[0][0] if rows else None
    return tuple(Pose(float(x), float(y), float(z), 0.0, 0.0, float(yaw or 0.0))
                 for layout, _a, x, y, z, yaw in rows if layout == first)


def _schedule_table(rows: dict[str, QueryResult]) -> dict[str, tuple[datetime, datetime]] | None:
    """Finish and start that decide each scheduled element's state (``world_element_schedule``).

    None when a finish or start is not a local date-time (e.g. one with a time zone): the states are
    then computed by ``element_state_at`` for each date, as SPARQL compares such values.
    """
    table: dict[str, tuple[datetime, datetime]] = {}
    for el, finish, start in rows["world_element_schedule"].rows:
        if not (isinstance(finish, datetime) and isinstance(start, datetime)
                and finish.tzinfo is None and start.tzinfo is None):
            return None
        table.setdefault(str(el), (finish, start))
    return table


def states_at(project: ProjectData, tables: WorldTables, at: datetime) -> dict[str, str]:
    """Every scheduled element's state at ``at`` (the rule of ``element_state_at``); others are built."""
    if at.tzinfo is not None or tables.schedule is None:
        from kbplanner.model.schedule import element_states  # raises QueryError for a date with a time zone

        rows = element_states(project.model, at)
        return {str(k): STATE_NAMES.get(str(v), str(v)) for k, v in rows.items()}
    return {el: BUILT if finish < at else NOT_STARTED if start > at else IN_PROGRESS
            for el, (finish, start) in tables.schedule.items()}


