"""``kbplanner init`` before/after B4's stop hook (issue 10): wall and CPU seconds, same proposals kept.

Runs ``kbplanner init IFC --task frame-interior-walls --out P`` (the CLI, with the plan check, in a child
process: wall seconds and the CPU seconds of its process tree, :func:`_common.run_measured`) on the code of
a git ref (``--before``, exported with ``git archive``) and on this tree, one after the other, per model:
the fixtures of ``tests/`` chosen with ``--fixtures`` (indices of ``benchmarks/init_models.py``'s list;
default 4 and 7, the split level and the geometry kinds, whose first placements do not install every
frame) and the Duplex with ``--duplex``. Compares the written projects: every file equal but the comment
lines of the scenarios (which list each proposal tried, and now which were abandoned) means the same
proposals kept, in the same order; prints per model the seconds, what each scenario's plan installs, and
the proposals abandoned, and writes ``benchmarks/results/init_stop.json``. With ``--doc
docs/own_building.md`` the table between ``<!-- init-stop:begin -->`` and ``<!-- init-stop:end -->`` is
rendered from the JSON (``--render-only``: from the existing JSON, without running anything).

    .venv/bin/python benchmarks/init_stop.py [--before main] [--fixtures 4,7] [--duplex] [--doc DOC]
    .venv/bin/python benchmarks/init_stop.py --render-only --doc docs/own_building.md
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from _common import REPO, RESULTS_DIR, machine_info, run_measured, write_json

RESULTS = RESULTS_DIR / "init_stop.json"
BEGIN, END = "<!-- init-stop:begin -->", "<!-- init-stop:end -->"
MARKER = ".kbplanner-run"  # the output folder's marker: the command, which names the folder (not compared)
DUPLEX = REPO.parent / "shared" / "data" / "ifc" / "Duplex_A_20110907.ifc"


def _export(ref: str, into: Path) -> tuple[Path, str]:
    sha = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", ref], check=True,
                         capture_output=True, text=True).stdout.strip()
    archive = subprocess.run(["git", "-C", str(REPO), "archive", ref], check=True, capture_output=True).stdout
    into.mkdir(parents=True)
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into / "src", sha


def _files(project: Path) -> dict[str, list[str]]:
    """Relative path -> lines, the comment lines of the scenario files left out (and the folder's
    :data:`MARKER`)."""
    out = {}
    for p in sorted(project.rglob("*")):
        if not p.is_file() or ".kbplanner-cache" in p.parts or p.name == MARKER:
            continue
        rel = str(p.relative_to(project))
        try:
            lines = p.read_text(encoding="utf-8").splitlines()
        except UnicodeDecodeError:
            lines = [p.read_bytes().hex()]
        if rel.startswith("scenarios/"):
            lines = [line for line in lines if not line.startswith("#")]
        out[rel] = lines
    return out


def _comments(project: Path) -> dict[str, list[str]]:
    return {p.name: [line[2:] for line in p.read_text(encoding="utf-8").splitlines()
                     if line.startswith("# proposal ") or line.startswith("# the kept proposal")]
            for p in sorted((project / "scenarios").glob("*.ttl"))}


def _init(src: Path, ifc: Path, out: Path, log: Path) -> dict[str, Any]:
    env = dict(os.environ, PYTHONPATH=str(src))
    cmd = [sys.executable, "-m", "kbplanner", "init", str(ifc), "--task", "frame-interior-walls",
           "--out", str(out)]
    measured = run_measured(cmd, log=log, timeout_s=7200.0, env=env)
    text = log.read_text(encoding="utf-8", errors="replace")
    measured["plans"] = dict(re.findall(r"scenario (storage-\w+): \d+ frame storage\(s\); plan \(B1-B4\): "
                                        r"(\d+ of \d+)", text))
    measured["traceback"] = "Traceback (most recent call last)" in text
    measured["tried"] = _comments(out) if (out / "scenarios").is_dir() else {}
    return measured


def bench(label: str, ifc: Path, before_src: Path, tmp: Path) -> dict[str, Any]:
    row: dict[str, Any] = {"model": label}
    projects = {}
    for which, src in (("before", before_src), ("after", REPO / "src")):
        folder = tmp / which / ifc.stem
        folder.mkdir(parents=True)
        projects[which] = folder / "p"  # the same name in both: files may name the project
        row[which] = _init(src, ifc, projects[which], folder / "init.log")
        r = row[which]
        print(f"{label} {which}: exit {r['exit']}, {r['seconds']:.0f} s wall, {r['cpu_s']:.0f} s CPU, plans "
              f"{r['plans']}", flush=True)
    a, b = _files(projects["after"]), _files(projects["before"])
    row["same_files"] = a == b
    row["differing"] = sorted(k for k in set(a) | set(b) if a.get(k) != b.get(k))
    row["abandoned"] = sum(line.count("abandoned after") for lines in row["after"]["tried"].values()
                           for line in lines)
    print(f"{label}: same files but the scenarios' comments: {row['same_files']} {row['differing']}; "
          f"{row['abandoned']} check(s) abandoned; wall {row['before']['seconds']:.0f} -> "
          f"{row['after']['seconds']:.0f} s, CPU {row['before']['cpu_s']:.0f} -> "
          f"{row['after']['cpu_s']:.0f} s", flush=True)
    for name, lines in row["after"]["tried"].items():
        for line in lines:
            print(f"    {name}: {line}")
    return row


def render(result: dict[str, Any]) -> str:
    """The before/after table of ``result`` (the JSON this script writes)."""
    lines = [f"Generated by `benchmarks/init_stop.py` from `benchmarks/results/init_stop.json` (do not edit "
             f"by hand); before = `{result['before']}`, 1-minute load average "
             f"{min(result['load_average_1min']):.1f}-{max(result['load_average_1min']):.1f} on "
             f"{result['machine'].get('cpus')} cores.", "",
             "| model | init wall before / after | init CPU before / after | plans (after) "
             "| checks abandoned | same project written (but the scenarios' comments) |",
             "| --- | --- | --- | --- | --- | --- |"]
    for r in result["models"]:
        b, a = r["before"], r["after"]
        plans = ", ".join(f"{k.removeprefix('storage-')} {v}" for k, v in a["plans"].items()) or "-"
        differing = [d for d in r["differing"] if d != MARKER]
        same = "no: " + ", ".join(differing) if differing else "yes"
        lines.append(f"| {r['model']} | {b['seconds']:.0f} / {a['seconds']:.0f} s | {b['cpu_s']:.0f} / "
                     f"{a['cpu_s']:.0f} s ({a['cpu_s'] / b['cpu_s']:.2f}x) | {plans} | {r['abandoned']} | "
                     f"{same} |")
    return "\n".join(lines)


def update_doc(doc: Path, result: dict[str, Any]) -> None:
    text = doc.read_text(encoding="utf-8")
    if BEGIN not in text or END not in text:
        raise SystemExit(f"{doc}: no {BEGIN} ... {END} block to replace")
    head, rest = text.split(BEGIN, 1)
    tail = rest.split(END, 1)[1]
    doc.write_text(f"{head}{BEGIN}\n{render(result)}\n{END}{tail}", encoding="utf-8")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--before", default="main", help="git ref of the baseline (default main)")
    ap.add_argument("--fixtures", default="4,7",
                    help="indices of benchmarks/init_models.py's fixtures (default 4,7); '' for none")
    ap.add_argument("--duplex", action="store_true", help=f"also the Duplex ({DUPLEX})")
    ap.add_argument("--results", type=Path, default=RESULTS, help=f"the JSON (default {RESULTS})")
    ap.add_argument("--doc", type=Path, help="render the table into this document (docs/own_building.md)")
    ap.add_argument("--render-only", action="store_true", help="only render --doc from the JSON")
    args = ap.parse_args()
    if args.render_only:
        if args.doc is None:
            ap.error("--render-only needs --doc")
        update_doc(args.doc, json.loads(args.results.read_text(encoding="utf-8")))
        return 0
    sys.path.insert(0, str(REPO / "benchmarks"))
    from init_models import fixtures

    load = [os.getloadavg()[0]]
    rows: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        before_src, sha = _export(args.before, tmp / "before-tree")
        models: list[tuple[str, Path]] = []
        if args.fixtures:
            wanted = {int(i) for i in args.fixtures.split(",")}
            models += [(label, path) for i, (label, path, _walls) in enumerate(fixtures(tmp / "fixtures"))
                       if i in wanted]
        if args.duplex:
            models.append(("Duplex_A_20110907.ifc", DUPLEX))
        for label, ifc in models:
            rows.append(bench(label, ifc, before_src, tmp))
            load.append(os.getloadavg()[0])
            result = {"before": f"{args.before} ({sha})", "machine": machine_info(),
                      "load_average_1min": load, "models": rows}
            write_json(args.results, result)
    if args.doc is not None and rows:
        update_doc(args.doc, result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
