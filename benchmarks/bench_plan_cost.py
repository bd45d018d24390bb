"""Navigation planning cost before/after over several seeds (issue 14: simulate >= 100x real time, with
the path quality of pathq11): the case study's ``kbplanner simulate`` run by a baseline's sources and by
this tree's, seed by seed (baseline first, then this tree), as ``bench_simspeed.py`` runs them (same
timed wrapper, B4 cold, no key frames).

Per run it records the step's planning time (``timing.json`` ``planning_total_s``: wall seconds of the
path planners), the simulation step's CPU seconds and whether ``trajectories.csv``, ``events.jsonl`` and
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

from _common import RESULTS_DIR, machine_info, write_json
from bench_simspeed import DETERMINISTIC, _export, _prime, _run

SCENARIOS = ("storage-outside", "storage-inside")


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
        out[side] = {"planning_total_s_median": round(statistics.median(plan), 3) if plan else None,
                     "planning_total_s_max": round(max(plan), 3) if plan else None,
                     "planning_total_s_sum": round(sum(plan), 3) if plan else None,
                     "simulation_cpu_s_median": round(statistics.median(cpu), 3) if cpu else None}
    return out


def table(result: dict[str, Any]) -> str:
    """The Markdown table of a result (docs/scale.md)."""
    lines = ["| scenario | seeds | planning_total_s median before / after | max before / after "
             "| sum before / after | simulation CPU median before / after | identical outputs |",
             "| --- | ---: | ---: | ---: | ---: | ---: | --- |"]
    for sc, rows in result["runs"].items():
        s = _summary(rows)
        b, a = s["before"], s["after"]
        lines.append(f"| {sc} | {s['seeds']} "
                     f"| {b['planning_total_s_median']} / {a['planning_total_s_median']} s "
                     f"| {b['planning_total_s_max']} / {a['planning_total_s_max']} s "
                     f"| {b['planning_total_s_sum']} / {a['planning_total_s_sum']} s "
                     f"| {b['simulation_cpu_s_median']} / {a['simulation_cpu_s_median']} s "
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
                    got = _run(src, sc, seed, out, tmp / f"{sc}-{seed}-{label}.log")
                    keys = ("planning_total_s", "simulation_cpu_s", "sim_time_s", "exit")
                    row[label] = {k: got[k] for k in keys}
                    outs[label] = out
                pair = (outs["before"], outs["after"])
                row["outputs_identical"] = all((pair[0] / f).read_bytes() == (pair[1] / f).read_bytes()
                                               for f in DETERMINISTIC)
                result["runs"][sc].append(row)
                print(f"{sc} seed {seed}: planning {row['before']['planning_total_s']} -> "
                      f"{row['after']['planning_total_s']} s, CPU {row['before']['simulation_cpu_s']} -> "
                      f"{row['after']['simulation_cpu_s']} s, identical {row['outputs_identical']}",
                      flush=True)
            result["load_average_end"] = list(os.getloadavg())
            write_json(a.out, result)
    print(table(result), end="")
    return 0 if all(r["outputs_identical"] for rows in result["runs"].values() for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
