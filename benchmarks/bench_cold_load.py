"""The serial stages of ``kbplanner run`` on a generated building (issue 14: 10 x 8 on 2 cores), before/after:
the cold scenario load (the IFC import: on the critical path before any task) and the bare load after it,
in one process as ``kbplanner run`` does them, by a baseline's sources and by this tree's, alternately.

Per round and tree, a fresh process with its own empty cache (``KBPLANNER_CACHE_DIR``) runs
``ProjectData.load(PROJECT, scenario=S)`` then ``ProjectData.load(PROJECT)`` and reports each load's wall
seconds and the CPU seconds of the loading process (the critical path) and of its children (the volume
process of this tree's import); ``model.ttl`` and the meshes of both trees' imports are compared byte for
byte, and the two loads' model graphs as triple sets.

Usage: .venv/bin/python benchmarks/bench_cold_load.py [--before REF] [--size 10x8] [--rounds N] [--out FILE]
Prints a table and writes benchmarks/results/cold_load.json (or --out).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from _common import REPO, RESULTS_DIR, machine_info, write_json

CHILD = r"""
import hashlib, json, os, resource, sys, time
from pathlib import Path
from kbplanner.model.project_data import ProjectData
project, scenario = Path(sys.argv[1]), sys.argv[2]
out = {}
for name, sc in (("scenario load", scenario), ("bare load", None)):
    t, c = time.perf_counter(), time.process_time()
    loaded = ProjectData.load(project, scenario=sc)
    out[name] = {"wall_s": time.perf_counter() - t, "cpu_s": time.process_time() - c}
    h = hashlib.sha256()
    for line in sorted(f"{s.n3()} {p.n3()} {o.n3()}" for s, p, o in loaded.model):
        h.update(line.encode())
    out[name]["model_sha256"] = h.hexdigest()
ru = resource.getrusage(resource.RUSAGE_CHILDREN)
out["children_cpu_s"] = ru.ru_utime + ru.ru_stime
files = hashlib.sha256()
for p in sorted(loaded.import_dir.rglob("*")):
    if p.is_file():
        files.update(p.relative_to(loaded.import_dir).as_posix().encode()); files.update(p.read_bytes())
out["import_sha256"] = files.hexdigest()
print(json.dumps(out))
"""


def _export(ref: str, into: Path) -> Path:
    into.mkdir(parents=True, exist_ok=True)
    archive = subprocess.run(["git", "-C", str(REPO), "archive", ref], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into / "src"


def _median(rows: list[dict[str, Any]], *keys: str) -> float:
    values = []
    for row in rows:
        v: Any = row
        for k in keys:
            v = v[k]
        values.append(float(v))
    return round(statistics.median(values), 2)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--before", default="main")
    ap.add_argument("--size", default="10x8", help="STOREYSxUNITS (default 10x8)")
    ap.add_argument("--scenario", default="storage-in-units")
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "cold_load.json")
    args = ap.parse_args()
    storeys, units = (int(x) for x in args.size.lower().split("x"))
    load_before = os.getloadavg()[0]
    runs: dict[str, list[dict[str, Any]]] = {"before": [], "after": []}
    with tempfile.TemporaryDirectory(prefix="bench-cold-load-") as tmp_name:
        tmp = Path(tmp_name)
        trees = {"before": _export(args.before, tmp / "before"), "after": REPO / "src"}
        project = tmp / "building"
        env = dict(os.environ, PYTHONPATH=str(trees["after"]), PYTHONHASHSEED="0",
                   KBPLANNER_CACHE_DIR=str(tmp / "cache-gen"))
        subprocess.run([sys.executable, "-m", "kbplanner", "generate-building", "--storeys", str(storeys),
                        "--units-per-storey", str(units), "--out", str(project)], check=True, env=env,
                       capture_output=True)
        for k in range(args.rounds):
            for label in ("before", "after"):
                env = dict(os.environ, PYTHONPATH=str(trees[label]), PYTHONHASHSEED="0",
                           KBPLANNER_CACHE_DIR=str(tmp / f"cache-{label}-{k}"))
                done = subprocess.run([sys.executable, "-c", CHILD, str(project), args.scenario], env=env,
                                      capture_output=True, text=True)
                if done.returncode != 0:
                    raise SystemExit(f"{label} failed:\n{done.stderr[-3000:]}")
                row = json.loads(done.stdout.strip().splitlines()[-1])
                runs[label].append(row)
                sys.stderr.write(f"round {k + 1}: {label} {row['scenario load']['wall_s']:.1f} s + "
                                 f"{row['bare load']['wall_s']:.1f} s\n")
    same = all(r[key] == runs["before"][0][key] for r in runs["before"] + runs["after"]
               for key in ("import_sha256",)) and all(
        r[n]["model_sha256"] == runs["before"][0][n]["model_sha256"]
        for r in runs["before"] + runs["after"] for n in ("scenario load", "bare load"))
    rows = [("scenario load (cold import), wall s", ("scenario load", "wall_s")),
            ("scenario load, CPU s of the loading process", ("scenario load", "cpu_s")),
            ("bare load after it, wall s", ("bare load", "wall_s")),
            ("bare load, CPU s", ("bare load", "cpu_s")),
            ("children's CPU s (volume process)", ("children_cpu_s",))]
    table = {name: {label: _median(runs[label], *keys) for label in runs} for name, keys in rows}
    result = {"size": args.size, "before": args.before, "rounds": args.rounds, "table": table,
              "identical": same, "runs": runs, "load_average": [load_before, os.getloadavg()[0]],
              "machine": machine_info()}
    write_json(args.out, result)
    print(f"{args.size}, cold scenario load then bare load; before = {args.before}")
    print("| | before | after | ratio |\n| --- | ---: | ---: | ---: |")
    for name, v in table.items():
        ratio = f"{v['before'] / v['after']:.2f}" if v["after"] else ""
        print(f"| {name} | {v['before']:.1f} | {v['after']:.1f} | {ratio} |")
    print(f"import files and model graphs identical: {'yes' if same else 'NO'}; load average "
          f"{load_before:.2f} -> {os.getloadavg()[0]:.2f}; wrote {args.out}")


if __name__ == "__main__":
    main()
