"""The case-study figures of README.md ("What the case study shows"), from a ``make run`` directory.

Reads ``RUN/comparison.csv`` (the [simulation] task, T-FRAME, per scenario) and, when ``make run``
simulated every robotized task, ``RUN/scenarios/<scenario>/tasks/tasks.csv``; prints the Markdown rows
of the README table and the per-task line, so the README's figures are the ones the code produces::

    .venv/bin/python data/case_study/tools/readme_table.py runs/case_study
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

ORDER = ("storage-outside", "storage-inside")


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(encoding="utf-8", newline="") as fh:
        return list(csv.DictReader(fh))


def table(run: Path) -> str:
    """The README table (header and our rows) from ``run/comparison.csv``."""
    rows = {r["scenario"]: r for r in _rows(run / "comparison.csv")}
    n = next(iter(rows.values()))["installed"].split("/")[1]
    out = [f"| scenario | installed | frame 1 | per frame | {n} frames | min. separation | time < 1 m | "
           "time < S_p | slow-downs (time lost) | collisions |",
           "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for name in [s for s in ORDER if s in rows] + sorted(set(rows) - set(ORDER)):
        r = rows[name]
        out.append(
            f"| {name.replace('-', ' ')} | {r['installed']} | {float(r['first frame (min)']):.1f} min | "
            f"{float(r['per frame (min)']):.1f} min | {float(r['total (min)']):.1f} min | "
            f"{float(r['min separation (m)']):.2f} m | {float(r['time < 1 m (s)']):.0f} s | "
            f"{float(r['time < ISO/TS 15066 S_p (s)']):.1f} s | {r['slow-downs']} "
            f"({float(r['time lost to monitoring (s)']):.1f} s) | {r['collisions']} |")
    return "\n".join(out)


def tasks(run: Path) -> str:
    """One line per scenario: each robotized task's installed count and simulated minutes."""
    lines = []
    for name in ORDER:
        path = run / "scenarios" / name / "tasks" / "tasks.csv"
        if path.is_file():
            parts = [f"{r['task']} {r['installed']}/{r['elements']} in {float(r['simulated (min)']):.1f} min"
                     for r in _rows(path) if r["task"] != "all"]
            lines.append(f"{name.replace('-', ' ')}: " + ", ".join(parts))
    return "\n".join(lines)


if __name__ == "__main__":
    run_dir = Path(sys.argv[1] if len(sys.argv) > 1 else "runs/case_study")
    print(table(run_dir))
    print()
    print(tasks(run_dir))
