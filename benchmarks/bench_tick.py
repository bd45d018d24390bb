"""The simulation step's per-period loop before/after (issues 11 and 14): the CPU seconds of the case
study's ``executor.simulate`` split into the navigation skills' planning (``NavigationSkill.start``),
the key frames (``render_png``) and the per-period loop (the rest: crowd, held element, recorder,
contact and monitor checks, the skills' updates), run by a baseline's sources and by this tree's.

Each tree runs, in a child process with ``PYTHONPATH`` at its sources, what ``kbplanner simulate
data/case_study --scenario S --seed N`` runs (B1-B4, then ``executor.simulate``), with thin CPU timers
(``time.process_time``) around the pieces; the pieces are the same functions in both trees. It
records per scenario and tree the simulated time, the control periods, the step's CPU seconds and
real-time factor, each piece's calls and CPU seconds, and the loop's CPU per period; whether the
run's ``trajectories.csv``, ``events.jsonl`` and ``metrics.json`` are byte-identical between the trees.
The timers cost both trees alike (a microsecond or so per call).

``--warm``: each tree runs once before the measured run, so that both read what their project caches keep
(the baseline's tree is exported to a temporary folder, its caches empty: without it the baseline builds
its configuration spaces in the measured run).

Usage: .venv/bin/python benchmarks/bench_tick.py [--before REF] [--scenario S ...] [--seed N] [--warm]
Prints a table and writes benchmarks/results/tick.json (or --out).
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

DETERMINISTIC = ("trajectories.csv", "events.jsonl", "metrics.json")

# argv: project scenario seed out_dir result_json
_CHILD = '''import importlib, json, sys, time
from pathlib import Path
project_dir, scenario, out_dir, result = sys.argv[1], sys.argv[2], sys.argv[4], sys.argv[5]
seed = int(sys.argv[3])
from kbplanner.planning.manipulation import refine_plan
from kbplanner.planning.planner import plan_task
from kbplanner.project import Project
from kbplanner.simulation import executor
from kbplanner.simulation.skills import ExecSettings
from kbplanner.world.build import build_world
from kbplanner.world.maps import storey_map
project = Project.load(Path(project_dir), scenario=scenario)
world = build_world(project, project.world_date(None), None)
plan = plan_task(project, None, None, world=world)
grid = storey_map(world).grid
refined = refine_plan(plan, world, seed=seed, grid=grid)
pieces = {}
def wrap(module, owner, name, key):
    obj = importlib.import_module(module)
    obj = getattr(obj, owner) if owner else obj
    f = getattr(obj, name)
    pieces[key] = [0, 0.0]
    def timed(*a, **k):
        c = time.process_time()
        try:
            return f(*a, **k)
        finally:
            pieces[key][0] += 1
            pieces[key][1] += time.process_time() - c
    setattr(obj, name, timed)
for spec in ("kbplanner.simulation.skills.navigation:NavigationSkill:start:planning",
             "kbplanner.simulation.executor::render_png:key frames",
             "kbplanner.simulation.sim_env:SimEnv:reset:load",
             "kbplanner.simulation.sim_env:SimEnv:step:env.step",
             "kbplanner.simulation.crowd:Crowd:step:crowd",
             "kbplanner.simulation.sim_env:SimEnv:follow:held element",
             "kbplanner.simulation.recorder:Recorder:sample:recorder",
             "kbplanner.simulation.safety:ContactMonitor:after_robot:contact (robot)",
             "kbplanner.simulation.safety:ContactMonitor:after_workers:contact (workers)",
             "kbplanner.simulation.separation_monitor:SeparationMonitor:decide:monitor"):
    wrap(*spec.split(":"))
c0 = time.process_time()
res = executor.simulate(project, refined, seed=seed, out_dir=Path(out_dir), world=world, grid=grid,
                        settings=ExecSettings())
cpu = time.process_time() - c0
ticks = pieces["env.step"][0]
loop = cpu - sum(pieces[k][1] for k in ("planning", "key frames", "load"))
json.dump({"sim_time_s": res.sim_time_s, "periods": ticks, "step_cpu_s": cpu, "loop_cpu_s": loop,
           "loop_ms_per_period": 1000 * loop / max(ticks, 1), "pieces": pieces}, open(result, "w"))
'''


def _export(ref: str, into: Path) -> Path:
    into.mkdir(parents=True, exist_ok=True)
    archive = subprocess.run(["git", "-C", str(REPO), "archive", ref], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into / "src"


def _run(src: Path, scenario: str, seed: int, out: Path) -> dict[str, Any]:
    result = out.with_suffix(".json")
    env = dict(os.environ, PYTHONPATH=str(src))
    proc = subprocess.run([sys.executable, "-c", _CHILD, str(src.parent / "data" / "case_study"), scenario,
                           str(seed), str(out), str(result)], env=env, capture_output=True, text=True,
                          timeout=1800)
    if proc.returncode != 0 or not result.is_file():
        raise SystemExit(f"{scenario} with {src} failed (exit {proc.returncode}):\n{proc.stderr[-2000:]}")
    data: dict[str, Any] = json.loads(result.read_text())
    return data


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", default="main", help="git ref of the baseline (default main)")
    ap.add_argument("--scenario", action="append", help="scenario(s) (default: both storage scenarios)")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "tick.json")
    ap.add_argument("--warm", action="store_true",
                    help="run each tree once first (outputs dropped): both measured runs then read what "
                         "their project caches keep (configuration spaces, cell paths, walking routes), as "
                         "a second command does")
    args = ap.parse_args(argv)
    scenarios = args.scenario or ["storage-outside", "storage-inside"]
    load_before = list(os.getloadavg())
    rows = []
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        before_src = _export(args.before, tmp / "before")
        for s in scenarios:
            if args.warm:
                for label, src in (("before", before_src), ("after", REPO / "src")):
                    _run(src, s, args.seed, tmp / f"{s}-{label}-warm")
            runs = {label: _run(src, s, args.seed, tmp / f"{s}-{label}")
                    for label, src in (("before", before_src), ("after", REPO / "src"))}
            same = all((tmp / f"{s}-before" / f).read_bytes() == (tmp / f"{s}-after" / f).read_bytes()
                       for f in DETERMINISTIC)
            b, a = runs["before"], runs["after"]
            rows.append({"scenario": s, "seed": args.seed, "outputs_identical": same, "before": b, "after": a,
                         "x_real_time_step_cpu": [round(r["sim_time_s"] / r["step_cpu_s"], 1)
                                                  for r in (b, a)],
                         "speedup_loop_cpu": round(b["loop_cpu_s"] / a["loop_cpu_s"], 2),
                         "speedup_step_cpu": round(b["step_cpu_s"] / a["step_cpu_s"], 2)})
    out = {"machine": machine_info(("python", "cpus", "platform")), "before": args.before, "warm": args.warm,
           "load_average_start": load_before, "load_average_end": list(os.getloadavg()), "scenarios": rows}
    write_json(args.out, out)
    w = sys.stdout.write
    for r in rows:
        b, a = r["before"], r["after"]
        w(f"{r['scenario']} (seed {r['seed']}, {a['sim_time_s']:.1f} s simulated, {a['periods']} periods), "
          f"identical: {'yes' if r['outputs_identical'] else 'no'}\n")
        w(f"  step CPU {b['step_cpu_s']:.2f} / {a['step_cpu_s']:.2f} s (x{r['speedup_step_cpu']}; "
          f"{r['x_real_time_step_cpu'][0]}x -> {r['x_real_time_step_cpu'][1]}x real time)\n")
        w(f"  per-period loop {b['loop_cpu_s']:.2f} / {a['loop_cpu_s']:.2f} s (x{r['speedup_loop_cpu']}; "
          f"{b['loop_ms_per_period']:.3f} / {a['loop_ms_per_period']:.3f} ms per period)\n")
        for k in b["pieces"]:
            (nb, cb), (na, ca) = b["pieces"][k], a["pieces"][k]
            w(f"    {k:22} {cb:7.2f} / {ca:7.2f} s  ({nb} / {na} calls)\n")
    w("warm (each tree ran once first); " if args.warm else "")
    w(f"load average {load_before[0]:.2f} -> {out['load_average_end'][0]:.2f}; wrote {args.out}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
