"""The scale benchmark (issue 6): every pipeline stage on generated buildings, one apartment to 10 storeys.

For each size (``SxU`` = S storeys x U units per storey, or ``N`` = N x N) a fresh Python process
(so that peak memory is per size) generates the building and runs every stage that exists
(``benchmarks/_stages.py``): import, requirements, validation, named queries, world, occupancy map,
planning of one storey and of every storey, B4 + B5 on small sizes (the simulated-to-wall time
ratio), and the named queries again on pyoxigraph and on a SPARQL endpoint (an Oxigraph server this
script starts on 127.0.0.1 and stops). It prints a table (seconds and peak memory per stage), fits the
growth exponent of each stage against the number of building elements (least squares on log-log),
flags stages that grow faster than linearly, gives the per-query time ratios rdflib : pyoxigraph and
embedded : endpoint, and writes ``benchmarks/results/bench.json``.

    .venv/bin/python benchmarks/run.py                      # default sizes (make bench), ~12 min on 2 cores
    .venv/bin/python benchmarks/run.py --sizes 1x1 2x2 4x4  # a quick run
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path
from typing import Any

from _common import RESULTS_DIR, Timer, machine_info, write_json

RESULTS = RESULTS_DIR / "bench.json"
DEFAULT_SIZES = ("1x1", "2x2", "4x4", "7x7", "10x10")
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
        secs = [next((st["seconds"] for st in s["stages"] if st["stage"] == name and st.get("ok")), None)
                for s in sizes]
        xs = [e for e, t in zip(elements, secs, strict=True) if t]
        ys = [t for t in secs if t]
        fit = fit_exponent(xs, ys)
        if fit is not None:
            # the slope between the two largest sizes shows the top end, past fixed start-up costs
            top = math.log(ys[-1] / ys[-2]) / math.log(xs[-1] / xs[-2]) if xs[-1] > xs[-2] else fit[0]
            growth[name] = {"exponent": round(fit[0], 2), "r2": round(fit[1], 3),
                            "exponent_top": round(top, 2),
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
                if g else "")
        out.write(f"{name:<26}" + "".join(f"{c:>18}" for c in cells) + tail + "\n")
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


# ---- main ----------------------------------------------------------------------------------------


def child(args: argparse.Namespace) -> int:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from _stages import measure_size

    storeys, units = args.child
    result = measure_size(storeys, units, Path(args.workdir), endpoint=args.endpoint, repeats=args.repeats,
                          simulate_max_frames=args.simulate_max_frames)
    write_json(Path(args.out), result, indent=1)
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--sizes", nargs="+", type=parse_size, default=[parse_size(s) for s in DEFAULT_SIZES],
                        help=f"building sizes STOREYSxUNITS or N (default: {' '.join(DEFAULT_SIZES)})")
    parser.add_argument("--no-endpoint", action="store_true", help="skip the SPARQL endpoint backend")
    parser.add_argument("--simulate-max-frames", type=int, default=20, metavar="N",
                        help="run B4 + B5 (the executor) on the simulation task of sizes with at most N "
                             "frames on it (default 20: the 1x1 building; 0: never)")
    parser.add_argument("--repeats", type=int, default=2, help="best of N for the per-query backend times")
    parser.add_argument("--out", type=Path, default=RESULTS, help="JSON results file")
    parser.add_argument("--child", type=parse_size, help=argparse.SUPPRESS)
    parser.add_argument("--workdir", help=argparse.SUPPRESS)
    parser.add_argument("--endpoint", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        return child(args)
    timer = Timer()
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
        finally:
            if server is not None:
                server.stop()
    if not sizes:
        sys.stderr.write("no size completed\n")
        return 1
    analysis = analyse(sizes)
    print_report(sizes, analysis)
    write_json(args.out, {
        "benchmark": "scale",
        **machine_info(("python", "machine", "cpus")),
        "seconds": round(timer.elapsed(), 1),
        "sizes": sizes,
        "analysis": analysis,
    }, indent=1)
    sys.stdout.write(f"\nwrote {args.out} ({timer.elapsed():.0f} s)\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
