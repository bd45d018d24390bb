"""Case study data check (not a pipeline step): a top view of the site layout for a human to look at.

Takes the project's IFC (Level-1 walls, doors, frames by their geometry), site layout, workers and both
storage scenarios (Turtle, read with rdflib) and writes a PNG (default ``/tmp/case_study_site.png``):
the whole site on the left, the apartment (unit A, Level 1) on the right. Worker routes are drawn as
straight lines between their stops; the robot legs of each scenario are straight lines from the
robot start to the pickup location and from there to the apartment's front door.

    .venv/bin/python data/case_study/tools/render_site.py [OUT.png]
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import ifcopenshell
import ifcopenshell.geom
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Polygon, Rectangle
from rdflib import RDF, RDFS, Graph, Namespace, URIRef

PROJECT = Path(__file__).resolve().parents[1]
KBP = Namespace("https://w3id.org/kbplanner/ontology#")
COLOURS = {
    "SiteOffice": "tab:blue", "Equipment": "tab:gray", "MaterialStorage": "saddlebrown",
    "Workspace": "tab:green", "NoGoZone": "tab:red", "SafetyFence": "black",
    "TemporaryStructure": "tab:purple",
}
ENTRANCE = (9.3, -16.18)  # just outside unit A's front door (east facade, door 1hOSvn6df7F8_7GcBWlRGQ)


def pose(g: Graph, node: URIRef) -> tuple[float, float, float]:
    p = g.value(node, KBP.installedPose) or node
    return tuple(float(g.value(p, k)) for k in (KBP.x, KBP.y, KBP.yaw))  # type: ignore[return-value]


def box_corners(x: float, y: float, yaw: float, sx: float, sy: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    local = np.array([[-sx / 2, -sy / 2], [sx / 2, -sy / 2], [sx / 2, sy / 2], [-sx / 2, sy / 2]])
    return local @ np.array([[c, s], [-s, c]]) + np.array([x, y])


def level1_outlines(ifc: Path) -> list[tuple[str, str, np.ndarray]]:
    f = ifcopenshell.open(str(ifc))
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    out = []
    for e in f.by_type("IfcProduct"):
        if not (e.is_a("IfcWall") or e.is_a("IfcDoor") or e.is_a("IfcStairFlight")
                or (e.is_a("IfcMember") and (e.Name or "").startswith("Stud frame"))):
            continue
        if e.Representation is None:
            continue
        v = np.array(ifcopenshell.geom.create_shape(settings, e).geometry.verts).reshape(-1, 3)
        if v[:, 2].min() > 1.0 or v[:, 2].max() < 0.5:
            continue  # not standing on Level 1
        out.append((e.is_a(), e.Name or "", v))
    return out


def draw(ax: plt.Axes, g: Graph, outlines: list[tuple[str, str, np.ndarray]], scenarios: list[Graph],
         zoom: bool) -> None:
    for cls, name, v in outlines:
        lo, hi = v[:, :2].min(axis=0), v[:, :2].max(axis=0)
        if cls.startswith("IfcWall"):
            colour = "dimgray" if "Partition" not in name else "silver"
        elif cls == "IfcDoor":
            colour = "lightskyblue"
        elif cls == "IfcStairFlight":
            colour = "wheat"
        else:
            colour = "gold"
        ax.add_patch(Rectangle(tuple(lo), *(hi - lo), color=colour, zorder=3 if colour == "gold" else 2))
        if colour == "gold" and zoom:
            ax.annotate(name.rsplit(" ", 1)[-1], (lo + hi) / 2, fontsize=6, zorder=6,
                        xytext=(4, 0), textcoords="offset points")
    for graph in [g, *scenarios]:
        for obj, _, cls in sorted(graph.triples((None, RDF.type, None))):
            key = str(cls).rsplit("#", 1)[-1]
            if key not in COLOURS or graph.value(obj, KBP.sizeX) is None:
                continue
            x, y, yaw = pose(graph, obj)
            sx, sy = float(graph.value(obj, KBP.sizeX)), float(graph.value(obj, KBP.sizeY))
            solid = graph.value(obj, KBP.obstructs)
            solid = solid is not None and solid.toPython()
            ax.add_patch(Polygon(box_corners(x, y, yaw, sx, sy), closed=True, zorder=4,
                                 facecolor=COLOURS[key] if solid else "none",
                                 edgecolor=COLOURS[key], alpha=0.7, hatch=None if solid else "//"))
            if not zoom and key != "SafetyFence":
                ax.annotate(str(graph.value(obj, RDFS.label)), (x, y), fontsize=5, zorder=6)
    # worker routes
    for i, w in enumerate(sorted(g.subjects(RDF.type, KBP.Worker))):
        stops = sorted(g.objects(w, KBP.routeStop), key=lambda s: int(g.value(s, KBP.order)))
        pts = [pose(g, g.value(s, KBP.location))[:2] for s in stops]
        pts.append(pts[0])
        xs, ys = zip(*pts, strict=True)
        ax.plot(xs, ys, "--", lw=1.0, color=["tab:orange", "tab:olive", "tab:cyan"][i % 3], zorder=5,
                label=str(g.value(w, RDFS.label)))
    # robot start, pickups and straight robot legs
    layout = next(g.subjects(RDF.type, KBP.SiteLayout))
    start = g.value(layout, KBP.robotStart)
    sx, sy, _ = pose(g, start)
    ax.plot([sx], [sy], "k^", ms=6, zorder=7, label="robot start")
    for sc, colour in zip(scenarios, ["tab:red", "tab:blue"], strict=True):
        storage = next(sc.subjects(KBP.pickupLocation, None))
        px, py, pyaw = pose(sc, sc.value(storage, KBP.pickupLocation))
        ax.add_patch(Polygon(box_corners(px, py, pyaw, 0.99, 0.67), closed=True, zorder=7,
                             facecolor="none", edgecolor=colour))
        ax.arrow(px, py, 0.5 * math.cos(pyaw), 0.5 * math.sin(pyaw), head_width=0.15, color=colour, zorder=7)
        legs = [(sx, sy), (px, py), ENTRANCE]
        xs, ys = zip(*legs, strict=True)
        ax.plot(xs, ys, ":", color=colour, lw=1.2, zorder=6,
                label=f"robot legs ({sc.value(next(sc.subjects(RDF.type, KBP.Scenario)), KBP.scenarioName)})")
    ax.set_aspect("equal")
    ax.grid(True, lw=0.3)


def main() -> None:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("/tmp/case_study_site.png")
    g = Graph()
    for rel in ("site/site_layout.ttl", "site/workers.ttl"):
        g.parse(PROJECT / rel)
    names = ("storage_outside.ttl", "storage_inside.ttl")
    scenarios = [Graph().parse(PROJECT / "scenarios" / n) for n in names]
    outlines = level1_outlines(PROJECT / "model" / "Duplex_A_frames.ifc")
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(18, 10), gridspec_kw={"width_ratios": [1.3, 1]})
    draw(a1, g, outlines, scenarios, zoom=False)
    ext = g.value(next(g.subjects(RDF.type, KBP.SiteLayout)), KBP.siteExtent)
    a1.set_xlim(float(g.value(ext, KBP.minX)), float(g.value(ext, KBP.maxX)))
    a1.set_ylim(float(g.value(ext, KBP.minY)), float(g.value(ext, KBP.maxY)))
    a1.legend(fontsize=7, loc="upper left")
    a1.set_title("Duplex site, 2022-05-10 (site frame, m)")
    draw(a2, g, outlines, scenarios, zoom=True)
    a2.set_xlim(-0.5, 11.0)
    a2.set_ylim(-19.0, -7.0)
    a2.set_title("Unit A, Level 1: frames F01-F11 (gold), doors (blue), storages and pickup poses")
    fig.tight_layout()
    fig.savefig(out, dpi=130)
    print(out)


if __name__ == "__main__":
    main()
