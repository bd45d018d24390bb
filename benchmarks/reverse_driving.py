"""How far the robot's base drives backwards in finished runs (from their trajectories only).

Reads ``trajectories.csv`` of one or more run directories and sums, per run, the distance driven with
the direction of travel more than 90 degrees off the base's yaw (backwards, towards the scanner's
blind sector behind the base), the whole distance driven, and how much of the backward distance is
driven while an element is carried (:func:`kbplanner.analysis.reverse_driving.reverse_of`, which the
tests use too). Prints a row per run and the medians, and writes JSON.

Usage: python benchmarks/reverse_driving.py RUN_DIR [RUN_DIR ...] [--out FILE]
"""

from __future__ import annotations

import argparse
import json
import statistics
from pathlib import Path

from kbplanner.analysis.reverse_driving import reverse_of


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results/reverse_driving.json"))
    a = ap.parse_args()
    rows = [reverse_of(r) for r in sorted(a.runs)]
    for r in rows:
        print(f"{r['run']}: backward {r['backward_m']} m (carrying {r['backward_carrying_m']} m) "
              f"of {r['driven_m']} m driven")
    groups: dict[str, list[dict[str, float | str]]] = {}
    for r in rows:
        groups.setdefault(Path(str(r["run"])).parent.name, []).append(r)
    summary = {}
    for name, rs in sorted(groups.items()):
        med = {k: statistics.median(float(x[k]) for x in rs)
               for k in ("backward_m", "backward_carrying_m", "driven_m")}
        summary[name] = {"runs": len(rs), **{f"median_{k}": round(v, 2) for k, v in med.items()}}
        print(f"{name}: {len(rs)} runs, median backward {med['backward_m']:.1f} m "
              f"(carrying {med['backward_carrying_m']:.1f} m) of {med['driven_m']:.1f} m driven")
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.write_text(json.dumps({"runs": rows, "summary": summary}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
