"""Key frames in a forked worker or in the process (issue 14, item 2: the ``simulate`` command's fixed
costs): the case study's B5 (``executor.simulate``, key frames on) run in one fresh process per
scenario and mode, the two modes alternately, the same tree.

``inline`` renders each key frame in the command's process (``render_png(..., worker=False)``, as
before session 11); ``worker`` in a forked copy of it beside the simulation step (the default on
Linux). Per run it records the process's CPU (user + system) and wall seconds of B5, its minor page
faults (the forks' copy-on-write shows there), the CPU of the workers (``RUSAGE_CHILDREN``) and the
SHA-256 of every output file but ``timing.json`` and ``manifest.json``; ``identical`` says whether both
modes wrote the same bytes (key frame PNGs included). B1-B4 run before the timed part (B4 read from the
refined-plan cache when a ``plan`` kept it; the script runs ``plan`` first).

Usage: .venv/bin/python benchmarks/bench_keyframes.py [--scenario S ...] [--seed N] [--rounds N]
Prints a table and writes benchmarks/results/keyframes.json (or --out).
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

_RUN = '''import functools, hashlib, json, resource, sys, time
from pathlib import Path
from kbplanner.planning.planner import plan_task
from kbplanner.planning.refine_cache import refine_kept
from kbplanner.project import Project
import kbplanner.simulation.executor as ex
from kbplanner.simulation import keyframes
from kbplanner.simulation.skills import ExecSettings
from kbplanner.world.build import build_world
from kbplanner.world.maps import storey_map
project_dir, scenario, seed, mode = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
out = Path(sys.argv[5])
project = Project.load(project_dir, scenario=scenario)
world = build_world(project, project.world_date(None), None)
plan = plan_task(project, None, None, world=world)
grid = storey_map(world).grid
refined = refine_kept(plan, world, seed=seed, grid=grid, cache_dir=project.cache_entry)
ex.render_png = functools.partial(keyframes.render_png, worker=mode == "worker")
me0, kids0 = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
w0 = time.perf_counter()
res = ex.simulate(project, refined, seed=seed, out_dir=out, world=world, grid=grid, settings=ExecSettings())
wall = time.perf_counter() - w0
me1, kids1 = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
files = {str(f.relative_to(out)): hashlib.sha256(f.read_bytes()).hexdigest() for f in sorted(out.rglob("*"))
         if f.is_file() and f.name not in ("timing.json", "manifest.json", ".kbplanner-run")}
json.dump({"cpu_s": round(me1.ru_utime + me1.ru_stime - me0.ru_utime - me0.ru_stime, 3),
           "wall_s": round(wall, 3), "minor_faults": me1.ru_minflt - me0.ru_minflt,
           "workers_cpu_s": round(kids1.ru_utime + kids1.ru_stime - kids0.ru_utime - kids0.ru_stime, 3),
           "keyframes": sum(1 for f in files if f.startswith("keyframes/")),
           "sim_time_s": res.sim_time_s, "files": files}, sys.stdout)
'''

MODES = ("inline", "worker")


def _run(scenario: str, seed: int, mode: str, out: Path) -> dict[str, Any]:
    env = dict(os.environ, PYTHONPATH=str(REPO / "src"))
    project = str(REPO / "data" / "case_study")
    done = subprocess.run([sys.executable, "-c", _RUN, project, scenario, str(seed), mode, str(out)],
                          check=True, capture_output=True, text=True, env=env)
    got: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    return got


def _scenario(scenario: str, seed: int, rounds: int, tmp: Path) -> dict[str, Any]:
    env = dict(os.environ, PYTHONPATH=str(REPO / "src"))
    project = str(REPO / "data" / "case_study")
    subprocess.run([sys.executable, "-m", "kbplanner", "plan", project, "--scenario", scenario,
                    "--seed", str(seed)], check=False, capture_output=True, env=env)  # the caches
    runs: dict[str, list[dict[str, Any]]] = {m: [] for m in MODES}
    for r in range(rounds):
        for mode in MODES:
            runs[mode].append(_run(scenario, seed, mode, tmp / f"{scenario}-{mode}-{r}"))
    hashes = [run["files"] for mode in MODES for run in runs[mode]]
    row: dict[str, Any] = {"scenario": scenario, "seed": seed, "rounds": rounds,
                           "sim_time_s": runs["worker"][0]["sim_time_s"],
                           "keyframes": runs["worker"][0]["keyframes"],
                           "identical": all(h == hashes[0] for h in hashes), "files": len(hashes[0])}
    for mode in MODES:
        row[mode] = {k: statistics.median(run[k] for run in runs[mode])
                     for k in ("cpu_s", "wall_s", "minor_faults", "workers_cpu_s")}
    return row


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", action="append", help="scenario(s) (default: both storage scenarios)")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--rounds", type=int, default=2, help="inline/worker pairs per scenario (median)")
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "keyframes.json")
    args = ap.parse_args(argv)
    load_before = list(os.getloadavg())
    with tempfile.TemporaryDirectory() as tmp:
        rows = [_scenario(s, args.seed, args.rounds, Path(tmp))
                for s in args.scenario or ["storage-outside", "storage-inside"]]
    out = {"machine": machine_info(("python", "cpus", "platform")), "load_average_start": load_before,
           "load_average_end": list(os.getloadavg()), "scenarios": rows}
    write_json(args.out, out)
    w = sys.stdout.write
    w("| scenario | key frames | B5 process CPU s inline / worker | workers' CPU s | B5 CPU with the workers "
      "inline / worker | B5 wall s inline / worker | minor faults inline / worker | identical |\n")
    w("| --- | ---: | ---: | ---: | ---: | ---: | ---: | --- |\n")
    for r in rows:
        i, k = r["inline"], r["worker"]
        w(f"| {r['scenario']} | {r['keyframes']} | {i['cpu_s']:.2f} / {k['cpu_s']:.2f} | "
          f"{k['workers_cpu_s']:.2f} | "
          f"{i['cpu_s'] + i['workers_cpu_s']:.2f} / {k['cpu_s'] + k['workers_cpu_s']:.2f} | "
          f"{i['wall_s']:.2f} / {k['wall_s']:.2f} | {i['minor_faults']:,.0f} / {k['minor_faults']:,.0f} | "
          f"{'yes' if r['identical'] else 'NO'} ({r['files']} files) |\n")
    w(f"\n(`bench_keyframes.py --rounds {args.rounds}`: medians, seed {args.seed}; load average "
      f"{load_before[0]:.1f} -> {out['load_average_end'][0]:.1f}; wrote {args.out})\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
