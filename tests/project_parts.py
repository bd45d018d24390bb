"""The shared factory of the test projects: every part that tests/project_factory.py (make_project),
sim_project_factory.py (make_sim_project) and world_project_factory.py (make_world_project) build
alike: deterministic GlobalIds, stud-frame-like panels added to an IFC with ifcopenshell.api, Turtle
for poses, site layouts, site objects, workers, storages and their stacks, project.toml text, and
writing the files. The three modules keep only what makes their project different (its building,
schedule and site). No tests live here.
"""

from __future__ import annotations

import math
import uuid
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import ifcopenshell
import ifcopenshell.api.geometry
import ifcopenshell.api.material
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.guid
import numpy as np

from kbplanner.core.iris import element_iri


def guid(key: str) -> str:
    """A GlobalId derived from ``key`` (the same key, the same id in every run)."""
    return str(ifcopenshell.guid.compress(uuid.uuid5(uuid.NAMESPACE_URL, key).hex))


@dataclass(frozen=True)
class PanelSpec:
    """One panel: its name ("P1"), GlobalId and installed pose (x, y, z in m, yaw in rad)."""

    name: str
    global_id: str
    x: float
    y: float
    z: float = 0.0
    yaw: float = 0.0


def add_panels(ifc_path: Path, panels: Sequence[PanelSpec], *, size: tuple[float, float, float],
               shape: str = "slab", mass_kg: float | None = None,
               guid_key: str = "") -> None:
    """Add IfcMember panels on Level 1 of the IFC at ``ifc_path`` (written back in place).

    ``size`` is (length along the wall, thickness, height); ``shape`` "slab" extrudes a centred
    rectangle, "wall" uses ifcopenshell's wall representation (starting at the placement);
    ``mass_kg`` adds a NetWeight quantity (its GlobalIds from ``guid_key``).
    """
    f = ifcopenshell.open(str(ifc_path))
    storey = next(s for s in f.by_type("IfcBuildingStorey") if s.Name == "Level 1")
    body = next(c for c in f.by_type("IfcGeometricRepresentationSubContext") if c.ContextIdentifier == "Body")
    wood = ifcopenshell.api.material.add_material(f, name="Wood - Stud")
    length, thickness, height = size
    for p in panels:
        panel = ifcopenshell.api.root.create_entity(f, ifc_class="IfcMember", name=f"Panel {p.name}")
        panel.GlobalId = p.global_id
        ifcopenshell.api.spatial.assign_container(f, products=[panel], relating_structure=storey)
        m = np.eye(4)
        c, s = math.cos(p.yaw), math.sin(p.yaw)
        if p.yaw != 0.0:
            m[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
        m[:3, 3] = [p.x, p.y, p.z]
        ifcopenshell.api.geometry.edit_object_placement(f, product=panel, matrix=m)
        if shape == "slab":
            hl, ht = length / 2, thickness / 2
            rep = ifcopenshell.api.geometry.add_slab_representation(
                f, context=body, depth=height, polyline=[(-hl, -ht), (hl, -ht), (hl, ht), (-hl, ht)])
        else:
            rep = ifcopenshell.api.geometry.add_wall_representation(
                f, context=body, length=length, height=height, thickness=thickness)
        ifcopenshell.api.geometry.assign_representation(f, product=panel, representation=rep)
        ifcopenshell.api.material.assign_material(f, products=[panel], material=wood)
        if mass_kg is not None:
            qty = f.create_entity("IfcQuantityWeight", Name="NetWeight", WeightValue=mass_kg)
            f.create_entity("IfcRelDefinesByProperties", GlobalId=guid(f"{guid_key}qto-rel-{p.name}"),
                            RelatedObjects=[panel], RelatingPropertyDefinition=f.create_entity(
                                "IfcElementQuantity", GlobalId=guid(f"{guid_key}qto-{p.name}"),
                                Name="BaseQuantities", Quantities=[qty]))
    f.write(str(ifc_path))


def pose_ttl(name: str, x: float, y: float, z: float, yaw: float = 0.0) -> str:
    """A ``site:`` pose in Turtle."""
    return (f"site:{name} a kbp:Pose ; kbp:x {x!r} ; kbp:y {y!r} ; kbp:z {z!r} ;\n"
            f"    kbp:roll 0.0 ; kbp:pitch 0.0 ; kbp:yaw {yaw!r} .\n")


def prefixes(base: str) -> str:
    """The prefixes of a site Turtle file (kbp, rdfs, site = ``{base}site/``)."""
    return ("@prefix kbp: <https://w3id.org/kbplanner/ontology#> .\n"
            "@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .\n"
            f"@prefix site: <{base}site/> .\n\n")


def layout_ttl(extent: tuple[float, float, float, float], start: tuple[float, float, float], *,
               start_name: str = "start") -> str:
    """The site layout: extent (x0, y0, x1, y1; z -1..10 m), robot start (x, y, yaw) ``site:{start_name}``."""
    x0, y0, x1, y1 = extent
    sx, sy, syaw = start
    return ("site:layout a kbp:SiteLayout ; kbp:siteExtent site:extent ;"
            f" kbp:robotStart site:{start_name} .\n"
            f"site:extent a kbp:Box ; kbp:minX {x0!r} ; kbp:minY {y0!r} ; kbp:minZ -1.0 ;\n"
            f"    kbp:maxX {x1!r} ; kbp:maxY {y1!r} ; kbp:maxZ 10.0 .\n"
            + pose_ttl(start_name, sx, sy, 0.0, syaw))


def site_object_ttl(name: str, cls: str, label: str, size: tuple[float, float, float],
                    at: tuple[float, float], *, obstructs: bool | None) -> str:
    """A site object ``site:{name}`` of class ``kbp:{cls}`` (office, workspace, no-go zone, fence), its
    size (x, y, z) and pose ``site:{name}-pose`` at (x, y) on the ground; ``kbp:obstructs`` unless None."""
    sx, sy, sz = size
    flag = "" if obstructs is None else f" ; kbp:obstructs {str(obstructs).lower()}"
    return (f"site:{name} a kbp:{cls} ; rdfs:label \"{label}\"{flag} ;\n"
            f"    kbp:sizeX {sx!r} ; kbp:sizeY {sy!r} ; kbp:sizeZ {sz!r} ;\n"
            f"    kbp:installedPose site:{name}-pose .\n"
            + pose_ttl(f"{name}-pose", at[0], at[1], 0.0))


def worker_ttl(speed: float, stops: Sequence[tuple[str, float]]) -> str:
    """The carpenter ``site:worker`` walking at ``speed`` (m/s) between site objects: (``site:`` name of
    the location, dwell time in s) per route stop ``site:stop-N``."""
    names = " , ".join(f"site:stop-{n}" for n in range(1, len(stops) + 1))
    text = ("site:worker a kbp:Worker ; rdfs:label \"Carpenter\" ; kbp:role \"carpenter\" ;\n"
            f"    kbp:walkingSpeed {speed!r} ; kbp:routeStop {names} .\n")
    for n, (location, dwell) in enumerate(stops, start=1):
        text += (f"site:stop-{n} a kbp:RouteStop ; kbp:order {n} ; kbp:location site:{location} ;"
                 f" kbp:dwellTime {dwell!r} .\n")
    return text


def storage_head_ttl(pose: tuple[float, float, float, float], size: tuple[float, float, float],
                     pickup: tuple[float, float, float, float]) -> str:
    """A material storage ``site:storage`` with its pose, size and pickup location."""
    x, y, z, yaw = pose
    sx, sy, sz = size
    px, py, pz, pyaw = pickup
    return ("site:storage a kbp:MaterialStorage ; rdfs:label \"Panel storage\" ; kbp:obstructs true ;\n"
            f"    kbp:sizeX {sx!r} ; kbp:sizeY {sy!r} ; kbp:sizeZ {sz!r} ;\n"
            "    kbp:installedPose site:storage-pose ; kbp:pickupLocation site:pickup .\n"
            + pose_ttl("storage-pose", x, y, z, yaw) + pose_ttl("pickup", px, py, pz, pyaw))


def stacked_ttl(base: str, global_id: str, stack_index: int, more: str = "") -> str:
    """An element stored on ``site:storage`` at ``stack_index`` (0 = bottom), with ``more`` predicates."""
    text = f"<{element_iri(base, global_id)}> kbp:storedIn site:storage ; kbp:stackIndex {stack_index}"
    return text + (f" ;\n    {more}" if more else "") + " .\n"


def project_toml(name: str, base: str, *, seed: int | None = None, site: Iterable[str] = ("site.ttl",),
                 simulation: Mapping[str, str] | None = None,
                 scenarios: Mapping[str, tuple[str, Sequence[str]]] | None = None) -> str:
    """The text of a test project's project.toml (IFC model.ifc, schedule.csv)."""
    text = f'[project]\nname = "{name}"\nbase_iri = "{base}"\n'
    if seed is not None:
        text += f"seed = {seed}\n"
    text += ('[model]\nifc = "model.ifc"\nschedule = "schedule.csv"\n'
             f"site = [{', '.join(repr(s).replace(chr(39), chr(34)) for s in site)}]\n")
    if simulation:
        text += "[simulation]\n" + "".join(f'{k} = "{v}"\n' for k, v in simulation.items())
    for sc, (description, overlays) in (scenarios or {}).items():
        text += (f'[scenarios.{sc}]\ndescription = "{description}"\n'
                 f"overlays = [{', '.join(chr(34) + o + chr(34) for o in overlays)}]\n")
    return text


def write_texts(directory: Path, files: Mapping[str, str]) -> None:
    """Write each text file (name relative to ``directory``: its content) as UTF-8."""
    for name, text in files.items():
        (directory / name).write_text(text, encoding="utf-8")
