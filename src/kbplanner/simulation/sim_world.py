"""A6 -> B5: load the world at a date into a PyBullet client.

Takes a :class:`~kbplanner.world.world_types.World` and a connected PyBullet client (``p.connect(p.DIRECT)``);
creates, and returns the handles of (:class:`SimWorld`):

- a ground plane at the ground level (``World.ground_z``);
- the static elements merged into few bodies: one per storey and class (``World.static_groups``),
  each a concave triangle mesh (``GEOM_FORCE_CONCAVE_TRIMESH``) with mass 0; a group larger than
  PyBullet's in-memory mesh limit is split into chunks of whole elements (one body each);
- each task element as its own dynamic body at its storage pose: a box collision shape (its extents
  in its own frame) centred on the box, mass from the model (``kbp:mass``, else the assumed mass
  said in the world), inertia of that box about its centre. PyBullet reports a body's position as
  its centre of mass; :func:`element_frame` gives the element's own frame back;
- solid site objects as static boxes. Areas (workspaces, no-go zones) are no bodies; workers are
  not loaded (their motion belongs to the executor).

Gravity is set to -9.81 m/s2 along z unless ``gravity=False``. Visual shapes (meshes for
TinyRenderer images) are added with ``visuals=True``; collision-only bodies load faster.

Example:
    >>> import pybullet as p
    >>> client = p.connect(p.DIRECT)  # doctest: +SKIP
    >>> sim = load_world(world, client)  # doctest: +SKIP
    >>> sim.task_bodies[world.task_elements[0].iri]  # doctest: +SKIP
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import pybullet as p
import trimesh

from kbplanner.core.errors import KbplannerError
from kbplanner.simulation import static_store
from kbplanner.world.meshes import element_local_mesh, element_mesh
from kbplanner.world.world_types import SiteObject, World, WorldElement

log = logging.getLogger(__name__)

# PyBullet refuses in-memory meshes much above 2^17 vertices; stay well below it.
MAX_VERTICES_PER_SHAPE = 100_000
MAX_FACES_PER_SHAPE = 150_000
GRAVITY_MPS2 = 9.81
TASK_FRICTION = 0.8  # timber on timber (stacked frames stay put)

_RGBA_STATIC = (0.8, 0.8, 0.78, 1.0)
# Key frames tell floors from walls: static bodies are coloured by the class of their merge group.
_RGBA_BY_KIND = {"slab": (0.86, 0.84, 0.78, 1.0), "covering": (0.86, 0.84, 0.78, 1.0),
                 "roof": (0.7, 0.55, 0.5, 1.0), "wall": (0.45, 0.47, 0.52, 1.0),
                 "door": (0.6, 0.42, 0.25, 1.0), "window": (0.55, 0.7, 0.85, 1.0),
                 "stair": (0.65, 0.6, 0.55, 1.0)}


def _static_colour(name: str) -> tuple[float, float, float, float]:
    """The colour of a merged static body by the class in its group name (``level-1_wall#0``)."""
    kind = name.split("#", 1)[0].rsplit("_", 1)[-1].lower()
    return _RGBA_BY_KIND.get(kind, _RGBA_STATIC)
_RGBA_TASK = (0.87, 0.67, 0.35, 1.0)
_RGBA_SITE = (0.94, 0.59, 0.16, 1.0)


@dataclass
class SimWorld:
    """Body ids of a loaded world in one PyBullet client."""

    client: int
    ground: int
    static_bodies: dict[str, tuple[int, ...]] = field(default_factory=dict)  # group -> bodies
    element_bodies: dict[str, int] = field(default_factory=dict)  # every present element IRI -> body
    task_bodies: dict[str, int] = field(default_factory=dict)  # task element IRI -> its own body
    site_object_bodies: dict[str, int] = field(default_factory=dict)  # solid site object IRI -> body
    load_seconds: float = 0.0
    triangles: int = 0

    @property
    def body_count(self) -> int:
        """Bodies created (ground, static chunks, task elements, site objects)."""
        return (1 + sum(len(v) for v in self.static_bodies.values()) + len(self.task_bodies)
                + len(self.site_object_bodies))

    def body_of(self, iri: str) -> int:
        """The body of an element or site object.

        Raises:
            KbplannerError: the IRI is not a body of this world.
        """
        body = self.element_bodies.get(iri, self.site_object_bodies.get(iri))
        if body is None:
            raise KbplannerError("no body for this IRI in the loaded world", element=iri,
                                 fix="use an IRI of a present element or solid site object (world.json)")
        return body


def _chunks(elements: Sequence[WorldElement]) -> list[list[tuple[WorldElement, trimesh.Trimesh]]]:
    """Whole elements with their meshes, grouped so that each chunk fits one PyBullet mesh shape."""
    chunks: list[list[tuple[WorldElement, trimesh.Trimesh]]] = [[]]
    nv = nf = 0
    for e in elements:
        mesh = element_mesh(e)
        if mesh is None or not len(mesh.faces):
            continue
        if chunks[-1] and (nv + len(mesh.vertices) > MAX_VERTICES_PER_SHAPE
                           or nf + len(mesh.faces) > MAX_FACES_PER_SHAPE):
            chunks.append([])
            nv = nf = 0
        chunks[-1].append((e, mesh))
        nv += len(mesh.vertices)
        nf += len(mesh.faces)
    return [c for c in chunks if c]


def _merged(meshes: Sequence[trimesh.Trimesh]) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    vertices: list[np.ndarray] = []
    faces: list[np.ndarray] = []
    offset = 0
    for m in meshes:
        vertices.append(np.asarray(m.vertices, dtype=np.float64))
        faces.append(np.asarray(m.faces, dtype=np.int64) + offset)
        offset += len(m.vertices)
    return np.concatenate(vertices), np.concatenate(faces)


def static_chunks(world: World) -> list[static_store.Chunk]:
    """The static bodies' triangles: every static group's chunks (:func:`_chunks`), their meshes merged;
    read from the kept folder given now when an earlier run kept them (:mod:`~.static_store`), else made
    from the mesh files and kept there."""
    kept = static_store.read(world)
    if kept is not None:
        return kept
    chunks: list[static_store.Chunk] = []
    for group, members in world.static_groups().items():
        for chunk in _chunks(members):
            vertices, faces = _merged([m for _, m in chunk])
            chunks.append(static_store.Chunk(group, tuple(e.iri for e, _ in chunk), vertices, faces))
    static_store.write(world, chunks)
    return chunks


def _check(value: int, what: str, name: str) -> int:
    if value < 0:
        raise KbplannerError(f"PyBullet could not create the {what}", element=name,
                             fix="check the element's mesh (kbplanner world --out DIR writes it as .obj)")
    return value


def _static_body(client: int, name: str, chunk: static_store.Chunk, visuals: bool) -> int:
    vertices, indices = chunk.vertices.tolist(), chunk.faces.ravel().tolist()
    shape = _check(p.createCollisionShape(p.GEOM_MESH, vertices=vertices, indices=indices,
                                          flags=p.GEOM_FORCE_CONCAVE_TRIMESH, physicsClientId=client),
                   "concave mesh shape", name)
    visual = -1
    if visuals:
        visual = p.createVisualShape(p.GEOM_MESH, vertices=vertices, indices=indices,
                                     rgbaColor=_static_colour(name), physicsClientId=client)
    return _check(p.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=shape, baseVisualShapeIndex=visual,
                                    physicsClientId=client), "static body", name)


def _task_body(client: int, e: WorldElement, visuals: bool) -> int:
    if e.pose is None or e.local_bounds is None:
        raise KbplannerError("a task element without pose or geometry cannot be a body", element=e.iri,
                             fix="place it at a storage (kbp:storedIn) with a mesh")
    centre = list(e.local_bounds.center)
    half = [max(s / 2, 1e-4) for s in e.local_bounds.size]
    shape = _check(p.createCollisionShape(p.GEOM_BOX, halfExtents=half, collisionFramePosition=centre,
                                          physicsClientId=client), "box shape", e.iri)
    visual = -1
    if visuals:
        mesh = element_local_mesh(e)
        if mesh is not None and len(mesh.faces):
            visual = p.createVisualShape(p.GEOM_MESH, vertices=np.asarray(mesh.vertices).tolist(),
                                         indices=np.asarray(mesh.faces).ravel().tolist(),
                                         rgbaColor=_RGBA_TASK, physicsClientId=client)
    body = _check(p.createMultiBody(
        baseMass=e.body_mass_kg, baseCollisionShapeIndex=shape, baseVisualShapeIndex=visual,
        basePosition=[e.pose.x, e.pose.y, e.pose.z],
        baseOrientation=p.getQuaternionFromEuler([e.pose.roll, e.pose.pitch, e.pose.yaw]),
        baseInertialFramePosition=centre, physicsClientId=client), "task body", e.iri)
    p.changeDynamics(body, -1, lateralFriction=TASK_FRICTION, physicsClientId=client)
    return int(body)


def _site_body(client: int, obj: SiteObject, visuals: bool) -> int:
    half = [max(s / 2, 1e-4) for s in obj.size]
    shape = _check(p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=client),
                   "box shape", obj.iri)
    visual = -1
    if visuals:
        visual = p.createVisualShape(p.GEOM_BOX, halfExtents=half, rgbaColor=_RGBA_SITE,
                                     physicsClientId=client)
    centre = obj.box_center
    return _check(p.createMultiBody(
        baseMass=0.0, baseCollisionShapeIndex=shape, baseVisualShapeIndex=visual,
        basePosition=centre[:3, 3].tolist(),
        baseOrientation=p.getQuaternionFromEuler([obj.pose.roll, obj.pose.pitch, obj.pose.yaw]),
        physicsClientId=client), "site object body", obj.iri)


def load_world(world: World, client: int, *, visuals: bool = False, gravity: bool = True) -> SimWorld:
    """Create the world's bodies in a connected PyBullet client (see module docstring)."""
    started = time.perf_counter()
    if gravity:
        p.setGravity(0.0, 0.0, -GRAVITY_MPS2, physicsClientId=client)
    plane = _check(p.createCollisionShape(p.GEOM_PLANE, physicsClientId=client), "ground plane", "ground")
    ground = p.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=plane,
                               basePosition=[0.0, 0.0, world.ground_z], physicsClientId=client)
    sim = SimWorld(client=client, ground=int(ground))
    for chunk in static_chunks(world):  # (in the order of the groups, then of each group's chunks)
        bodies = sim.static_bodies.get(chunk.group, ())
        body = _static_body(client, f"{chunk.group}#{len(bodies)}", chunk, visuals)
        sim.static_bodies[chunk.group] = (*bodies, body)
        sim.triangles += len(chunk.faces)
        for iri in chunk.iris:
            sim.element_bodies[iri] = body
    for e in world.task_elements:
        body = _task_body(client, e, visuals)
        sim.task_bodies[e.iri] = body
        sim.element_bodies[e.iri] = body
    for obj in world.solid_site_objects:
        sim.site_object_bodies[obj.iri] = _site_body(client, obj, visuals)
    sim.load_seconds = time.perf_counter() - started
    log.info("PyBullet world: %d bodies (%d static groups, %d task elements, %d site objects), "
             "%d triangles, %.2f s", sim.body_count, len(sim.static_bodies), len(sim.task_bodies),
             len(sim.site_object_bodies), sim.triangles, sim.load_seconds)
    return sim


def element_frame(sim: SimWorld, element: WorldElement) -> npt.NDArray[np.float64]:
    """The 4x4 transform of a task element's own frame now (PyBullet reports the body's centre of mass).

    Composed with the element's local mesh it gives the mesh where the body is.
    """
    body = sim.task_bodies.get(element.iri)
    if body is None or element.local_bounds is None:
        raise KbplannerError("not a task element body of this world", element=element.iri,
                             fix="pass one of world.task_elements")
    pos, orn = p.getBasePositionAndOrientation(body, physicsClientId=sim.client)
    com = np.eye(4)
    com[:3, :3] = np.asarray(p.getMatrixFromQuaternion(orn), dtype=np.float64).reshape(3, 3)
    com[:3, 3] = pos
    offset = np.eye(4)
    offset[:3, 3] = element.local_bounds.center
    return np.asarray(com @ np.linalg.inv(offset), dtype=np.float64)


def settle(sim: SimWorld, seconds: float = 1.0, time_step_s: float = 1.0 / 240.0) -> float:
    """Step the simulation for ``seconds``; returns the largest displacement (m) of a task element body.

    A world whose task elements rest stably on their storage gives (almost) zero.
    """
    start = {iri: np.array(p.getBasePositionAndOrientation(b, physicsClientId=sim.client)[0])
             for iri, b in sim.task_bodies.items()}
    p.setTimeStep(time_step_s, physicsClientId=sim.client)
    for _ in range(max(1, round(seconds / time_step_s))):
        p.stepSimulation(physicsClientId=sim.client)
    moved = 0.0
    for iri, b in sim.task_bodies.items():
        now = np.array(p.getBasePositionAndOrientation(b, physicsClientId=sim.client)[0])
        moved = max(moved, float(np.linalg.norm(now - start[iri])))
    return moved
