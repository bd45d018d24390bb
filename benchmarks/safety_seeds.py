"""Safety over seeds: median and worst case per scenario from simulated run directories.

Each argument is a run directory written by ``kbplanner simulate`` (``metrics.json`` with its ``safety``
section, ``manifest.json`` with the scenario and seed). Prints, per scenario, the number of runs, the
median and the worst case (minimum separation: lowest; times, stops, collisions: highest) of each
figure, and the simulated duration; writes the table as JSON (``--json FILE``).

Usage: python benchmarks/safety_seeds.py [--json FILE] RUN_DIR [RUN_DIR ...]
"""

from __future__ import annotations

import json
import statistics
import sys
from pathlib import Path
from typing import Any

# Runs that installed nothing (B4 found no feasible first element) are counted, not averaged in.
FIGURES = (  # (key in metrics.json "safety", worst is the max (True) or the min (False))
    ("min_separation_m", False),
    ("time_below_1m_s", True),
    ("time_below_protective_s", True),
    ("stops", True),
    ("slowdowns", True),
    ("time_lost_s", True),
    ("collisions", True),
)


def summary(runs: list[Path]) -> dict[str, Any]:
    per: dict[str, list[dict[str, Any]]] = {}
    for run in runs:
        metrics = json.loads((run / "metrics.json").read_text())
        manifest = json.loads((run / "manifest.json").read_text())
        scenario = str(manifest.get("scenario") or run.name)
        row = {k: metrics["safety"][k] for k, _ in FIGURES}
        row["duration_min"] = metrics["totals"]["sim_time_s"] / 60.0 if "sim_time_s" in metrics["totals"] \
            else None
        row["seed"] = manifest.get("seed")
        row["installed"] = f"{metrics['totals']['installed']}/{metrics['totals']['elements']}"
        per.setdefault(scenario, []).append(row)
    out: dict[str, Any] = {}
    for scenario, all_rows in sorted(per.items()):
        rows = [r for r in all_rows if r["duration_min"]]  # a run that moved nothing has no figures
        fig: dict[str, Any] = {"runs": len(all_rows), "seeds": sorted(r["seed"] for r in all_rows),
                               "installed": sorted(f"seed {r['seed']}: {r['installed']}" for r in all_rows),
                               "nothing_simulated": sorted(r["seed"] for r in all_rows
                                                          if not r["duration_min"])}
        if not rows:
            out[scenario] = fig
            continue
        for key, worst_is_max in FIGURES:
            vals = [float(r[key]) for r in rows]
            fig[key] = {"median": round(statistics.median(vals), 3),
                        "worst": round(max(vals) if worst_is_max else min(vals), 3)}
        durations = [r["duration_min"] for r in rows if r["duration_min"] is not None]
        if durations:
            fig["duration_min"] = {"median": round(statistics.median(durations), 2),
                                   "worst": round(max(durations), 2)}
        out[scenario] = fig
    return out


def main(argv: list[str]) -> int:
    json_out = None
    if argv[:1] == ["--json"]:
        json_out, argv = Path(argv[1]), argv[2:]
    table = summary([Path(a) for a in argv])
    for scenario, fig in table.items():
        sys.stdout.write(f"{scenario}: {fig['runs']} runs (seeds {fig['seeds']}), "
                         f"installed {fig['installed']}\n")
        for key, val in fig.items():
            if isinstance(val, dict):
                sys.stdout.write(f"  {key:26s} median {val['median']:>8}  worst {val['worst']:>8}\n")
    if json_out is not None:
        json_out.write_text(json.dumps(table, indent=2, sort_keys=True, allow_nan=False) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
