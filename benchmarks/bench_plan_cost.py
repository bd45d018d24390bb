"""Navigation planning cost before/after over several seeds (issue 14: simulate >= 100x real time, with
the path quality of pathq11): the case study's ``kbplanner simulate`` run by a baseline's sources and by
this tree's, seed by seed (baseline first, then this tree), as ``bench_simspeed.py`` runs them (same
timed wrapper, B4 cold, no key frames).

Per run it records the step's planning time (``timing.json`` ``planning_total_s``: wall seconds of the
path planners), the CPU seconds of the navigation skills' route planning (``NavigationSkill._plan``, timed
by a wrapper the same for both trees: the planners, the one-turn and turn-pose searches, the legs'
yardsticks and timing; steadier than wall seconds on a shared machine), the simulation step's CPU
seconds and whether ``trajectories.csv``, ``events.jsonl`` and
``metrics.json`` of both trees are byte-identical; per scenario the median and max of the planning
time and the median CPU over the seeds. The JSON is written after every seed (a stopped run keeps the
seeds done).

Usage: .venv/bin/python benchmarks/bench_plan_cost.py [--before REF] [--seeds 1-20] [--scenario S ...]
[--out JSON]; ``--print JSON`` prints the table of such a result without running anything.
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

from _common import RESULTS_DIR, machine_info, run_measured, write_json
from bench_simspeed import DETERMINISTIC, _export, _prime

SCENARIOS = ("storage-outside", "storage-inside")

# ``python -m kbplanner ARGS`` with the simulation step and the navigation skills' route planning timed
# (CPU and wall seconds) into the file named by the first argument; B4 cold, as bench_simspeed.py runs it.
_TIMED = '''import json, sys, time
import kbplanner.simulation.executor as ex
import kbplanner.simulation.skills.navigation as nav
from kbplanner.cli import main
try:
    import kbplanner.planning.refine_cache as rc
    rc._read = lambda path: None
except ImportError:
    pass
acc = {"plan_cpu_s": 0.0, "plan_wall_s": 0.0, "plans": 0}
inner_plan = nav.NavigationSkill._plan
def plan(self, *args, **kwargs):
    c0, w0 = time.process_time(), time.perf_counter()
    try:
        return inner_plan(self, *args, **kwargs)
    finally:
        acc["plan_cpu_s"] += time.process_time() - c0
        acc["plan_wall_s"] += time.perf_counter() - w0
        acc["plans"] += 1
nav.NavigationSkill._plan = plan
inner = ex.simulate
def timed(*args, **kwargs):
    c0, w0 = time.process_time(), time.perf_counter()
    try:
        return inner(*args, **kwargs)
    finally:
        with open(sys.argv[1], "w") as f:
            json.dump({"cpu_s": time.process_time() - c0, "wall_s": time.perf_counter() - w0, **acc}, f)
ex.simulate = timed
raise SystemExit(main(sys.argv[2:]))
'''


def _run(src: Path, scenario: str, seed: int, out: Path, log: Path) -> dict[str, Any]:
    env = dict(os.environ, PYTHONPATH=str(src))
    step_file = log.with_suffix(".step.json")
    cmd = [sys.executable, "-c", _TIMED, str(step_file), "simulate", str(src.parent / "data" / "case_study"),
           "--scenario", scenario, "--seed", str(seed), "--out", str(out), "--no-keyframes"]
    measured = run_measured(cmd, log=log, timeout_s=1800.0, env=env)
    if not (out / "timing.json").is_file() or not step_file.is_file():
        tail = log.read_text()[-2000:]
        raise SystemExit(f"{' '.join(cmd)} wrote no run (exit {measured['exit']}):\n{tail}")
    step = json.loads(step_file.read_text())
    timing = json.loads((out / "timing.json").read_text())
    return {"exit": measured["exit"], "planning_total_s": timing.get("planning_total_s"),
            "sim_time_s": timing.get("sim_time_s"), "simulation_cpu_s": round(step["cpu_s"], 3),
            "route_planning_cpu_s": round(step["plan_cpu_s"], 3), "routes_planned": step["plans"]}


def _seeds(text: str) -> list[int]:
    out: list[int] = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out += list(range(int(a), int(b or a) + 1))
    return out


def _summary(runs: list[dict[str, Any]]) -> dict[str, Any]:
    def pick(side: str, key: str) -> list[float]:
        return [r[side][key] for r in runs if isinstance(r[side].get(key), (int, float))]

    out: dict[str, Any] = {"seeds": len(runs), "identical": sum(1 for r in runs if r["outputs_identical"])}
    for side in ("before", "after"):
        plan, cpu = pick(side, "planning_total_s"), pick(side, "simulation_cpu_s")
        route = pick(side, "route_planning_cpu_s")
        out[side] = {"route_planning_cpu_s_median": round(statistics.median(route), 3) if route else None,
                     "route_planning_cpu_s_max": round(max(route), 3) if route else None,
                     "route_planning_cpu_s_sum": round(sum(route), 3) if route else None,
                     "planning_total_s_median": round(statistics.median(plan), 3) if plan else None,
                     "planning_total_s_max": round(max(plan), 3) if plan else None,
                     "planning_total_s_sum": round(sum(plan), 3) if plan else None,
                     "simulation_cpu_s_median": round(statistics.median(cpu), 3) if cpu else None}
    return out


def table(result: dict[str, Any]) -> str:
    """The Markdown table of a result (docs/scale.md)."""
    lines = ["| scenario | seeds | route planning CPU median / max / sum, before -> after "
             "| planning_total_s (wall) median / max, before -> after "
             "| simulation CPU median before -> after | identical outputs |",
             "| --- | ---: | --- | --- | --- | --- |"]
    for sc, rows in result["runs"].items():
        s = _summary(rows)
        b, a = s["before"], s["after"]
        lines.append(f"| {sc} | {s['seeds']} "
                     f"| {b['route_planning_cpu_s_median']} / {b['route_planning_cpu_s_max']} / "
                     f"{b['route_planning_cpu_s_sum']} -> {a['route_planning_cpu_s_median']} / "
                     f"{a['route_planning_cpu_s_max']} / {a['route_planning_cpu_s_sum']} s "
                     f"| {b['planning_total_s_median']} / {b['planning_total_s_max']} -> "
                     f"{a['planning_total_s_median']} / {a['planning_total_s_max']} s "
                     f"| {b['simulation_cpu_s_median']} -> {a['simulation_cpu_s_median']} s "
                     f"| {s['identical']} of {s['seeds']} |")
    end = result.get("load_average_end", [0.0])
    load = f"load average {result['load_average_start'][0]:.1f} -> {end[0]:.1f}"
    after = f" --after {result['after']}" if result.get("after") else ""
    how = f"bench_plan_cost.py --before {result['before']}{after} --seeds {result['seeds']}"
    lines += ["", f"(`{how}`; {load})"]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", default="main", help="git ref of the baseline (default main)")
    ap.add_argument("--after", help="git ref of the tree measured (default: this working tree's sources)")
    ap.add_argument("--seeds", default="1-20", help="seeds, e.g. 1-20 or 1-5,7")
    ap.add_argument("--scenario", action="append", help="scenario(s) (default: both storage scenarios)")
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "plan_cost.json")
    ap.add_argument("--print", type=Path, dest="print_file", help="print the table of a result JSON")
    a = ap.parse_args(argv)
    if a.print_file:
        print(table(json.loads(a.print_file.read_text())), end="")
        return 0
    scenarios = a.scenario or list(SCENARIOS)
    result: dict[str, Any] = {"before": a.before, "after": a.after, "seeds": a.seeds,
                              "machine": machine_info(),
                              "load_average_start": list(os.getloadavg()), "runs": {s: [] for s in scenarios}}
    here = Path(__file__).resolve().parents[1] / "src"
    with tempfile.TemporaryDirectory(prefix="bench_plan_cost_") as tmp_name:
        tmp = Path(tmp_name)
        (tmp / "before").mkdir()
        before = _export(a.before, tmp / "before")
        if a.after:
            (tmp / "after").mkdir()
            here = _export(a.after, tmp / "after")
        for sc in scenarios:
            for label, src in (("before", before), ("after", here)):
                _prime(src, sc, _seeds(a.seeds)[0], False, tmp / f"{sc}-{label}-prime.log")
        for seed in _seeds(a.seeds):
            for sc in scenarios:
                row: dict[str, Any] = {"seed": seed}
                outs = {}
                for label, src in (("before", before), ("after", here)):
                    out = tmp / f"{sc}-{seed}-{label}"
                    row[label] = _run(src, sc, seed, out, tmp / f"{sc}-{seed}-{label}.log")
                    outs[label] = out
                pair = (outs["before"], outs["after"])
                row["outputs_identical"] = all((pair[0] / f).read_bytes() == (pair[1] / f).read_bytes()
                                               for f in DETERMINISTIC)
                result["runs"][sc].append(row)
                rb, ra = row["before"], row["after"]
                print(f"{sc} seed {seed}: route planning CPU {rb['route_planning_cpu_s']} -> "
                      f"{ra['route_planning_cpu_s']} s, planning {rb['planning_total_s']} -> "
                      f"{ra['planning_total_s']} s, CPU {rb['simulation_cpu_s']} -> "
                      f"{ra['simulation_cpu_s']} s, identical {row['outputs_identical']}",
                      flush=True)
            result["load_average_end"] = list(os.getloadavg())
            write_json(a.out, result)
    print(table(result), end="")
    return 0 if all(r["outputs_identical"] for rows in result["runs"].values() for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
