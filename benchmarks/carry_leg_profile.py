"""B4's carry-leg check, counted (issue 14, item 2): which questions it asks, how often, on which parts.

Not a pipeline step: a measurement. Runs B4 (``refine_plan``) in this process for each project and
scenario given (the project loaded, the world, plan and occupancy map built as ``kbplanner plan`` does;
the refined-plan cache is not used) with counting wrappers around the carry-leg check: per carry-leg
check (``CarryReach``, one per grid, pick base pose and installed pose) the install base poses asked
(``way``: 2 driven directly, 1 only by turning the load, 0 walled off), how many of them needed a new
part of a window (``PartJoin``, its cells) or a whole window labelled, and the CPU seconds of B4, of the
check, of the parts' free maps and labels and of the joint components. Prints a summary per scenario
and writes ``benchmarks/results/carry_leg_profile.json`` (or ``--out``).

Usage: .venv/bin/python benchmarks/carry_leg_profile.py [--project DIR --scenario S ...] [--seed N]
(default: the case study's storage-outside and storage-inside; ``--project`` and ``--scenario`` pair up)
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from _common import REPO, RESULTS_DIR, machine_info, write_json


def _profile(project_dir: Path, scenario: str, seed: int) -> dict[str, Any]:
    import kbplanner.planning.carry_parts as cp
    import kbplanner.planning.carry_reach as cr
    import kbplanner.world.cspace_join as cj
    import kbplanner.world.footprint as fpm
    from kbplanner.planning.manipulation import refine_plan
    from kbplanner.planning.planner import plan_task
    from kbplanner.project import Project
    from kbplanner.world.build import build_world
    from kbplanner.world.maps import storey_map

    project = Project.load(str(project_dir), scenario=scenario)
    world = build_world(project, project.world_date(None), None)
    plan = plan_task(project, None, None, world=world)
    grid = storey_map(world).grid
    cpu: dict[str, float] = {}
    checks: list[dict[str, Any]] = []
    current: list[dict[str, Any]] = []

    def timed(name: str, fn: Callable[..., Any],
              after: Callable[[Any, tuple[Any, ...], float], None] | None = None) -> Callable[..., Any]:
        depth = [0]

        def wrapped(*args: Any, **kwargs: Any) -> Any:
            if depth[0]:
                return fn(*args, **kwargs)
            depth[0] += 1
            c0 = time.process_time()
            try:
                got = fn(*args, **kwargs)
            finally:
                depth[0] -= 1
                dt = time.process_time() - c0
                cpu[name] = cpu.get(name, 0.0) + dt
            if after is not None:
                after(got, args, dt)
            return got
        return wrapped

    def on_reach(_got: Any, args: tuple[Any, ...], _dt: float) -> None:
        reach = args[0]
        checks.append({"start": [round(reach.start.x, 2), round(reach.start.y, 2)],
                       "around": [round(reach.around[0], 2), round(reach.around[1], 2)],
                       "ways": {"2": 0, "1": 0, "0": 0}, "new_parts": 0, "part_cells": 0,
                       "windows_labelled": 0, "cpu_s": 0.0})
        current[:] = [checks[-1]]

    def on_way(got: Any, _args: tuple[Any, ...], dt: float) -> None:
        if current:
            current[0]["ways"][str(got)] += 1
            current[0]["cpu_s"] = round(current[0]["cpu_s"] + dt, 4)

    def on_part(_got: Any, args: tuple[Any, ...], _dt: float) -> None:
        part = args[0]
        if current:
            current[0]["new_parts"] += 1
            current[0]["part_cells"] += (part.y1 - part.y0) * (part.x1 - part.x0)

    cr.CarryReach.__init__ = timed("carry-leg checks made", cr.CarryReach.__init__, on_reach)
    cr.CarryReach.way = timed("carry-leg check (way)", cr.CarryReach.way, on_way)
    cr.CarryReach.turn_route = timed("turning the load (turn_route)", cr.CarryReach.turn_route)
    level = timed("whole windows labelled", cr.CarryReach._level)

    def counted_level(self: Any, i: int) -> Any:
        if current and i not in self._levels:
            current[0]["windows_labelled"] += 1
        return level(self, i)

    cr.CarryReach._level = counted_level
    cj.PartJoin.__init__ = timed("parts (PartJoin)", cj.PartJoin.__init__, on_part)
    if hasattr(cj, "part_free"):
        cj.part_free = timed("parts' free maps", cj.part_free)
    fpm.ConfigurationSpace._labels_and_roots = timed(
        "labellings", fpm.ConfigurationSpace._labels_and_roots)
    joint = timed("joint components", cp.joint_components)
    cp.joint_components = joint
    cr.joint_components = joint
    c0 = time.process_time()
    refine_plan(plan, world, seed=seed, grid=grid)
    b4 = time.process_time() - c0
    ways = {k: sum(c["ways"][k] for c in checks) for k in ("2", "1", "0")}
    return {"project": str(project_dir), "scenario": scenario, "seed": seed, "b4_cpu_s": round(b4, 3),
            "cpu_s": {k: round(v, 3) for k, v in sorted(cpu.items())}, "checks": len(checks),
            "ways": ways, "new_parts": sum(c["new_parts"] for c in checks),
            "windows_labelled": sum(c["windows_labelled"] for c in checks),
            "ways_without_new_part": sum(sum(c["ways"].values()) for c in checks if c["new_parts"] == 0),
            "per_check": checks}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--project", type=Path, action="append", help="project folder (default: the case study)")
    ap.add_argument("--scenario", action="append",
                    help="scenario per project (default: both storage scenarios)")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "carry_leg_profile.json")
    ap.add_argument("--one", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    scenarios = args.scenario or ["storage-outside", "storage-inside"]
    projects = args.project or [REPO / "data" / "case_study"] * len(scenarios)
    if len(projects) != len(scenarios):
        ap.error("give one --scenario per --project")
    if args.one is not None:  # the child: one scenario, its row to the file named
        write_json(args.one, _profile(projects[0], scenarios[0], args.seed))
        return 0
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n, (project, scenario) in enumerate(zip(projects, scenarios, strict=True)):
            row_file = Path(tmp) / f"{n}.json"  # a fresh process per scenario: no space kept from another
            subprocess.run([sys.executable, __file__, "--project", str(project), "--scenario", scenario,
                            "--seed", str(args.seed), "--one", str(row_file)], check=True)
            rows.append(json.loads(row_file.read_text()))
    for row in rows:
        scenario, project = row["scenario"], Path(row["project"])
        print(f"{scenario} ({project.name}): B4 {row['b4_cpu_s']} s CPU; {row['checks']} carry-leg checks, "
              f"install base poses asked {sum(row['ways'].values())} (way 2/1/0: {row['ways']['2']}/"
              f"{row['ways']['1']}/{row['ways']['0']}), {row['new_parts']} new parts, "
              f"{row['windows_labelled']} whole windows labelled", file=sys.stderr)
        for name, sec in row["cpu_s"].items():
            print(f"    {name}: {sec} s", file=sys.stderr)
    write_json(args.out, {"machine": machine_info(), "seed": args.seed, "runs": rows})
    print(f"wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
