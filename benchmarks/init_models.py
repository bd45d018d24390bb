"""``kbplanner init`` on real IFC models: walls chosen, frames, scenarios and the time it takes.

For each model (the Duplex of the case study and ``../shared/data/ifc/public/*.ifc`` when present, or
the files given): ``init_project`` into a temporary folder, then the figures: walls in the file and
chosen, frames and their masses, the reasons the other walls were not chosen (counted by kind), the
scenarios written, the notes, and the seconds. Prints a table and writes
``benchmarks/results/init_models.json``. The simulation of the result is ``kbplanner run`` (slow; see
docs/own_building.md for its figures).

    .venv/bin/python benchmarks/init_models.py [IFC ...]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from collections import Counter
from pathlib import Path
from typing import Any

from _common import REPO, RESULTS_DIR, Timer, write_json

RESULTS = RESULTS_DIR / "init_models.json"
DUPLEX = REPO / "data" / "case_study" / "model" / "Duplex_A_20110907.ifc"
PUBLIC = REPO.parent / "shared" / "data" / "ifc" / "public"


def _kind(reason: str) -> str:
    return reason.split(" (", 1)[0].split(":", 1)[0]


def measure(ifc: Path) -> dict[str, Any]:
    """Run init on ``ifc`` (into a temporary folder); returns the figures."""
    from kbplanner.scale.project_init import init_project

    with tempfile.TemporaryDirectory() as tmp, Timer() as t:
        r = init_project(ifc, Path(tmp) / "project")
    masses = [f.mass_kg for f in r.frames]
    return {
        "file": ifc.name, "written": r.written, "storey": r.storey, "entrance": r.entrance,
        "walls": len(r.walls), "walls_chosen": len(r.chosen), "frames": len(r.frames),
        "frame_mass_kg": [min(masses), max(masses)] if masses else None,
        "not_chosen": dict(sorted(Counter(_kind(w.reason) for w in r.walls if not w.chosen).items())),
        "scenarios": r.scenarios, "notes": r.notes, "seconds": round(t.seconds, 2),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("ifc", nargs="*", type=Path)
    args = parser.parse_args()
    files = args.ifc or [DUPLEX, *sorted(PUBLIC.glob("*.ifc"))]
    rows = []
    for ifc in files:
        if not ifc.is_file():
            print(f"{ifc}: not present, skipped", file=sys.stderr)
            continue
        row = measure(ifc)
        rows.append(row)
        print(f"{row['file']}: {'written' if row['written'] else 'nothing written (exit 1)'}, storey "
              f"{row['storey']}, {row['walls_chosen']}/{row['walls']} walls, {row['frames']} frames, "
              f"scenarios {row['scenarios']}, {row['seconds']} s")
        for kind, n in row["not_chosen"].items():
            print(f"  {n:>4} not chosen: {kind}")
    write_json(RESULTS, {"models": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
