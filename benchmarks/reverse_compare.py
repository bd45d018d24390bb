"""Backward driving and the safety figures of runs before and after a change, as markdown table rows.

Takes two folders of run directories named ``SCENARIO-SEED`` (``kbplanner simulate data/case_study
--scenario SCENARIO --seed SEED --no-keyframes --out BEFORE/SCENARIO-SEED``, the same for AFTER with the
changed code) and prints, per run, the backward and carried-backward metres
(:func:`kbplanner.analysis.reverse_driving.reverse_of`, as ``benchmarks/reverse_driving.py``), the
driven metres, simulated time, minimum separation, safety stops, collisions, elements installed
(``metrics.json``) and ``cpu_time_s`` (``timing.json``; a shared machine's, not a controlled
comparison): "a -> b" where they differ. The docs/scale.md tables of sessions 12 and 13 on backward
driving.

Usage: python benchmarks/reverse_compare.py BEFORE AFTER [--seeds 7,1,2,3,4] [--after-name reverse13]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from kbplanner.analysis.reverse_driving import reverse_of

SCENARIOS = ("storage-outside", "storage-inside")


def figures(run: Path) -> dict[str, object]:
    """One run's figures for the table."""
    m = json.loads((run / "metrics.json").read_text())
    t = json.loads((run / "timing.json").read_text())
    r = reverse_of(run)
    s = m["safety"]
    return {"back": f"{r['backward_m']} ({r['backward_carrying_m']})", "driven": r["driven_m"],
            "sim": m["totals"]["sim_time_s"], "sep": s["min_separation_m"], "stops": s["stops"],
            "coll": s["collisions"], "inst": f"{m['totals']['installed']}/{m['totals']['elements']}",
            "cpu": t["cpu_time_s"]}


def _pair(a: object, b: object) -> str:
    return f"{a}" if a == b else f"{a} -> {b}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("before", type=Path)
    ap.add_argument("after", type=Path)
    ap.add_argument("--seeds", default="7,1,2,3,4")
    ap.add_argument("--after-name", default="after")
    a = ap.parse_args()
    print(f"| scenario | seed | backward m (carrying), main -> {a.after_name} | driven m | simulated s | "
          "min. separation m | safety stops | collisions | installed | cpu_time_s |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for scenario in SCENARIOS:
        for seed in a.seeds.split(","):
            x, y = figures(a.before / f"{scenario}-{seed}"), figures(a.after / f"{scenario}-{seed}")
            cells = [_pair(x[k], y[k]) for k in ("back", "driven", "sim", "sep", "stops", "coll", "inst")]
            print(f"| {scenario} | {seed} | {' | '.join(cells)} | {x['cpu']} -> {y['cpu']} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
