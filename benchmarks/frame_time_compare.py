"""Issue 14 item 3 figures of runs before and after a change, as markdown table rows (docs/scale.md,
session 14, pathq14).

Takes two folders laid out ``SCENARIO/seed-SEED`` (as ``kbplanner study`` writes them, or by hand:
``kbplanner simulate data/case_study --scenario SCENARIO --seed SEED --no-keyframes --out
DIR/SCENARIO/seed-SEED``) and prints per run from ``metrics.json``: elements installed, collisions,
frame time over its lower bound (median, max; ``path_quality``), the largest driven / shortest path, the
minimum separation, the simulated time and the backward metres
(:func:`kbplanner.analysis.reverse_driving.reverse_of`): "a -> b" where they differ.

With ``--study``, instead one row per scenario over the runs both folders hold (every ``seed-*``
folder, the ``-monitoring-off`` ones included): runs, installed, collisions, the median of the runs'
median frame ratios, the largest frame ratio, frames over 1.3, the largest driven / shortest and the
smallest minimum separation.

Usage: python benchmarks/frame_time_compare.py BEFORE AFTER [--runs storage-inside:17,storage-outside:7]
       python benchmarks/frame_time_compare.py BEFORE AFTER --study
"""

from __future__ import annotations

import argparse
import json
import statistics
from pathlib import Path

from kbplanner.analysis.reverse_driving import reverse_of


def figures(run: Path) -> dict[str, object]:
    """One run's figures for the table."""
    m = json.loads((run / "metrics.json").read_text())
    q, s = m["path_quality"], m["safety"]
    return {"inst": f"{m['totals']['installed']}/{m['totals']['elements']}", "coll": s["collisions"],
            "median": q["time_over_lower_bound"]["median"], "max": q["time_over_lower_bound"]["max"],
            "path": q["driven_over_shortest"]["max"], "sep": s["min_separation_m"],
            "sim": m["totals"]["sim_time_s"], "back": reverse_of(run)["backward_m"]}


def study(folder: Path, scenario: str, names: list[str]) -> dict[str, object]:
    """One scenario's figures over the runs ``names`` of ``folder``."""
    ms = [json.loads((folder / scenario / n / "metrics.json").read_text()) for n in names]
    quality = [m["path_quality"] for m in ms]
    frames = [f["time_over_lower_bound"] for m in ms for f in m["path_quality"]["per_element"]]
    return {"runs": len(ms), "inst": sum(m["totals"]["installed"] for m in ms),
            "coll": sum(m["safety"]["collisions"] for m in ms),
            "median": round(statistics.median(q["time_over_lower_bound"]["median"] for q in quality), 3),
            "max": max(frames), "over": sum(1 for f in frames if f > 1.3),
            "path": max(m["path_quality"]["driven_over_shortest"]["max"] for m in ms),
            "sep": min(m["safety"]["min_separation_m"] for m in ms)}


def _pair(a: object, b: object) -> str:
    return f"{a}" if a == b else f"{a} -> {b}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("before", type=Path)
    ap.add_argument("after", type=Path)
    ap.add_argument("--runs", default="storage-inside:17,storage-inside:11,storage-inside:18,"
                                      "storage-inside:7,storage-outside:7,storage-outside:1")
    ap.add_argument("--study", action="store_true")
    a = ap.parse_args()
    if a.study:
        print("| scenario | runs | installed | collisions | median of the runs' median frame / bound | max | "
              "frames over 1.3 | driven / shortest, max | min. separation m |")
        print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
        for scenario in sorted(p.name for p in a.after.iterdir() if p.is_dir()):
            names = sorted(p.name for p in (a.after / scenario).glob("seed-*")
                           if (p / "metrics.json").exists()
                           and (a.before / scenario / p.name / "metrics.json").exists())
            x, y = study(a.before, scenario, names), study(a.after, scenario, names)
            keys = ("runs", "inst", "coll", "median", "max", "over", "path", "sep")
            print(f"| {scenario} | {' | '.join(_pair(x[k], y[k]) for k in keys)} |")
        return 0
    keys = ("inst", "coll", "median", "max", "path", "sep", "sim", "back")
    print("| scenario | seed | installed | collisions | frame time / bound, median | max | "
          "driven / shortest, max | min. separation m | simulated s | backward m |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for run in a.runs.split(","):
        scenario, seed = run.split(":")
        x = figures(a.before / scenario / f"seed-{seed}")
        y = figures(a.after / scenario / f"seed-{seed}")
        print(f"| {scenario} | {seed} | {' | '.join(_pair(x[k], y[k]) for k in keys)} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
