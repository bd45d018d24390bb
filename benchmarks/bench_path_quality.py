"""Path quality before/after (issue 14, item 3): the case study's ``kbplanner simulate`` run by a
baseline's sources and by this tree's, in one run of this script, compared by ``metrics.json``
``"path_quality"`` (docs/simulation.md): frame time over the kinematic lower bound and driven over
shortest collision-free path, median and max per run, with the simulated time, frames installed, collisions
and the minimum separation to the workers.

The baseline is a git ref (default ``main``) exported with ``git archive``; both run
``kbplanner simulate data/case_study --scenario S --seed N --out DIR`` with the shared virtualenv (the
helpers of ``bench_simspeed.py``). ``--determinism`` runs this tree a second time per scenario and
checks that ``trajectories.csv``, ``events.jsonl`` and ``metrics.json`` are byte-identical.

Usage: .venv/bin/python benchmarks/bench_path_quality.py [--before REF] [--scenario S ...] [--seed N]
[--determinism]. Prints a table (Markdown, as in docs/scale.md) and the frames' times, and writes
benchmarks/results/path_quality.json (or --out); ``--print FILE`` prints them again from such a file.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path
from typing import Any

from _common import REPO, RESULTS_DIR, machine_info, write_json
from bench_simspeed import _export, _run

SAME = ("trajectories.csv", "events.jsonl", "metrics.json")


def _figures(run: Path, measured: dict[str, Any]) -> dict[str, Any]:
    metrics = json.loads((run / "metrics.json").read_text())
    q = metrics["path_quality"]
    totals = metrics["totals"]
    return {"time_over_lower_bound": q["time_over_lower_bound"],
            "driven_over_shortest": q["driven_over_shortest"], "per_element": q["per_element"],
            "sim_time_s": totals["sim_time_s"], "installed": totals["installed"],
            "elements": totals["elements"], "driven_m": totals["driven_m"],
            "collisions": metrics["safety"]["collisions"],
            "min_separation_m": metrics["safety"]["min_separation_m"],
            "command_s": measured["command_s"],
            "exit": measured["exit"]}


def bench(before_src: Path, scenario: str, seed: int, determinism: bool, tmp: Path) -> dict[str, Any]:
    row: dict[str, Any] = {"scenario": scenario, "seed": seed}
    for label, src in (("before", before_src), ("after", REPO / "src")):
        out = tmp / f"{scenario}-{label}"
        row[label] = _figures(out, _run(src, scenario, seed, out, tmp / f"{scenario}-{label}.log"))
    if determinism:
        again = tmp / f"{scenario}-after-again"
        _run(REPO / "src", scenario, seed, again, tmp / f"{scenario}-after-again.log")
        row["after_identical_on_repeat"] = all(
            (tmp / f"{scenario}-after" / f).read_bytes() == (again / f).read_bytes() for f in SAME)
    return row


def _pair(q: dict[str, Any]) -> str:
    return f"{q['median']} / {q['max']}"


def report(out: dict[str, Any]) -> str:
    """The Markdown table and the per-frame lines of a result (``main``'s JSON)."""
    rows = out["scenarios"]
    text = [f"Seed {rows[0]['seed'] if rows else '?'}; before = {out['before']}, after = this tree.\n",
            "| scenario | frame time / lower bound, median / max | driven / shortest, median / max | "
            "simulated | installed | collisions | min separation |",
            "| --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        b, a = r["before"], r["after"]
        tb, ta = _pair(b["time_over_lower_bound"]), _pair(a["time_over_lower_bound"])
        db, da = _pair(b["driven_over_shortest"]), _pair(a["driven_over_shortest"])
        text.append(f"| {r['scenario']} | {tb} -> {ta} | {db} -> {da} | {b['sim_time_s']:,.1f} -> "
                    f"{a['sim_time_s']:,.1f} s | {b['installed']} -> {a['installed']} of {a['elements']} | "
                    f"{b.get('collisions', '?')} -> {a.get('collisions', '?')} | "
                    f"{b.get('min_separation_m', '?')} -> {a.get('min_separation_m', '?')} m |")
    for r in rows:
        before = {f["global_id"]: f for f in r["before"]["per_element"]}
        text.append(f"\n{r['scenario']}, per frame: time (s) before -> after (over the lower bound)")
        for f in r["after"]["per_element"]:
            g = before.get(f["global_id"])
            was = f"{g['duration_s']} -> " if g else ""
            ratio = f"{g['time_over_lower_bound']} -> " if g else ""
            text.append(f"  {f['global_id']}: {was}{f['duration_s']} ({ratio}{f['time_over_lower_bound']})")
        if "after_identical_on_repeat" in r:
            text.append(f"  this tree's outputs identical on a second run: "
                        f"{'yes' if r['after_identical_on_repeat'] else 'NO'}")
    text.append(f"\nload average {out['load_average_start'][0]:.2f} -> {out['load_average_end'][0]:.2f}")
    return "\n".join(text) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", default="main", help="git ref of the baseline (default main)")
    ap.add_argument("--scenario", action="append", help="scenario(s) (default: both storage scenarios)")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--determinism", action="store_true", help="run this tree twice, compare the outputs")
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "path_quality.json")
    ap.add_argument("--print", type=Path, dest="print_file",
                    help="print the figures of a result file, run nothing")
    args = ap.parse_args(argv)
    if args.print_file:
        sys.stdout.write(report(json.loads(args.print_file.read_text())))
        return 0
    scenarios = args.scenario or ["storage-outside", "storage-inside"]
    load_before = list(os.getloadavg())
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        before_src = _export(args.before, tmp)
        rows = [bench(before_src, s, args.seed, args.determinism, tmp) for s in scenarios]
    out = {"machine": machine_info(("python", "cpus", "platform")), "before": args.before,
           "load_average_start": load_before, "load_average_end": list(os.getloadavg()), "scenarios": rows}
    write_json(args.out, out)
    sys.stdout.write(report(out) + f"wrote {args.out}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
