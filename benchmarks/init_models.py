"""``kbplanner import-ifc``, ``init`` and ``run`` on IFC models as a new user runs them (issue 10's check).

For each model (the Duplex of the case study and ``../shared/data/ifc/public/*.ifc`` when present, the
ifcopenshell-written fixtures of ``tests/`` with ``--fixtures``, or the files given):

- ``kbplanner import-ifc`` (the CLI, in a child process): exit code, traceback or not, and the doors,
  windows and walls skipped (``skipped.json``) against the count in the file;
- ``init_project`` into a temporary folder: walls in the file and chosen, frames and their masses, the
  reasons the other walls were not chosen (counted by kind), the scenarios written, the notes, the
  seconds;
- with ``--run``: ``kbplanner run PROJECT --out RUN`` (the CLI, in a child process, the project's own
  seed): exit code, traceback or not, seconds, and per scenario the frames installed, the reasons of
  the others (counted by kind) and the number of elements not installed without a reason (must be 0).

Prints a line per model and writes ``benchmarks/results/init_models.json`` after each model. With
``--doc docs/own_building.md`` the table of section 7 (between ``<!-- init-models:begin -->`` and
``<!-- init-models:end -->``) is rendered from the JSON (``--doc`` alone, without models, only
re-renders it from the existing JSON).

    .venv/bin/python benchmarks/init_models.py [IFC ...] [--fixtures] [--no-public] [--run] [--append]
    .venv/bin/python benchmarks/init_models.py --render-only --doc docs/own_building.md
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

from _common import REPO, RESULTS_DIR, Timer, write_json

RESULTS = RESULTS_DIR / "init_models.json"
DUPLEX = REPO / "data" / "case_study" / "model" / "Duplex_A_20110907.ifc"
PUBLIC = REPO.parent / "shared" / "data" / "ifc" / "public"
BEGIN, END = "<!-- init-models:begin -->", "<!-- init-models:end -->"
COUNTED = ("IfcDoor", "IfcWindow", "IfcWall")  # the classes issue 10 says import-ifc must not drop


def _kind(reason: str) -> str:
    return reason.split(" (", 1)[0].split(":", 1)[0]


def _run_kind(reason: str) -> str:
    """``step 28 (install frame): installed pose out of reach from 0 ...: no base pose ...`` -> kind."""
    m = re.match(r"step \d+ \(([^)]*)\): ([^:(]*)", reason)
    return f"{m.group(1)}: {m.group(2).strip()}" if m else _kind(reason)


def _plan_kinds(failures: list[Any]) -> dict[str, int]:
    """The reasons of the frames a checked init's plan cannot install, counted by kind."""
    return dict(sorted(Counter(_run_kind(f.reason) for f in failures).items()))


def _cli(args: list[str]) -> tuple[int, str, str, float]:
    env = {**os.environ, "PYTHONPATH": str(REPO / "src")}
    with Timer() as t:
        p = subprocess.run([sys.executable, "-m", "kbplanner", *args], capture_output=True, text=True,
                           env=env, check=False)
    return p.returncode, p.stdout, p.stderr, t.seconds


def _traceback(text: str) -> bool:
    return "Traceback (most recent call last)" in text


def _counts_in_file(ifc: Path) -> dict[str, int]:
    import ifcopenshell

    f = ifcopenshell.open(str(ifc))
    return {c: len(f.by_type(c)) for c in COUNTED}  # by_type includes subtypes (IfcWallStandardCase)


def measure_import(ifc: Path, tmp: Path) -> dict[str, Any]:
    code, out, err, seconds = _cli(["import-ifc", str(ifc), "--out", str(tmp / "import")])
    skipped: list[dict[str, Any]] = []
    report = tmp / "import" / "skipped.json"
    if report.is_file():
        skipped = json.loads(report.read_text(encoding="utf-8"))["skipped"]
    dropped = Counter(s.get("ifc_class", "?") for s in skipped
                      if str(s.get("ifc_class", "")).startswith(COUNTED))
    return {"exit": code, "traceback": _traceback(out + err), "in_file": _counts_in_file(ifc),
            "skipped": len(skipped), "doors_windows_walls_skipped": dict(sorted(dropped.items())),
            "seconds": round(seconds, 2)}


def measure_run(project: Path, tmp: Path) -> dict[str, Any]:
    out_dir = tmp / "run"
    code, out, err, seconds = _cli(["run", str(project), "--out", str(out_dir)])
    scenarios: dict[str, Any] = {}
    for metrics in sorted(out_dir.glob("scenarios/*/simulation/metrics.json")):
        data = json.loads(metrics.read_text(encoding="utf-8"))
        elements = data["per_element"]
        failed = [e for e in elements if e["outcome"] != "installed"]
        scenarios[metrics.parents[1].name] = {
            "installed": data["totals"]["installed"], "elements": len(elements),
            "reasons": dict(sorted(Counter(_run_kind(e["reason"]) for e in failed if e["reason"]).items())),
            "without_reason": sum(1 for e in failed if not e["reason"]),
            "sim_time_s": data["totals"]["sim_time_s"],
        }
    last = (err.strip().splitlines() or [""])[-1]
    return {"exit": code, "traceback": _traceback(out + err), "seconds": round(seconds, 1),
            "scenarios": scenarios, "message": last if code == 2 or not scenarios else ""}


def measure(ifc: Path, *, run: bool = False, label: str | None = None, run_max_frames: int = 40,
            max_walls: int = 8, check_max_frames: int = 20, keep: Path | None = None) -> dict[str, Any]:
    """import-ifc, init (and ``run``) on ``ifc`` in a temporary folder; returns the figures.

    init runs twice: without the plan check (``--no-plan-check``: the seconds of reading and proposing)
    and, for projects of at most ``check_max_frames`` frames, as a user runs it (each scenario's storage
    proposals planned, the best kept: ``plan_check``); ``run`` runs on the checked project. ``keep``: the
    folders (import, project, checked, run) are written into ``keep/<file stem>`` and kept, not into a
    temporary folder.
    """
    from kbplanner.scale.project_init import init_project

    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name) if keep is None else keep / ifc.stem
        tmp.mkdir(parents=True, exist_ok=True)
        imported = measure_import(ifc, tmp)
        with Timer() as t:  # the first placements, unchecked: how long reading and proposing take
            r = init_project(ifc, tmp / "project", max_walls=max_walls, check_plan=False)
        masses = [f.mass_kg for f in r.frames]
        row: dict[str, Any] = {
            "file": label or ifc.name, "schema": _schema(ifc), "import": imported, "max_walls": max_walls,
            "written": r.written, "storey": r.storey, "entrance": r.entrance,
            "walls": len(r.walls), "walls_chosen": len(r.chosen), "frames": len(r.frames),
            "frame_mass_kg": [round(min(masses), 1), round(max(masses), 1)] if masses else None,
            "not_chosen": dict(sorted(Counter(_kind(w.reason) for w in r.walls if not w.chosen).items())),
            "scenarios": r.scenarios, "notes": r.notes, "seconds": round(t.seconds, 2),
        }
        project = tmp / "project"
        if r.written and len(r.frames) <= check_max_frames:  # as a user runs it: proposals planned (B1-B4)
            with Timer() as tc:
                checked = init_project(ifc, tmp / "checked", max_walls=max_walls)
            row["plan_check"] = {
                "seconds": round(tc.seconds, 1), "scenarios": list(checked.scenarios),
                "plans": {k: {"installable": c.installable, "total": c.total,
                              "reasons": _plan_kinds(c.failures)} for k, c in checked.checks.items()},
            }
            project = tmp / "checked"
        if run and r.written and len(r.frames) <= run_max_frames:
            row["run"] = measure_run(project, tmp)
        elif run and r.written:
            row["run_skipped"] = f"{len(r.frames)} frames > --run-max-frames {run_max_frames}"
    return row


def _schema(ifc: Path) -> str:
    import ifcopenshell

    return str(ifcopenshell.open(str(ifc)).schema)


def fixtures(folder: Path) -> list[tuple[str, Path, int]]:
    """Write the ifcopenshell fixtures of tests/ into ``folder``; (label, path, init's --max-walls) each."""
    sys.path.insert(0, str(REPO / "tests"))
    from ifc_factory import write_test_building
    from ifc_office import write_office
    from ifc_traits import write_length_unit, write_mass_unit, write_traits, write_unnamed_sets
    from ifc_wild import write_geometry_kinds, write_placed, write_without_storeys

    writers: list[tuple[str, Callable[[Path], Any], int]] = [
        ("small office, IFC2X3 as ArchiCAD writes it (tests/ifc_office.py: 2 x 2 offices, 2 storeys)",
         lambda p: write_office(p, schema="IFC2X3", rooms_per_side=2), 2),
        ("test building (tests/ifc_factory.py)", lambda p: write_test_building(p, schema="IFC4"), 8),
        ("test building, mm", lambda p: write_test_building(p, schema="IFC2X3", unit_mm=True), 8),
        ("unnamed psets (tests/ifc_traits.py)", write_unnamed_sets, 8),
        ("split level, door without host, storey without spaces", write_traits, 8),
        ("no storeys (tests/ifc_wild.py)", write_without_storeys, 8),
        ("rotated 30 degrees", lambda p: write_placed(p, "rotated"), 8),
        ("geometry kinds", write_geometry_kinds, 8),
        ("office (2 x 6 offices, 2 storeys)", lambda p: write_office(p, schema="IFC4"), 8),
        ("office, IFC2X3 as ArchiCAD writes it (2 x 6 offices)",
         lambda p: write_office(p, schema="IFC2X3"), 8),
        ("gram mass unit", lambda p: write_mass_unit(p, "gram", 13630.0), 8),
        ("foot length unit", lambda p: write_length_unit(p, "FOOT"), 8),
        ("georeferenced, IfcMapConversion", lambda p: write_placed(p, "georeferenced"), 8),
        ("site at survey coordinates, mm", lambda p: write_placed(p, "site-far"), 8),
        ("storeys at survey coordinates", lambda p: write_placed(p, "storeys-far"), 8),
    ]
    out = []
    for n, (label, write, max_walls) in enumerate(writers):
        path = folder / f"fixture_{n:02d}.ifc"
        write(path)
        out.append((label if max_walls == 8 else f"{label}, --max-walls {max_walls}", path, max_walls))
    return out


def _cell_run(row: dict[str, Any]) -> str:
    run = row.get("run")
    if run is None:
        return f"not run: {row['run_skipped']}" if "run_skipped" in row else "-"
    parts = []
    for name, s in run["scenarios"].items():
        text = f"{name.removeprefix('storage-')}: {s['installed']}/{s['elements']}"
        if s["reasons"]:
            text += " (" + "; ".join(f"{n} {k}" for k, n in s["reasons"].items()) + ")"
        if s["without_reason"]:
            text += f", {s['without_reason']} without a reason"
        parts.append(text)
    tb = ", traceback" if run["traceback"] else ""
    return f"exit {run['exit']}{tb}, {run['seconds']:.0f} s; " + "; ".join(parts) if parts else \
        f"exit {run['exit']}{tb}: {run['message']}"


def render(rows: list[dict[str, Any]]) -> str:
    lines = ["Generated by `benchmarks/init_models.py` from `benchmarks/results/init_models.json` (do not "
             "edit by hand).", "",
             "| model | import-ifc: doors, windows, walls in file / skipped | init | walls chosen / frames "
             "| scenarios (the plan of each: installable / frames) "
             "| run (installed / frames, reasons of the others by kind) |",
             "| --- | --- | --- | --- | --- | --- |"]
    for row in rows:
        imp = row["import"]
        counts = ", ".join(str(imp["in_file"][c]) for c in COUNTED)
        dropped = sum(imp["doors_windows_walls_skipped"].values())
        tb = ", traceback" if imp["traceback"] else ""
        init = f"exit {0 if row['written'] else 1}, {row['seconds']:.0f} s"
        chosen = f"{row['walls_chosen']} of {row['walls']} / {row['frames']}"
        if not row["written"]:
            chosen += " (" + "; ".join(f"{n} {k}" for k, n in row["not_chosen"].items()) + ")"
        scen = ", ".join(s.removeprefix("storage-") for s in row["scenarios"]) or "-"
        check = row.get("plan_check")
        if check is not None:
            init += f"; with the plan check {check['seconds']:.0f} s"
            scen = ", ".join(f"{k.removeprefix('storage-')} (plan: {c['installable']}/{c['total']})"
                             for k, c in check["plans"].items()) or "-"
        lines.append(f"| {row['file']} ({row['schema']}) | {counts} / {dropped} (exit {imp['exit']}{tb}) | "
                     f"{init} | {chosen} | {scen} | {_cell_run(row)} |")
    return "\n".join(lines)


def _row_key(line: str) -> str:
    """A table row's first cell (the model and its schema), which names the row."""
    return line.split("|")[1].strip() if line.startswith("| ") else ""


def kept_rows(old: str, new: str) -> str:
    """``new`` (a rendered table) with the rows of ``old`` (the document's table) that ``new`` does not
    measure kept, in the document's order: a pass over some models updates their rows only."""
    new_lines = new.splitlines()
    fresh = {_row_key(line): line for line in new_lines[4:] if _row_key(line)}
    out = new_lines[:4]
    seen = set()
    for line in old.strip().splitlines()[4:]:
        key = _row_key(line)
        if key:
            out.append(fresh.get(key, line))
            seen.add(key)
    out += [line for key, line in fresh.items() if key not in seen]
    return "\n".join(out)


def update_doc(doc: Path, rows: list[dict[str, Any]], *, keep: bool = False) -> None:
    """Render ``rows`` into ``doc``'s block; ``keep``: the rows of models not in ``rows`` stay as they
    are (:func:`kept_rows`)."""
    text = doc.read_text(encoding="utf-8")
    if BEGIN not in text or END not in text:
        raise SystemExit(f"{doc}: no {BEGIN} ... {END} block to replace")
    head, rest = text.split(BEGIN, 1)
    old, tail = rest.split(END, 1)
    table = kept_rows(old, render(rows)) if keep else render(rows)
    doc.write_text(f"{head}{BEGIN}\n{table}\n{END}{tail}", encoding="utf-8")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("ifc", nargs="*", type=Path)
    parser.add_argument("--fixtures", action="store_true", help="also the ifcopenshell fixtures of tests/")
    parser.add_argument("--no-public", action="store_true", help="not the Duplex and the public models")
    parser.add_argument("--run", action="store_true", help="also `kbplanner run` on each project (slow)")
    parser.add_argument("--run-max-frames", type=int, default=40,
                        help="run only projects with at most this many frames (default 40)")
    parser.add_argument("--only", help="with --fixtures: only these fixtures, by index (0 = the small "
                                       "office), comma-separated (to measure them in several processes)")
    parser.add_argument("--check-max-frames", type=int, default=20,
                        help="init with the plan check only on projects of at most this many frames "
                             "(default 20)")
    parser.add_argument("--append", action="store_true",
                        help="keep the other models' rows of the JSON (a model measured again is replaced)")
    parser.add_argument("--doc", type=Path, help="render the table into this document (section 7)")
    parser.add_argument("--render-only", action="store_true", help="only render --doc from the JSON")
    parser.add_argument("--keep-doc-rows", action="store_true",
                        help="with --doc: keep the document's rows of the models not measured (or merged) "
                             "now, as they are")
    parser.add_argument("--results", type=Path, default=RESULTS, help=f"the JSON (default {RESULTS})")
    parser.add_argument("--keep", type=Path, help="write each model's folders (import, project, checked, "
                                                  "run) into KEEP/<file stem> and keep them")
    parser.add_argument("--merge", type=Path, action="append", default=[],
                        help="with --render-only: rows of another results JSON (a row with a run wins)")
    args = parser.parse_args()
    if args.render_only:
        if args.doc is None:
            parser.error("--render-only needs --doc")
        merged: dict[str, dict[str, Any]] = {}
        for results in (args.results, *args.merge):
            for row in json.loads(results.read_text(encoding="utf-8"))["models"]:
                if row["file"] not in merged or "run" in row:
                    merged[row["file"]] = row
        update_doc(args.doc, list(merged.values()), keep=args.keep_doc_rows)
        return 0
    rows: list[dict[str, Any]] = []
    if args.append and args.results.is_file():
        rows = json.loads(args.results.read_text(encoding="utf-8"))["models"]
    with tempfile.TemporaryDirectory() as fixture_dir:
        files: list[tuple[str | None, Path, int]] = [(None, p, 8) for p in args.ifc]
        if args.fixtures:
            written = list(fixtures(Path(fixture_dir)))
            only = {int(i) for i in args.only.split(",")} if args.only else set(range(len(written)))
            files += [f for i, f in enumerate(written) if i in only]
        if not args.ifc and not args.no_public:
            files += [*((None, p, 8) for p in sorted(PUBLIC.glob("*.ifc"))), (None, DUPLEX, 8)]
        for label, ifc, max_walls in files:
            if not ifc.is_file():
                print(f"{ifc}: not present, skipped", file=sys.stderr)
                continue
            row = measure(ifc, run=args.run, label=label, run_max_frames=args.run_max_frames,
                          max_walls=max_walls, check_max_frames=args.check_max_frames, keep=args.keep)
            rows = [r for r in rows if r["file"] != row["file"]] + [row]
            print(f"{row['file']}: {'written' if row['written'] else 'nothing written (exit 1)'}, storey "
                  f"{row['storey']}, {row['walls_chosen']}/{row['walls']} walls, {row['frames']} frames, "
                  f"scenarios {row['scenarios']}, {row['seconds']} s; import {row['import']}", flush=True)
            for kind, n in row["not_chosen"].items():
                print(f"  {n:>4} not chosen: {kind}")
            if "run" in row:
                print(f"  run: {_cell_run(row)}", flush=True)
            write_json(args.results, {"models": rows})
    if args.doc is not None:
        update_doc(args.doc, rows, keep=args.keep_doc_rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
