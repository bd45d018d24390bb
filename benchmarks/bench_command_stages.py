"""Where the case study's ``kbplanner simulate`` command spends its CPU (issue 14, item 2): its stages,
timed in one fresh process per scenario, the same steps as the command.

Stages, in the command's order (CPU and wall seconds each): ``imports`` (the modules the command
imports), ``project load`` (``Project.load``, from the project cache when it is warm), ``world``
(``build_world``), ``plan`` (B1-B3, ``plan_task``), ``occupancy map`` (``storey_map``), ``B4``
(``refine_plan``: never read from the refined-plan cache), ``B5`` (``executor.simulate``), split into
``B5 key frames`` (the TinyRenderer images, ``render_png``), ``B5 environment`` (``SimEnv`` loaded and
reset), ``B5 outputs`` (the safety summary, the trajectory and event texts and the files written: with
key frames rendered in worker processes, the wait for the last of them) and ``B5 step`` (the rest: the
executed plan). ``B5 key frame workers`` is the CPU of the forked processes that render key frames beside
the step (session 11; not the command process's, so not in ``total_cpu_s``: ``total_cpu_with_workers_s``
adds it). Before the timed run the project is loaded once (its cache
entry written).

Usage: .venv/bin/python benchmarks/bench_command_stages.py [--scenario S ...] [--seed N]
Prints a table and writes benchmarks/results/command_stages.json (or --out); ``--compare BEFORE AFTER``
prints the before / after table of two such files (e.g. one written by a baseline's copy of this script).
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

_STAGES = '''import json, resource, sys, time
def children_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime
c, w = time.process_time(), time.perf_counter()
marks = []
def mark(name):
    global c, w
    c1, w1 = time.process_time(), time.perf_counter()
    marks.append((name, round(c1 - c, 3), round(w1 - w, 3)))
    c, w = c1, w1
from pathlib import Path
from rich.console import Console
from kbplanner.planning.manipulation import refine_plan
from kbplanner.planning.planner import plan_task
from kbplanner.project import Project
import kbplanner.simulation.executor as ex
from kbplanner.simulation.skills import ExecSettings
from kbplanner.world.build import build_world
from kbplanner.world.maps import storey_map
mark("imports")
project_dir, scenario, seed, out = sys.argv[1], sys.argv[2], int(sys.argv[3]), Path(sys.argv[4])
project = Project.load(project_dir, scenario=scenario)
mark("project load")
world = build_world(project, project.world_date(None), None)
mark("world")
plan = plan_task(project, None, None, world=world)
mark("plan")
grid = storey_map(world).grid
mark("occupancy map")
refined = refine_plan(plan, world, seed=seed, grid=grid)
mark("B4")
parts = {"B5 key frames": [0.0, 0.0], "B5 environment": [0.0, 0.0], "B5 outputs": [0.0, 0.0]}
def timed(name, fn):
    def wrapped(*args, **kwargs):
        c0, w0 = time.process_time(), time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            parts[name][0] += time.process_time() - c0
            parts[name][1] += time.perf_counter() - w0
    return wrapped
ex.render_png = timed("B5 key frames", ex.render_png)
ex.SimEnv.__init__ = timed("B5 environment", ex.SimEnv.__init__)
ex.SimEnv.reset = timed("B5 environment", ex.SimEnv.reset)
for attr in ("safety_summary", "atomic_write_text", "atomic_write_bytes", "write_json"):
    setattr(ex, attr, timed("B5 outputs", getattr(ex, attr)))
for attr in ("trajectories_csv", "events_jsonl"):
    setattr(ex.Recorder, attr, timed("B5 outputs", getattr(ex.Recorder, attr)))
workers0 = children_cpu()
res = ex.simulate(project, refined, seed=seed, out_dir=out, world=world, grid=grid, settings=ExecSettings())
mark("B5")
workers = children_cpu() - workers0
name, b5_cpu, b5_wall = marks[-1]
step = [b5_cpu - sum(v[0] for v in parts.values()), b5_wall - sum(v[1] for v in parts.values())]
for k, v in [*parts.items(), ("B5 step", step)]:
    marks.append((k, round(v[0], 3), round(v[1], 3)))
marks.append(("B5 key frame workers", round(workers, 3), 0.0))
json.dump({"stages": marks, "sim_time_s": res.sim_time_s}, sys.stdout)
'''


def _stages(scenario: str, seed: int, tmp: Path) -> dict[str, Any]:
    env = dict(os.environ, PYTHONPATH=str(REPO / "src"))
    project = str(REPO / "data" / "case_study")
    subprocess.run([sys.executable, "-m", "kbplanner", "plan", project, "--scenario", scenario,
                    "--no-feasibility"], check=False, capture_output=True, env=env)  # the project cache
    done = subprocess.run([sys.executable, "-c", _STAGES, project, scenario, str(seed), str(tmp / scenario)],
                          check=True, capture_output=True, text=True, env=env)
    got = json.loads(done.stdout.strip().splitlines()[-1])
    stages = {name: {"cpu_s": cpu, "wall_s": wall} for name, cpu, wall in got["stages"]}
    top = [n for n in stages if not n.startswith("B5 ")]
    total = sum(stages[n]["cpu_s"] for n in top)
    wall = sum(stages[n]["wall_s"] for n in top)
    workers = stages.get("B5 key frame workers", {"cpu_s": 0.0})["cpu_s"]
    return {"scenario": scenario, "seed": seed, "sim_time_s": got["sim_time_s"], "stages": stages,
            "total_cpu_s": round(total, 3), "x_real_time_cpu": round(got["sim_time_s"] / total, 1),
            "total_cpu_with_workers_s": round(total + workers, 3), "total_wall_s": round(wall, 3),
            "x_real_time_wall": round(got["sim_time_s"] / wall, 1)}


def _wall(r: dict[str, Any]) -> str:
    """Wall seconds of the command's stages (and x real time) of one scenario's result."""
    wall = r.get("total_wall_s")
    if wall is None:
        wall = sum(v["wall_s"] for n, v in r["stages"].items() if not n.startswith("B5 "))
    return f"{wall:.2f} ({r['sim_time_s'] / wall:.1f}x)"


def compare(before: dict[str, Any], after: dict[str, Any]) -> str:
    """A Markdown table of two results of this script: CPU seconds per stage, before / after."""
    rows = list(zip(before["scenarios"], after["scenarios"], strict=True))
    lines = ["| stage, CPU s before / after | " + " | ".join(a["scenario"] for _b, a in rows) + " |",
             "| --- |" + " ---: |" * len(rows)]
    def cpu(r: dict[str, Any], n: str) -> str:
        return f"{r['stages'][n]['cpu_s']:.2f}" if n in r["stages"] else "-"

    for n in after["scenarios"][0]["stages"]:
        lines.append(f"| {n} | " + " | ".join(f"{cpu(b, n)} / {cpu(a, n)}" for b, a in rows) + " |")
    whole = [f"{b['total_cpu_s']:.2f} ({b['sim_time_s']:,.1f} s: {b['x_real_time_cpu']}x) / "
             f"{a['total_cpu_s']:.2f} ({a['sim_time_s']:,.1f} s: {a['x_real_time_cpu']}x)" for b, a in rows]
    lines.append("| whole, CPU s (simulated s: x real time) | " + " | ".join(whole) + " |")
    both = [f"{b.get('total_cpu_with_workers_s', b['total_cpu_s']):.2f} / "
            f"{a.get('total_cpu_with_workers_s', a['total_cpu_s']):.2f}" for b, a in rows]
    lines.append("| whole with the key frame workers, CPU s | " + " | ".join(both) + " |")
    walls = [f"{_wall(b)} / {_wall(a)}" for b, a in rows]
    lines.append("| whole, wall s (x real time) | " + " | ".join(walls) + " |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--compare", nargs=2, type=Path, metavar=("BEFORE", "AFTER"),
                    help="print the before / after table of two written results and stop")
    ap.add_argument("--scenario", action="append", help="scenario(s) (default: both storage scenarios)")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "command_stages.json")
    args = ap.parse_args(argv)
    if args.compare:
        before, after = (json.loads(f.read_text(encoding="utf-8")) for f in args.compare)
        sys.stdout.write(compare(before, after))
        return 0
    load_before = list(os.getloadavg())
    with tempfile.TemporaryDirectory() as tmp:
        scenarios = args.scenario or ["storage-outside", "storage-inside"]
        rows = [_stages(s, args.seed, Path(tmp)) for s in scenarios]
    out = {"machine": machine_info(("python", "cpus", "platform")), "load_average_start": load_before,
           "load_average_end": list(os.getloadavg()), "scenarios": rows}
    write_json(args.out, out)
    names = list(rows[0]["stages"])
    w = sys.stdout.write
    w("| stage, CPU s | " + " | ".join(r["scenario"] for r in rows) + " |\n")
    w("| --- |" + " ---: |" * len(rows) + "\n")
    for n in names:
        w(f"| {n} | " + " | ".join(f"{r['stages'][n]['cpu_s']:.2f}" for r in rows) + " |\n")
    w("| whole (simulated s / CPU s) | " + " | ".join(
        f"{r['total_cpu_s']:.2f} ({r['sim_time_s']:,.1f} s: {r['x_real_time_cpu']}x)" for r in rows) + " |\n")
    w("| whole with the key frame workers, CPU s | " + " | ".join(
        f"{r['total_cpu_with_workers_s']:.2f}" for r in rows) + " |\n")
    w("| whole, wall s (x real time) | " + " | ".join(_wall(r) for r in rows) + " |\n")
    w(f"\n(`bench_command_stages.py`, seed {args.seed}; load average {load_before[0]:.1f} -> "
      f"{out['load_average_end'][0]:.1f}; wrote {args.out})\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
