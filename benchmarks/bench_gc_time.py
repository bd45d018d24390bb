"""The cyclic garbage collector's time in a ``kbplanner run``'s command process, per stage (issue 14:
core/heap's set-aside of the loaded project), by a baseline's sources and by this tree's.

For each tree, in a fresh process with its own empty cache (``KBPLANNER_CACHE_DIR``, a cold load), the
script generates nothing: it runs ``run_pipeline(PROJECT, OUT, tasks="all", workers=W, max_elements=N)``
(the pipeline of ``kbplanner run --tasks all``) with a ``gc.callbacks`` hook that adds up the full
(generation 2) collections and their wall seconds, and prints at each stage's end the collections and
seconds so far, and the process's CPU seconds so far. The spawned task processes are not counted
(their own collections). Wall seconds of
the collector grow with the machine's load, like every wall time here: compare the two trees in one
run of this script.

Usage: .venv/bin/python benchmarks/bench_gc_time.py PROJECT [--before REF] [--max-elements N]
       [--workers 2] [--out FILE]
(PROJECT: e.g. the generated 10 x 8 building, ``kbplanner generate-building --storeys 10
--units-per-storey 8 --out PROJECT``). Writes benchmarks/results/gc_time.json (or --out).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from _common import REPO, RESULTS_DIR, machine_info, write_json

CHILD = r"""
import gc, json, sys, time
from pathlib import Path
import kbplanner.pipeline as pl

full = {"n": 0, "s": 0.0}
began = [0.0]

def hook(phase, info):
    if info["generation"] != 2:
        return
    if phase == "start":
        began[0] = time.perf_counter()
    else:
        full["n"] += 1
        full["s"] += time.perf_counter() - began[0]

rows = []

def say(line):
    if " done in " in line:
        rows.append({"stage": line.split(" done in ")[0], "full_collections": full["n"],
                     "collector_s": round(full["s"], 2), "cpu_s": round(time.process_time(), 1)})

if __name__ == "__main__":
    gc.callbacks.append(hook)
    me = None if sys.argv[3] == "none" else int(sys.argv[3])
    t0 = time.perf_counter()
    pl.run_pipeline(Path(sys.argv[1]), Path(sys.argv[2]), tasks="all", workers=int(sys.argv[4]),
                    max_elements=me, say=say)
    print(json.dumps({"seconds": round(time.perf_counter() - t0, 1), "cpu_s": round(time.process_time(), 1),
                      "stages": rows,
                      "full_collections": full["n"], "collector_s": round(full["s"], 2)}))
"""


def _export(ref: str, into: Path) -> Path:
    into.mkdir(parents=True, exist_ok=True)
    archive = subprocess.run(["git", "-C", str(REPO), "archive", ref], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into / "src"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("project", type=Path)
    ap.add_argument("--before", default="main", help="git ref of the baseline (default main)")
    ap.add_argument("--max-elements", type=int, default=2)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "gc_time.json")
    args = ap.parse_args(argv)
    load_start = list(os.getloadavg())
    result: dict[str, Any] = {"machine": machine_info(("python", "cpus", "platform")), "before": args.before,
                              "project": str(args.project), "max_elements": args.max_elements}
    with tempfile.TemporaryDirectory(prefix="bench-gc-") as tmp_name:
        tmp = Path(tmp_name)
        script = tmp / "child.py"
        script.write_text(CHILD, encoding="utf-8")
        trees = {"before": _export(args.before, tmp / "before"), "after": REPO / "src"}
        for label, src in trees.items():
            env = dict(os.environ, PYTHONPATH=str(src), PYTHONHASHSEED="0",
                       KBPLANNER_CACHE_DIR=str(tmp / f"cache-{label}"))
            me = "none" if args.max_elements is None else str(args.max_elements)
            done = subprocess.run([sys.executable, str(script), str(args.project.resolve()),
                                   str(tmp / f"run-{label}"), me, str(args.workers)],
                                  env=env, check=True, capture_output=True, text=True)
            result[label] = json.loads(done.stdout.strip().splitlines()[-1])
    result["load_average_start"], result["load_average_end"] = load_start, list(os.getloadavg())
    write_json(args.out, result)
    w = sys.stdout.write
    w(f"the command's process, so far: full collections / their seconds / CPU s; before = {args.before}\n")
    after = {r["stage"]: r for r in result["after"]["stages"]}
    for row in result["before"]["stages"]:
        a = after.get(row["stage"], {})
        w(f"  {row['stage'][:40]:40}{row['full_collections']:5} /{row['collector_s']:6.1f} s"
          f" /{row['cpu_s']:6.1f}{a.get('full_collections', 0):7} /{a.get('collector_s', 0.0):6.1f} s"
          f" /{a.get('cpu_s', 0.0):6.1f}\n")
    for label in ("before", "after"):
        r = result[label]
        w(f"{label}: {r['seconds']} s in all, {r['cpu_s']} s CPU (the command's process), "
          f"{r['full_collections']} full collections, {r['collector_s']} s\n")
    w(f"load average {load_start[0]:.2f} -> {result['load_average_end'][0]:.2f}; wrote {args.out}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
