"""``kbplanner info PROJECT``: summarise a project (counts per class, storeys, tasks, date range)."""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict

from kbplanner.core.store_spec import OXIGRAPH, add_store_argument


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("info", help="summarise a project: elements per class, storeys, tasks, date range")
    p.add_argument("project", help="project directory (holding project.toml)")
    p.add_argument("--scenario", help="scenario overlay to apply (default: the bare model)")
    add_store_argument(p, default=OXIGRAPH)  # same rows as rdflib, faster (tests/test_startup.py)
    p.add_argument("--format", choices=("text", "json"), default="text")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from kbplanner.project import Project

    project = Project.load(args.project, scenario=args.scenario, store=args.store)
    info = project.info()
    if args.format == "json":
        sys.stdout.write(json.dumps(asdict(info), indent=2, default=str, allow_nan=False) + "\n")
        return 0
    out = [f"{info.name}  ({info.path})"]
    out.append(f"  model: {info.ifc} ({info.schema}), {info.triples} triples"
               + (f", scenario {info.scenario}" if info.scenario else ", bare model"))
    out.append(f"  scenarios: {', '.join(info.scenarios) or 'none'}")
    out.append("  storeys:")
    for label, elev, n in info.storeys:
        e = f"{elev:+.2f} m" if elev is not None else "?"
        out.append(f"    {label:<20} {e:>9}  {n} elements")
    out.append("  elements:")
    for cls, n in info.counts.items():
        extra = ""
        if cls == "Wall":
            extra = f"  ({info.walls_interior} interior, {info.walls_exterior} exterior)"
        out.append(f"    {cls:<20} {n:>5}{extra}")
    first, last = info.date_range
    out.append(f"  schedule: {info.tasks} tasks, {first or '-'} .. {last or '-'}")
    for task_id, label, spec in info.robotized_tasks:
        out.append(f"    robotized: {task_id} {label} -> {spec}")
    if info.site_objects:
        out.append("  site objects: " + ", ".join(f"{k} {v}" for k, v in info.site_objects.items()))
    out.append(f"  workers: {info.workers}")
    sys.stdout.write("\n".join(out) + "\n")
    return 0
