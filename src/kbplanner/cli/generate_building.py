"""``kbplanner generate-building``: write a generated test building as a complete project (scale).

``kbplanner generate-building --storeys N --units-per-storey M --out DIR [--seed S] [--force]`` writes a
real IFC4 building (``kbplanner.scale.building_generator``) with its schedule, site layout, workers, jobsite
parameters and a storage scenario into DIR, and prints what it holds. Exit code 0, or 2 on bad input.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict
from pathlib import Path

from kbplanner.cli.arguments import check_out, seed_int


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("generate-building",
                       help="write a generated multi-storey test building (IFC4, schedule, site) project")
    p.add_argument("--storeys", type=int, required=True, help="number of storeys (1-60)")
    p.add_argument("--units-per-storey", type=int, required=True, help="apartments per storey (1-40)")
    p.add_argument("--out", type=Path, required=True, help="project directory to write")
    p.add_argument("--seed", type=seed_int, default=0, help="moves partitions and doors per unit (default 0)")
    p.add_argument("--force", action="store_true",
                   help="write into an existing folder that kbplanner did not write; files in it are "
                        "kept (kbplanner never deletes a file it did not write)")
    p.add_argument("--format", choices=("text", "json"), default="text")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from kbplanner.scale.building_generator import generate_building

    check_out(args.out)
    b = generate_building(args.out, storeys=args.storeys, units_per_storey=args.units_per_storey,
                          seed=args.seed, force=args.force)
    if args.format == "json":
        data = asdict(b)
        data["directory"], data["ifc"] = str(b.directory), str(b.ifc)
        sys.stdout.write(json.dumps(data, indent=2, allow_nan=False) + "\n")
        return 0
    lines = [
        f"{b.directory}: {b.storeys} storeys x {b.units_per_storey} units (seed {b.seed}), "
        f"{b.seconds:.1f} s",
        f"  {b.ifc.name}: {b.elements} building elements, {b.frames} stud-frame panels "
        f"({b.frame_mass_kg[0]:.1f}-{b.frame_mass_kg[1]:.1f} kg)",
        "  " + ", ".join(f"{cls} {n}" for cls, n in b.counts.items()),
        f"  schedule: {len(b.tasks)} tasks, robotized: {', '.join(b.robotized_tasks)}",
        f"  simulation: {b.simulation_task} at {b.simulation_date}; scenario {b.scenario}",
        f"  next: kbplanner requirements {b.directory}",
        f"        kbplanner validate {b.directory} --scenario {b.scenario}",
    ]
    sys.stdout.write("\n".join(lines) + "\n")
    return 0
