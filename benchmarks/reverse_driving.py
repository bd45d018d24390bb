"""How far the robot's base drives backwards in finished runs (an independent check, no kbplanner import).

Reads ``trajectories.csv`` of one or more run directories and sums, per run, the distance driven with
the direction of travel more than 90 degrees off the base's yaw (backwards, towards the scanner's
blind sector behind the base), the whole distance driven, and how much of the backward distance is
driven while an element is carried. Prints a row per run and the medians, and writes JSON.

Usage: python benchmarks/reverse_driving.py RUN_DIR [RUN_DIR ...] [--out FILE]
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import statistics
from pathlib import Path


def reverse_of(run: Path) -> dict[str, float | str]:
    """Backward, carried-backward and whole distance (m) driven in one run."""
    back = carried = total = 0.0
    with (run / "trajectories.csv").open(newline="") as fh:
        rows = csv.DictReader(fh)
        prev = next(rows, None)
        for row in rows:
            assert prev is not None
            dx, dy = float(row["x"]) - float(prev["x"]), float(row["y"]) - float(prev["y"])
            d = math.hypot(dx, dy)
            if d > 1e-6:
                total += d
                yaw = float(prev["yaw"])
                if dx * math.cos(yaw) + dy * math.sin(yaw) < -0.01 * d:
                    back += d
                    if prev.get("carried"):
                        carried += d
            prev = row
    return {"run": str(run), "backward_m": round(back, 2), "backward_carrying_m": round(carried, 2),
            "driven_m": round(total, 2)}


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
