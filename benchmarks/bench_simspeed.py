"""Simulation speed before/after (issue 14, items 2-3): the case study's ``kbplanner simulate``, run
by a baseline's sources and by this tree's, alternately, in one run of this script.

The baseline is a git ref (default ``main``) whose tree is exported (``git archive``) into a
temporary folder; both run the same command with the same shared virtualenv, one after the other per
round (baseline first, then this tree; rounds alternate the machine's load between them), with
``PYTHONPATH`` pointing at their sources::

    kbplanner simulate data/case_study --scenario S --seed N [--task T] --out DIR

Per scenario it records each command's wall time (``os.wait4``, with CPU seconds and peak memory),
the simulation step's wall time and real-time factor from the run's ``timing.json`` and its CPU
time (``executor.simulate`` timed by a wrapper around the command, the same for both trees), the
simulated time, whether ``trajectories.csv``, ``events.jsonl`` and ``metrics.json`` of both are
byte-identical (``outputs_identical``), and this tree's path-quality figures (``metrics.json``
``path_quality``, when present). Ratios are baseline /
this tree (> 1: faster now), from the median over rounds. The load average is recorded before and
after: on a shared machine absolute seconds vary, the ratios of one run much less.

Usage: .venv/bin/python benchmarks/bench_simspeed.py [--before REF] [--scenario S ...] [--task T] [--rounds N]
(``--task``: one robotized task of the case study, e.g. T-BOARD, instead of the project's default task)
Prints a table and writes benchmarks/results/simspeed.json (or --out); ``--markdown-from JSON`` prints
the Markdown table of such a result (for the docs) without running anything.
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

DETERMINISTIC = ("trajectories.csv", "events.jsonl", "metrics.json")


def _export(ref: str, into: Path) -> Path:
    """The tree of git ``ref`` under ``into`` (sources, ontology, shapes, robots); returns its ``src``."""
    archive = subprocess.run(["git", "-C", str(REPO), "archive", ref], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into / "src"


# ``python -m kbplanner ARGS`` with the simulation step (executor.simulate) timed in CPU and wall seconds
# into the file named by the first argument: the same measurement for a baseline whose timing.json has
# no CPU time.
_TIMED = '''import json, os, sys, time
import kbplanner.simulation.executor as ex
from kbplanner.cli import main
if os.environ.get("BENCH_B4_CACHE") != "warm":
    try:  # cold: B4 runs, a refined plan kept by an earlier command (planning/refine_cache.py) is not read
        import kbplanner.planning.refine_cache as rc
        rc._read = lambda path: None
    except ImportError:  # a tree without the cache
        pass
inner = ex.simulate
def timed(*args, **kwargs):
    c0, w0 = time.process_time(), time.perf_counter()
    try:
        return inner(*args, **kwargs)
    finally:
        with open(sys.argv[1], "w") as f:
            json.dump({"cpu_s": time.process_time() - c0, "wall_s": time.perf_counter() - w0}, f)
ex.simulate = timed
raise SystemExit(main(sys.argv[2:]))
'''


def _prime(src: Path, scenario: str, seed: int, b4: bool, log: Path) -> None:
    """Load the tree's project once (its project cache entry; with ``b4`` also B4, its refined plan kept)
    so that the timed runs of both trees start from the same state of the caches."""
    env = dict(os.environ, PYTHONPATH=str(src))
    cmd = [sys.executable, "-m", "kbplanner", "plan", str(src.parent / "data" / "case_study"), "--scenario",
           scenario, "--seed", str(seed)] + ([] if b4 else ["--no-feasibility"])
    run_measured(cmd, log=log, timeout_s=1800.0, env=env)


def _run(src: Path, scenario: str, seed: int, out: Path, log: Path, b4_cache: str = "cold",
         task: str | None = None) -> dict[str, Any]:
    env = dict(os.environ, PYTHONPATH=str(src), BENCH_B4_CACHE=b4_cache)
    step_file = log.with_suffix(".step.json")
    cmd = [sys.executable, "-c", _TIMED, str(step_file), "simulate", str(src.parent / "data" / "case_study"),
           "--scenario", scenario, "--seed", str(seed), "--out", str(out)]
    if task:
        cmd += ["--task", task]
    measured = run_measured(cmd, log=log, timeout_s=1800.0, env=env)
    step = json.loads(step_file.read_text()) if step_file.is_file() else {}
    if not (out / "timing.json").is_file():
        tail = log.read_text()[-2000:]
        raise SystemExit(f"{' '.join(cmd)} wrote no run (exit {measured['exit']}):\n{tail}")
    timing = json.loads((out / "timing.json").read_text()) if (out / "timing.json").is_file() else {}
    metrics = json.loads((out / "metrics.json").read_text()) if (out / "metrics.json").is_file() else {}
    quality = metrics.get("path_quality")
    return {"command_s": measured["seconds"], "exit": measured["exit"], "cpu_s": measured["cpu_s"],
            "peak_rss_mb": measured["peak_rss_mb"], "simulation_s": timing.get("wall_time_s"),
            "simulation_cpu_s": round(step["cpu_s"], 3) if "cpu_s" in step else None,
            "sim_time_s": timing.get("sim_time_s"), "planning_total_s": timing.get("planning_total_s"),
            "path_quality": {k: v for k, v in quality.items() if k != "per_element"} if quality else None}


#: what a simulate run keeps in the project's cache folder
KEPT_BY_RUNS = ("cspace", "cells", "walks", "static")


def _forget_runs(src: Path) -> None:
    """A first run: remove what earlier ``simulate`` runs of this tree kept (configuration spaces, cell
    paths, walking legs and map, static bodies' triangles; kbplanner's own cache files), keeping the
    parsed project."""
    cache = src.parent / "data" / "case_study" / ".kbplanner-cache"
    for sub in KEPT_BY_RUNS:
        shutil.rmtree(cache / sub, ignore_errors=True)


def _median(rows: list[dict[str, Any]], key: str) -> float | None:
    values = [r[key] for r in rows if isinstance(r.get(key), (int, float))]
    return round(statistics.median(values), 3) if values else None


def bench(before_src: Path, after_src: Path, scenario: str, seed: int, rounds: int, tmp: Path,
          b4_cache: str = "cold", task: str | None = None, first_run: bool = False) -> dict[str, Any]:
    runs: dict[str, list[dict[str, Any]]] = {"before": [], "after": []}
    identical = True
    for label, src in (("before", before_src), ("after", after_src)):
        warm = b4_cache == "warm" and label == "after"
        _prime(src, scenario, seed, warm, tmp / f"{scenario}-{label}-prime.log")
    for k in range(rounds):
        outs = {}
        for label, src in (("before", before_src), ("after", after_src)):
            out = tmp / f"{scenario}-{label}-{k}"
            if first_run:
                _forget_runs(src)
            runs[label].append(_run(src, scenario, seed, out, tmp / f"{scenario}-{label}-{k}.log", b4_cache,
                                    task))
            outs[label] = out
        identical = identical and all(
            (outs["before"] / f).read_bytes() == (outs["after"] / f).read_bytes() for f in DETERMINISTIC)
    row: dict[str, Any] = {"scenario": scenario, "seed": seed, "rounds": rounds,
                           "outputs_identical": identical, "b4_cache": b4_cache, "first_run": first_run}
    if task:
        row["task"] = task
    for label in ("before", "after"):
        rs = runs[label]
        sim = _median(rs, "sim_time_s")
        cmd, step = _median(rs, "command_s"), _median(rs, "simulation_s")
        cmd_cpu, step_cpu = _median(rs, "cpu_s"), _median(rs, "simulation_cpu_s")
        row[label] = {"command_s": cmd, "simulation_s": step, "sim_time_s": sim,
                      "command_cpu_s": cmd_cpu, "simulation_cpu_s": step_cpu,
                      "x_real_time_command_cpu": round(sim / cmd_cpu, 1) if sim and cmd_cpu else None,
                      "x_real_time_simulation_cpu": round(sim / step_cpu, 1) if sim and step_cpu else None,
                      "x_real_time_command": round(sim / cmd, 1) if sim and cmd else None,
                      "x_real_time_simulation": round(sim / step, 1) if sim and step else None,
                      "planning_total_s": _median(rs, "planning_total_s"),
                      "exit": [r["exit"] for r in rs], "runs": rs}
    b, a = row["before"], row["after"]
    row["speedup_command"] = round(b["command_s"] / a["command_s"], 2) if a["command_s"] else None
    row["speedup_simulation"] = round(b["simulation_s"] / a["simulation_s"], 2) if a["simulation_s"] else None
    cpu_b, cpu_a = b["command_cpu_s"], a["command_cpu_s"]
    row["speedup_command_cpu"] = round(cpu_b / cpu_a, 2) if cpu_a else None
    sb, sa = b["simulation_cpu_s"], a["simulation_cpu_s"]
    row["speedup_simulation_cpu"] = round(sb / sa, 2) if sb and sa else None
    row["path_quality_after"] = runs["after"][-1]["path_quality"]
    return row


def markdown(out: dict[str, Any]) -> str:
    """The Markdown table of a result (docs/scale.md, docs/simulation.md): CPU figures first, they are
    the steadier ones on a shared machine."""
    lines = ["| scenario | simulated | simulation step CPU before / after | step x real time (CPU) "
             "| command CPU before / after | command wall before / after | peak memory | identical |",
             "| --- | ---: | ---: | --- | ---: | ---: | ---: | --- |"]
    for r in out["scenarios"]:
        b, a = r["before"], r["after"]
        mem = [_median(side["runs"], "peak_rss_mb") for side in (b, a)]
        lines.append(
            f"| {r['scenario']}{' ' + r['task'] if r.get('task') else ''} | {a['sim_time_s']:,.1f} s "
            f"| {b['simulation_cpu_s']:.1f} / {a['simulation_cpu_s']:.1f} s (x{r['speedup_simulation_cpu']}) "
            f"| {b['x_real_time_simulation_cpu']:.0f}x -> {a['x_real_time_simulation_cpu']:.0f}x "
            f"| {b['command_cpu_s']:.1f} / {a['command_cpu_s']:.1f} s (x{r['speedup_command_cpu']}) "
            f"| {b['command_s']:.0f} / {a['command_s']:.0f} s "
            f"| {mem[0]:.0f} / {mem[1]:.0f} MB | {'yes' if r['outputs_identical'] else 'no'} |")
    load = f"load average {out['load_average_start'][0]:.1f} -> {out['load_average_end'][0]:.1f}"
    rounds = out["scenarios"][0]["rounds"] if out["scenarios"] else 0
    task = f" --task {out['task']}" if out.get("task") else ""
    lines.append("")
    cache = out.get("b4_cache", "")
    flag = f" --b4-cache {cache}" if cache else ""
    if out.get("first_run"):
        flag += " --first-run"
    how = {"cold": "; B4 run by both (cold)",
           "warm": "; this tree's B4 read from the refined-plan cache (warm)"}.get(cache, "")
    seed = out["scenarios"][0]["seed"] if out["scenarios"] else ""
    lines.append(f"(`bench_simspeed.py --before {out['before']}{task} --rounds {rounds}{flag}`: medians of "
                 f"{rounds} round(s), seed {seed}{how}; {load})")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--markdown-from", type=Path, metavar="JSON",
                    help="print the Markdown table of an earlier result and exit (no runs)")
    ap.add_argument("--before", default="main", help="git ref of the baseline (default main)")
    ap.add_argument("--scenario", action="append", help="scenario(s) (default: both storage scenarios)")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--task", help="robotized task to simulate (default: the project's [simulation] task)")
    ap.add_argument("--rounds", type=int, default=1, help="before/after pairs per scenario (median)")
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "simspeed.json")
    ap.add_argument("--b4-cache", choices=("cold", "warm"), default="cold",
                    help="cold (default): B4 runs in every command; warm: this tree reads the refined plan "
                         "its `kbplanner plan` kept before the rounds (planning/refine_cache.py)")
    ap.add_argument("--first-run", action="store_true",
                    help="before every timed run remove what earlier simulate runs kept in the tree's "
                         f"project cache ({', '.join(KEPT_BY_RUNS)}): a user's first simulate of a scenario")
    args = ap.parse_args(argv)
    if args.markdown_from:
        sys.stdout.write(markdown(json.loads(args.markdown_from.read_text())))
        return 0
    scenarios = args.scenario or ["storage-outside", "storage-inside"]
    load_before = list(os.getloadavg())
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        before_src = _export(args.before, tmp)
        rows = [bench(before_src, REPO / "src", s, args.seed, args.rounds, tmp, args.b4_cache, args.task,
                      args.first_run) for s in scenarios]
    out = {"machine": machine_info(("python", "cpus", "platform")), "before": args.before,
           "b4_cache": args.b4_cache, "task": args.task, "first_run": args.first_run,
           "load_average_start": load_before, "load_average_end": list(os.getloadavg()), "scenarios": rows}
    write_json(args.out, out)
    w = sys.stdout.write
    w(f"{'scenario':16} {'sim s':>7} {'command s':>17} {'x real':>13} {'sim step s':>15} {'x real':>13} "
      f"{'same':>5}\n{'':16} {'':>7} {'before / after':>17} {'before/after':>13} {'before / after':>15} "
      f"{'before/after':>13}\n")
    for r in rows:
        b, a = r["before"], r["after"]
        w(f"{r['scenario']:16} {a['sim_time_s'] or 0:7.1f} {b['command_s']:8.1f} / {a['command_s']:6.1f} "
          f"{b['x_real_time_command'] or 0:6.1f}/{a['x_real_time_command'] or 0:6.1f} "
          f"{b['simulation_s'] or 0:7.1f} / {a['simulation_s'] or 0:5.1f} "
          f"{b['x_real_time_simulation'] or 0:6.1f}/{a['x_real_time_simulation'] or 0:6.1f} "
          f"{'yes' if r['outputs_identical'] else 'no':>5}\n")
        w(f"{'':16} command CPU s {b['command_cpu_s']} / {a['command_cpu_s']} (x{r['speedup_command_cpu']}); "
          f"speed-up wall: command x{r['speedup_command']}, simulation x{r['speedup_simulation']}\n")
        w(f"{'':16} CPU: command {b['x_real_time_command_cpu']}x -> {a['x_real_time_command_cpu']}x "
          f"real time; simulation step {b['simulation_cpu_s']} / {a['simulation_cpu_s']} s "
          f"({b['x_real_time_simulation_cpu']}x -> {a['x_real_time_simulation_cpu']}x, "
          f"x{r['speedup_simulation_cpu']})\n")
        if r["path_quality_after"]:
            q = r["path_quality_after"]
            w(f"{'':16} path quality: time / lower bound median {q['time_over_lower_bound']['median']} max "
              f"{q['time_over_lower_bound']['max']}; driven / shortest median "
              f"{q['driven_over_shortest']['median']} max {q['driven_over_shortest']['max']}\n")
    w(f"load average {load_before[0]:.2f} -> {out['load_average_end'][0]:.2f}; wrote {args.out}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
