"""Sweep benchmark: speed-up of ``kbplanner sweep`` with 2 local worker processes over 1 (serial).

Runs the same small sweep on the case study (4 storage candidates x 1 seed, the first 2 frames of
each) serially and with 2 processes, checks that both give the same table, prints the wall times,
the speed-up and the table, and writes ``benchmarks/results/sweep.json``.

    .venv/bin/python benchmarks/bench_sweep.py [--workers 2] [--max-elements 2]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

from _common import REPO, RESULTS_DIR, Timer, cpu_seconds, write_json

from kbplanner.core.outputs import versions
from kbplanner.scale.sweep import SweepSpec, run_sweep
from kbplanner.scale.sweep_axes import parse_vary

CANDIDATES = "storage-outside;storage-inside;15.0,-16.0;18.5,-13.0"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0] if __doc__ else None)
    ap.add_argument("--project", type=Path, default=REPO / "data" / "case_study")
    ap.add_argument("--scenario", default="storage-outside")
    ap.add_argument("--storage", default=CANDIDATES)
    ap.add_argument("--seed", default="7")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--max-elements", type=int, default=2)
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "sweep.json")
    args = ap.parse_args()
    spec = SweepSpec(args.project, scenario=args.scenario, max_elements=args.max_elements,
                     axes=parse_vary([f"storage={args.storage}", f"seed={args.seed}"]))
    load_before = os.getloadavg()[0]
    walls: dict[int, float] = {}
    cpu: dict[int, float] = {}
    tables: dict[int, str] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for n in (1, args.workers):
            c0 = cpu_seconds()
            with Timer() as timer:
                res = run_sweep(spec, out_dir=Path(tmp) / f"w{n}", workers=n)
            walls[n] = timer.seconds
            cpu[n] = cpu_seconds() - c0
            tables[n] = (Path(tmp) / f"w{n}" / "sweep.csv").read_text()
            print(f"workers={n}: {walls[n]:.1f} s wall, {cpu[n]:.1f} s CPU (this process + workers) "
                  f"for {len(res.rows)} variants", flush=True)
    same = tables[1] == tables[args.workers]
    speedup = walls[1] / walls[args.workers]
    print(res.table())
    print(f"speed-up with {args.workers} workers: {speedup:.2f}x (identical tables: {same})")
    simulated = [r for r in res.rows if r.status == "ok"]
    out = {
        "project": str(args.project.relative_to(REPO) if args.project.is_relative_to(REPO) else args.project),
        "storage_candidates": args.storage, "seeds": args.seed, "max_elements": args.max_elements,
        "variants": len(res.rows), "simulated": len(simulated), "cpu_count": os.cpu_count(),
        "load_average_1min": {"before": round(load_before, 2), "after": round(os.getloadavg()[0], 2),
                              "note": "other processes on the machine: above the core count, less speed-up"},
        "wall_s": {str(k): round(v, 2) for k, v in walls.items()},
        "cpu_s": {str(k): round(v, 2) for k, v in cpu.items()},
        "cores_busy": {str(k): round(cpu[k] / walls[k], 2) for k in walls},
        "speedup": round(speedup, 2), "identical_tables": same,
        "rows": [{"variant": r.variant, "status": r.status, "installed": r.installed,
                  "total_min": r.total_min, "below_threshold_s": r.below_threshold_s} for r in res.rows],
        "pareto": [r.variant for r in res.front],
        "versions": versions(),
    }
    write_json(args.out, out)
    print(f"wrote {args.out}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
