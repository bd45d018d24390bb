"""Path quality before/after (issue 14, item 3): the case study's ``kbplanner simulate`` run by a
baseline's sources and by this tree's, in one run of this script, compared by ``metrics.json``
``"path_quality"`` (docs/simulation.md): frame time over the kinematic lower bound and driven over
shortest collision-free path, median and max per run, with the simulated time, frames installed, collisions
and the minimum separation to the workers; over several seeds (``--seeds 1-20``) also the median and max
of those per-run figures over the seeds, and a table of the legs (navigation steps) whose driven / shortest
is over ``--leg-over`` (default 1.15) with what they did (carry modes, replans, stops).

The baseline is a git ref (default ``main``) exported with ``git archive``; both run
``kbplanner simulate data/case_study --scenario S --seed N --out DIR --no-keyframes`` with the shared
virtualenv (the export of ``bench_simspeed.py``). ``--determinism`` runs this tree a second time per
scenario and checks that ``trajectories.csv``, ``events.jsonl`` and ``metrics.json`` are byte-identical.
``--jobs N`` runs N commands at a time; ``--keep DIR`` keeps the run folders under DIR (``before/S-N``,
``after/S-N``) and takes a folder already there when it was written by the same sources (the baseline's,
or this tree's committed ones: git trees of src, data, ontology, shapes), so the baseline's runs can be
made once.

Usage: .venv/bin/python benchmarks/bench_path_quality.py [--before REF] [--scenario S ...] [--seed N |
--seeds 1-20] [--jobs N] [--keep DIR] [--determinism]. Prints a table (Markdown, as in docs/scale.md) and
the frames' times, and writes benchmarks/results/path_quality.json (or --out); ``--print FILE`` prints them
again from such a file.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from _common import REPO, RESULTS_DIR, machine_info, run_measured, write_json
from bench_simspeed import _export

SAME = ("trajectories.csv", "events.jsonl", "metrics.json")
STAMP = "bench_source.txt"  # in a kept run folder: the commit whose sources wrote it


def _run(src: Path, scenario: str, seed: int, out: Path, log: Path) -> dict[str, Any]:
    """``kbplanner simulate`` of the case study by the sources ``src`` (no key frames: the figures are
    those of ``metrics.json``, which key frames do not change), measured."""
    env = dict(os.environ, PYTHONPATH=str(src))
    cmd = [sys.executable, "-m", "kbplanner", "simulate", str(src.parent / "data" / "case_study"),
           "--scenario", scenario, "--seed", str(seed), "--out", str(out), "--no-keyframes"]
    measured = run_measured(cmd, log=log, timeout_s=1800.0, env=env)
    if not (out / "metrics.json").is_file():
        tail = log.read_text()[-2000:]
        raise SystemExit(f"{' '.join(cmd)} wrote no run (exit {measured['exit']}):\n{tail}")
    return {"command_s": measured["seconds"], "exit": measured["exit"], "cpu_s": measured["cpu_s"]}


def _legs(metrics: dict[str, Any], over: float) -> list[dict[str, Any]]:
    """The run's navigation steps whose driven / shortest is over ``over``, with what they did."""
    legs = []
    for n in metrics["navigation"]:
        short = n.get("shortest_m")
        if n.get("outcome") != "succeeded" or not short or float(short) <= 0.05:
            continue
        ratio = float(n["driven_m"]) / float(short)
        if ratio <= over:
            continue
        modes = n.get("carry_modes") or []
        kind = "NV-2" if modes else "NV-1"
        what = ["load turned (" + "+".join(modes) + ")" if len(modes) > 1 else "",
                f"{n['replans']} replan(s)" if n.get("replans") else "",
                f"{n['stops']} stop(s)" if n.get("stops") else "",
                f"{n['slowdowns']} slow-down(s)" if n.get("slowdowns") else ""]
        legs.append({"step": n["step"], "element": n["element"], "action": n["action"], "kind": kind,
                     "planned_m": round(float(n["path_length_m"]), 3), "driven_m": n["driven_m"],
                     "shortest_m": short, "ratio": round(ratio, 3),
                     "what": ", ".join(w for w in what if w) or "planned path"})
    return legs


def _figures(run: Path, measured: dict[str, Any], over: float) -> dict[str, Any]:
    metrics = json.loads((run / "metrics.json").read_text())
    q = metrics["path_quality"]
    totals = metrics["totals"]
    return {"time_over_lower_bound": q["time_over_lower_bound"],
            "driven_over_shortest": q["driven_over_shortest"], "per_element": q["per_element"],
            "sim_time_s": totals["sim_time_s"], "installed": totals["installed"],
            "elements": totals["elements"], "driven_m": totals["driven_m"],
            "collisions": metrics["safety"]["collisions"],
            "min_separation_m": metrics["safety"]["min_separation_m"],
            "legs_over": _legs(metrics, over),
            "command_s": measured.get("command_s"),
            "exit": measured.get("exit")}


SOURCES = ("src", "data", "ontology", "shapes")  # what a run reads: a kept run is of the same trees


def _source_id(ref: str | None) -> str | None:
    """The git trees of ``SOURCES`` at ``ref`` (None: this tree's ``HEAD``, or None where they have
    uncommitted changes): a commit that changes only docs or benchmarks keeps the runs."""
    def git(*args: str) -> str:
        return subprocess.run(["git", "-C", str(REPO), *args], check=True, capture_output=True,
                              text=True).stdout.strip()
    if ref is None and git("status", "--porcelain", "--untracked-files=no", "--", *SOURCES):
        return None
    return " ".join(git("rev-parse", f"{ref or 'HEAD'}:{d}") for d in SOURCES)


def _one(src: Path, source: str | None, scenario: str, seed: int, out: Path, over: float
         ) -> dict[str, Any]:
    """One run (or the kept folder ``out`` when ``source`` wrote it) and its figures."""
    stamp = out / STAMP
    if source is not None and stamp.is_file() and stamp.read_text().strip() == source \
            and (out / "metrics.json").is_file():
        return _figures(out, {"kept": True}, over)
    out.parent.mkdir(parents=True, exist_ok=True)
    measured = _run(src, scenario, seed, out, out.with_name(out.name + ".log"))
    if source is not None:
        stamp.write_text(source + "\n")
    return _figures(out, measured, over)


def bench(before_src: Path, scenarios: list[str], seeds: list[int], determinism: bool, runs: Path,
          jobs: int, sources: dict[str, str | None], over: float, only: str | None = None
          ) -> list[dict[str, Any]]:
    """Every (scenario, seed) run by both trees (``only``: by that one, no rows); a row per pair with the
    figures of each."""
    trees = {"before": before_src, "after": REPO / "src"}
    work = [(s, n, label) for s in scenarios for n in seeds for label in trees if only in (None, label)]
    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        done = list(pool.map(lambda w: _one(trees[w[2]], sources[w[2]], w[0], w[1],
                                            runs / w[2] / f"{w[0]}-{w[1]}", over), work))
    got = {w: f for w, f in zip(work, done, strict=True)}
    if only is not None:
        return []
    rows = []
    for s in scenarios:
        for n in seeds:
            row: dict[str, Any] = {"scenario": s, "seed": n, "before": got[(s, n, "before")],
                                   "after": got[(s, n, "after")]}
            if determinism:
                again = runs / "after-again" / f"{s}-{n}"
                again.parent.mkdir(parents=True, exist_ok=True)
                _run(REPO / "src", s, n, again, again.with_name(again.name + ".log"))
                row["after_identical_on_repeat"] = all(
                    (runs / "after" / f"{s}-{n}" / f).read_bytes() == (again / f).read_bytes() for f in SAME)
            rows.append(row)
    return rows


def _pair(q: dict[str, Any]) -> str:
    return f"{q['median']} / {q['max']}"


def _over_seeds(rows: list[dict[str, Any]], label: str, key: str) -> str:
    """Median of the runs' medians / max of the runs' maxima over the seeds."""
    meds = [r[label][key]["median"] for r in rows if r[label][key]["median"] is not None]
    maxs = [r[label][key]["max"] for r in rows if r[label][key]["max"] is not None]
    if not meds:
        return "-"
    return f"{round(statistics.median(meds), 3)} / {round(max(maxs), 3)}"


def _summary(rows: list[dict[str, Any]]) -> list[str]:
    """Per scenario, over the seeds: the figures' median / max, collisions, worst separation."""
    text = ["| scenario | seeds | frame time / lower bound, median / max | driven / shortest, median / max | "
            "runs with driven / shortest max > 1.3 | collisions | worst min separation | simulated, sum | "
            "runs simulated longer / shorter | runs with a smaller min separation |",
            "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for s in dict.fromkeys(r["scenario"] for r in rows):
        mine = [r for r in rows if r["scenario"] == s]
        parts = []
        for key in ("time_over_lower_bound", "driven_over_shortest"):
            parts.append(f"{_over_seeds(mine, 'before', key)} -> {_over_seeds(mine, 'after', key)}")
        high = [sum(1 for r in mine if (r[lab]["driven_over_shortest"]["max"] or 0) > 1.3)
                for lab in ("before", "after")]
        coll = [sum(int(r[lab]["collisions"]) for r in mine) for lab in ("before", "after")]
        seps = [min((r[lab]["min_separation_m"] for r in mine if r[lab]["min_separation_m"] is not None),
                    default=None) for lab in ("before", "after")]
        sums = [sum(float(r[lab]["sim_time_s"]) for r in mine) for lab in ("before", "after")]
        dt = [float(r["after"]["sim_time_s"]) - float(r["before"]["sim_time_s"]) for r in mine]
        longer, shorter = sum(1 for d in dt if d > 1e-9), sum(1 for d in dt if d < -1e-9)
        pairs = [(r["before"]["min_separation_m"], r["after"]["min_separation_m"]) for r in mine]
        closer = sum(1 for b, a in pairs if None not in (b, a) and float(a) < float(b) - 1e-9)
        text.append(f"| {s} | {len(mine)} | {parts[0]} | {parts[1]} | "
                    f"{high[0]} -> {high[1]} of {len(mine)} | "
                    f"{coll[0]} -> {coll[1]} | {seps[0]} -> {seps[1]} m | "
                    f"{sums[0]:,.1f} -> {sums[1]:,.1f} s | "
                    f"{longer} / {shorter} of {len(mine)} | {closer} of {len(mine)} |")
    return text


def report(out: dict[str, Any]) -> str:
    """The Markdown tables, the legs over the threshold and the per-frame lines of a result."""
    rows = out["scenarios"]
    seeds = sorted({r["seed"] for r in rows})
    text = [f"Seed(s) {', '.join(map(str, seeds)) or '?'}; before = {out['before']}, after = this tree.\n",
            "| scenario | seed | frame time / lower bound, median / max | driven / shortest, median / max | "
            "simulated | installed | collisions | min separation |",
            "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        b, a = r["before"], r["after"]
        tb, ta = _pair(b["time_over_lower_bound"]), _pair(a["time_over_lower_bound"])
        db, da = _pair(b["driven_over_shortest"]), _pair(a["driven_over_shortest"])
        text.append(f"| {r['scenario']} | {r['seed']} | {tb} -> {ta} | {db} -> {da} | "
                    f"{b['sim_time_s']:,.1f} -> "
                    f"{a['sim_time_s']:,.1f} s | {b['installed']} -> {a['installed']} of {a['elements']} | "
                    f"{b.get('collisions', '?')} -> {a.get('collisions', '?')} | "
                    f"{b.get('min_separation_m', '?')} -> {a.get('min_separation_m', '?')} m |")
    if len(seeds) > 1:
        text += ["", "Over the seeds (median of the runs' medians / max of the runs' maxima):", "",
                 *_summary(rows)]
    over = out.get("leg_over", 1.15)
    for label in ("before", "after"):
        text += ["", f"Legs with driven / shortest over {over}, {label}:", "",
                 "| scenario | seed | step | element | kind | planned | driven | shortest | ratio | what |",
                 "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
        for r in rows:
            for g in r[label].get("legs_over", []):
                text.append(f"| {r['scenario']} | {r['seed']} | {g['step']} | {g['element'][:8]} | "
                            f"{g['kind']} | "
                            f"{g['planned_m']} | {g['driven_m']} | {g['shortest_m']} | {g['ratio']} | "
                            f"{g['what']} |")
    for r in rows if len(seeds) == 1 else []:
        before = {f["global_id"]: f for f in r["before"]["per_element"]}
        text.append(f"\n{r['scenario']}, per frame: time (s) before -> after (over the lower bound)")
        for f in r["after"]["per_element"]:
            g = before.get(f["global_id"])
            was = f"{g['duration_s']} -> " if g else ""
            ratio = f"{g['time_over_lower_bound']} -> " if g else ""
            text.append(f"  {f['global_id']}: {was}{f['duration_s']} ({ratio}{f['time_over_lower_bound']})")
    for r in rows:
        if "after_identical_on_repeat" in r:
            text.append(f"  {r['scenario']} seed {r['seed']}: this tree's outputs identical on a second run: "
                        f"{'yes' if r['after_identical_on_repeat'] else 'NO'}")
    text.append(f"\nload average {out['load_average_start'][0]:.2f} -> {out['load_average_end'][0]:.2f}")
    return "\n".join(text) + "\n"


def _seeds(spec: str) -> list[int]:
    """``"1-20"``, ``"1,2,7"`` or a mix."""
    out: list[int] = []
    for part in spec.split(","):
        lo, _, hi = part.partition("-")
        out += list(range(int(lo), int(hi) + 1)) if hi else [int(lo)]
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", default="main", help="git ref of the baseline (default main)")
    ap.add_argument("--scenario", action="append", help="scenario(s) (default: both storage scenarios)")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--seeds", help="several seeds, e.g. 1-20 (instead of --seed)")
    ap.add_argument("--jobs", type=int, default=1, help="commands run at a time")
    ap.add_argument("--keep", type=Path, help="keep the run folders here (and take those of the same commit)")
    ap.add_argument("--only", choices=("before", "after"),
                    help="with --keep: make only these runs (kept for a later run), report nothing")
    ap.add_argument("--leg-over", type=float, default=1.15, help="list legs with driven / shortest over this")
    ap.add_argument("--determinism", action="store_true", help="run this tree twice, compare the outputs")
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "path_quality.json")
    ap.add_argument("--print", type=Path, dest="print_file",
                    help="print the figures of a result file, run nothing")
    args = ap.parse_args(argv)
    if args.print_file:
        sys.stdout.write(report(json.loads(args.print_file.read_text())))
        return 0
    scenarios = args.scenario or ["storage-outside", "storage-inside"]
    seeds = _seeds(args.seeds) if args.seeds else [args.seed]
    sources = {"before": _source_id(args.before), "after": _source_id(None)}
    load_before = list(os.getloadavg())
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        before_src = _export(args.before, tmp)
        runs = args.keep.resolve() if args.keep else tmp / "runs"
        rows = bench(before_src, scenarios, seeds, args.determinism, runs, args.jobs, sources, args.leg_over,
                     args.only if args.keep else None)
    if args.only and args.keep:
        sys.stdout.write(f"made the {args.only} runs under {args.keep}\n")
        return 0
    out = {"machine": machine_info(("python", "cpus", "platform")), "before": args.before,
           "before_commit": sources["before"], "after_commit": sources["after"], "leg_over": args.leg_over,
           "load_average_start": load_before, "load_average_end": list(os.getloadavg()), "scenarios": rows}
    write_json(args.out, out)
    sys.stdout.write(report(out) + f"wrote {args.out}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
