"""A6 exports of the world at a date: occupancy maps, SDF (Gazebo) and glTF files, world.json.

Takes a :class:`~kbplanner.world.world_types.World` and writes, into a directory:

- ``map.pgm`` + ``map.yaml``: the occupancy grid (ROS map_server format) of one storey, by default
  the storey of the robotized task. Obstacles are what lies within the robot's height band above
  that storey's floor (a band, not one slice: ``floor + floor_clearance_m`` to
  ``floor + robot_height_m``): the static element meshes (doors are open, so they are not there),
  the solid site objects, and the no-go zones (marked occupied: the robot must not enter them;
  workspaces stay free). Task elements at their storage are left out (they move; their storage is a
  solid site object). The grid covers the site extent (``kbp:siteExtent``; without one, the
  obstacles' box plus a margin). On a storey at ground level the site outside the building is free
  ground; on any other storey a cell is free only where a built floor is under it (the top of a
  static element within 0.3 m below the floor level), so the robot never drives off a slab edge
  or into a stair opening.
- ``world_existing.sdf``: an SDF 1.6 world with everything static (the paper's layout): a ground
  plane, one model per merged group of static elements (storey and class) whose mesh is written to
  ``meshes/static_<group>.obj`` (site frame, referenced relatively), and one box model per solid
  site object. Areas are no bodies and are not in it (they are in world.json).
- ``element_<GlobalId>.sdf``: one SDF model per element to install, at its storage pose, with
  its mass, a box collision, box inertia about the box centre and its mesh
  (``meshes/element_<GlobalId>.obj``, in the element's own frame).
- ``world.glb``: the whole world as one glTF scene (static groups, task elements at storage, solid
  site objects), converted to glTF's y-up convention (site x, y, z -> glTF x, z, -y) so viewers
  show it upright; node names say what each node is.
- ``world.json``: the typed world (counts, elements with their states, site objects, workers) and
  the map's figures.

All output is deterministic: sorted iteration, fixed number formatting, no time stamps or random
ids; writing twice gives byte-identical files.
"""

from __future__ import annotations

import json
import logging
import time
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from kbplanner.core.errors import KbplannerError
from kbplanner.core.outputs import atomic_write_bytes
from kbplanner.world.maps import MapSettings, StoreyMap, storey_map, write_map
from kbplanner.world.meshes import element_local_mesh, group_mesh
from kbplanner.world.world_types import World, WorldElement, pose_matrix

log = logging.getLogger(__name__)


SDF_VERSION = "1.6"
MESH_DIR = "meshes"

# Site frame (z up) -> glTF (y up): x stays, z becomes y, y becomes -z.
Y_UP = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])

_COLOURS: dict[str, tuple[int, int, int, int]] = {
    "Wall": (200, 200, 195, 255), "Slab": (160, 160, 160, 255), "Window": (150, 190, 230, 160),
    "Roof": (140, 90, 70, 255), "Beam": (120, 120, 140, 255), "Column": (120, 120, 140, 255),
    "Member": (190, 150, 100, 255), "Stair": (170, 170, 170, 255), "task": (222, 170, 90, 255),
    "site": (240, 150, 40, 255),
}
_DEFAULT_COLOUR = (180, 180, 180, 255)



# --------------------------------------------------------------------------------------------
# Meshes and SDF
# --------------------------------------------------------------------------------------------


def _num(v: float) -> str:
    r = round(float(v), 6) + 0.0
    return repr(r)


def _vec(values: Sequence[float]) -> str:
    return " ".join(_num(v) for v in values)


def _pose_text(x: float, y: float, z: float, roll: float, pitch: float, yaw: float) -> str:
    return _vec((x, y, z, roll, pitch, yaw))


def obj_bytes(mesh: trimesh.Trimesh) -> bytes:
    """A mesh as Wavefront OBJ text (positions and faces only; 6 decimals): stable bytes."""
    text = trimesh.exchange.obj.export_obj(mesh, include_normals=False, include_color=False,
                                           include_texture=False, digits=6)
    return str(text).encode("utf-8")


def _sub(parent: ET.Element, tag: str, text: str | None = None, **attrib: str) -> ET.Element:
    el = ET.SubElement(parent, tag, attrib)
    if text is not None:
        el.text = text
    return el


def _xml_bytes(root: ET.Element) -> bytes:
    ET.indent(root, space="  ")
    body = ET.tostring(root, encoding="unicode", short_empty_elements=True)
    return ('<?xml version="1.0" encoding="UTF-8"?>\n' + body + "\n").encode("utf-8")


def _mesh_geometry(parent: ET.Element, uri: str) -> None:
    geometry = _sub(parent, "geometry")
    mesh = _sub(geometry, "mesh")
    _sub(mesh, "uri", uri)


def _box_geometry(parent: ET.Element, size: Sequence[float]) -> None:
    geometry = _sub(parent, "geometry")
    box = _sub(geometry, "box")
    _sub(box, "size", _vec(size))


def _ground_model(world_el: ET.Element, ground_z: float) -> None:
    model = _sub(world_el, "model", name="ground_plane")
    _sub(model, "static", "true")
    _sub(model, "pose", _pose_text(0.0, 0.0, ground_z, 0.0, 0.0, 0.0))
    link = _sub(model, "link", name="link")
    for tag in ("collision", "visual"):
        part = _sub(link, tag, name=tag)
        geometry = _sub(part, "geometry")
        plane = _sub(geometry, "plane")
        _sub(plane, "normal", "0 0 1")
        _sub(plane, "size", "200 200")


def static_group_name(group: str) -> str:
    """Model and mesh file stem of a static group."""
    return f"static_{group}"


def element_model_name(element: WorldElement) -> str:
    """Model and file stem of a task element: ``element_<GlobalId>``."""
    return f"element_{element.global_id}"


def write_world_existing_sdf(world: World, directory: Path) -> list[Path]:
    """Write ``world_existing.sdf`` and the static group meshes; returns the files written."""
    directory = Path(directory)
    written: list[Path] = []
    sdf = ET.Element("sdf", version=SDF_VERSION)
    world_el = _sub(sdf, "world", name="world_existing")
    _sub(world_el, "gravity", "0 0 -9.81")
    _ground_model(world_el, world.ground_z)
    for group, members in world.static_groups().items():
        name = static_group_name(group)
        mesh = group_mesh(members)
        if not len(mesh.faces):
            continue
        rel = f"{MESH_DIR}/{name}.obj"
        atomic_write_bytes(directory / rel, obj_bytes(mesh))
        written.append(directory / rel)
        model = _sub(world_el, "model", name=name)
        _sub(model, "static", "true")
        _sub(model, "pose", _pose_text(0, 0, 0, 0, 0, 0))
        link = _sub(model, "link", name="link")
        for tag in ("collision", "visual"):
            _mesh_geometry(_sub(link, tag, name=tag), rel)
    for obj in world.solid_site_objects:
        model = _sub(world_el, "model", name=f"site_{obj.iri.rsplit('/', 1)[-1]}")
        _sub(model, "static", "true")
        p = obj.pose
        _sub(model, "pose", _pose_text(p.x, p.y, p.z + obj.size[2] / 2, p.roll, p.pitch, p.yaw))
        link = _sub(model, "link", name="link")
        for tag in ("collision", "visual"):
            _box_geometry(_sub(link, tag, name=tag), obj.size)
    path = directory / "world_existing.sdf"
    atomic_write_bytes(path, _xml_bytes(sdf))
    written.append(path)
    return written


def box_inertia(mass_kg: float, size: Sequence[float]) -> tuple[float, float, float]:
    """Principal moments (kg m2) of a solid box about its centre."""
    sx, sy, sz = size
    k = mass_kg / 12.0
    return (k * (sy * sy + sz * sz), k * (sx * sx + sz * sz), k * (sx * sx + sy * sy))


def write_element_sdf(element: WorldElement, directory: Path) -> list[Path]:
    """Write ``element_<GlobalId>.sdf`` (a model at its storage pose) and its mesh; returns the files."""
    directory = Path(directory)
    if element.pose is None or element.local_bounds is None:
        raise KbplannerError("a task element without pose or geometry has no SDF model",
                             element=element.iri, fix="place it at a storage (kbp:storedIn)")
    name = element_model_name(element)
    written: list[Path] = []
    rel = f"{MESH_DIR}/{name}.obj"
    mesh = element_local_mesh(element)
    sdf = ET.Element("sdf", version=SDF_VERSION)
    model = _sub(sdf, "model", name=name)
    _sub(model, "static", "false")
    p = element.pose
    _sub(model, "pose", _pose_text(p.x, p.y, p.z, p.roll, p.pitch, p.yaw))
    link = _sub(model, "link", name="link")
    centre = element.local_bounds.center
    size = element.local_bounds.size
    inertial = _sub(link, "inertial")
    _sub(inertial, "pose", _pose_text(*centre, 0.0, 0.0, 0.0))
    mass = element.body_mass_kg
    _sub(inertial, "mass", _num(mass))
    inertia = _sub(inertial, "inertia")
    ixx, iyy, izz = box_inertia(mass, size)
    for tag, value in (("ixx", ixx), ("ixy", 0.0), ("ixz", 0.0), ("iyy", iyy), ("iyz", 0.0), ("izz", izz)):
        _sub(inertia, tag, _num(value))
    collision = _sub(link, "collision", name="collision")
    _sub(collision, "pose", _pose_text(*centre, 0.0, 0.0, 0.0))
    _box_geometry(collision, size)
    if mesh is not None and len(mesh.faces):
        atomic_write_bytes(directory / rel, obj_bytes(mesh))
        written.append(directory / rel)
        _mesh_geometry(_sub(link, "visual", name="visual"), rel)
    else:
        visual = _sub(link, "visual", name="visual")
        _sub(visual, "pose", _pose_text(*centre, 0.0, 0.0, 0.0))
        _box_geometry(visual, size)
    path = directory / f"{name}.sdf"
    atomic_write_bytes(path, _xml_bytes(sdf))
    written.append(path)
    return written


# --------------------------------------------------------------------------------------------
# glTF
# --------------------------------------------------------------------------------------------


def _coloured(mesh: trimesh.Trimesh, colour: tuple[int, int, int, int]) -> trimesh.Trimesh:
    mesh.visual = trimesh.visual.ColorVisuals(mesh=mesh, face_colors=np.tile(colour, (len(mesh.faces), 1)))
    return mesh


def world_scene(world: World) -> trimesh.Scene:
    """The world as a trimesh scene in glTF's y-up frame (see module docstring)."""
    scene = trimesh.Scene()
    for group, members in world.static_groups().items():
        mesh = group_mesh(members)
        if not len(mesh.faces):
            continue
        name = f"static/{group}"
        colour = _COLOURS.get(members[0].kind, _DEFAULT_COLOUR)
        scene.add_geometry(_coloured(mesh, colour), node_name=name, geom_name=name, transform=Y_UP)
    for e in world.task_elements:
        local = element_local_mesh(e)
        if local is None or e.pose is None:
            continue
        name = f"task/{e.global_id}"
        scene.add_geometry(_coloured(local, _COLOURS["task"]), node_name=name, geom_name=name,
                           transform=Y_UP @ pose_matrix(e.pose))
    for obj in world.solid_site_objects:
        name = f"site/{obj.iri.rsplit('/', 1)[-1]}"
        box = trimesh.creation.box(extents=obj.size)
        scene.add_geometry(_coloured(box, _COLOURS["site"]), node_name=name, geom_name=name,
                           transform=Y_UP @ obj.box_center)
    return scene


def glb_bytes(world: World) -> bytes:
    """The world as binary glTF (deterministic bytes)."""
    return bytes(world_scene(world).export(file_type="glb"))


# --------------------------------------------------------------------------------------------
# Everything
# --------------------------------------------------------------------------------------------


@dataclass
class WorldExport:
    """What :func:`export_world` wrote."""

    directory: Path
    files: list[Path] = field(default_factory=list)
    map: StoreyMap | None = None
    seconds: dict[str, float] = field(default_factory=dict)

    def relative_files(self) -> list[str]:
        """Written files relative to the directory, sorted."""
        return sorted(str(p.relative_to(self.directory)) for p in self.files)


def world_json(world: World, storey_map_: StoreyMap | None = None) -> dict[str, Any]:
    """world.json content: the typed world and the map's figures."""
    data = world.to_dict()
    data["map"] = storey_map_.to_dict() if storey_map_ is not None else None
    return data


def _json_bytes(data: Any) -> bytes:
    return (json.dumps(data, indent=2, sort_keys=True, ensure_ascii=False, allow_nan=False) + "\n").encode()


def export_world(
    world: World,
    directory: Path,
    *,
    settings: MapSettings | None = None,
    storey: str | None = None,
) -> WorldExport:
    """Write every export of the world into ``directory`` (see module docstring)."""
    directory = Path(directory)
    out = WorldExport(directory)
    t0 = time.perf_counter()
    m = storey_map(world, storey, settings)
    out.files.extend(write_map(m, directory))
    out.map = m
    t1 = time.perf_counter()
    out.files.extend(write_world_existing_sdf(world, directory))
    for e in world.task_elements:
        out.files.extend(write_element_sdf(e, directory))
    t2 = time.perf_counter()
    glb = directory / "world.glb"
    atomic_write_bytes(glb, glb_bytes(world))
    out.files.append(glb)
    t3 = time.perf_counter()
    path = directory / "world.json"
    atomic_write_bytes(path, _json_bytes(world_json(world, m)))
    out.files.append(path)
    out.seconds = {"map": t1 - t0, "sdf": t2 - t1, "glb": t3 - t2}
    log.info("world exports in %s: %d files", directory, len(out.files))
    return out

