"""Simulation benchmark (B4 + B5): the case study's two storage scenarios, end to end.

For each scenario: load the project, build the world and map, plan (B1-B3), refine (B4) and simulate
(B5, key frames off so only the simulation is timed); reports simulated time / wall time of B5, the
OMPL planning time of each navigation (from the run's timing.json), B5's CPU time and the real-time
factor on it (steadier than wall time on a busy machine), each navigation's path length
against the grid yardstick (:func:`kbplanner.simulation.grid_yardstick.grid_shortest_path_length`:
8-connected Dijkstra over cells where the footprint fits at some yaw, then line-of-sight shortcuts, on the map
with the elements installed before that step; the robot's footprint for NV-1, the narrow carry for
NV-2, on a 10 m window around start and goal), the time spent planning worker motions, and the
process's peak memory.

Usage: .venv/bin/python benchmarks/bench_simulation.py [--scenario S ...] [--seed N]
Prints a table and writes benchmarks/results/simulation.json.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from _common import REPO, RESULTS_DIR, machine_info, peak_rss_mb, write_json

from kbplanner.model.dates import parse_date
from kbplanner.planning.base_poses import element_polygon, mark_polygon
from kbplanner.planning.carry import transform
from kbplanner.planning.manipulation import refine_plan
from kbplanner.planning.planner import plan_task
from kbplanner.project import Project
from kbplanner.simulation.executor import simulate
from kbplanner.simulation.grid_yardstick import grid_shortest_path_length
from kbplanner.simulation.skills import ExecSettings
from kbplanner.simulation.skills.navigation import window
from kbplanner.simulation.workers import plan_workers
from kbplanner.world.build import build_world
from kbplanner.world.footprint import Footprint, Rect
from kbplanner.world.maps import storey_map
from kbplanner.world.occupancy import OccupancyGrid
from kbplanner.world.world_types import World

RESULTS = RESULTS_DIR
CASE_STUDY = REPO / "data" / "case_study"


def _rect(d: dict[str, float]) -> Rect:
    return Rect(d["cx"], d["cy"], d["length"], d["width"], d["yaw"])


def _yardsticks(run: Path, world: World, grid: OccupancyGrid) -> list[dict[str, Any]]:
    """Path length / grid shortest path per navigation step of a run directory."""
    metrics = json.loads((run / "metrics.json").read_text())
    fps = json.loads((run / "footprints.json").read_text())
    robot = Footprint(tuple(_rect(r) for r in fps["robot"]), name="robot")
    rows = [r.split(",") for r in (run / "trajectories.csv").read_text().splitlines()[1:]]
    times = [float(r[0]) for r in rows]
    fixes = [json.loads(line) for line in (run / "events.jsonl").read_text().splitlines()]
    fixes = [e for e in fixes if e["kind"] == "fix"]
    by_gid = {e.global_id: e for e in world.task_elements}
    steps = {(s["step"]): s for e in metrics["per_element"] for s in e["steps"]}
    out = []
    for nav in metrics["navigation"]:
        if nav["outcome"] != "succeeded" or nav["path_length_m"] <= 0:
            continue
        s = steps[nav["step"]]
        i0 = min(range(len(times)), key=lambda i: abs(times[i] - s["start_s"]))
        i1 = min(range(len(times)), key=lambda i: abs(times[i] - s["end_s"]))
        start = (float(rows[i0][1]), float(rows[i0][2]), float(rows[i0][3]))
        goal = (float(rows[i1][1]), float(rows[i1][2]), float(rows[i1][3]))
        g = grid
        for f in fixes:
            if f["t_s"] <= s["start_s"]:
                e = by_gid[f["element"]]
                ip = e.installed_pose
                assert ip is not None and e.local_bounds is not None
                frame = transform(ip.x, ip.y, ip.z, ip.roll, ip.pitch, ip.yaw)
                g = mark_polygon(g, element_polygon(e.local_bounds, frame))
        fp = robot
        if nav["element"] in fps["elements"] and nav["carry_modes"]:
            fp = robot.with_rect(_rect(fps["elements"][nav["element"]]["narrow"]))
        sub = window(g, [start[:2], goal[:2]], 10.0)
        ref = grid_shortest_path_length(sub, start, goal, fp)
        out.append({"step": nav["step"], "action": nav["action"], "path_length_m": nav["path_length_m"],
                    "grid_shortest_m": round(ref, 3),
                    "ratio": round(nav["path_length_m"] / ref, 3) if 0 < ref < float("inf") else None})
    return out


def bench(scenario: str, seed: int, tmp: Path) -> dict[str, Any]:
    t0 = time.perf_counter()
    project = Project.load(CASE_STUDY, scenario=scenario)
    world = build_world(project, parse_date(str(project.manifest.simulation["date"])))
    grid = storey_map(world).grid
    t1 = time.perf_counter()
    plan = plan_task(project, world=world)
    t2 = time.perf_counter()
    refined = refine_plan(plan, world, seed=seed, grid=grid)
    t3 = time.perf_counter()
    horizon = 1800.0 + 120.0 * len(refined.steps)
    workers = plan_workers(project.model, grid, seed=seed, horizon_s=horizon)
    t4 = time.perf_counter()
    c4 = time.process_time()
    run = tmp / scenario
    result = simulate(project, refined, seed=seed, out_dir=run, world=world, grid=grid, workers=workers,
                      settings=ExecSettings(keyframes=False))
    t5 = time.perf_counter()
    cpu_b5 = time.process_time() - c4
    timing = result.timing
    planning = sorted(timing["planning_time_s"].values())
    yard = _yardsticks(run, world, grid)
    ratios = [y["ratio"] for y in yard if y["ratio"] is not None]
    totals = result.metrics["totals"]
    return {
        "scenario": scenario,
        "installed": f"{totals['installed']} of {totals['elements']}",
        "sim_time_s": round(result.sim_time_s, 1),
        "wall_s": {"load_world_map": round(t1 - t0, 2), "plan_b1_b3": round(t2 - t1, 2),
                   "refine_b4": round(t3 - t2, 2), "workers": round(t4 - t3, 2),
                   "simulate_b5": round(t5 - t4, 2),
                   "ompl_planning_in_b5": timing["planning_total_s"]},
        "real_time_factor_b5": round(result.sim_time_s / (t5 - t4), 1),
        "cpu_b5_s": round(cpu_b5, 2),  # steadier than wall time on a busy machine
        "real_time_factor_b5_cpu": round(result.sim_time_s / cpu_b5, 1) if cpu_b5 > 0 else None,
        "real_time_factor_b4_b5": round(result.sim_time_s / (t5 - t2), 1),
        "navigations": len(planning),
        "planning_s": {"median": round(statistics.median(planning), 4) if planning else None,
                       "max": round(max(planning), 4) if planning else None},
        "path_vs_grid_shortest": {"median": round(statistics.median(ratios), 3) if ratios else None,
                                  "min": min(ratios, default=None), "max": max(ratios, default=None),
                                  "per_step": yard},
        "stops": totals["stops"], "replans": totals["replans"],
        "max_placement_error_m": result.metrics["placement"]["max_error_m"],
        "max_placement_error_deg": result.metrics["placement"]["max_error_deg"],
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", action="append", help="scenario(s) (default: both storage scenarios)")
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args(argv)
    scenarios = args.scenario or ["storage-outside", "storage-inside"]
    with tempfile.TemporaryDirectory() as tmp:
        rows = [bench(s, args.seed, Path(tmp)) for s in scenarios]
    peak_mb = peak_rss_mb()
    out = {"machine": machine_info(("python", "cpus", "platform")),
           "seed": args.seed, "peak_memory_mb": round(peak_mb, 1), "scenarios": rows}
    write_json(RESULTS / "simulation.json", out)
    w = sys.stdout.write
    w(f"{'scenario':18} {'installed':10} {'sim s':>7} {'B5 wall s':>9} {'x real':>7} {'B5 CPU s':>8} "
      f"{'x CPU':>6} {'OMPL s':>7} {'B4 s':>6} {'path/grid':>9} {'stops':>5}\n")
    for r in rows:
        w(f"{r['scenario']:18} {r['installed']:10} {r['sim_time_s']:7.1f} "
          f"{r['wall_s']['simulate_b5']:9.1f} "
          f"{r['real_time_factor_b5']:7.1f} {r['cpu_b5_s']:8.1f} {r['real_time_factor_b5_cpu'] or 0:6.1f} "
          f"{r['wall_s']['ompl_planning_in_b5']:7.2f} "
          f"{r['wall_s']['refine_b4']:6.1f} {r['path_vs_grid_shortest']['median'] or 0:9.3f} "
          f"{r['stops']:5d}\n")
    w(f"peak memory {peak_mb:.0f} MB; wrote {RESULTS / 'simulation.json'}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
