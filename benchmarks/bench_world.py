"""Benchmark of A6, the world at a date: world build, occupancy map, exports and PyBullet load.

Cases: the case study (both scenarios, at the manifest's simulation date) and generated projects
(tests/world_project_factory.py) of growing size. Each case runs in a fresh subprocess so that its peak
resident memory (``ru_maxrss``) is its own. Prints a table and writes ``benchmarks/results/world.json``.

    .venv/bin/python benchmarks/bench_world.py [--quick]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

from _common import REPO, RESULTS_DIR, machine_info, peak_rss_mb, run_child_json, write_json

RESULTS = RESULTS_DIR / "world.json"
CASE_STUDY = REPO / "data" / "case_study"
GENERATED = {"generated-2x2": (2, 2), "generated-6x8": (6, 8), "generated-12x16": (12, 16)}


def run_case(project_dir: Path, scenario: str | None, date: str | None) -> dict[str, object]:
    """Build, map, export and load one world in this process; returns the figures."""
    import pybullet as p

    from kbplanner.model.dates import parse_date
    from kbplanner.project import Project
    from kbplanner.simulation.sim_world import load_world, settle
    from kbplanner.world.build import build_world
    from kbplanner.world.exports import export_world
    from kbplanner.world.maps import storey_map

    t0 = time.perf_counter()
    project = Project.load(project_dir, scenario=scenario)
    t1 = time.perf_counter()
    at = parse_date(date or str(project.manifest.simulation["date"]))
    world = build_world(project, at)
    t2 = time.perf_counter()
    m = storey_map(world)
    t3 = time.perf_counter()
    with tempfile.TemporaryDirectory() as out:
        export = export_world(world, Path(out))
        t4 = time.perf_counter()
        export_mb = sum(f.stat().st_size for f in export.files) / 1e6
    client = p.connect(p.DIRECT)
    sim = load_world(world, client)
    moved = settle(sim, seconds=1.0)
    p.disconnect(client)
    client = p.connect(p.DIRECT)
    visual = load_world(world, client, visuals=True)
    p.disconnect(client)
    ny, nx = m.grid.shape
    return {
        "project_load_s": round(t1 - t0, 3),
        "world_build_s": round(t2 - t1, 3),
        "map_s": round(t3 - t2, 3),
        "exports_s": round(t4 - t3, 3),
        "pybullet_load_s": round(sim.load_seconds, 3),
        "pybullet_load_with_visuals_s": round(visual.load_seconds, 3),
        "peak_rss_mb": round(peak_rss_mb(), 1),
        "static_elements": len(world.static),
        "static_groups": len(world.static_groups()),
        "task_elements": len(world.task_elements),
        "bodies": sim.body_count,
        "triangles": sim.triangles,
        "map_cells": nx * ny,
        "map_occupied_pct": round(100 * (1 - m.grid.free_fraction), 2),
        "export_files": len(export.files),
        "export_mb": round(export_mb, 2),
        "task_elements_moved_in_1s_m": round(moved, 4),
    }


def in_subprocess(project_dir: Path, scenario: str | None, date: str | None) -> dict[str, object]:
    cmd = [sys.executable, __file__, "--one", str(project_dir)]
    if scenario:
        cmd += ["--scenario", scenario]
    if date:
        cmd += ["--date", date]
    return run_child_json(cmd)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="case study and smallest generated project")
    parser.add_argument("--one", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--scenario", help=argparse.SUPPRESS)
    parser.add_argument("--date", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        print(json.dumps(run_case(args.one, args.scenario, args.date)))
        return 0

    sys.path.insert(0, str(REPO / "tests"))
    from world_project_factory import DATE, make_world_project

    cases: list[tuple[str, Path, str | None, str | None]] = []
    if (CASE_STUDY / "project.toml").is_file():
        cases += [("case-study outside", CASE_STUDY, "storage-outside", None),
                  ("case-study inside", CASE_STUDY, "storage-inside", None)]
    work = Path(tempfile.mkdtemp(prefix="kbplanner-bench-world-"))
    for name, (storeys, bays) in GENERATED.items():
        if args.quick and name != "generated-2x2":
            continue
        make_world_project(work / name, storeys=storeys, bays=bays)
        cases.append((name, work / name, "stored", DATE))

    rows = []
    for name, path, scenario, date in cases:
        in_subprocess(path, scenario, date)  # warm: the IFC import is cached per project
        figures = {"case": name, **in_subprocess(path, scenario, date)}
        rows.append(figures)
        print(f"{name:<20} build {figures['world_build_s']:>6} s  map {figures['map_s']:>6} s  "
              f"exports {figures['exports_s']:>6} s  pybullet {figures['pybullet_load_s']:>6} s  "
              f"peak {figures['peak_rss_mb']:>7} MB  {figures['static_elements']} static in "
              f"{figures['bodies']} bodies, {figures['triangles']} triangles")
    write_json(RESULTS, {"machine": machine_info(), "cases": rows})
    print(f"wrote {RESULTS.relative_to(REPO)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
