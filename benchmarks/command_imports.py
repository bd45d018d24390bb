"""What the imports of ``kbplanner simulate`` cost, and what parts of them add (issue 14, session 13).

Not a pipeline step. Each figure is the CPU seconds (``time.process_time``) of imports made in a fresh
process (the median of ``--repeat``), with ``PYTHONPATH`` at this checkout's sources:

- ``command``: the imports ``cli/simulate.run`` makes (as ``simulate_phases.py`` does), and the
  number of modules they load;
- ``trimesh``: ``import trimesh`` after everything else the command uses at run time is imported (NumPy,
  SciPy's spatial, sparse graph and ndimage, shapely, PIL, PyBullet, OMPL, rdflib with its SPARQL
  engine, rich): what trimesh brings on its own (its package imports all its submodules, networkx and
  SciPy's optimize among them), and the packages (subpackages of those already there) that come only
  with it;
- ``B4 search``: ``kbplanner.planning.manipulation`` (B4's pose search and IK) after the command's
  imports: what a command whose refined plan is kept no longer imports (0 when the command imports it).

    PYTHONPATH=src python benchmarks/command_imports.py [--repeat 5] [--out FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path
from typing import Any

from _common import REPO, RESULTS_DIR, machine_info, write_json

COMMAND = ("rich.console", "rich.progress", "rich.table", "kbplanner.planning.planner",
           "kbplanner.planning.refine_cache", "kbplanner.project", "kbplanner.simulation.executor",
           "kbplanner.world.build", "kbplanner.world.maps", "kbplanner.cli", "kbplanner.cli.simulate")
RUNTIME_NEEDS = ("numpy", "scipy.spatial", "scipy.sparse.csgraph", "scipy.ndimage", "shapely", "PIL.Image",
                 "pybullet", "ompl.base", "ompl.geometric", "ompl.util", "rdflib", "rdflib.plugins.sparql",
                 "rich.console", "rich.progress", "rich.table")
PROBE = """
import importlib, json, sys, time
first, then = json.loads(sys.argv[1]), json.loads(sys.argv[2])
for m in first:
    importlib.import_module(m)
before = set(sys.modules)
t = time.process_time()
for m in then:
    importlib.import_module(m)
cpu = time.process_time() - t
tops = {m.split(".")[0] for m in before}
added = set(sys.modules) - before
new = sorted({m.split(".")[0] if m.split(".")[0] not in tops else ".".join(m.split(".")[:2]) for m in added
              if m.split(".")[0] not in sys.stdlib_module_names})
print(json.dumps({"cpu_s": cpu, "modules": len(set(sys.modules) - before), "new_packages": new}))
"""


def _probe(first: tuple[str, ...], then: tuple[str, ...]) -> dict[str, Any]:
    env = {**os.environ, "PYTHONPATH": str(REPO / "src")}
    out = subprocess.run([sys.executable, "-c", PROBE, json.dumps(first), json.dumps(then)], env=env,
                         capture_output=True, text=True, check=True).stdout
    data: dict[str, Any] = json.loads(out.splitlines()[-1])
    return data


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=5, help="fresh processes per figure (median; default 5)")
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "command_imports.json")
    args = ap.parse_args()
    cases = {"command": ((), COMMAND), "trimesh": (RUNTIME_NEEDS, ("trimesh",)),
             "B4 search": (COMMAND, ("kbplanner.planning.manipulation",))}
    load_start = os.getloadavg()
    runs: dict[str, list[dict[str, Any]]] = {name: [] for name in cases}
    for _ in range(args.repeat):  # the cases alternate: all see the same machine load
        for name, (first, then) in cases.items():
            runs[name].append(_probe(first, then))
    load_end = os.getloadavg()
    rows = [{"imports": name, "cpu_s": round(statistics.median(r["cpu_s"] for r in runs[name]), 3),
             "cpu_s_runs": [round(r["cpu_s"], 3) for r in runs[name]], "modules": runs[name][-1]["modules"],
             "new_packages": runs[name][-1]["new_packages"]} for name in cases]
    write_json(args.out, {"benchmark": "command_imports", "repeat": args.repeat,
                          "load_average_start": [round(x, 2) for x in load_start],
                          "load_average_end": [round(x, 2) for x in load_end],
                          "machine": machine_info(), "rows": rows})
    print(f"imports of kbplanner simulate, CPU s, median of {args.repeat}; load average "
          f"{load_start[0]:.2f} -> {load_end[0]:.2f} (1 min)")
    for r in rows:
        extra = [p for p in r["new_packages"] if p.split(".")[0] not in ("kbplanner", "trimesh", "_")
                 and not p.startswith("_") and "._" not in p]
        print(f"{r['imports']:<10} {r['cpu_s']:6.3f} s {r['modules']:5d} modules"
              + (f"  (with it only: {', '.join(extra)})" if r["imports"] == "trimesh" else ""))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
