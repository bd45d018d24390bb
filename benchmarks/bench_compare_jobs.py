"""How much ``kbplanner compare --seeds ... --jobs 2`` saves against ``--jobs 1`` (docs/safety.md).

Runs the same study twice, serially and with ``--jobs 2``, one after the other, and records each
command's wall time and CPU seconds (``run_measured``), the ratio (jobs 2 / serial) and the load
average before and after (on a shared machine absolute seconds vary with the other work), and whether
the two ``seeds.csv`` are identical (they must be: every run is seeded on its own)::

    kbplanner compare PROJECT --scenarios S --seeds SEEDS --jobs N --out DIR

Usage: .venv/bin/python benchmarks/bench_compare_jobs.py [PROJECT] [--scenarios S] [--seeds 1-4]
Without PROJECT it writes the small test project of ``tests/sim_project_factory.py`` (two panels,
scenario ``stored``). Prints the figures and writes benchmarks/results/compare_jobs.json (or --out).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

from _common import REPO, RESULTS_DIR, machine_info, run_measured, write_json


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("project", nargs="?", type=Path)
    ap.add_argument("--scenarios", default="stored")
    ap.add_argument("--seeds", default="1-4")
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "compare_jobs.json")
    a = ap.parse_args()
    env = {**os.environ, "PYTHONPATH": str(REPO / "src")}
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        project = a.project
        if project is None:
            sys.path.insert(0, str(REPO / "tests"))
            from sim_project_factory import make_sim_project

            project = work / "project"
            make_sim_project(project, high_panel=False)
        runs = {}
        for jobs in (1, 2):
            out = work / f"jobs{jobs}"
            cmd = [sys.executable, "-m", "kbplanner", "compare", str(project), "--scenarios", a.scenarios,
                   "--seeds", a.seeds, "--jobs", str(jobs), "--out", str(out)]
            load = os.getloadavg()
            r = run_measured(cmd, log=work / f"jobs{jobs}.log", timeout_s=7200.0, env=env)
            after = os.getloadavg()
            r.update(load_before=[round(x, 2) for x in load], load_after=[round(x, 2) for x in after])
            seeds_csv = out / "seeds.csv"
            r["seeds_csv"] = seeds_csv.read_text() if seeds_csv.exists() else None
            runs[jobs] = r
            print(f"--jobs {jobs}: {r['seconds']:.1f} s wall, {r['cpu_s']} s CPU, exit {r['exit']}, "
                  f"load {r['load_before']}")
        same = runs[1]["seeds_csv"] is not None and runs[1]["seeds_csv"] == runs[2]["seeds_csv"]
        ratio = runs[2]["seconds"] / runs[1]["seconds"]
        print(f"--jobs 2 / serial: {ratio:.2f}; seeds.csv identical: {same}")
        for r in runs.values():
            r.pop("seeds_csv")
        write_json(a.out, {"project": str(a.project or "tests/sim_project_factory.py (stored, 2 panels)"),
                           "scenarios": a.scenarios, "seeds": a.seeds, "serial": runs[1], "jobs2": runs[2],
                           "ratio_jobs2_to_serial": round(ratio, 3), "seeds_csv_identical": same,
                           "machine": machine_info()})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
