"""Plans that hold: does ``plan`` (B4) predict what ``simulate`` (B5) hits? Per run folder of ``simulate``.

Not a pipeline step: a measurement. Takes run folders written by ``kbplanner simulate --out DIR`` (each
holds the B4-refined ``plan.json``, the same plan ``kbplanner plan`` gives for that project, scenario and
seed, and ``metrics.json``, the simulated outcome per element); prints per folder the elements installed,
the elements the plan calls infeasible, the elements that failed in simulation, and where the two
disagree (with the reasons), and writes ``benchmarks/results/carry_legs.json``.

Usage (the Duplex project of docs/own_building.md, both scenarios)::

    kbplanner init ../shared/data/ifc/Duplex_A_20110907.ifc --task frame-interior-walls --out /tmp/dx
    kbplanner simulate /tmp/dx --scenario storage-inside --no-keyframes --out /tmp/dx-inside
    kbplanner simulate /tmp/dx --scenario storage-outside --no-keyframes --out /tmp/dx-outside
    python benchmarks/carry_legs.py /tmp/dx-inside /tmp/dx-outside
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from _common import RESULTS_DIR, machine_info, write_json


def compare(run: Path) -> dict[str, Any]:
    """Plan verdicts against simulated outcomes of one run folder."""
    plan = json.loads((run / "plan.json").read_text(encoding="utf-8"))
    metrics = json.loads((run / "metrics.json").read_text(encoding="utf-8"))
    labels = {e["iri"]: e["label"] for e in plan["elements"]}
    predicted: dict[str, str] = {}
    for s in sorted(plan["steps"], key=lambda s: s["step"]):
        reason = s.get("reason") or ""
        if not s["feasible"] and s["element"] not in predicted and not reason.startswith("skipped"):
            predicted[labels[s["element"]]] = f"step {s['step']} ({s['action_label']}): {reason}"
    for s in plan["steps"]:  # an element whose steps are all "skipped" (none has its own reason)
        if not s["feasible"] and labels[s["element"]] not in predicted:
            predicted[labels[s["element"]]] = s.get("reason") or ""
    simulated = {e["label"]: e.get("reason") or "" for e in metrics["per_element"]
                 if e["outcome"] != "installed"}
    failed_in_sim_only = {k: v for k, v in simulated.items() if k not in predicted}
    predicted_not_failed = sorted(k for k in predicted if k not in simulated)
    return {
        "run": str(run),
        "scenario": metrics.get("scenario"),
        "seed": metrics.get("seed"),
        "elements": metrics["totals"]["elements"],
        "installed": metrics["totals"]["installed"],
        "plan_infeasible": len(predicted),
        "simulated_failed": len(simulated),
        "agree": not failed_in_sim_only and not predicted_not_failed,
        "order_rule": plan.get("order_rule"),
        "plan_reasons": predicted,
        "failed_in_simulation_only": failed_in_sim_only,
        "infeasible_in_plan_but_installed": predicted_not_failed,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path, help="run folders of kbplanner simulate")
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "carry_legs.json")
    args = ap.parse_args(argv)
    rows = [compare(r) for r in args.runs]
    for r in rows:
        print(f"{r['run']} ({r['scenario']}, seed {r['seed']}): installed {r['installed']} of "
              f"{r['elements']}; plan: {r['plan_infeasible']} infeasible; simulation: "
              f"{r['simulated_failed']} failed; {'agree' if r['agree'] else 'DISAGREE'}")
        for label, why in sorted(r["plan_reasons"].items()):
            print(f"  plan: {label}: {why[:220]}")
        for label, why in sorted(r["failed_in_simulation_only"].items()):
            print(f"  failed in simulation only: {label}: {why[:220]}")
        for label in r["infeasible_in_plan_but_installed"]:
            print(f"  infeasible in the plan but installed: {label}")
    write_json(args.out, {"machine": machine_info(), "runs": rows})
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
