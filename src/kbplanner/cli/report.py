"""``kbplanner report RUN_DIR [RUN_DIR ...] [--out DIR]``: the report of simulation run directories.

Each RUN_DIR is a directory written by ``kbplanner simulate`` (or a scenario directory of ``compare``).
The report (``report.html``, self-contained, and ``report.md`` with ``figures/``) is written to ``--out``
(default: the single RUN_DIR). The project is found through the run's manifest, for the site layout.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from kbplanner.cli.arguments import add_force, check_out, positive_float
from kbplanner.core.errors import InputFileError


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "report",
        help="write report.html and report.md for simulation run directories",
        description=__doc__.split("\n\n", 1)[1] if __doc__ else None,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("runs", nargs="+", type=Path, metavar="RUN_DIR")
    p.add_argument("--out", type=Path, help="where to write the report (default: the single RUN_DIR)")
    add_force(p)
    p.add_argument("--threshold", type=positive_float, default=1.0,
                   help="proximity threshold in metres (default 1.0)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from kbplanner.analysis.comparison import ScenarioRun, write_outputs
    from kbplanner.analysis.run_record import RunRecord
    from kbplanner.project import Project
    from kbplanner.world.maps import storey_map

    if args.out is None and len(args.runs) > 1:
        raise InputFileError("several run directories and no --out", fix="give --out DIR for the report")
    if args.out is not None:
        check_out(args.out)
    else:
        check_out(args.runs[0], option="RUN_DIR (the report's folder without --out)")
    records = [RunRecord.load(d) for d in args.runs]
    project_dir = records[0].manifest.get("project_dir")
    if not project_dir or not Path(project_dir).is_dir():
        raise InputFileError(
            "the run's project directory is not available",
            file=args.runs[0] / "manifest.json",
            fix="run the report where the project directory named in manifest.json exists",
        )
    runs = []
    for d, rec in zip(args.runs, records, strict=True):
        project = Project.load(project_dir, scenario=rec.scenario)
        world = project.world()
        layout_grid = storey_map(world).grid
        from kbplanner.analysis.plots import LayoutObject

        layout = [
            LayoutObject(o.label, o.kind, o.pose.x, o.pose.y, o.size[0], o.size[1], o.pose.yaw)
            for o in world.site_objects
        ]
        totals = rec.metrics.get("totals", {})
        runs.append(
            ScenarioRun(
                scenario=rec.scenario or d.name,
                run_dir=d,
                installed=int(totals.get("installed", 0)),
                elements=int(totals.get("elements", 0)),
                grid=layout_grid,
                layout=layout,
            )
        )
    out = args.out or args.runs[0]
    from kbplanner.core.outputs import run_directory

    with run_directory(out, replace=False) as stage:  # adds the report to the run folder
        comp = write_outputs(Path(project_dir), runs, stage, threshold_m=args.threshold)
    sys.stdout.write(comp.text())
    sys.stdout.write(f"report: {out / 'report.html'}\n")
    return 0
