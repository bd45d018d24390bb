"""Benchmark of requirement derivation (A3) and validation (A4) against the number of robotized elements.

Synthetic models: one robotized task (I-W-F-#1) building N frame elements (10, 100, 1,000, 10,000),
each with an installed pose, bounds, mesh file and mass, plus an unrelated manual task. Two variants:
"bare" (no storage, no grasp points: every element has two unmet requirements) and "augmented" (a
storage with a pickup location and a grasp point per element: nothing missing, the model conforms).
For each, times ``derive_requirements`` (shape generation + pySHACL + translation) and
``validate_model`` (well-formedness + requirement shapes on a copy of the model).
Prints a table and writes ``benchmarks/results/requirements.json``.

    .venv/bin/python benchmarks/bench_requirements.py [--quick] [--sizes 10 100 1000]
"""

from __future__ import annotations

import argparse
import sys
from datetime import datetime

from _common import REPO, RESULTS_DIR, Timer, machine_info, write_json
from _common import rdf_box as _box
from _common import rdf_pose as _pose
from rdflib import RDF, RDFS, XSD, Graph, Literal

from kbplanner.core.iris import element_iri, mint, task_iri
from kbplanner.core.rdf_io import bind_prefixes
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.knowledge_base import load_kb
from kbplanner.knowledge.requirements import derive_requirements
from kbplanner.knowledge.validation import validate_model

RESULTS = RESULTS_DIR / "requirements.json"
BASE = "https://w3id.org/kbplanner/data/bench/"


def synthetic_model(n: int, *, augmented: bool) -> Graph:
    """A model with one robotized task building ``n`` frames (see module docstring)."""
    g = Graph()
    bind_prefixes(g)
    task = task_iri(BASE, "T1")
    g.add((task, RDF.type, KBP.ConstructionTask))
    g.add((task, KBP.taskId, Literal("T1")))
    g.add((task, RDFS.label, Literal("Frames")))
    g.add((task, KBP.start, Literal(datetime(2022, 5, 10, 7), datatype=XSD.dateTime)))
    g.add((task, KBP.finish, Literal(datetime(2022, 5, 23, 15), datatype=XSD.dateTime)))
    g.add((task, KBP.robotized, Literal(True)))
    g.add((task, KBP.taskSpecificationId, Literal("I-W-F-#1")))
    layout = mint(BASE, "site", "layout")
    g.add((layout, RDF.type, KBP.SiteLayout))
    g.add((layout, KBP.siteExtent, _box(g, mint(BASE, "box", "site"), (-50, -50, 0), (1000, 1000, 10))))
    storage = mint(BASE, "site", "storage")
    if augmented:
        g.add((storage, RDF.type, KBP.MaterialStorage))
        g.add((storage, RDFS.label, Literal("Frame storage")))
        g.add((storage, KBP.installedPose, _pose(g, mint(BASE, "pose", "storage"), -10.0, 0.0)))
        for p in (KBP.sizeX, KBP.sizeY, KBP.sizeZ):
            g.add((storage, p, Literal(2.0)))
        g.add((storage, KBP.pickupLocation, _pose(g, mint(BASE, "pose", "pickup"), -8.0, 0.0)))
    for i in range(n):
        gid = f"F{i:06d}"
        el = element_iri(BASE, gid)
        x, y = float(i % 100), float(i // 100)
        g.add((el, RDF.type, KBP.Member))
        g.add((el, KBP.globalId, Literal(gid)))
        g.add((el, KBP.ifcClass, Literal("IfcMember")))
        g.add((el, RDFS.label, Literal(f"Frame {i}")))
        g.add((el, KBP.installedPose, _pose(g, mint(BASE, "pose", gid), x, y)))
        box = _box(g, mint(BASE, "box", gid), (x - 0.3, y - 0.05, 0), (x + 0.3, y + 0.05, 2.4))
        g.add((el, KBP.bounds, box))
        g.add((el, KBP.meshFile, Literal(f"meshes/{gid}.glb")))
        g.add((el, KBP.mass, Literal(10.0)))
        g.add((task, KBP.buildsElement, el))
        if augmented:
            g.add((el, KBP.storedIn, storage))
            g.add((el, KBP.stackIndex, Literal(i)))
            g.add((el, KBP.graspPoint, _pose(g, mint(BASE, "pose", f"{gid}-grasp"), 0.0, 0.0, 1.2)))
    return g


def measure(n: int, augmented: bool, kb: Graph) -> dict[str, object]:
    """Time derivation and validation on one synthetic model."""
    model = synthetic_model(n, augmented=augmented)
    timer = Timer()
    req = derive_requirements(model, kb)
    derive_s = timer.lap()
    val = validate_model(model, kb)
    validate_s = timer.lap()
    return {
        "elements": n,
        "variant": "augmented" if augmented else "bare",
        "triples": len(model),
        "requirements": len(req.requirements),
        "unmet_elements": sum(len(r.elements) for r in req.requirements),
        "derive_s": round(derive_s, 3),
        "validate_s": round(validate_s, 3),
        "total_s": round(derive_s + validate_s, 3),
        "conforms": val.conforms,
        "violations": len(val.violations),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="only 10 and 100 elements")
    parser.add_argument("--sizes", type=int, nargs="+", default=[10, 100, 1000, 10000])
    args = parser.parse_args(argv)
    sizes = [10, 100] if args.quick else args.sizes
    kb = load_kb()
    rows = []
    header = f"{'elements':>8} {'variant':>9} {'triples':>8} {'reqs':>4} {'unmet':>6} " \
             f"{'derive s':>9} {'validate s':>10} {'total s':>8} {'conforms':>8}"
    sys.stdout.write(header + "\n")
    for n in sizes:
        for augmented in (False, True):
            r = measure(n, augmented, kb)
            rows.append(r)
            sys.stdout.write(f"{r['elements']:>8} {r['variant']:>9} {r['triples']:>8} {r['requirements']:>4} "
                             f"{r['unmet_elements']:>6} {r['derive_s']:>9} {r['validate_s']:>10} "
                             f"{r['total_s']:>8} {r['conforms']!s:>8}\n")
            sys.stdout.flush()
    write_json(RESULTS, {
        "benchmark": "requirements",
        **machine_info(("python", "machine")),
        "cases": rows,
    })
    sys.stdout.write(f"wrote {RESULTS.relative_to(REPO)}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
