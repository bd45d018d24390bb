"""The scale benchmark (issue 6): every pipeline stage on generated buildings, one apartment to 10 storeys.

Not a pipeline step: measurement of the pipeline. For each size (``SxU`` = S storeys x U units per
storey, or ``N`` = N x N) a fresh Python process (so that peak memory is per size) generates the
building and runs every stage that exists (``benchmarks/_stages.py``): import, requirements,
validation, named queries, world, occupancy map, planning of one storey and of every storey, and on
sizes whose simulation task has at most ``--simulate-max-frames`` frames (default 150: one storey at
every default size) refine (B4), simulation (B5, key frames off; simulated time, installed / elements,
real-time factor of B5 and of B4 + B5), analysis (the run read back: durations, worker proximity) and
report (comparison, results written back, report.html); then the named queries again on pyoxigraph
and on a SPARQL endpoint (an Oxigraph server this script starts on 127.0.0.1 and stops). It prints a
table (seconds and peak memory per stage), fits the growth exponent of each stage against the number
of building elements (the simulation stages against the simulated task's frames; least squares on
log-log), flags stages that grow faster than linearly, gives the per-query time ratios
rdflib : pyoxigraph and embedded : endpoint.

Then the end-to-end run (``--end-to-end SxU``, default 10x8: 1,120 frames on 10 storeys;
``--no-end-to-end`` skips it): ``kbplanner generate-building`` and ``kbplanner run DIR --out OUT
--tasks all --workers 2`` as subprocesses in a temporary directory, each timed, with the peak resident
memory of the largest process of each (``os.wait4``: worker processes included), the pipeline's stage
timings (OUT/run_timings.json), installed / elements, simulated time and real-time factor of every task
(``tasks/tasks.json``, ``tasks_timings.json``), and whether generate-to-report took less than the aim
(600 s). It prints its own table. Everything goes to ``benchmarks/results/bench.json`` (``--out``),
the end-to-end figures under ``"end_to_end"``.

    .venv/bin/python benchmarks/run.py                      # default sizes and 10x8 end to end (make bench)
    .venv/bin/python benchmarks/run.py --sizes 1x1 2x2 4x4 --no-end-to-end   # a quick run
    .venv/bin/python benchmarks/run.py --sizes --end-to-end 10x8             # the end-to-end run only
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path
from typing import Any

from _common import RESULTS_DIR, Timer, machine_info, run_measured, write_json

RESULTS = RESULTS_DIR / "bench.json"
DEFAULT_SIZES = ("1x1", "2x2", "4x4", "7x7", "10x10")
DEFAULT_END_TO_END = "10x8"  # 1,120 frames on 10 storeys
END_TO_END_WORKERS = 2
END_TO_END_AIM_S = 600.0     # generate to report
SUPERLINEAR = 1.15          # exponents above this are flagged
CHILD_TIMEOUT_S = 3600.0
SERVER_TIMEOUT_S = 15.0


def parse_size(text: str) -> tuple[int, int]:
    """``"4x3"`` -> (4, 3); ``"5"`` -> (5, 5)."""
    parts = text.lower().split("x")
    try:
        values = [int(p) for p in parts]
    except ValueError:
        raise argparse.ArgumentTypeError(f"size {text!r}: write STOREYSxUNITS, e.g. 10x10, or N") from None
    if len(values) == 1:
        values *= 2
    if len(values) != 2 or min(values) < 1:
        raise argparse.ArgumentTypeError(f"size {text!r}: write STOREYSxUNITS, e.g. 10x10, or N")
    return values[0], values[1]


# ---- the SPARQL endpoint -----------------------------------------------------------------------


class Server:
    """An Oxigraph SPARQL server on a free local port (``oxigraph serve``), stopped by :meth:`stop`."""

    def __init__(self, location: Path) -> None:
        binary = Path(sys.executable).parent / "oxigraph"
        exe = str(binary) if binary.is_file() else shutil.which("oxigraph")
        if exe is None:
            raise RuntimeError("the oxigraph server binary is not installed (pip install -e '.[dev]')")
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        self.url = f"http://127.0.0.1:{port}/query"
        self.log = (location.parent / "oxigraph.log").open("wb")
        cmd = [exe, "serve", "--location", str(location), "--bind", f"127.0.0.1:{port}"]
        self.proc = subprocess.Popen(cmd, stdout=self.log, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + SERVER_TIMEOUT_S
        while True:
            try:
                req = urllib.request.Request(self.url, data=b"ASK {}",
                                             headers={"Content-Type": "application/sparql-query"})
                with urllib.request.urlopen(req, timeout=1.0):
                    return
            except OSError:
                if self.proc.poll() is not None or time.monotonic() > deadline:
                    self.stop()
                    raise RuntimeError("the oxigraph server did not start") from None
                time.sleep(0.05)

    def stop(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(timeout=5)
        self.log.close()


# ---- analysis ----------------------------------------------------------------------------------


def fit_exponent(xs: list[float], ys: list[float]) -> tuple[float, float] | None:
    """Least-squares slope of log(y) on log(x) and its R^2 (None with fewer than 3 usable points)."""
    pts = [(math.log(x), math.log(y)) for x, y in zip(xs, ys, strict=True) if x > 0 and y and y > 0]
    if len(pts) < 3:
        return None
    mx = sum(p[0] for p in pts) / len(pts)
    my = sum(p[1] for p in pts) / len(pts)
    sxx = sum((p[0] - mx) ** 2 for p in pts)
    if sxx == 0:
        return None
    slope = sum((p[0] - mx) * (p[1] - my) for p in pts) / sxx
    ss_tot = sum((p[1] - my) ** 2 for p in pts)
    ss_res = sum((p[1] - (my + slope * (p[0] - mx))) ** 2 for p in pts)
    return slope, (1.0 - ss_res / ss_tot) if ss_tot > 0 else 1.0


def analyse(sizes: list[dict[str, Any]]) -> dict[str, Any]:
    """Growth exponents per stage and per named query, and the backend ratios."""
    elements = [float(s["elements"] or 0) for s in sizes]
    stage_names: list[str] = []
    for s in sizes:
        stage_names += [st["stage"] for st in s["stages"] if st["stage"] not in stage_names]
    growth = {}
    for name in stage_names:
        recs = [next((st for st in s["stages"] if st["stage"] == name and st.get("ok")), None) for s in sizes]
        # the simulation stages (B4, B5, analysis, report) work on one task: x = its frames
        against = "frames" if any(r is not None and r.get("frames") for r in recs) else "elements"
        pts = [(float(r["frames"]) if against == "frames" else e, r["seconds"])
               for e, r in zip(elements, recs, strict=True) if r is not None and r.get("seconds")]
        xs, ys = [x for x, _ in pts], [t for _, t in pts]
        fit = fit_exponent(xs, ys)
        if fit is not None:
            # the slope between the two largest sizes shows the top end, past fixed start-up costs
            top = math.log(ys[-1] / ys[-2]) / math.log(xs[-1] / xs[-2]) if xs[-1] > xs[-2] else fit[0]
            growth[name] = {"exponent": round(fit[0], 2), "r2": round(fit[1], 3),
                            "exponent_top": round(top, 2), "against": against,
                            "superlinear": fit[0] > SUPERLINEAR or top > SUPERLINEAR + 0.1}
    queries: dict[str, Any] = {}
    names = sorted(sizes[-1]["queries"].get("memory", {}))
    for q in names:
        secs = [s["queries"].get("memory", {}).get(q) for s in sizes]
        fit = fit_exponent([e for e, t in zip(elements, secs, strict=True) if t], [t for t in secs if t])
        largest = sizes[-1]["queries"]
        row: dict[str, Any] = {"memory_s": largest.get("memory", {}).get(q)}
        for other in ("oxigraph", "endpoint"):
            t = largest.get(other, {}).get(q)
            row[f"{other}_s"] = t
        if row["memory_s"] and row["oxigraph_s"]:
            row["rdflib_to_oxigraph"] = round(row["memory_s"] / row["oxigraph_s"], 1)
        if row["oxigraph_s"] and row["endpoint_s"]:
            row["oxigraph_to_endpoint"] = round(row["oxigraph_s"] / row["endpoint_s"], 2)
        if row["memory_s"] and row["endpoint_s"]:
            row["rdflib_to_endpoint"] = round(row["memory_s"] / row["endpoint_s"], 1)
        if fit is not None:
            row["exponent_rdflib"] = round(fit[0], 2)
        queries[q] = row
    totals = {}
    for backend in ("memory", "oxigraph", "endpoint"):
        totals[backend] = [round(sum(s["queries"].get(backend, {}).values()), 3) if s["queries"].get(backend)
                           else None for s in sizes]
    return {"growth": growth, "queries_at_largest_size": queries, "query_totals_s": totals}


def print_report(sizes: list[dict[str, Any]], analysis: dict[str, Any]) -> None:
    out = sys.stdout
    heads = [f"{s['storeys']}x{s['units_per_storey']}" for s in sizes]
    out.write("\n" + " " * 26 + "".join(f"{h:>18}" for h in heads) + "   exponent (all, top)\n")
    out.write(f"{'elements / frames':<26}" + "".join(f"{str(s['elements']) + ' / ' + str(s['frames']):>18}"
                                                   for s in sizes) + "\n")
    out.write(f"{'triples (scenario model)':<26}" + "".join(f"{s['triples']!s:>18}" for s in sizes) + "\n")
    names: list[str] = []
    for s in sizes:
        names += [st["stage"] for st in s["stages"] if st["stage"] not in names]
    for name in names:
        cells = []
        for s in sizes:
            st = next((x for x in s["stages"] if x["stage"] == name), None)
            if st is None:
                cells.append("-")
            elif not st.get("ok"):
                cells.append("FAILED")
            else:
                cells.append(f"{st['seconds']:.2f} s {st['peak_rss_mb']:.0f} MB")
        g = analysis["growth"].get(name)
        tail = (f"   {g['exponent']:.2f} {g['exponent_top']:.2f}{' superlinear' if g['superlinear'] else ''}"
                f"{' (per frame)' if g.get('against') == 'frames' else ''}" if g else "")
        out.write(f"{name:<26}" + "".join(f"{c:>18}" for c in cells) + tail + "\n")
    if any(s.get("simulation") for s in sizes):
        def sim(key: str, fmt: str) -> str:
            cells = [fmt.format(**s["simulation"]) if s.get("simulation", {}).get(key) is not None else "-"
                     for s in sizes]
            return "".join(f"{c:>18}" for c in cells)
        out.write(f"{'B5 installed / frames':<26}" + sim("installed", "{installed} / {frames}") + "\n")
        out.write(f"{'B5 simulated time':<26}" + sim("sim_time_s", "{sim_time_s:.0f} s") + "\n")
        out.write(f"{'real-time factor, B5':<26}" + sim("real_time_factor", "{real_time_factor:.0f}x") + "\n")
        out.write(f"{'real-time factor, B4+B5':<26}"
                  + sim("real_time_factor_b4_b5", "{real_time_factor_b4_b5:.0f}x") + "\n")
        out.write("(exponents marked 'per frame': against the simulated task's frames, not the building's "
                  "elements)\n")
    out.write("\nnamed queries at the largest size (s; ratios of times):\n")
    out.write(f"{'query':<30}{'rdflib':>9}{'oxigraph':>10}{'endpoint':>10}{'rdf:oxi':>9}{'oxi:ep':>8}"
              f"{'growth':>8}\n")
    for q, r in analysis["queries_at_largest_size"].items():
        def f(v: Any, fmt: str = ".4f") -> str:
            return format(v, fmt) if isinstance(v, int | float) else "-"
        out.write(f"{q:<30}{f(r.get('memory_s')):>9}{f(r.get('oxigraph_s')):>10}{f(r.get('endpoint_s')):>10}"
                  f"{f(r.get('rdflib_to_oxigraph'), '.1f'):>9}{f(r.get('oxigraph_to_endpoint'), '.2f'):>8}"
                  f"{f(r.get('exponent_rdflib'), '.2f'):>8}\n")
    t = analysis["query_totals_s"]
    out.write(f"all named queries, total s: rdflib {t['memory']}, oxigraph {t['oxigraph']}, "
              f"endpoint {t['endpoint']}\n")
    failed = [(f"{s['storeys']}x{s['units_per_storey']}", st["stage"], st.get("error"))
              for s in sizes for st in s["stages"] if not st.get("ok")]
    for size, stage, err in failed:
        out.write(f"FAILED {size} {stage}: {err}\n")


# ---- end to end ----------------------------------------------------------------------------------


def kbplanner_command() -> list[str]:
    """The ``kbplanner`` console script next to this Python, else ``python -m kbplanner``."""
    script = Path(sys.executable).parent / "kbplanner"
    return [str(script)] if script.is_file() else [sys.executable, "-m", "kbplanner"]


def _tail(path: Path, lines: int = 15) -> list[str]:
    text = path.read_text(encoding="utf-8", errors="replace") if path.is_file() else ""
    return text.splitlines()[-lines:]


def _read_json(path: Path) -> Any:
    return json.loads(path.read_text(encoding="utf-8")) if path.is_file() else None


def measure_end_to_end(storeys: int, units: int, work: Path, *, workers: int = END_TO_END_WORKERS,
                       timeout_s: float = CHILD_TIMEOUT_S) -> dict[str, Any]:
    """``kbplanner generate-building`` then ``kbplanner run --tasks all`` in ``work``, as subprocesses.

    Wall time, exit code, peak memory (largest process of the tree, workers included) and CPU time of
    each command; the pipeline's stage timings (``run_timings.json``); per scenario the tasks, installed /
    elements, simulated time, the simulation's wall time and real-time factor (``tasks/tasks.json``,
    ``tasks_timings.json``); whether the report was written and generate-to-report met the aim.
    """
    kb = kbplanner_command()
    project, out = work / "building", work / "run"
    env = dict(os.environ, PYTHONHASHSEED="0")
    gen_cmd = [*kb, "generate-building", "--storeys", str(storeys), "--units-per-storey", str(units),
               "--out", str(project), "--format", "json"]
    run_cmd = [*kb, "run", str(project), "--out", str(out), "--tasks", "all", "--workers", str(workers)]
    record: dict[str, Any] = {"storeys": storeys, "units_per_storey": units, "workers": workers,
                              "commands": [" ".join(gen_cmd), " ".join(run_cmd)],
                              "aim_s": END_TO_END_AIM_S}
    sys.stderr.write(f"end to end: {storeys} storeys x {units} units, kbplanner run --tasks all "
                     f"--workers {workers}\n")
    gen = run_measured(gen_cmd, log=work / "generate.log", timeout_s=timeout_s, env=env)
    record["generate"] = gen
    if gen["exit"] != 0:
        record["error"] = "generate-building failed"
        record["log_tail"] = _tail(work / "generate.log")
        return record
    text = (work / "generate.log").read_text(encoding="utf-8")
    built = json.loads(text[text.index("{"):])
    record["elements"], record["frames"] = built.get("elements"), built.get("frames")
    sys.stderr.write(f"  generate-building {gen['seconds']:9.2f} s  peak {gen['peak_rss_mb']:7.0f} MB\n")
    run = run_measured(run_cmd, log=work / "run.log", timeout_s=timeout_s, env=env)
    record["run"] = run
    sys.stderr.write(f"  kbplanner run     {run['seconds']:9.2f} s  peak {run['peak_rss_mb']:7.0f} MB"
                     f"{'' if run['exit'] in (0, 1) else '  FAILED (exit ' + str(run['exit']) + ')'}\n")
    record["total_s"] = round(gen["seconds"] + run["seconds"], 2)
    # exit 1 is a reported negative result (e.g. an element not installed), not a failure of the run
    if run["exit"] not in (0, 1):
        record["error"] = "kbplanner run failed"
        record["log_tail"] = _tail(work / "run.log")
    metrics = _read_json(out / "run_timings.json") or {}
    record["pipeline_stages"] = metrics.get("stages", [])
    record["pipeline_total_s"] = metrics.get("total_seconds")
    record["pipeline_main_peak_rss_mb"] = metrics.get("peak_rss_mb")
    scenarios: dict[str, Any] = {}
    for tasks_dir in sorted(out.glob("scenarios/*/tasks")):
        tasks = _read_json(tasks_dir / "tasks.json") or {}
        timings = _read_json(tasks_dir / "tasks_timings.json") or {}
        walls = sorted((timings.get("tasks") or {}).values())
        scenarios[tasks_dir.parent.name] = {
            "tasks": len(tasks.get("tasks", [])), "installed": tasks.get("installed"),
            "elements": tasks.get("elements"), "sim_time_s": tasks.get("sim_time_s"),
            "simulation_wall_s": timings.get("wall_s"), "workers": timings.get("workers"),
            "real_time_factor": timings.get("real_time_factor"),
            "task_wall_s_median": round(statistics.median(walls), 2) if walls else None,
            "task_wall_s_max": walls[-1] if walls else None,
        }
    record["scenarios"] = scenarios
    done = [v for v in scenarios.values() if v.get("installed") is not None]
    record["installed"] = sum(v["installed"] for v in done) if done else None
    record["elements_simulated"] = sum(v["elements"] or 0 for v in done) if done else None
    sim_s = sum(v["sim_time_s"] or 0.0 for v in done)
    record["sim_time_s"] = round(sim_s, 1) if done else None
    record["real_time_factor_end_to_end"] = round(sim_s / record["total_s"], 1) if done else None
    record["report_html"] = (out / "report.html").is_file()
    record["met_aim"] = bool(run["exit"] in (0, 1) and record["report_html"]
                             and record["total_s"] < END_TO_END_AIM_S)
    return record


def print_end_to_end(e2e: dict[str, Any]) -> None:
    out = sys.stdout
    out.write(f"\nend to end: {e2e['storeys']} storeys x {e2e['units_per_storey']} units "
              f"({e2e.get('elements')} elements, {e2e.get('frames')} frames), "
              f"kbplanner run --tasks all --workers {e2e['workers']}\n")
    out.write(f"{'step':<44}{'seconds':>10}{'peak MB':>10}{'CPU s':>10}\n")
    for key, label in (("generate", "kbplanner generate-building"), ("run", "kbplanner run")):
        r = e2e.get(key)
        if r is not None:
            failed = ("" if r["exit"] == 0 else "   exit 1: not every element installed" if r["exit"] == 1
                      and key == "run" else f"   FAILED (exit {r['exit']})")
            out.write(f"{label:<44}{r['seconds']:>10.1f}{r['peak_rss_mb']:>10.0f}{r['cpu_s']:>10.1f}{failed}\n")
    for st in e2e.get("pipeline_stages", []):
        label = f"  {st['stage']}" + (f" [{st['scenario']}]" if st.get("scenario") else "")
        out.write(f"{label:<44}{st['seconds']:>10.1f}{st['peak_rss_mb']:>10.0f}\n")
    for name, sc in e2e.get("scenarios", {}).items():
        out.write(f"{name}: {sc['tasks']} tasks, installed {sc['installed']} / {sc['elements']}, simulated "
                  f"{(sc['sim_time_s'] or 0) / 3600:.2f} h in {sc['simulation_wall_s'] or 0:.1f} s on "
                  f"{sc['workers']} workers: real-time factor {sc['real_time_factor']}x "
                  f"(wall per task: median {sc['task_wall_s_median']} s, max {sc['task_wall_s_max']} s)\n")
    if e2e.get("total_s") is not None:
        out.write(f"generate to report: {e2e['total_s']:.1f} s (aim < {e2e['aim_s']:.0f} s: "
                  f"{'met' if e2e.get('met_aim') else 'NOT met'}); simulated time / that: "
                  f"{e2e.get('real_time_factor_end_to_end')}x; report.html "
                  f"{'written' if e2e.get('report_html') else 'MISSING'}\n")
    if e2e.get("error"):
        out.write(f"FAILED end to end: {e2e['error']}\n")
        out.write("".join(f"  | {x}\n" for x in e2e.get("log_tail", [])))


# ---- main ----------------------------------------------------------------------------------------


def child(args: argparse.Namespace) -> int:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from _stages import measure_size

    storeys, units = args.child
    result = measure_size(storeys, units, Path(args.workdir), endpoint=args.endpoint, repeats=args.repeats,
                          simulate_max_frames=args.simulate_max_frames)
    write_json(Path(args.out), result, indent=1)
    return 0


def measure_sizes(args: argparse.Namespace) -> list[dict[str, Any]]:
    """Every size in its own child process (``--child``), with the SPARQL endpoint when wanted."""
    sizes: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory(prefix="kbplanner-bench-") as tmp:
        work = Path(tmp)
        server = None
        if not args.no_endpoint:
            try:
                (work / "oxigraph").mkdir()
                server = Server(work / "oxigraph")
            except RuntimeError as exc:
                sys.stderr.write(f"no SPARQL endpoint: {exc}\n")
        try:
            for storeys, units in args.sizes:
                sys.stderr.write(f"{storeys} storeys x {units} units\n")
                out = work / f"size-{storeys}x{units}.json"
                cmd = [sys.executable, str(Path(__file__).resolve()), "--child", f"{storeys}x{units}",
                       "--workdir", str(work), "--out", str(out), "--repeats", str(args.repeats)]
                if server is not None:
                    cmd += ["--endpoint", f"sparql+{server.url}"]
                cmd += ["--simulate-max-frames", str(args.simulate_max_frames)]
                env = dict(os.environ, PYTHONHASHSEED="0")
                proc = subprocess.run(cmd, env=env, timeout=CHILD_TIMEOUT_S, check=False)
                if proc.returncode != 0 or not out.is_file():
                    sys.stderr.write(f"size {storeys}x{units} failed (exit {proc.returncode})\n")
                    continue
                sizes.append(json.loads(out.read_text(encoding="utf-8")))
                shutil.rmtree(work / f"building-{storeys}x{units}", ignore_errors=True)
                shutil.rmtree(work / f"sim-{storeys}x{units}", ignore_errors=True)
        finally:
            if server is not None:
                server.stop()
    return sizes


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--sizes", nargs="*", type=parse_size, default=[parse_size(s) for s in DEFAULT_SIZES],
                        help=f"building sizes STOREYSxUNITS or N (default: {' '.join(DEFAULT_SIZES)}; "
                             "none: the end-to-end run only)")
    parser.add_argument("--no-endpoint", action="store_true", help="skip the SPARQL endpoint backend")
    parser.add_argument("--simulate-max-frames", type=int, default=150, metavar="N",
                        help="run B4, B5, analysis and report on the simulation task (one storey) of sizes "
                             "with at most N frames on it (default 150: every default size; 0: never)")
    parser.add_argument("--end-to-end", type=parse_size, default=parse_size(DEFAULT_END_TO_END),
                        metavar="SxU",
                        help=f"building of the end-to-end run: generate-building, then kbplanner run "
                             f"--tasks all --workers {END_TO_END_WORKERS} (default {DEFAULT_END_TO_END}: "
                             "1,120 frames)")
    parser.add_argument("--no-end-to-end", action="store_true", help="skip the end-to-end run")
    parser.add_argument("--repeats", type=int, default=2, help="best of N for the per-query backend times")
    parser.add_argument("--out", type=Path, default=RESULTS, help="JSON results file")
    parser.add_argument("--child", type=parse_size, help=argparse.SUPPRESS)
    parser.add_argument("--workdir", help=argparse.SUPPRESS)
    parser.add_argument("--endpoint", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        return child(args)
    if not args.sizes and args.no_end_to_end:
        parser.error("nothing to measure: give --sizes or leave the end-to-end run on")
    timer = Timer()
    sizes = measure_sizes(args) if args.sizes else []
    e2e = None
    if not args.no_end_to_end:
        with tempfile.TemporaryDirectory(prefix="kbplanner-e2e-") as tmp:
            storeys, units = args.end_to_end
            e2e = measure_end_to_end(storeys, units, Path(tmp))
    if args.sizes and not sizes and e2e is None:
        sys.stderr.write("no size completed\n")
        return 1
    analysis = analyse(sizes) if sizes else None
    if sizes and analysis is not None:
        print_report(sizes, analysis)
    if e2e is not None:
        print_end_to_end(e2e)
    write_json(args.out, {
        "benchmark": "scale",
        **machine_info(("python", "machine", "cpus")),
        "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
        "seconds": round(timer.elapsed(), 1),
        "sizes": sizes,
        "analysis": analysis,
        "end_to_end": e2e,
    }, indent=1)
    sys.stdout.write(f"\nwrote {args.out} ({timer.elapsed():.0f} s)\n")
    failed = (args.sizes and len(sizes) < len(args.sizes)) or (e2e is not None and e2e.get("error"))
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
