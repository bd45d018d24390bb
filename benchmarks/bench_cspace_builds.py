"""Configuration-space builds of a first command (issue 14, item 2): where a ``kbplanner simulate`` whose
configuration-space folder is empty spends its builds, for a baseline's sources and this tree's.

Each tree runs ``kbplanner simulate data/case_study --scenario S --seed N`` once per scenario in a child
process, with its own empty cache folder (``KBPLANNER_CACHE_DIR``: the project loaded there once first,
so only the spaces and B4's refined plan are new) and B4 run (the refined-plan cache not read). Counting
wrappers (``time.process_time``) around ``ConfigurationSpace.build``, the correlation
(``cspace_fft.hits_many``, or ``footprint._hits`` in a tree before session 11), the kernels' rasterisation,
``cspace_cache._cropped``, the labellings, the store's reads and writes and the simulation step
(``executor.simulate``) give CPU seconds and calls (the correlation's calls: batches of bins in this tree);
``command_cpu_s`` is the command's after its imports. ``--rounds N``: N runs per tree, alternating,
medians. On a shared machine read the seconds as shares.

Usage: .venv/bin/python benchmarks/bench_cspace_builds.py [--before REF] [--scenario S ...] [--seed N]
       [--rounds N]
Prints a table and writes benchmarks/results/cspace_builds.json (or --out); ``--markdown-from JSON`` prints
the Markdown table of such a result (for the docs) without running anything.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from _common import REPO, RESULTS_DIR, write_scenarios

_CHILD = r'''import functools, json, sys, time
import kbplanner.world.footprint as fp
import kbplanner.world.cspace_cache as cc
import kbplanner.world.cspace_store as cst
import kbplanner.planning.refine_cache as rc
from kbplanner.cli import main
rc._read = lambda path: None
T = {}
def add(label, dt):
    d = T.setdefault(label, [0, 0.0]); d[0] += 1; d[1] += dt
def wrap(mod, name, label):
    f = getattr(mod, name)
    @functools.wraps(f)
    def w(*a, **k):
        t = time.process_time()
        try:
            return f(*a, **k)
        finally:
            add(label, time.process_time() - t)
    setattr(mod, name, w)
    return w
build = fp.ConfigurationSpace.build.__func__
def timed_build(cls, *a, **k):
    t = time.process_time()
    try:
        return build(cls, *a, **k)
    finally:
        add("build", time.process_time() - t)
fp.ConfigurationSpace.build = classmethod(timed_build)
label = fp.ConfigurationSpace._labels_and_roots
def timed_label(self, diagonal):
    t = time.process_time()
    try:
        return label(self, diagonal)
    finally:
        add("labelling", time.process_time() - t)
fp.ConfigurationSpace._labels_and_roots = timed_label
try:
    import kbplanner.world.cspace_fft as cf
    fp.rasterised_kernel = wrap(cf, "rasterised_kernel", "kernels")
    wrap(cf, "hits_many", "correlation")
except ImportError:
    fp._kernel = wrap(fp, "_kernel", "kernels")
    wrap(fp, "_hits", "correlation")
import kbplanner.simulation.executor as ex
wrap(ex, "simulate", "step")
wrap(cc, "_cropped", "crops")
wrap(cst, "write", "store_write")
wrap(cst, "read", "store_read")
t0 = time.process_time()
try:
    main(sys.argv[2:])
except SystemExit:
    pass
out = {"command_cpu_s": round(time.process_time() - t0, 3),
       "functions": {k: {"calls": v[0], "cpu_s": round(v[1], 3)} for k, v in sorted(T.items())}}
open(sys.argv[1], "w").write(json.dumps(out))
'''


def _export(ref: str, into: Path) -> Path:
    archive = subprocess.run(["git", "-C", str(REPO), "archive", ref], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into / "src"


def _run(src: Path, scenario: str, seed: int, tmp: Path, label: str, k: int,
         same_project: bool = False) -> dict[str, Any]:
    cache = tmp / f"cache-{label}-{scenario}-{k}"
    env = dict(os.environ, PYTHONPATH=str(src), KBPLANNER_CACHE_DIR=str(cache))
    project = (REPO if same_project else src.parent) / "data" / "case_study"
    subprocess.run([sys.executable, "-m", "kbplanner", "plan", str(project), "--scenario", scenario,
                    "--seed", str(seed), "--no-feasibility"], env=env, check=True, capture_output=True)
    result = tmp / f"{label}-{scenario}-{k}.json"
    cmd = [sys.executable, "-c", _CHILD, str(result), "simulate", str(project), "--scenario", scenario,
           "--seed", str(seed), "--out", str(tmp / f"out-{label}-{scenario}-{k}")]
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if not result.is_file():
        raise SystemExit(f"{label} {scenario}: no result (exit {proc.returncode}):\n{proc.stderr[-2000:]}")
    data: dict[str, Any] = json.loads(result.read_text())
    return data


def _median_of(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """Per function, the median CPU seconds (and calls) over the runs; the command's median."""
    names = sorted({n for r in runs for n in r["functions"]})
    def med(name: str, key: str, default: float) -> float:
        return float(statistics.median(r["functions"].get(name, {}).get(key, default) for r in runs))

    funcs = {n: {"calls": int(med(n, "calls", 0)), "cpu_s": round(med(n, "cpu_s", 0.0), 3)} for n in names}
    command = round(statistics.median(r["command_cpu_s"] for r in runs), 3)
    return {"command_cpu_s": command, "functions": funcs}


_ROWS = (("step", "the simulation step (`executor.simulate`)"), ("build", "`ConfigurationSpace.build`"),
         ("correlation", "of it, the FFT correlations"),
         ("kernels", "of it, rasterising kernels"), ("crops", "crops of kept spaces (`_cropped`)"),
         ("labelling", "labellings"), ("store_write", "written to the folder"))


def markdown(data: dict[str, Any]) -> str:
    """The Markdown table of a result: one row per function, CPU s (calls) before / after per scenario."""
    rows = data["scenarios"]
    names = [f"{r['scenario']} {data['before']} / this tree" for r in rows]
    head = "| CPU s (calls) | " + " | ".join(names) + " |"
    lines = [head, "| --- |" + " ---: |" * len(rows)]
    for key, name in _ROWS:
        if not any(key in r[side]["functions"] for r in rows for side in ("before", "after")):
            continue
        cells = []
        for r in rows:
            b, a = r["before"]["functions"].get(key, {}), r["after"]["functions"].get(key, {})
            cells.append(f"{b.get('cpu_s', 0.0):.2f} ({b.get('calls', 0)}) / {a.get('cpu_s', 0.0):.2f} "
                         f"({a.get('calls', 0)})")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    lines.append("| the command after its imports | " + " | ".join(
        f"{r['before']['command_cpu_s']:.2f} / {r['after']['command_cpu_s']:.2f}" for r in rows) + " |")
    load = data.get("load_average_end", ["?"])[0]
    lines.append("")
    flags = f"--rounds {rows[0].get('rounds', 1)}"
    flags += " --same-project" if rows[0].get("same_project") else ""
    lines.append(f"(`bench_cspace_builds.py --before {data['before']} {flags}`: "
                 f"medians, runs alternating, seed "
                 f"{rows[0]['seed']}, the configuration-space folder empty, B4 run; load average {load} "
                 "at the end)")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", default="main", help="git ref of the baseline (default main)")
    ap.add_argument("--scenario", action="append",
                    help="scenario(s); default storage-inside, storage-outside")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--rounds", type=int, default=1, help="runs per tree, alternating (medians reported)")
    ap.add_argument("--same-project", action="store_true",
                    help="both trees run this tree's data/case_study (default: each its own)")
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "cspace_builds.json")
    ap.add_argument("--markdown-from", type=Path, help="print the Markdown table of a result and stop")
    args = ap.parse_args()
    if args.markdown_from:
        print(markdown(json.loads(args.markdown_from.read_text())))
        return
    scenarios = args.scenario or ["storage-inside", "storage-outside"]
    rows = []
    with tempfile.TemporaryDirectory() as name:
        tmp = Path(name)
        (tmp / "before").mkdir()
        before_src = _export(args.before, tmp / "before")
        for s in scenarios:
            runs: dict[str, list[dict[str, Any]]] = {"before": [], "after": []}
            for k in range(args.rounds):
                runs["before"].append(_run(before_src, s, args.seed, tmp, "before", k, args.same_project))
                runs["after"].append(_run(REPO / "src", s, args.seed, tmp, "after", k, args.same_project))
            row = {"scenario": s, "seed": args.seed, "rounds": args.rounds, "runs": runs,
                   "same_project": args.same_project,
                   "before": _median_of(runs["before"]), "after": _median_of(runs["after"])}
            rows.append(row)
            print(f"{s} (seed {args.seed}): CPU s before / after")
            names = sorted(set(row["before"]["functions"]) | set(row["after"]["functions"]))
            for n in names:
                b, a = row["before"]["functions"].get(n, {}), row["after"]["functions"].get(n, {})
                print(f"  {n:<12} {b.get('calls', 0):>5} / {a.get('calls', 0):<5} calls "
                      f"{b.get('cpu_s', 0.0):7.3f} / {a.get('cpu_s', 0.0):.3f}")
            cpu = (row["before"]["command_cpu_s"], row["after"]["command_cpu_s"])
            print(f"  command after imports {cpu[0]:.2f} / {cpu[1]:.2f}")
    write_scenarios(args.out, args.before, rows)


if __name__ == "__main__":
    main()
