"""The workers' timeline of a ``kbplanner run --tasks all`` folder (issue 14: where the 2 cores wait).

Reads ``RUN/run_timings.json`` (the stages' wall seconds, the command process's CPU seconds in each
(since session 14), and, per task, its start and end from the
simulation stage's start, its CPU seconds and the process that ran it: 0 the command's own) and prints,
from the run's start: the serial stages, each process's tasks in turn, the time each process waited
before its first task and after its last one (until the stage's end), and each process's first task's
CPU seconds against the median of its later ones (what a process pays once: imports, tables, maps).

Usage: .venv/bin/python benchmarks/run_timeline.py RUN [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path
from typing import Any


def timeline(run: Path) -> dict[str, Any]:
    """The figures printed, from a run folder's ``run_timings.json``."""
    data = json.loads((run / "run_timings.json").read_text(encoding="utf-8"))
    stages = [(s["stage"] + (f" [{s['scenario']}]" if s.get("scenario") else ""), float(s["seconds"]),
               s.get("cpu_s")) for s in data["stages"]]
    before = sum(sec for name, sec, _cpu in stages if name.startswith("load"))  # the stage starts after these
    sim = data.get("simulation", {})
    tasks: list[dict[str, Any]] = []
    for scenario, figures in sim.get("scenarios", {}).items():
        for task, t in figures.get("per_task", {}).items():
            tasks.append({"scenario": scenario, "task": task, **t})
    wall = float(sim.get("wall_s", 0.0))
    procs: dict[int, dict[str, Any]] = {}
    for p in sorted({int(t["process"]) for t in tasks}):
        mine = sorted((t for t in tasks if int(t["process"]) == p), key=lambda t: t["start_s"])
        later = [t["cpu_s"] for t in mine[1:]]
        procs[p] = {
            "tasks": [(t["task"], t["start_s"], t["end_s"], t["cpu_s"]) for t in mine],
            "waited_before_s": round(mine[0]["start_s"], 1),
            "idle_after_s": round(wall - mine[-1]["end_s"], 1),
            "first_cpu_s": mine[0]["cpu_s"],
            "later_cpu_median_s": round(statistics.median(later), 2) if later else None}
    return {"run": str(run), "total_s": data.get("total_seconds"), "stages": stages,
            "simulation_starts_s": round(before, 1), "simulation_wall_s": wall,
            "tasks_cpu_s": round(sum(t["cpu_s"] for t in tasks), 1), "processes": procs}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("--json", type=Path, help="also write the figures as JSON")
    args = ap.parse_args(argv)
    t = timeline(args.run)
    w = sys.stdout.write
    w(f"{t['run']}: {t['total_s']} s in all\n")
    for name, sec, cpu in t["stages"]:  # CPU: the command's process (recorded since session 14)
        w(f"  {name:48}{sec:9.1f} s" + (f"{cpu:9.1f} s CPU" if cpu is not None else "") + "\n")
    w(f"simulation stage from {t['simulation_starts_s']} s, {t['simulation_wall_s']:.1f} s wall, "
      f"tasks {t['tasks_cpu_s']} s CPU\n")
    for p, fig in t["processes"].items():
        who = "the command" if p == 0 else "spawned"
        w(f"process {p} ({who}): first task at {fig['waited_before_s']} s, "
          f"idle {fig['idle_after_s']} s after its last; first task {fig['first_cpu_s']:.1f} s CPU, "
          f"later ones median {fig['later_cpu_median_s']} s\n")
        for task, start, end, cpu in fig["tasks"]:
            w(f"    {task:24}{start:9.1f} -> {end:9.1f} s  {cpu:6.1f} s CPU\n")
    if args.json is not None:
        args.json.write_text(json.dumps(t, indent=1) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
