"""Navigation planning speed before/after (issue 14, item 2; B5): the case study's ``plan_path`` queries,
recorded once and planned again by a baseline's sources and by this tree's, alternately, in one run.

The simulate command runs once per scenario (this tree's sources) with ``plan_path`` wrapped so that each
query (its configuration space, start, goal and settings) is pickled. Each tree then plans every query
again in a fresh process (``PYTHONPATH`` at its sources, the baseline exported by ``git archive`` as in
``bench_simspeed.py``), the spaces as the space cache hands them out (free maps read-only, nothing
labelled yet), and records the CPU seconds of all queries and each result (status, reason, planner,
poses). Ratios are baseline / this tree (> 1: faster now), medians over rounds; ``identical`` says
whether every result of both trees is the same. This isolates B5's planning (OMPL with the Python
checks, the walled-off question, the cell path, the path rewrites) from the rest of the step.

Usage: .venv/bin/python benchmarks/bench_nav_replay.py [--before REF] [--scenario S ...] [--task T]
[--rounds N]
(``--task``: record one robotized task of the case study, e.g. T-BOARD, instead of the project's default task)
Prints a table and writes benchmarks/results/nav_replay.json (or --out); ``--markdown-from JSON`` prints
the Markdown table of such a result (for the docs) without running anything.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
from pathlib import Path
from typing import Any

from _common import REPO, RESULTS_DIR, machine_info, run_measured, write_json
from bench_simspeed import _export

# python -c RECORD PICKLE simulate ...: the simulate command with every plan_path query pickled.
_RECORD = '''import pickle, sys
import kbplanner.simulation.navigation as nav
import kbplanner.simulation.carry_paths as cp
import kbplanner.simulation.skills.navigation as sn
from kbplanner.cli import main
queries = []
inner = nav.plan_path
def recording(space, start, goal, footprint=None, settings=None):
    queries.append((space, start, goal, footprint, settings))
    return inner(space, start, goal, footprint, settings)
nav.plan_path = cp.plan_path = sn.plan_path = recording
try:
    code = main(sys.argv[2:])
finally:
    for q in queries:
        for memo in ("memo", "open_memo", "near_memo"):
            getattr(q[0], memo, {}).clear()
    with open(sys.argv[1], "wb") as f:
        pickle.dump(queries, f)
raise SystemExit(code)
'''

# python -c REPLAY PICKLE JSON: every query planned again, CPU seconds and results written as JSON.
_REPLAY = '''import hashlib, json, pickle, sys, time
from kbplanner.simulation.navigation import plan_path
with open(sys.argv[1], "rb") as f:
    queries = pickle.load(f)
for q in queries:
    if hasattr(q[0], "free"):
        q[0].free.setflags(write=False)
results, cpu = [], 0.0
for space, start, goal, footprint, settings in queries:
    c0 = time.process_time()
    path = plan_path(space, start, goal, footprint, settings)
    cpu += time.process_time() - c0
    poses = hashlib.sha1(repr(path.poses).encode()).hexdigest()
    results.append([path.status, path.reason, path.planner, poses])
with open(sys.argv[2], "w") as f:
    json.dump({"cpu_s": cpu, "results": results}, f)
'''


def _median(values: list[float]) -> float:
    return round(statistics.median(values), 3)


def bench(before_src: Path, after_src: Path, scenario: str, seed: int, rounds: int, tmp: Path,
          task: str | None = None) -> dict[str, Any]:
    queries = tmp / f"{scenario}.pkl"
    env = dict(os.environ, PYTHONPATH=str(after_src))
    cmd = [sys.executable, "-c", _RECORD, str(queries), "simulate", str(REPO / "data" / "case_study"),
           "--scenario", scenario, "--seed", str(seed), "--out", str(tmp / f"{scenario}-run")]
    if task:
        cmd += ["--task", task]
    recorded = run_measured(cmd, log=tmp / f"{scenario}-record.log", timeout_s=1800.0, env=env)
    if not queries.is_file():
        raise SystemExit(f"recording {scenario} wrote no queries (exit {recorded['exit']}): "
                         f"{(tmp / f'{scenario}-record.log').read_text()[-2000:]}")
    cpu: dict[str, list[float]] = {"before": [], "after": []}
    results: dict[str, list[Any]] = {}
    for k in range(rounds):
        for label, src in (("before", before_src), ("after", after_src)):
            out = tmp / f"{scenario}-{label}-{k}.json"
            run_measured([sys.executable, "-c", _REPLAY, str(queries), str(out)],
                         log=tmp / f"{scenario}-{label}-{k}.log", timeout_s=1800.0,
                         env=dict(os.environ, PYTHONPATH=str(src)))
            got = json.loads(out.read_text())
            cpu[label].append(got["cpu_s"])
            results.setdefault(label, got["results"])
    b, a = _median(cpu["before"]), _median(cpu["after"])
    kinds: dict[str, int] = {}
    for status, reason, planner, _ in results["after"]:
        kind = "walled off" if "walled off" in reason else planner if status == "ok" else "failed"
        kinds[kind] = kinds.get(kind, 0) + 1
    return {"scenario": scenario, "seed": seed, "rounds": rounds, "queries": len(results["after"]),
            "kinds": kinds, "before_cpu_s": b, "after_cpu_s": a,
            "speedup_cpu": round(b / a, 2) if a else None, "cpu_s": cpu,
            "identical": results["before"] == results["after"]}


def markdown(out: dict[str, Any]) -> str:
    """The Markdown table of a result (docs/scale.md)."""
    lines = ["| scenario | queries | planning CPU before / after | identical results |",
             "| --- | ---: | ---: | --- |"]
    for r in out["scenarios"]:
        kinds = ", ".join(f"{n} {k}" for k, n in sorted(r["kinds"].items()))
        same = "yes" if r["identical"] else "no"
        lines.append(f"| {r['scenario']} | {r['queries']} ({kinds}) | {r['before_cpu_s']:.2f} / "
                     f"{r['after_cpu_s']:.2f} s (x{r['speedup_cpu']}) | {same} |")
    rounds = out["scenarios"][0]["rounds"] if out["scenarios"] else 0
    seed = out["scenarios"][0]["seed"] if out["scenarios"] else ""
    lines.append("")
    task = f" --task {out['task']}" if out.get("task") else ""
    lines.append(f"(`bench_nav_replay.py --before {out['before']}{task} --rounds {rounds}`: medians of "
                 f"{rounds} round(s), seed {seed}; load average {out['load_average_start'][0]:.1f} -> "
                 f"{out['load_average_end'][0]:.1f})")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--markdown-from", type=Path, metavar="JSON",
                    help="print the Markdown table of an earlier result and exit (no runs)")
    ap.add_argument("--before", default="main", help="git ref of the baseline (default main)")
    ap.add_argument("--scenario", action="append", help="scenario(s) (default: both storage scenarios)")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--task", help="robotized task to record (default: the project's [simulation] task)")
    ap.add_argument("--rounds", type=int, default=2, help="before/after pairs per scenario (median)")
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "nav_replay.json")
    args = ap.parse_args(argv)
    if args.markdown_from:
        sys.stdout.write(markdown(json.loads(args.markdown_from.read_text())))
        return 0
    scenarios = args.scenario or ["storage-outside", "storage-inside"]
    load_before = list(os.getloadavg())
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        before_src = _export(args.before, tmp)
        rows = [bench(before_src, REPO / "src", s, args.seed, args.rounds, tmp, args.task) for s in scenarios]
    out = {"machine": machine_info(("python", "cpus", "platform")), "before": args.before, "task": args.task,
           "load_average_start": load_before, "load_average_end": list(os.getloadavg()), "scenarios": rows}
    write_json(args.out, out)
    sys.stdout.write(markdown(out))
    sys.stdout.write(f"wrote {args.out}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
