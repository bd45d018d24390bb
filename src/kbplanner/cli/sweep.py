"""``kbplanner sweep PROJECT --vary AXIS=VALUES ... --out DIR``: many variants of a project, compared.

Axes: ``storage=`` candidates separated by ``;`` (a scenario name, ``X,Y`` or ``X,Y,YAW`` in the site
frame, metres and radians: the base scenario's storage moved there with its pickup location, or
``grid:STEP``: every free position of a STEP-metre grid), ``seed=1,2,3``, ``start=07:00,10:00`` (robot
start times into the workers' day). Variants run in local processes (``--workers N``) or on a cluster
(``--cluster dask://HOST:PORT`` needs ``pip install 'kbplanner[cluster]'``; ``ray://HOST:PORT`` needs
``pip install 'kbplanner[ray]'``).

Writes ``sweep.csv``, ``sweep.json``, ``pareto.csv``, ``pareto.png`` (and ``runs/<variant>/`` with
``--keep-runs``), prints the table and the Pareto front over (time below the safety threshold, total
duration). Exit 0 when at least one variant installed every element, 1 otherwise, 2 on bad input.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from kbplanner.cli.arguments import add_force, check_out, positive_float, positive_int


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "sweep",
        help="simulate many variants (storage locations, seeds, start times) and report the Pareto front",
        description=__doc__.split("\n\n", 1)[1] if __doc__ else None,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("project", help="project directory (holding project.toml)")
    p.add_argument("--vary", action="append", default=[], metavar="AXIS=VALUES",
                   help="storage=A;X,Y;X,Y,YAW;grid:STEP | seed=1,2 | start=07:00,10:00 (repeatable)")
    p.add_argument("--scenario", help="base scenario of moved storage candidates (default: the first)")
    p.add_argument("--out", type=Path, required=True, metavar="DIR",
                   help="output folder: new, or one kbplanner wrote (replaced)")
    add_force(p)
    p.add_argument("--workers", type=positive_int, default=1, help="local processes (default 1: serial)")
    p.add_argument("--cluster", metavar="URL", help="dask://HOST:PORT or ray://HOST:PORT")
    p.add_argument("--max-elements", type=positive_int, metavar="N",
                   help="simulate only the first N elements")
    p.add_argument("--keep-runs", action="store_true", help="keep each variant's run directory")
    p.add_argument("--threshold", type=positive_float, default=1.0,
                   help="proximity threshold in metres (default 1.0)")
    p.add_argument("--safety", choices=["threshold", "iso"], default="threshold",
                   help="Pareto safety objective: time below --threshold, or below ISO/TS 15066 S_p")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from kbplanner.cli.progress import plain_counter
    from kbplanner.scale.sweep import SweepSpec, run_sweep
    from kbplanner.scale.sweep_axes import SweepError, parse_vary

    check_out(args.out)
    if args.max_elements is not None and args.max_elements < 1:
        raise SweepError(f"--max-elements {args.max_elements} is not positive", element="--max-elements",
                         fix="give 1 or more, or leave it out to simulate every element")
    spec = SweepSpec(Path(args.project), scenario=args.scenario, axes=parse_vary(args.vary),
                     max_elements=args.max_elements, threshold_m=args.threshold)
    err = Console(stderr=True)
    lines = plain_counter(err)  # plain lines where stderr is no terminal (logs, nohup)
    with Progress(TextColumn("sweep"), BarColumn(), MofNCompleteColumn(), TextColumn("{task.description}"),
                  TimeElapsedColumn(), console=err, transient=True, disable=lines is not None) as bar:
        job = bar.add_task("preparing", total=None)

        def tell(done: int, total: int, variant: str) -> None:
            bar.update(job, completed=done, total=total, description=variant)
            if lines is not None:
                lines.count(f"sweep ({variant})", done, total)

        result = run_sweep(spec, out_dir=args.out, workers=args.workers, cluster=args.cluster,
                           keep_runs=args.keep_runs, safety=args.safety, progress=tell)
    sys.stdout.write(result.table())
    sys.stdout.write("\nPareto front (time below the safety threshold, total duration; both minimised):\n")
    sys.stdout.write(result.table(result.front))
    sys.stdout.write(f"\ntable: {Path(args.out) / 'sweep.csv'}  front: {Path(args.out) / 'pareto.png'}\n")
    return 0 if result.front else 1
