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

from kbplanner.cli.arguments import add_force, check_out, positive_float, seed_int


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "compare",
        help="simulate scenarios with the same seed and compare them (table + report)",
        description=__doc__.split("\n\n", 1)[1] if __doc__ else None,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("project", help="project directory (holding project.toml)")
    p.add_argument("--scenarios", required=True, help="comma-separated scenario names, e.g. A,B")
    p.add_argument("--seed", type=seed_int, help="random seed (default: [project] seed)")
    p.add_argument("--threshold", type=positive_float, default=1.0,
                   help="proximity threshold in metres (default 1.0)")
    p.add_argument("--out", type=Path, required=True, metavar="DIR",
                   help="output folder: new, or one kbplanner wrote (replaced)")
    add_force(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rich.console import Console

    from kbplanner.analysis.comparison import compare
    from kbplanner.cli.progress import status

    check_out(args.out)
    names = [s.strip() for s in args.scenarios.split(",") if s.strip()]
    err = Console(stderr=True)
    with status(err, "comparing") as say:
        comp, runs = compare(
            Path(args.project),
            names,
            out_dir=args.out,
            seed=args.seed,
            threshold_m=args.threshold,
            progress=say,
        )
    sys.stdout.write(comp.text())
    sys.stdout.write(f"report: {Path(args.out) / 'report.html'}\n")
    return 0 if all(r.installed == r.elements for r in runs) else 1
