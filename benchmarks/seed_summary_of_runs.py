"""The ``compare --seeds`` summary from run directories already on disk (no simulation).

For runs made one by one (``kbplanner simulate --seed N``) or a ``compare --seeds`` that was stopped
before it finished (its ``DIR.partial/<scenario>/seed-<N>/`` folders): finds every run directory (a
folder with ``metrics.json`` and ``manifest.json``) under the given folders and writes the same
``seeds.csv``, ``seed_summary.csv/json``, ``figures/seeds.png`` and ``summary.md/html`` into OUT.
Scenarios appear in the order of ``--scenarios`` (the first is the one the others are compared with).

Usage: python benchmarks/seed_summary_of_runs.py --out OUT [--scenarios A,B] RUNS_FOLDER [...]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from kbplanner.analysis.seed_report import write_seed_outputs
from kbplanner.analysis.seed_study import study_of_runs
from kbplanner.core.outputs import run_directory


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folders", nargs="+", type=Path)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--scenarios", default="")
    a = ap.parse_args(argv)
    found = {m.parent for f in a.folders for m in f.rglob("metrics.json")}
    dirs = sorted(d for d in found if (d / "manifest.json").is_file() and not d.name.endswith(".partial"))
    if not dirs:
        print("no run directories found")
        return 2
    study = study_of_runs(dirs, a.folders[0])
    order = [s for s in a.scenarios.split(",") if s]
    study.scenarios.sort(key=lambda s: order.index(s) if s in order else len(order))
    with run_directory(a.out) as stage:
        write_seed_outputs(study, stage, title=f"{len(study.seeds)} seeds (runs on disk)")
    print(f"{len(study.runs)} runs, {len(study.cost_runs)} with monitoring off; wrote {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
