"""The pipeline's simulation stage on the case study (issues 11 and 14): ``make run``'s command with 1 and
2 workers, by a baseline's sources and by this tree's, alternately, in one run of this script.

Per round, for the baseline (a git ref, default ``main``, exported by ``git archive``) and this tree,
each with 1 and then 2 workers::

    kbplanner run data/case_study --tasks all --workers W --out DIR

Each command starts with its own empty project cache (``KBPLANNER_CACHE_DIR``: cold, as on a fresh
clone) or, with ``--warm``, with a cache that an untimed run of the same tree and workers filled first
(the project import and, for this tree, the last run's CPU seconds per task, from which it orders the
tasks). Records per command the wall time, CPU seconds and peak memory of its process tree
(``os.wait4``), the pipeline's stage times (``run_timings.json``), and for the simulation stage: the
simulated seconds, the stage's wall seconds and real-time factor (simulated / wall) over both
scenarios and per scenario, and for this tree each task's CPU seconds and process, hence the stage's
critical path in CPU seconds (the busiest process's CPU: what the stage's wall would be on an idle
machine with one core per process) and the real-time factor per critical-path CPU second, a figure
that the machine's load changes much less than the wall. Every file of every run is compared with
the first run's, except the wall-clock ones (``run_timings.json``, ``tasks_timings.json``, each run's
``timing.json``) and the run folders' markers (they name the command).

Usage: .venv/bin/python benchmarks/bench_stage.py [--before REF] [--rounds N] [--warm] [--out FILE]
Prints a table and writes benchmarks/results/stage.json (or --out); ``--markdown-from FILE`` prints
the docs table of a written result without running anything; ``--stage-of RUN --out FILE`` the stage's
figures of one existing run folder (e.g. ``runs/case_study`` of ``make run``); ``--spawn-costs --out
FILE`` a spawned worker's start-up (bare and warmed) and the pickling of the main task's outcome.
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
TIMEOUT_S = 3600.0
STAGE = "simulation (every task)"


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


def _stage_figures(out: Path) -> dict[str, Any]:
    """The simulation stage of a run folder: from ``run_timings.json`` (``simulation``: this tree) or,
    for a baseline without it, from the stage times and each scenario's ``tasks/tasks.json``."""
    timings = _read(out / "run_timings.json") or {}
    stage_wall = sum(s["seconds"] for s in timings.get("stages", []) if s["stage"] == STAGE)
    scenarios: dict[str, Any] = {}
    for tasks_dir in sorted(out.glob("scenarios/*/tasks")):
        tasks, wall = _read(tasks_dir / "tasks.json") or {}, _read(tasks_dir / "tasks_timings.json") or {}
        scenarios[tasks_dir.parent.name] = {
            "sim_time_s": tasks.get("sim_time_s"), "installed": tasks.get("installed"),
            "elements": tasks.get("elements"), "wall_s": wall.get("wall_s"),
            "real_time_factor": wall.get("real_time_factor"), "task_wall_s": wall.get("tasks")}
    sim_s = sum(s["sim_time_s"] or 0.0 for s in scenarios.values())
    figures: dict[str, Any] = {
        "sim_time_s": round(sim_s, 1), "stage_wall_s": round(stage_wall, 2),
        "real_time_factor": round(sim_s / stage_wall, 1) if stage_wall else None, "scenarios": scenarios}
    sim = timings.get("simulation")
    if sim:  # this tree: CPU per task and the process that ran it
        per_process: dict[int, float] = {}
        for sc in sim["scenarios"].values():
            for t in sc["per_task"].values():
                per_process[t["process"]] = per_process.get(t["process"], 0.0) + t["cpu_s"]
        critical = max(per_process.values()) if per_process else 0.0
        per_cpu = round(sim_s / critical, 1) if critical else None
        figures.update({"cpu_s": sim["cpu_s"], "busy": sim["busy"], "critical_cpu_s": round(critical, 2),
                        "real_time_factor_per_critical_cpu_s": per_cpu,
                        "per_process_cpu_s": {str(k): round(v, 2) for k, v in sorted(per_process.items())}})
        for name, sc in sim["scenarios"].items():
            figures["scenarios"].setdefault(name, {})["cpu_s"] = sc["cpu_s"]
    return figures


def _child_cpu() -> float:
    import resource

    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def spawn_costs(project: Path) -> dict[str, Any]:
    """What a spawned worker costs (this tree): the wall seconds until a new process answers and its
    CPU seconds, bare and warmed with the case study's two scenarios (``task_jobs.warm``); the pickled
    size and the CPU seconds to pickle and unpickle the main task's outcome (with its run), which a
    spawned process sends back."""
    import multiprocessing
    import pickle
    import time
    from concurrent.futures import ProcessPoolExecutor

    sys.path.insert(0, str(REPO / "src"))
    from kbplanner.scale.task_jobs import _Job, run_job, warm

    scenarios = ("storage-inside", "storage-outside")
    out: dict[str, Any] = {"load_average": list(os.getloadavg())}
    for label, init, args in (("bare", None, ()), ("warm", warm, (project, scenarios))):
        t0 = time.perf_counter()
        ex = ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"), initializer=init,
                                 initargs=args)
        cpu = ex.submit(_child_cpu).result()
        out[f"spawn_{label}"] = {"wall_s": round(time.perf_counter() - t0, 2), "child_cpu_s": round(cpu, 2)}
        ex.shutdown()
    with tempfile.TemporaryDirectory(prefix="bench-stage-pickle-") as tmp:
        warm(project, scenarios[:1])
        job = _Job(project, scenarios[0], "T-FRAME", "T-FRAME", None, Path(tmp) / "run", "run", True, True,
                   None)
        outcome = run_job(job)
        c0 = time.process_time()
        data = pickle.dumps(outcome)
        c1 = time.process_time()
        pickle.loads(data)
        out["main_task_outcome"] = {"mb": round(len(data) / 1e6, 2), "dumps_cpu_s": round(c1 - c0, 4),
                                    "loads_cpu_s": round(time.process_time() - c1, 4),
                                    "task_cpu_s": round(outcome.cpu_s, 2)}
    return out


def _run(src: Path, out: Path, cache: Path, log: Path, workers: int) -> dict[str, Any]:
    env = dict(os.environ, PYTHONPATH=str(src), PYTHONHASHSEED="0", KBPLANNER_CACHE_DIR=str(cache))
    cmd = [sys.executable, "-m", "kbplanner", "run", str(REPO / "data" / "case_study"), "--tasks", "all",
           "--workers", str(workers), "--out", str(out)]
    measured = run_measured(cmd, log=log, timeout_s=TIMEOUT_S, env=env)
    if measured["exit"] not in (0, 1) or not (out / "report.html").is_file():
        raise SystemExit(f"{' '.join(cmd)} failed (exit {measured['exit']}):\n{log.read_text()[-3000:]}")
    timings = _read(out / "run_timings.json") or {}
    return {"workers": workers, "seconds": measured["seconds"], "cpu_s": measured["cpu_s"],
            "peak_rss_mb": measured["peak_rss_mb"], "exit": measured["exit"],
            "stages": {f"{s['stage']}{' [' + s['scenario'] + ']' if s.get('scenario') else ''}": s["seconds"]
                       for s in timings.get("stages", [])},
            "stage": _stage_figures(out)}


def _median(rows: list[dict[str, Any]], *keys: str) -> float | None:
    values = []
    for r in rows:
        v: Any = r
        for k in keys:
            v = v.get(k) if isinstance(v, dict) else None
        if isinstance(v, (int, float)):
            values.append(float(v))
    return round(statistics.median(values), 2) if values else None


def markdown(result: dict[str, Any]) -> str:
    """The docs table of a result (``--markdown-from FILE``: the figures are printed, never retyped)."""
    lines = ["| tree | workers | command wall | command CPU | stage wall | simulated | "
             "real-time factor (wall) | outside / inside (wall) | busiest process CPU | per its CPU second |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for label in ("before", "after"):
        for w, rows in sorted(result["runs"][label].items()):
            last = rows[-1]["stage"]
            sc = last["scenarios"]
            per = " / ".join(f"{sc[n]['real_time_factor']}x" for n in ("storage-outside", "storage-inside")
                             if n in sc)
            crit = _median(rows, "stage", "critical_cpu_s")
            per_cpu = _median(rows, "stage", "real_time_factor_per_critical_cpu_s")
            lines.append(
                f"| {label} | {w} | {_median(rows, 'seconds')} s | {_median(rows, 'cpu_s')} s | "
                f"{_median(rows, 'stage', 'stage_wall_s')} s | {last['sim_time_s']:,.1f} s | "
                f"{_median(rows, 'stage', 'real_time_factor')}x | {per} | "
                f"{'' if crit is None else f'{crit} s'} | {'' if per_cpu is None else f'{per_cpu}x'} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", default="main", help="git ref of the baseline (default main)")
    ap.add_argument("--rounds", type=int, default=1, help="rounds of the four commands (median)")
    ap.add_argument("--workers", default="1,2", help="worker counts to run (default 1,2)")
    ap.add_argument("--warm", action="store_true",
                    help="an untimed run first fills each tree's cache (else every command starts cold)")
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "stage.json")
    ap.add_argument("--markdown-from", type=Path, help="print the table of a written result and stop")
    ap.add_argument("--stage-of", type=Path, metavar="RUN",
                    help="the simulation stage's figures of an existing `kbplanner run --tasks all` folder "
                         "(written to --out) and stop")
    ap.add_argument("--spawn-costs", action="store_true",
                    help="measure a spawned worker's start-up and the pickling of a task's outcome "
                         "(to --out)")
    args = ap.parse_args(argv)
    if args.spawn_costs:
        costs = spawn_costs(REPO / "data" / "case_study")
        write_json(args.out, costs)
        sys.stdout.write(json.dumps(costs, indent=1) + "\n")
        return 0
    if args.stage_of is not None:
        figures = {"run": str(args.stage_of), "load_average": list(os.getloadavg()),
                   "stage": _stage_figures(args.stage_of)}
        write_json(args.out, figures)
        st = figures["stage"]
        sys.stdout.write(f"{st['sim_time_s']:,.1f} s simulated, stage {st['stage_wall_s']} s wall "
                         f"({st['real_time_factor']}x); busiest process {st.get('critical_cpu_s')} s CPU "
                         f"({st.get('real_time_factor_per_critical_cpu_s')}x per its CPU second), "
                         f"per process {st.get('per_process_cpu_s')}\n")
        return 0
    if args.markdown_from is not None:
        sys.stdout.write(markdown(json.loads(args.markdown_from.read_text(encoding="utf-8"))))
        return 0
    counts = [int(w) for w in args.workers.split(",")]
    load_start = list(os.getloadavg())
    runs: dict[str, dict[int, list[dict[str, Any]]]] = {"before": {w: [] for w in counts},
                                                        "after": {w: [] for w in counts}}
    first: dict[str, bytes] | None = None
    differing: set[str] = set()
    with tempfile.TemporaryDirectory(prefix="bench-stage-") as tmp_name:
        tmp = Path(tmp_name)
        trees = {"before": _export(args.before, tmp / "before"), "after": REPO / "src"}
        if args.warm:
            for label in trees:
                for w in counts:
                    sys.stderr.write(f"warm-up: {label}, {w} worker(s) ...\n")
                    _run(trees[label], tmp / "warm", tmp / f"cache-{label}-{w}", tmp / "warm.log", w)
                    shutil.rmtree(tmp / "warm")
        for k in range(args.rounds):
            for label in ("before", "after"):
                for w in counts:
                    sys.stderr.write(f"round {k + 1}/{args.rounds}: {label}, {w} worker(s) ...\n")
                    cache = tmp / (f"cache-{label}-{w}" if args.warm else f"cache-{label}-{w}-{k}")
                    out = tmp / f"run-{label}-{w}-{k}"
                    row = _run(trees[label], out, cache, tmp / f"{label}-{w}-{k}.log", w)
                    st = row["stage"]
                    sys.stderr.write(f"  {row['seconds']:.1f} s wall, {row['cpu_s']:.1f} s CPU; stage "
                                     f"{st['stage_wall_s']:.1f} s, {st['real_time_factor']}x\n")
                    runs[label][w].append(row)
                    files = _files(out)
                    if first is None:
                        first = files
                    else:
                        differing.update(n for n in set(first) | set(files) if first.get(n) != files.get(n))
                    shutil.rmtree(out)
    result: dict[str, Any] = {
        "machine": machine_info(("python", "cpus", "platform")), "before": args.before,
        "rounds": args.rounds, "warm": args.warm, "load_average_start": load_start,
        "load_average_end": list(os.getloadavg()), "outputs_identical": not differing,
        "differing_files": sorted(differing)[:50],
        "runs": {label: {str(w): rows for w, rows in by.items()} for label, by in runs.items()}}
    write_json(args.out, result)
    sys.stdout.write(markdown(result))
    sys.stdout.write(f"outputs identical (every run, all files but wall-clock ones): {not differing}\n"
                     f"load average {load_start[0]:.1f} -> {result['load_average_end'][0]:.1f}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
