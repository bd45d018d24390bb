"""``kbplanner compare PROJECT --scenarios A,B --out DIR``: simulate scenarios with one seed, side by side.

Writes ``DIR/<scenario>/`` (each run), ``comparison.csv``, ``comparison.json``, the simulated durations
written back to the 4D model (``scenarios/<scenario>/results.ttl``, ``schedule_with_results.csv``) and
``report.html`` / ``report.md``. Exit 0 when every element was installed in every scenario, 1 otherwise,
2 on bad input.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rich.console import Console

from kbplanner.errors import ProjectError


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "compare",
        help="simulate scenarios with the same seed and compare them (table + report)",
        description=__doc__.split("\n\n", 1)[1] if __doc__ else None,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("project", help="project directory (holding project.toml)")
    p.add_argument("--scenarios", required=True, help="comma-separated scenario names, e.g. A,B")
    p.add_argument("--seed", type=int, help="random seed (default: [project] seed)")
    p.add_argument("--threshold", type=float, default=1.0, help="proximity threshold in metres (default 1.0)")
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="output directory (replaced)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from kbplanner.comparison import simulate_scenario, write_outputs
    from kbplanner.outputs import run_directory
    from kbplanner.project import read_manifest

    names = [s.strip() for s in args.scenarios.split(",") if s.strip()]
    manifest = read_manifest(Path(args.project))
    unknown = [n for n in names if n not in manifest.scenarios]
    if unknown or not names:
        raise ProjectError(
            f"unknown scenario(s) {unknown}",
            file=manifest.path,
            fix="choose from: " + ", ".join(sorted(manifest.scenarios)),
        )
    err = Console(stderr=True)
    runs = []
    with run_directory(args.out) as stage, err.status("comparing") as status:
        for name in names:
            runs.append(
                simulate_scenario(
                    Path(args.project),
                    name,
                    seed=args.seed,
                    out_dir=stage / name,
                    progress=lambda m: status.update(m),
                )
            )
        status.update("report")
        comp = write_outputs(Path(args.project), runs, stage, threshold_m=args.threshold)
    for r in runs:
        r.run_dir = Path(args.out) / r.scenario
    sys.stdout.write(comp.text())
    sys.stdout.write(f"report: {Path(args.out) / 'report.html'}\n")
    return 0 if all(r.installed == r.elements for r in runs) else 1
