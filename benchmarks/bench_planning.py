"""Benchmark of planning (B1-B3) against the number of elements of the robotized task.

Cases: the case study (scenario storage-outside, 11 frames x 4 actions) and synthetic projects with
one robotized task (I-W-F-#1) building N frames (10, 100, 1,000 by default) on a 100-wide grid, a
storage with a pickup location, a grasp point, mass and a box mesh per frame, and a robot start.
For each, times ``plan_task`` as a whole and, separately, its parts: robot selection (B3), the world
that places the elements at their storage (A6), element order (B1) and the skill inputs fetched by
SPARQL (B2, every binding of every element). Prints a table and writes
``benchmarks/results/planning.json``.

    .venv/bin/python benchmarks/bench_planning.py [--quick] [--sizes 10 100 1000]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from datetime import datetime
from pathlib import Path

import trimesh
from _common import REPO, RESULTS_DIR, Timer, machine_info, timed, write_json
from _common import rdf_box as _box
from _common import rdf_pose as _pose
from rdflib import RDF, RDFS, XSD, Graph, Literal

from kbplanner.core.iris import element_iri, mint, task_iri
from kbplanner.core.rdf_io import bind_prefixes
from kbplanner.core.vocab import BOT, KBP
from kbplanner.knowledge.knowledge_base import load_kb
from kbplanner.knowledge.robot_selection import select_robots
from kbplanner.knowledge.task_specs import task_specification
from kbplanner.planning.element_order import element_order
from kbplanner.planning.planner import plan_task
from kbplanner.planning.skill_inputs import resolve_inputs
from kbplanner.planning.task_and_robot import resolve_task
from kbplanner.project import Calendar, Manifest, Project
from kbplanner.world.build import build_world

RESULTS = RESULTS_DIR / "planning.json"
BASE = "https://w3id.org/kbplanner/data/bench-plan/"
DATE = datetime(2022, 5, 10, 7)


def synthetic_project(n: int, directory: Path) -> Project:
    """A project of ``n`` frames (see module docstring) in ``directory`` (meshes written there)."""
    g = Graph()
    bind_prefixes(g)
    task = task_iri(BASE, "T1")
    g.add((task, RDF.type, KBP.ConstructionTask))
    g.add((task, KBP.taskId, Literal("T1")))
    g.add((task, RDFS.label, Literal("Frames")))
    g.add((task, KBP.start, Literal(DATE, datatype=XSD.dateTime)))
    g.add((task, KBP.finish, Literal(datetime(2022, 5, 23, 15), datatype=XSD.dateTime)))
    g.add((task, KBP.robotized, Literal(True)))
    g.add((task, KBP.taskSpecificationId, Literal("I-W-F-#1")))
    layout = mint(BASE, "site", "layout")
    g.add((layout, RDF.type, KBP.SiteLayout))
    g.add((layout, KBP.siteExtent, _box(g, mint(BASE, "box", "site"), (-50, -50, 0), (150, 150, 10))))
    g.add((layout, KBP.robotStart, _pose(g, mint(BASE, "pose", "start"), -20.0, 0.0)))
    storey = mint(BASE, "storey", "L1")
    g.add((storey, RDF.type, BOT.Storey))
    g.add((storey, RDFS.label, Literal("Level 1")))
    g.add((storey, KBP.elevation, Literal(0.0)))
    storage = mint(BASE, "site", "storage")
    g.add((storage, RDF.type, KBP.MaterialStorage))
    g.add((storage, RDFS.label, Literal("Frame storage")))
    g.add((storage, KBP.installedPose, _pose(g, mint(BASE, "pose", "storage"), -10.0, 0.0)))
    for p, v in ((KBP.sizeX, 3.0), (KBP.sizeY, 1.2), (KBP.sizeZ, 0.1)):
        g.add((storage, p, Literal(v)))
    g.add((storage, KBP.pickupLocation, _pose(g, mint(BASE, "pose", "pickup"), -8.0, 0.0)))
    (directory / "meshes").mkdir(parents=True, exist_ok=True)
    for i in range(n):
        gid = f"F{i:06d}"
        el = element_iri(BASE, gid)
        x, y = float(i % 100), float(i // 100)
        for cls in (KBP.Member, BOT.Element):
            g.add((el, RDF.type, cls))
        g.add((el, KBP.globalId, Literal(gid)))
        g.add((el, KBP.ifcClass, Literal("IfcMember")))
        g.add((el, RDFS.label, Literal(f"Frame {i}")))
        g.add((el, KBP.installedPose, _pose(g, mint(BASE, "pose", gid), x, y)))
        box = _box(g, mint(BASE, "box", gid), (x - 0.3, y - 0.05, 0), (x + 0.3, y + 0.05, 2.4))
        g.add((el, KBP.bounds, box))
        g.add((el, KBP.meshFile, Literal(f"meshes/{gid}.obj")))
        g.add((el, KBP.mass, Literal(10.0)))
        g.add((el, KBP.storedIn, storage))
        g.add((el, KBP.stackIndex, Literal(i)))
        g.add((el, KBP.graspPoint, _pose(g, mint(BASE, "pose", f"{gid}-grasp"), 0.0, 0.0, 1.2)))
        g.add((storey, BOT.containsElement, el))
        g.add((task, KBP.buildsElement, el))
        mesh = trimesh.creation.box(extents=(0.6, 0.1, 2.4))
        mesh.apply_translation((x, y, 1.2))
        mesh.export(directory / "meshes" / f"{gid}.obj")
    manifest = Manifest(
        path=directory / "project.toml", name="bench-plan", description="", base=BASE, seed=0,
        ifc=directory / "model.ifc", schedule=None, schedule_from_ifc=False, site=(), jobsite=(),
        knowledge_base=(), augmentation=(), calendar=Calendar(), simulation={}, scenarios={})
    return Project(manifest=manifest, scenario=None, model=g, kb=load_kb(), import_dir=directory)


def measure(case: str, project: Project) -> dict[str, object]:
    """Time the whole plan, then its parts on the same project."""
    plan, total = timed(lambda: plan_task(project))
    task = resolve_task(project)
    spec = task_specification(project.kb, task.spec_id or "")
    timer = Timer()
    select_robots(project.model, project.kb, task.task_id, scenario=project.scenario)
    selection_s = timer.lap()
    world = build_world(project, DATE if project.manifest.simulation.get("date") is None
                        else datetime.fromisoformat(str(project.manifest.simulation["date"])), task.task_id)
    world_s = timer.lap()
    start = world.robot_start
    element_order(project.model, task.iri, (start.x, start.y) if start else None)
    order_s = timer.lap()
    n_inputs = 0
    for el in task.elements:
        for a in spec.actions:
            n_inputs += len(resolve_inputs(project.model, a.bindings, element=el.iri, task=task.iri))
    inputs_s = timer.lap()
    return {
        "case": case,
        "elements": len(plan.elements),
        "steps": len(plan.steps),
        "feasible": plan.feasible,
        "inputs_fetched": n_inputs,
        "triples": len(project.model),
        "plan_s": round(total, 3),
        "selection_s": round(selection_s, 3),
        "world_s": round(world_s, 3),
        "order_s": round(order_s, 3),
        "inputs_s": round(inputs_s, 3),
        "inputs_ms_per_query": round(1000 * inputs_s / max(n_inputs, 1), 3),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="only 10 and 100 synthetic elements")
    parser.add_argument("--sizes", type=int, nargs="+", default=[10, 100, 1000])
    parser.add_argument("--no-case-study", action="store_true", help="synthetic projects only")
    args = parser.parse_args(argv)
    sizes = [10, 100] if args.quick else args.sizes
    rows = []
    header = (f"{'case':>16} {'elements':>8} {'steps':>6} {'triples':>8} {'plan s':>7} {'select s':>8} "
              f"{'world s':>8} {'order s':>7} {'inputs s':>8} {'ms/query':>8}")
    sys.stdout.write(header + "\n")

    def show(r: dict[str, object]) -> None:
        sys.stdout.write(f"{r['case']!s:>16} {r['elements']!s:>8} {r['steps']!s:>6} {r['triples']!s:>8} "
                         f"{r['plan_s']!s:>7} {r['selection_s']!s:>8} {r['world_s']!s:>8} "
                         f"{r['order_s']!s:>7} "
                         f"{r['inputs_s']!s:>8} {r['inputs_ms_per_query']!s:>8}\n")
        sys.stdout.flush()

    if not args.no_case_study:
        project = Project.load(REPO / "data" / "case_study", scenario="storage-outside")
        rows.append(measure("case study", project))
        show(rows[-1])
    for n in sizes:
        with tempfile.TemporaryDirectory() as tmp:
            rows.append(measure("synthetic", synthetic_project(n, Path(tmp))))
        show(rows[-1])
    write_json(RESULTS, {
        "benchmark": "planning",
        **machine_info(("python", "machine")),
        "cases": rows,
    })
    sys.stdout.write(f"wrote {RESULTS.relative_to(REPO)}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
