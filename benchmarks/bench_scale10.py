"""Whole-building end to end before/after (issue 14: 10 x 8 on 2 cores): ``kbplanner run --tasks all``
by a baseline's sources and by this tree's, alternately, in one run of this script.

Per round: ``kbplanner generate-building --storeys S --units-per-storey U`` (this tree; the generator is
the same in both) into one project folder, then for the baseline and for this tree, each with its own
empty cache (``KBPLANNER_CACHE_DIR``: both start cold, neither reuses the other's import)::

    kbplanner run PROJECT --out RUN --tasks all --workers W [--max-elements N]

into the same ``RUN`` path (the first run's folder is moved aside), so that every file can be compared
byte for byte: all but the wall-clock ones (``run_timings.json``, ``tasks_timings.json``, each run's
``timing.json``) and the run folders' markers (they name the command: the baseline's worker processes
wrote "kbplanner (Python API)" into the task folders, this tree's the command that was run). Records
per command the wall time, CPU seconds and peak memory of its process tree (``os.wait4``), the
pipeline's stage times, per scenario installed / elements and simulated time; ratios are baseline /
this tree (> 1: faster now), from the median over rounds; the load average before and after (the
machine may be shared: CPU seconds are the steadier figure).

Usage: .venv/bin/python benchmarks/bench_scale10.py [--before REF] [--size 10x8] [--workers 2]
       [--max-elements N] [--rounds N] [--out FILE]
Prints a table and writes benchmarks/results/scale10.json (or --out); ``bench_scale10.py --table FILE``
prints the docs/scale.md table of a written result.
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

from _common import REPO, RESULTS_DIR, machine_info, run_measured, write_json

WALL_CLOCK = {"run_timings.json", "tasks_timings.json", "timing.json"}
MARKER = ".kbplanner-run"
TIMEOUT_S = 4 * 3600.0


def _export(ref: str, into: Path) -> Path:
    """The tree of git ``ref`` under ``into``; returns its ``src``."""
    into.mkdir(parents=True, exist_ok=True)
    archive = subprocess.run(["git", "-C", str(REPO), "archive", ref], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into / "src"


def _files(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and p.name not in WALL_CLOCK and p.name != MARKER}


def _read(path: Path) -> Any:
    return json.loads(path.read_text(encoding="utf-8")) if path.is_file() else None


def _run(src: Path, project: Path, out: Path, cache: Path, log: Path, workers: int,
         max_elements: int | None) -> dict[str, Any]:
    env = dict(os.environ, PYTHONPATH=str(src), PYTHONHASHSEED="0", KBPLANNER_CACHE_DIR=str(cache))
    cmd = [sys.executable, "-m", "kbplanner", "run", str(project), "--out", str(out), "--tasks", "all",
           "--workers", str(workers)]
    if max_elements is not None:
        cmd += ["--max-elements", str(max_elements)]
    measured = run_measured(cmd, log=log, timeout_s=TIMEOUT_S, env=env)
    if measured["exit"] not in (0, 1) or not (out / "report.html").is_file():
        raise SystemExit(f"{' '.join(cmd)} failed (exit {measured['exit']}):\n{log.read_text()[-3000:]}")
    timings = _read(out / "run_timings.json") or {}
    scenarios = {}
    for tasks_dir in sorted(out.glob("scenarios/*/tasks")):
        tasks, wall = _read(tasks_dir / "tasks.json") or {}, _read(tasks_dir / "tasks_timings.json") or {}
        scenarios[tasks_dir.parent.name] = {
            "tasks": len(tasks.get("tasks", [])), "installed": tasks.get("installed"),
            "elements": tasks.get("elements"), "sim_time_s": tasks.get("sim_time_s"),
            "simulation_wall_s": wall.get("wall_s"), "task_wall_s": wall.get("tasks")}
    return {"command": " ".join(cmd), "seconds": measured["seconds"], "cpu_s": measured["cpu_s"],
            "peak_rss_mb": measured["peak_rss_mb"], "exit": measured["exit"],
            "stages": {f"{s['stage']}{' [' + s['scenario'] + ']' if s.get('scenario') else ''}": s["seconds"]
                       for s in timings.get("stages", [])},
            "scenarios": scenarios}


def _median(rows: list[dict[str, Any]], key: str) -> float | None:
    values = [r[key] for r in rows if isinstance(r.get(key), (int, float))]
    return round(statistics.median(values), 2) if values else None


def markdown(result: dict[str, Any]) -> str:
    """The docs/scale.md table of a result (``--table FILE``: the figures are printed, never retyped)."""
    b, a = result["before"], result["after"]
    rows = [("`kbplanner run`, wall", b["run_s"], a["run_s"], result["ratio_wall"]),
            ("`kbplanner run`, CPU (all processes)", b["run_cpu_s"], a["run_cpu_s"], result["ratio_cpu"])]
    sb, sa = b["runs"][-1]["stages"], a["runs"][-1]["stages"]
    rows += [(f"stage: {k}", sb.get(k), sa.get(k), round(sb[k] / sa[k], 2) if sa.get(k) else None)
             for k in sb]
    lines = ["| | before | after | ratio |", "| --- | ---: | ---: | ---: |"]
    lines += [f"| {n} | {x:.1f} s | {y:.1f} s | {r if r is not None else ''} |" for n, x, y, r in rows
              if x is not None and y is not None]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    if argv is None and sys.argv[1:2] == ["--table"]:
        sys.stdout.write(markdown(json.loads(Path(sys.argv[2]).read_text(encoding="utf-8"))))
        return 0
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", default="main", help="git ref of the baseline (default main)")
    ap.add_argument("--size", default="10x8", help="STOREYSxUNITS of the generated building (default 10x8)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--max-elements", type=int, help="simulate the first N elements of each task only")
    ap.add_argument("--rounds", type=int, default=1, help="before/after pairs (median)")
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "scale10.json")
    args = ap.parse_args(argv)
    storeys, units = (int(v) for v in args.size.lower().split("x"))
    load_start = list(os.getloadavg())
    runs: dict[str, list[dict[str, Any]]] = {"before": [], "after": []}
    generate: list[dict[str, Any]] = []
    identical, differing = True, set()
    with tempfile.TemporaryDirectory(prefix="bench-scale10-") as tmp_name:
        tmp = Path(tmp_name)
        trees = {"before": _export(args.before, tmp / "before"), "after": REPO / "src"}
        for k in range(args.rounds):
            project, out = tmp / f"building-{k}", tmp / f"run-{k}"
            env = dict(os.environ, PYTHONPATH=str(trees["after"]), PYTHONHASHSEED="0",
                       KBPLANNER_CACHE_DIR=str(tmp / f"cache-gen-{k}"))
            generate.append(run_measured(
                [sys.executable, "-m", "kbplanner", "generate-building", "--storeys", str(storeys),
                 "--units-per-storey", str(units), "--out", str(project)],
                log=tmp / f"generate-{k}.log", timeout_s=TIMEOUT_S, env=env))
            kept: dict[str, dict[str, bytes]] = {}
            for label in ("before", "after"):
                sys.stderr.write(f"round {k + 1}/{args.rounds}: {label} ...\n")
                row = _run(trees[label], project, out, tmp / f"cache-{label}-{k}", tmp / f"{label}-{k}.log",
                           args.workers, args.max_elements)
                sys.stderr.write(f"  {row['seconds']:.1f} s wall, {row['cpu_s']:.1f} s CPU\n")
                runs[label].append(row)
                kept[label] = _files(out)
                shutil.move(str(out), str(tmp / f"run-{k}-{label}"))
            diff = sorted(n for n in set(kept["before"]) | set(kept["after"])
                          if kept["before"].get(n) != kept["after"].get(n))
            identical = identical and not diff
            differing.update(diff)
    result: dict[str, Any] = {
        "machine": machine_info(("python", "cpus", "platform")), "before": args.before,
        "size": args.size, "workers": args.workers, "max_elements": args.max_elements, "rounds": args.rounds,
        "load_average_start": load_start, "load_average_end": list(os.getloadavg()),
        "generate_s": _median(generate, "seconds"), "generate_cpu_s": _median(generate, "cpu_s"),
        "outputs_identical": identical, "differing_files": sorted(differing)[:50]}
    for label in ("before", "after"):
        rs = runs[label]
        result[label] = {"run_s": _median(rs, "seconds"), "run_cpu_s": _median(rs, "cpu_s"),
                         "peak_rss_mb": _median(rs, "peak_rss_mb"), "runs": rs}
        gen = result["generate_s"] or 0.0
        result[label]["generate_to_report_s"] = round(gen + (result[label]["run_s"] or 0.0), 2)
    b, a = result["before"], result["after"]
    result["ratio_wall"] = round(b["run_s"] / a["run_s"], 2) if a["run_s"] else None
    result["ratio_cpu"] = round(b["run_cpu_s"] / a["run_cpu_s"], 2) if a["run_cpu_s"] else None
    write_json(args.out, result)
    w = sys.stdout.write
    w(f"{args.size}, kbplanner run --tasks all --workers {args.workers}"
      f"{f' --max-elements {args.max_elements}' if args.max_elements else ''}; before = {args.before}\n")
    w(f"{'':34}{'before':>12}{'after':>12}{'ratio':>8}\n")
    w(f"{'kbplanner run, wall s':34}{b['run_s']:12.1f}{a['run_s']:12.1f}{result['ratio_wall']:8.2f}\n")
    w(f"{'kbplanner run, CPU s':34}{b['run_cpu_s']:12.1f}{a['run_cpu_s']:12.1f}{result['ratio_cpu']:8.2f}\n")
    w(f"{'generate to report, wall s':34}{b['generate_to_report_s']:12.1f}"
      f"{a['generate_to_report_s']:12.1f}\n")
    for stage in b["runs"][-1]["stages"]:
        sb, sa = b["runs"][-1]["stages"].get(stage), a["runs"][-1]["stages"].get(stage)
        w(f"  {stage[:32]:32}{sb if sb is not None else float('nan'):12.1f}"
          f"{sa if sa is not None else float('nan'):12.1f}\n")
    for name, sc in a["runs"][-1]["scenarios"].items():
        w(f"{name}: {sc['tasks']} tasks, {sc['installed']}/{sc['elements']} installed, "
          f"{sc['sim_time_s']} s simulated\n")
    w(f"outputs identical: {'yes' if identical else 'no: ' + ', '.join(sorted(differing)[:5])}\n")
    w(f"load average {load_start[0]:.2f} -> {result['load_average_end'][0]:.2f}; wrote {args.out}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
