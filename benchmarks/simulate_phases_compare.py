"""CPU seconds of the phases of ``kbplanner simulate``, two source trees side by side (issue 14).

Not a pipeline step. Runs :mod:`simulate_phases` (in its own process each time) on a git ref's exported
tree (``--before``, default ``main``) and on this checkout, alternately, ``--repeat`` times per
scenario and tree, warm: each tree has its own cache folder (``KBPLANNER_CACHE_DIR``, seeded with this
checkout's IFC import of the case study) and first runs the command once, unmeasured, so that its
project cache, refined plan, configuration spaces and maps are kept. Both use this checkout's case
study folder (the outputs name it). Compares the outputs of the
last runs of both trees (``trajectories.csv``, ``events.jsonl``, ``metrics.json``: byte-identical or
not). Writes the runs to ``--out`` and prints the median CPU seconds per phase.

    python benchmarks/simulate_phases_compare.py [--before main] [--repeat 2] \\
        [--scenario storage-outside --scenario storage-inside] [--seed 7] [--out FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from _common import REPO, RESULTS_DIR, machine_info, write_json

CASE = REPO / "data" / "case_study"
SCRIPT = Path(__file__).resolve().parent / "simulate_phases.py"
OUTPUTS = ("trajectories.csv", "events.jsonl", "metrics.json")


def _export(ref: str, into: Path) -> Path:
    archive = subprocess.run(["git", "-C", str(REPO), "archive", ref], capture_output=True, check=True).stdout
    into.mkdir(parents=True)
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into / "src"


def _seed_imports(cache: Path) -> None:
    """Give ``cache`` the case study's IFC import (when this checkout has one), so no side imports the IFC."""
    src = CASE / ".kbplanner-cache"
    for d in (src.iterdir() if src.is_dir() else []):
        if (d / "model.ttl").is_file():
            shutil.copytree(d, cache / d.name)


def _phases(src: Path, cache: Path, scenario: str, seed: int, out: Path, result: Path) -> dict[str, Any]:
    env = {**os.environ, "PYTHONPATH": str(src), "KBPLANNER_CACHE_DIR": str(cache)}
    env.pop("KBPLANNER_NO_CACHE", None)
    cmd = [sys.executable, str(SCRIPT), str(result), "warm", "simulate", str(CASE), "--scenario", scenario,
           "--seed", str(seed), "--out", str(out), "--force"]
    subprocess.run(cmd, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    data: dict[str, Any] = json.loads(result.read_text(encoding="utf-8"))
    return data


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--before", default="main", help="git ref of the before tree (default main)")
    ap.add_argument("--repeat", type=int, default=2, help="measured runs per scenario and tree (default 2)")
    ap.add_argument("--scenario", action="append", help="scenario (repeatable; default storage-outside)")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "simulate_phases-compare.json")
    args = ap.parse_args()
    scenarios = args.scenario or ["storage-outside"]

    work = Path(tempfile.mkdtemp(prefix="kbp-phases-"))
    try:
        trees = {"before": _export(args.before, work / "before"), "after": REPO / "src"}
        caches = {side: work / f"cache-{side}" for side in trees}  # each tree its own project cache entries
        for cache in caches.values():
            cache.mkdir()
            _seed_imports(cache)
        load_start = os.getloadavg()
        runs: dict[str, dict[str, list[dict[str, Any]]]] = {s: {t: [] for t in trees} for s in scenarios}
        same: dict[str, dict[str, bool]] = {}
        for scenario in scenarios:
            for side, src in trees.items():  # warm-up: each tree keeps its own refined plan and maps
                _phases(src, caches[side], scenario, args.seed, work / f"run-{side}", work / "warm.json")
            for _ in range(args.repeat):
                for side, src in trees.items():
                    runs[scenario][side].append(_phases(src, caches[side], scenario, args.seed,
                                                        work / f"run-{side}", work / f"{side}.json"))
            before, after = work / "run-before", work / "run-after"
            same[scenario] = {f: (before / f).read_bytes() == (after / f).read_bytes() for f in OUTPUTS}
        load_end = os.getloadavg()
    finally:
        shutil.rmtree(work, ignore_errors=True)

    result = {"benchmark": "simulate_phases_compare", "before": args.before, "repeat": args.repeat,
              "seed": args.seed, "load_average_start": [round(x, 2) for x in load_start],
              "load_average_end": [round(x, 2) for x in load_end], "machine": machine_info(),
              "same_outputs": same, "runs": runs}
    write_json(args.out, result)
    print(f"kbplanner simulate, warm, seed {args.seed}: CPU s per phase, median of {args.repeat} "
          f"(before = {args.before}); load average {load_start[0]:.2f} -> {load_end[0]:.2f} (1 min)")
    for scenario in scenarios:
        print(f"{scenario}: same outputs {same[scenario]}")
        phases = list(runs[scenario]["before"][0]["phases_cpu_s"])
        for ph in phases:
            med = {side: statistics.median(r["phases_cpu_s"].get(ph, 0.0) for r in runs[scenario][side])
                   for side in trees}
            print(f"  {ph:<18} {med['before']:7.3f} {med['after']:7.3f}  {med['after'] - med['before']:+.3f}")
        for side in trees:
            r = runs[scenario][side][-1]
            b4 = r["b4_search_imported"] or "none"
            print(f"  {side}: {r['modules']} modules, B4 search imported: {b4}")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
