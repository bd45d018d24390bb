"""Issue 14 at a glance: each of its aims against the figure the benchmarks measured, in one table.

Not a pipeline step and no measurement of its own: it reads the JSON that the benchmark scripts wrote
and the run folders of a seed study, and prints which aim is met by which figure and from which file,
so that the table in docs/scale.md is the code's, not retyped.

Sources (each optional; an aim without its source is listed as "not measured"):

- ``--startup FILE``: ``bench_startup.py``'s JSON (``--version`` and ``--help`` < 0.3 s; ``info`` and
  ``query`` on a cached project < 1.5 s; this tree's, ``after``, wall seconds);
- ``--first FILE`` and ``--kept FILE``: ``bench_simspeed.py`` JSON of a first run (``--first-run``: the
  files earlier runs keep removed) and of a repeated run (the default) of the case study's
  ``simulate``: the simulation step >= 300x real time per CPU second, the command >= 100x by the wall
  clock, per scenario;
- ``--scale10 FILE``: ``bench_scale10.py``'s JSON, the whole 10 x 8 building end to end < 180 s wall;
- ``--study DIR``: a ``kbplanner compare --seeds`` folder; every run with monitoring on
  (``metrics.json`` ``safety.monitoring == "ssm"``) gives its path quality: frame time / kinematic
  lower bound and driven / shortest collision-free path, per run median and max; the aim (median <=
  1.15, max <= 1.3) is taken per scenario as the median of the runs' medians and the largest value of
  any run.

    python benchmarks/issue14_status.py --startup F --first F --kept F --scale10 F --study DIR [--out F]

Prints a Markdown table and writes ``benchmarks/results/issue14_status.json`` (or ``--out``).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path
from typing import Any

from _common import RESULTS_DIR, write_json

Row = dict[str, Any]


def _read(path: Path | None) -> dict[str, Any] | None:
    if path is None:
        return None
    try:
        data = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise SystemExit(f"{path}: cannot read it as JSON ({exc}); give a file the benchmark script "
                         "wrote") from None
    if not isinstance(data, dict):
        raise SystemExit(f"{path}: not a benchmark result (a JSON object); give a file the benchmark "
                         "script wrote")
    return data


def _row(item: str, aim: str, measured: float | None, limit: float, *, below: bool, unit: str,
         source: Path | None, note: str = "") -> Row:
    """One aim: ``measured`` against ``limit`` (``below``: measured must be under it, else at least it)."""
    met = None if measured is None else (measured < limit if below else measured >= limit)
    return {"item": item, "aim": aim, "measured": measured, "unit": unit, "met": met,
            "source": str(source) if source else None, "note": note}


def startup_rows(path: Path | None) -> list[Row]:
    data = _read(path)
    aims = (("--version", "`kbplanner --version` < 0.3 s", 0.3),
            ("--help", "`kbplanner --help` < 0.3 s", 0.3),
            ("info (cached)", "`info` on a cached project < 1.5 s", 1.5),
            ("query storeys (cached)", "`query` on a cached project < 1.5 s", 1.5))
    rows = {r["command"]: r for r in (data or {}).get("rows", [])}
    out = []
    for command, aim, limit in aims:
        wall = rows.get(command, {}).get("after_wall_s")
        out.append(_row(f"start-up: {command}", aim, wall, limit, below=True, unit="s wall", source=path))
    return out


def simspeed_rows(path: Path | None, run: str) -> list[Row]:
    data = _read(path)
    out = []
    for r in (data or {}).get("scenarios", []) or [{"scenario": "case study"}]:
        after = r.get("after", {})
        rounds = r.get("rounds")
        note = f"{rounds} round(s), median" if rounds else ""
        name = r["scenario"]
        out.append(_row(f"{run} `simulate` {name}: step", "simulation step >= 300x real time (per CPU s)",
                        after.get("x_real_time_simulation_cpu"), 300.0, below=False, unit="x", source=path,
                        note=note))
        out.append(_row(f"{run} `simulate` {name}: command", "`simulate` command >= 100x real time (wall)",
                        after.get("x_real_time_command"), 100.0, below=False, unit="x", source=path,
                        note=note))
    return out


def scale_rows(path: Path | None) -> list[Row]:
    data = _read(path)
    after = (data or {}).get("after", {})
    load = (data or {}).get("load_average_start")
    note = f"load average {load[0]:.1f} at the start" if load else ""
    return [_row("10 x 8 building, `kbplanner run`", "whole 10 x 8 building end to end < 3 min on 2 cores",
                 after.get("run_s"), 180.0, below=True, unit="s wall", source=path, note=note)]


def study_runs(folder: Path) -> dict[str, list[dict[str, Any]]]:
    """The path quality of every monitored run under ``folder``, by scenario (sorted by run folder)."""
    runs: dict[str, list[dict[str, Any]]] = {}
    for metrics in sorted(folder.glob("*/*/metrics.json")):
        m = json.loads(metrics.read_text())
        if m.get("safety", {}).get("monitoring") != "ssm" or not m.get("path_quality"):
            continue
        runs.setdefault(metrics.parent.parent.name, []).append(m["path_quality"])
    return runs


def study_rows(folder: Path | None) -> list[Row]:
    if folder is None:
        return [_row("path quality", "frame time / lower bound median <= 1.15, max <= 1.3", None, 1.15,
                     below=False, unit="", source=None)]
    if not folder.is_dir():
        raise SystemExit(f"{folder}: no such folder; give the --out folder of `kbplanner compare --seeds`")
    runs = study_runs(folder)
    if not runs:
        raise SystemExit(f"{folder}: no run with monitoring on and path quality (metrics.json); give "
                         "the --out folder of `kbplanner compare --seeds`")
    out = []
    for scenario, quality in sorted(runs.items()):
        n = len(quality)
        for key, label in (("time_over_lower_bound", "frame time / lower bound"),
                           ("driven_over_shortest", "driven / shortest path")):
            medians = [q[key]["median"] for q in quality if q.get(key, {}).get("count")]
            maxima = [q[key]["max"] for q in quality if q.get(key, {}).get("count")]
            over = sum(1 for v in maxima if v > 1.3)
            out.append(_row(f"{scenario}: {label}, median", "median <= 1.15",
                            round(statistics.median(medians), 3) if medians else None, 1.15 + 1e-9,
                            below=True, unit="", source=folder,
                            note=f"median of {len(medians)} runs' medians"))
            out.append(_row(f"{scenario}: {label}, max", "max <= 1.3", max(maxima) if maxima else None,
                            1.3 + 1e-9, below=True, unit="", source=folder,
                            note=f"largest of {n} runs; {over} run(s) over 1.3"))
    return out


def machine_speeds(paths: list[Path | None]) -> dict[str, float]:
    """Each source's machine speed as its benchmark recorded it (``machine.python_loop_1e6_s``, from
    ``_common.loop_s``; files written before session 15 have none), by file name."""
    out: dict[str, float] = {}
    for path in paths:
        data = _read(path)
        speed = (data or {}).get("machine", {}).get("python_loop_1e6_s")
        if path is not None and isinstance(speed, (int, float)):
            out[path.name] = float(speed)
    return out


def markdown(rows: list[Row]) -> str:
    lines = ["| what | aim | measured | met | from |", "| --- | --- | ---: | --- | --- |"]
    for r in rows:
        value = "not measured" if r["measured"] is None else f"{r['measured']:g} {r['unit']}".strip()
        met = {True: "yes", False: "**no**", None: "-"}[r["met"]]
        src = Path(r["source"]).name if r["source"] else "-"
        note = f" ({r['note']})" if r["note"] else ""
        lines.append(f"| {r['item']} | {r['aim']} | {value}{note} | {met} | `{src}` |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--startup", type=Path, help="bench_startup.py JSON")
    ap.add_argument("--first", type=Path, help="bench_simspeed.py --first-run JSON")
    ap.add_argument("--kept", type=Path, help="bench_simspeed.py JSON (a repeated run, the default mode)")
    ap.add_argument("--scale10", type=Path, help="bench_scale10.py JSON")
    ap.add_argument("--study", type=Path, help="`kbplanner compare --seeds` output folder")
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "issue14_status.json")
    args = ap.parse_args(argv)
    rows = (startup_rows(args.startup) + simspeed_rows(args.first, "first run:")
            + simspeed_rows(args.kept, "repeated:") + scale_rows(args.scale10) + study_rows(args.study))
    speeds = machine_speeds([args.startup, args.first, args.kept, args.scale10])
    sys.stdout.write(markdown(rows))
    if speeds:
        listed = ", ".join(f"`{k}` {v:g} s" for k, v in speeds.items())
        sys.stdout.write("\nMachine speed when measured (`python_loop_1e6_s`, the CPU seconds of a fixed "
                         f"Python loop; lower is quicker): {listed}\n")
    write_json(args.out, {"benchmark": "issue14_status", "rows": rows, "python_loop_1e6_s": speeds})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
