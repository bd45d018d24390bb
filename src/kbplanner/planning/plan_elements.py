"""B1, the elements of a plan: each element of the task with its mass, size, installed and storage pose.

:func:`plan_elements` reads the task's elements by SPARQL (``plan_element_info``), in the work order
given; size = extents of the element mesh in its own (installed-pose) frame (:func:`local_size`);
storage pose = where :func:`kbplanner.world.build.build_world` placed the element at its storage
(``None`` when it could not be placed). Elements without pose, mesh or storage pose are listed in the
plan notes with the reason. Used by :mod:`kbplanner.planning.planner`.
"""

from __future__ import annotations

import numpy as np
import trimesh
from rdflib import URIRef
from rdflib.term import Node

from kbplanner.core.literals import literal_float as _f
from kbplanner.knowledge.knowledge_base import curie, select
from kbplanner.knowledge.task_specs import RobotizedTask
from kbplanner.model.poses import Pose
from kbplanner.model.project_data import ProjectData
from kbplanner.planning.plan_model import ElementInfo, Pose6
from kbplanner.world.meshes import load_mesh
from kbplanner.world.world_types import World, pose_matrix


def local_size(project: ProjectData, mesh_file: str, installed: Pose6) -> tuple[float, float, float]:
    """Extents (m) of an element's mesh along its own x, y, z: the mesh moved into its installed frame.

    Raises:
        InputFileError: the mesh file is missing or unreadable.
    """
    mesh = load_mesh(project.mesh_path(mesh_file))
    pose = Pose(installed.x, installed.y, installed.z, installed.roll, installed.pitch, installed.yaw)
    pts = trimesh.transform_points(np.asarray(mesh.vertices, dtype=np.float64),
                                   np.linalg.inv(pose_matrix(pose)))
    if len(pts) == 0:
        return (0.0, 0.0, 0.0)
    ext = pts.max(axis=0) - pts.min(axis=0)
    return (round(float(ext[0]), 6) + 0.0, round(float(ext[1]), 6) + 0.0, round(float(ext[2]), 6) + 0.0)


def _pose6(p: Pose) -> Pose6:
    return Pose6(p.x, p.y, p.z, p.roll, p.pitch, p.yaw)


def plan_elements(project: ProjectData, task: RobotizedTask, order: tuple[URIRef, ...], world: World,
                  notes: list[str]) -> list[ElementInfo]:
    """The task's elements in ``order`` as :class:`ElementInfo`; what is lacking is added to ``notes``."""
    rows: dict[URIRef, dict[str, Node | None]] = {}
    for r in select(project.model, "plan_element_info", task=task.iri):
        el = r["element"]
        if isinstance(el, URIRef):
            rows.setdefault(el, r)
    at_storage = {e.iri: e for e in world.task_elements}
    out: list[ElementInfo] = []
    no_pose: list[str] = []
    no_mesh: list[str] = []
    for el in order:
        r = rows[el]
        gid = str(r["globalId"]) if r["globalId"] is not None else curie(project.model, el)
        nums = [_f(r[k]) for k in ("x", "y", "z")]
        angles = [_f(r[k]) or 0.0 for k in ("roll", "pitch", "yaw")]
        if any(v is None for v in nums):
            no_pose.append(gid)
            installed = Pose6(0.0, 0.0, 0.0)
        else:
            installed = Pose6(*(float(v or 0.0) for v in nums), *angles)
        mesh_file = str(r["meshFile"]) if r["meshFile"] is not None else None
        size = (0.0, 0.0, 0.0)
        if mesh_file is not None:
            size = local_size(project, mesh_file, installed)
        else:
            no_mesh.append(gid)
        placed = at_storage.get(str(el))
        out.append(ElementInfo(
            iri=str(el), global_id=gid, label=str(r["label"]) if r["label"] is not None else gid,
            mass_kg=_f(r["mass"]), size_m=size, installed_pose=installed,
            storage_pose=_pose6(placed.pose) if placed is not None and placed.pose is not None else None,
            mesh_file=mesh_file))
    if no_pose:
        notes.append(f"{len(no_pose)} element(s) have no installed pose (first: {no_pose[0]}): "
                     "installed_pose is 0, 0, 0 there")
    if no_mesh:
        notes.append(f"{len(no_mesh)} element(s) have no mesh (kbp:meshFile; first: {no_mesh[0]}): "
                     "size 0, 0, 0")
    by_reason: dict[str, list[str]] = {}
    for o in world.unplaced():
        if URIRef(o.iri) in rows:
            by_reason.setdefault(o.reason, []).append(o.global_id)
    for reason, gids in sorted(by_reason.items()):
        notes.append(f"{len(gids)} element(s) have no storage pose (first: {sorted(gids)[0]}): {reason}")
    return out

