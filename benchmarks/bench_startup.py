"""Benchmark: command start-up (issue 14), before and after, measured side by side in one run.

Not a pipeline step. Times ``kbplanner --version``, ``--help``, ``info PROJECT`` and ``query PROJECT
storeys`` (and with ``--plan``: ``plan PROJECT --scenario storage-outside``) on the case study, each
in a fresh process, for two source trees: ``before`` (a git ref, default ``main``,
exported with ``git archive``) and ``after`` (this checkout). Both use the shared
virtualenv and one copy of the case study; each side has its own cache folder (``KBPLANNER_CACHE_DIR``)
seeded with the same IFC import, so neither imports the IFC. ``info`` and ``query`` run ``cold`` (no
project cache: the state after any input change) and ``cached`` (the second command on an unchanged
project). Runs alternate between the sides so that both see the same machine load; the figure is the
median of ``--repeat`` runs, wall and CPU seconds, and the ratio before/after. The load average at the
start and the end is recorded (2 cores shared with other jobs inflate wall times; CPU seconds much
less). The outputs of the two sides are compared (same stdout).

    python benchmarks/bench_startup.py [--before main] [--repeat 3] [--plan]

Writes ``benchmarks/results/startup.json`` and prints the table (docs/scale.md quotes it).
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from _common import REPO, RESULTS_DIR, machine_info, write_json

CASE = REPO / "data" / "case_study"
PY = sys.executable


def _export(ref: str, into: Path) -> Path:
    """The source tree of git ``ref`` (its ``src/`` and package data) in ``into``."""
    archive = subprocess.run(["git", "-C", str(REPO), "archive", ref], capture_output=True, check=True).stdout
    into.mkdir(parents=True)
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into


def _run(cmd: list[str], env: dict[str, str]) -> tuple[float, float, str, int]:
    """Wall seconds, CPU seconds (user + system of the process and its children), stdout, exit code."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env, text=True)
    out = proc.stdout.read() if proc.stdout is not None else ""
    _pid, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    return wall, usage.ru_utime + usage.ru_stime, out, proc.returncode


def _seed_imports(cache: Path, env: dict[str, str], project: Path) -> None:
    """Give ``cache`` the IFC import of the case study (copied, or made once by an ``info``)."""
    src = CASE / ".kbplanner-cache"
    found = [d for d in (src.iterdir() if src.is_dir() else []) if (d / "model.ttl").is_file()]
    for d in found:
        shutil.copytree(d, cache / d.name)
    if not found:
        _run([PY, "-m", "kbplanner", "--no-cache", "info", str(project)], env)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--before", default="main",
                    help="git ref of the before tree (default main; when main has moved on, give the commit "
                         "this branch started from, so that both sides read the same case study)")
    ap.add_argument("--repeat", type=int, default=3, help="runs per command and side (median; default 3)")
    ap.add_argument("--query", default="storeys", help="the named query timed (default storeys)")
    ap.add_argument("--plan", action="store_true",
                    help="also time 'plan --scenario storage-outside' (B1-B3; world tables cached too)")
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "startup.json")
    args = ap.parse_args()

    work = Path(tempfile.mkdtemp(prefix="kbp-startup-"))
    try:
        project = work / "case"
        shutil.copytree(CASE, project, ignore=shutil.ignore_patterns(".kbplanner-cache", "tools"))
        trees = {"before": _export(args.before, work / "before"), "after": REPO}
        envs: dict[str, dict[str, str]] = {}
        for side, tree in trees.items():
            cache = work / f"cache-{side}"
            cache.mkdir()
            envs[side] = {**os.environ, "PYTHONPATH": str(tree / "src"), "KBPLANNER_CACHE_DIR": str(cache)}
            envs[side].pop("KBPLANNER_NO_CACHE", None)
            _seed_imports(cache, envs[side], project)
        p = str(project)
        cases: list[tuple[str, list[str], bool]] = [
            ("--version", ["--version"], False),
            ("--help", ["--help"], False),
            ("info (cold)", ["info", p], True),
            ("info (cached)", ["info", p], False),
            (f"query {args.query} (cold)", ["query", p, args.query], True),
            (f"query {args.query} (cached)", ["query", p, args.query], False),
        ]
        if args.plan:
            plan = ["plan", p, "--scenario", "storage-outside"]
            cases += [("plan (cold)", plan, True), ("plan (cached)", plan, False)]
        load_start = os.getloadavg()
        runs: dict[str, dict[str, list[tuple[float, float]]]] = {c[0]: {s: [] for s in trees} for c in cases}
        outputs: dict[str, dict[str, str]] = {c[0]: {} for c in cases}
        for _ in range(args.repeat):
            for name, words, cold in cases:
                for side in trees:
                    if cold:
                        shutil.rmtree(Path(envs[side]["KBPLANNER_CACHE_DIR"]) / "project", ignore_errors=True)
                    wall, cpu, out, code = _run([PY, "-m", "kbplanner", *words], envs[side])
                    if code not in (0, 1):  # plan: 1 = some step infeasible, still a plan
                        raise SystemExit(f"{side}: kbplanner {' '.join(words)} exited {code}")
                    runs[name][side].append((wall, cpu))
                    outputs[name][side] = out
        load_end = os.getloadavg()
    finally:
        shutil.rmtree(work, ignore_errors=True)

    rows: list[dict[str, Any]] = []
    for name, _words, _cold in cases:
        row: dict[str, Any] = {"command": name}
        for side in ("before", "after"):
            row[f"{side}_wall_s"] = round(statistics.median(w for w, _ in runs[name][side]), 3)
            row[f"{side}_cpu_s"] = round(statistics.median(c for _, c in runs[name][side]), 3)
        row["ratio_wall"] = round(row["before_wall_s"] / row["after_wall_s"], 1)
        row["ratio_cpu"] = round(row["before_cpu_s"] / max(row["after_cpu_s"], 1e-3), 1)
        row["same_output"] = outputs[name]["before"] == outputs[name]["after"]
        rows.append(row)
    result = {"benchmark": "startup", "before": args.before, "repeat": args.repeat,
              "load_average_start": [round(x, 2) for x in load_start],
              "load_average_end": [round(x, 2) for x in load_end],
              "machine": machine_info(), "rows": rows}
    write_json(args.out, result)
    print(f"start-up, median of {args.repeat} (before = {args.before}); load average "
          f"{load_start[0]:.2f} -> {load_end[0]:.2f} (1 min)")
    print(f"{'command':<24} {'before wall':>11} {'after wall':>10} {'ratio':>6} {'before cpu':>10} "
          f"{'after cpu':>9} {'ratio':>6}  same output")
    for r in rows:
        print(f"{r['command']:<24} {r['before_wall_s']:>10.2f}s {r['after_wall_s']:>9.2f}s "
              f"{r['ratio_wall']:>5.1f}x {r['before_cpu_s']:>9.2f}s {r['after_cpu_s']:>8.2f}s "
              f"{r['ratio_cpu']:>5.1f}x  {r['same_output']}")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
