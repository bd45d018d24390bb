"""The reactive crowd's step before/after (issue 14, item 2; B5): the case study's crowd, recorded once
and stepped again by a baseline's sources and by this tree's, state for state.

The simulate command runs once per scenario (``--record-with``'s sources, default the baseline) with
``Crowd`` wrapped so that its construction (the workers, the walking map, the seed), every ``step``
(the robot as the workers see it: pose and footprint) and every ``make_way`` request are pickled,
together with a digest of the crowd's positions, velocities and headings after each step and each
``make_way`` answer. Each tree then replays the calls in a fresh process (``PYTHONPATH`` at its
sources, the baseline exported by ``git archive`` as in ``bench_simspeed.py``), counts the steps whose
state differs from the recording (``mismatches``: 0 means bit-identical), and times the replay in CPU
seconds (best of ``--repeat``; the digests are taken in the first pass only). Ratios are baseline /
this tree (> 1: faster now).

Usage: .venv/bin/python benchmarks/bench_crowd_replay.py [--before REF] [--scenario S ...] [--seed N]
[--repeat N]
Prints a table and writes benchmarks/results/crowd_replay.json (or --out).
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

# argv: trace.pkl, then the simulate command's arguments
_RECORD = '''import hashlib, pickle, sys
import kbplanner.simulation.crowd as cr
from kbplanner.cli import main
log = {"init": None, "calls": []}
init0, step0, way0 = cr.Crowd.__init__, cr.Crowd.step, cr.Crowd.make_way
def digest(c):
    return hashlib.sha1(c.pos.tobytes() + c.vel.tobytes() + c.heading.tobytes()).hexdigest()
def init(self, specs, grid, *, seed, control_hz=10.0):
    log["init"] = (specs, grid, seed, control_hz)
    init0(self, specs, grid, seed=seed, control_hz=control_hz)
def step(self, robot):
    seen = None if robot is None else (robot.pose, list(robot.rects))
    step0(self, robot)
    log["calls"].append(("step", seen, digest(self)))
def make_way(self, i, path, clear_m):
    out = way0(self, i, path, clear_m)
    log["calls"].append(("make_way", (i, path.copy(), clear_m), out))
    return out
cr.Crowd.__init__, cr.Crowd.step, cr.Crowd.make_way = init, step, make_way
try:
    main(sys.argv[2:])
except SystemExit:
    pass
with open(sys.argv[1], "wb") as f:
    pickle.dump(log, f)
'''

# argv: trace.pkl, repeat, result.json
_REPLAY = '''import hashlib, json, pickle, sys, time
from kbplanner.simulation.crowd import Crowd
from kbplanner.simulation.social_force import Obstacle
with open(sys.argv[1], "rb") as f:
    log = pickle.load(f)
specs, grid, seed, hz = log["init"]
calls = [(k, (None if a is None else Obstacle(a[0], a[1])) if k == "step" else a, want)
         for k, a, want in log["calls"]]
best, mismatches = None, 0
for rep in range(int(sys.argv[2])):
    crowd = Crowd(specs, grid, seed=seed, control_hz=hz)
    c0 = time.process_time()
    for kind, arg, want in calls:
        if kind == "step":
            crowd.step(arg)
            if rep == 0:
                got = hashlib.sha1(crowd.pos.tobytes() + crowd.vel.tobytes() + crowd.heading.tobytes())
                mismatches += got.hexdigest() != want
        elif crowd.make_way(*arg) != want and rep == 0:
            mismatches += 1
    cpu = time.process_time() - c0
    best = cpu if best is None or cpu < best else best
steps = sum(1 for k, _, _ in calls if k == "step")
with open(sys.argv[3], "w") as f:
    json.dump({"steps": steps, "workers": len(specs), "cpu_s": best, "ms_per_step": 1000 * best / steps,
               "mismatches": mismatches}, f)
'''


def _export(ref: str, into: Path) -> Path:
    into.mkdir(parents=True, exist_ok=True)
    archive = subprocess.run(["git", "-C", str(REPO), "archive", ref], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into / "src"


def _child(src: Path, code: str, args: list[str]) -> None:
    env = dict(os.environ, PYTHONPATH=str(src))
    proc = subprocess.run([sys.executable, "-c", code, *args], env=env, capture_output=True, text=True,
                          timeout=3600)
    if proc.returncode != 0:
        raise SystemExit(f"{src}: exit {proc.returncode}:\n{proc.stderr[-2000:]}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", default="main", help="git ref of the baseline (default main)")
    ap.add_argument("--record-with", choices=("before", "after"), default="before",
                    help="whose sources record the crowd (default the baseline's)")
    ap.add_argument("--scenario", action="append", help="scenario(s) (default: both storage scenarios)")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--repeat", type=int, default=3, help="replays per tree (the best CPU time counts)")
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "crowd_replay.json")
    args = ap.parse_args(argv)
    scenarios = args.scenario or ["storage-outside", "storage-inside"]
    load_before = list(os.getloadavg())
    rows: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        trees = {"before": _export(args.before, tmp / "before"), "after": REPO / "src"}
        for s in scenarios:
            trace = tmp / f"{s}.pkl"
            rec = trees[args.record_with]
            command = ["simulate", str(rec.parent / "data" / "case_study"), "--scenario", s, "--seed",
                       str(args.seed), "--no-keyframes", "--out", str(tmp / f"{s}-run")]
            _child(rec, _RECORD, [str(trace), *command])
            runs = {}
            for label, src in trees.items():
                result = tmp / f"{s}-{label}.json"
                _child(src, _REPLAY, [str(trace), str(args.repeat), str(result)])
                runs[label] = json.loads(result.read_text())
            b, a = runs["before"], runs["after"]
            rows.append({"scenario": s, "seed": args.seed, "recorded_with": args.record_with, "before": b,
                         "after": a, "identical": b["mismatches"] == 0 and a["mismatches"] == 0,
                         "speedup_cpu": round(b["cpu_s"] / a["cpu_s"], 2)})
    out = {"machine": machine_info(("python", "cpus", "platform")), "before": args.before,
           "load_average_start": load_before, "load_average_end": list(os.getloadavg()), "scenarios": rows}
    write_json(args.out, out)
    w = sys.stdout.write
    for r in rows:
        b, a = r["before"], r["after"]
        w(f"{r['scenario']} (seed {r['seed']}, {a['steps']} steps, {a['workers']} workers): crowd CPU "
          f"{b['cpu_s']:.3f} / {a['cpu_s']:.3f} s (x{r['speedup_cpu']}; {b['ms_per_step']:.4f} / "
          f"{a['ms_per_step']:.4f} ms per step); mismatches {b['mismatches']} / {a['mismatches']}; "
          f"identical: {'yes' if r['identical'] else 'no'}\n")
    w(f"load average {load_before[0]:.2f} -> {out['load_average_end'][0]:.2f}; wrote {args.out}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
