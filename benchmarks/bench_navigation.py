"""Navigation benchmark (B5): planning time, success and path-length ratio vs the grid shortest path.

Maps: synthetic two-room maps (0.9 m and 1.2 m doors), a four-room flat with a corridor, and, when
the case study's Duplex IFC is present, its Level 1 imported with kbplanner.model.ifc_import (doors open,
spaces not obstacles). Planners: RRTConnect (default, stops at the first solution, deterministic per
seed) against BIT* and InformedRRT* with a fixed time budget; every path is shortcut-simplified.
Also the carry-mode planner (wide 1.2 m panel through a 0.9 m door).

Usage: .venv/bin/python benchmarks/bench_navigation.py [--quick]
Prints a table and writes benchmarks/results/navigation.json (and the Duplex map as PGM/YAML).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from typing import Any

import numpy as np
import trimesh
from _common import REPO, RESULTS_DIR, Timer, machine_info, write_json

from kbplanner.simulation.carry_paths import plan_with_carry_modes
from kbplanner.simulation.grid_yardstick import grid_shortest_path_length
from kbplanner.simulation.nav_path import NavSettings
from kbplanner.simulation.navigation import plan_path
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import Box, OccupancyGrid, occupancy_from_meshes

RESULTS = RESULTS_DIR
DUPLEX = REPO / "data" / "case_study" / "model" / "Duplex_A_20110907.ifc"

BASE = Footprint((Rect(0.0, 0.0, 0.99, 0.67),), name="husky")
NARROW = BASE.with_rect(Rect(0.0, 0.0, 1.2, 0.1), name="panel on its side")
WIDE = BASE.with_rect(Rect(0.0, 0.0, 0.6, 1.2), name="panel flat across")


def box(x0: float, y0: float, x1: float, y1: float) -> trimesh.Trimesh:
    mesh = trimesh.creation.box(extents=(x1 - x0, y1 - y0, 2.7))
    mesh.apply_translation(((x0 + x1) / 2, (y0 + y1) / 2, 1.35))
    return mesh


def two_rooms(door: float) -> OccupancyGrid:
    lo, hi = 2.0 - door / 2, 2.0 + door / 2
    walls = [
        box(-0.2, -0.2, 8.4, 0.0),
        box(-0.2, 4.0, 8.4, 4.2),
        box(-0.2, 0.0, 0.0, 4.0),
        box(8.2, 0.0, 8.4, 4.0),
        box(4.0, 0.0, 4.2, lo),
        box(4.0, hi, 4.2, 4.0),
    ]
    return occupancy_from_meshes(walls, (0.05, 1.5), Box(-0.5, -0.5, 8.7, 4.5))


def flat() -> OccupancyGrid:
    """Four 7 x 3.3 m rooms off a 1.4 m corridor through 0.9 m doors, like the case study's apartment."""
    w = [
        box(-0.2, -0.2, 14.4, 0.0),
        box(-0.2, 8.4, 14.4, 8.6),
        box(-0.2, 0.0, 0.0, 8.4),
        box(14.2, 0.0, 14.4, 8.4),
    ]
    for y0, y1 in ((3.3, 3.5), (4.9, 5.1)):  # corridor walls, doors at x 1.0-1.9 and 8.0-8.9
        for a, b in ((0.0, 1.0), (1.9, 8.0), (8.9, 14.2)):
            w.append(box(a, y0, b, y1))
    w += [box(7.0, 0.0, 7.2, 3.3), box(7.0, 5.1, 7.2, 8.4)]  # room dividers
    return occupancy_from_meshes(w, (0.05, 1.5), Box(-0.5, -0.5, 14.7, 8.9))


def duplex_level1() -> (
    tuple[OccupancyGrid, tuple[float, float, float], tuple[float, float, float]] | None
):
    if not DUPLEX.is_file():
        return None
    from rdflib import RDF

    from kbplanner.core.iris import base_iri
    from kbplanner.core.vocab import BOT, KBP
    from kbplanner.model.ifc_import import import_ifc_graph

    res = import_ifc_graph(DUPLEX, base=base_iri("duplex"))
    storey = min((s for s in res.storeys if s.elevation_m > -0.5), key=lambda s: s.elevation_m)
    open_or_void = {KBP.Door, BOT.Space, KBP.Opening}
    blocking = []
    for node, gid in res.graph.subject_objects(KBP.globalId):
        types = set(res.graph.objects(node, RDF.type))
        if types & open_or_void or str(gid) not in res.meshes:
            continue
        blocking.append(res.meshes[str(gid)])
    z0 = storey.elevation_m
    walls = [m for m in blocking if m.bounds[0][2] < z0 + 1.5 and m.bounds[1][2] > z0 + 0.05]
    grid = occupancy_from_meshes(walls, (z0 + 0.05, z0 + 1.5), Box.around(walls, 0.5), 0.05)
    grid.to_pgm_yaml(RESULTS, "duplex_level1_map")
    # Start and goal: the two best-cleared cells of the largest free component, far apart.
    cs = ConfigurationSpace.build(grid, BASE)
    from scipy import ndimage

    free = cs.free_any_yaw()
    labels, _ = ndimage.label(free, structure=np.ones((3, 3)))
    largest = np.bincount(labels.ravel())[1:].argmax() + 1
    clearance = grid.clearance_m()
    iy, ix = np.nonzero((labels == largest) & (clearance > 0.55))
    pts = np.c_[grid.origin[0] + (ix + 0.5) * 0.05, grid.origin[1] + (iy + 0.5) * 0.05]
    d = np.hypot(*(pts[:, None, :] - pts[None, ::50, :]).transpose(2, 0, 1))
    i, j = np.unravel_index(np.argmax(d), d.shape)
    start = (float(pts[i, 0]), float(pts[i, 1]), 0.0)
    goal = (float(pts[::50][j, 0]), float(pts[::50][j, 1]), 0.0)
    if not (cs.is_free(*start) and cs.is_free(*goal)):
        return None
    return grid, start, goal


def run_case(
    name: str,
    grid: OccupancyGrid,
    start: tuple[float, float, float],
    goal: tuple[float, float, float],
    footprint: Footprint,
    planners: list[tuple[str, float, list[int]]],
) -> list[dict[str, Any]]:
    with Timer() as timer:
        cs = ConfigurationSpace.build(grid, footprint)
    build_s = timer.seconds
    shortest = grid_shortest_path_length(cs, start, goal)
    rows = []
    for planner, budget, seeds in planners:
        times, lengths, ok = [], [], 0
        for seed in seeds:
            path = plan_path(
                cs, start, goal, settings=NavSettings(planner=planner, time_limit_s=budget, seed=seed)
            )
            if path.ok:
                ok += 1
                times.append(path.planning_time_s)
                lengths.append(path.length_m)
        row = {
            "map": name,
            "footprint": footprint.name,
            "cells": list(grid.shape),
            "cspace_build_s": round(build_s, 3),
            "planner": planner,
            "budget_s": budget,
            "runs": len(seeds),
            "solved": ok,
            "time_median_s": round(statistics.median(times), 3) if times else None,
            "time_max_s": round(max(times), 3) if times else None,
            "grid_shortest_m": round(shortest, 3),
            "length_median_m": round(statistics.median(lengths), 3) if lengths else None,
            "ratio_median": round(statistics.median(lengths) / shortest, 3) if lengths else None,
            "ratio_max": round(max(lengths) / shortest, 3) if lengths else None,
        }
        rows.append(row)
        print(
            f"{name:22s} {footprint.name:18s} {planner:16s} {ok}/{len(seeds)} "
            f"t_med={row['time_median_s']} t_max={row['time_max_s']} ratio_med={row['ratio_median']} "
            f"ratio_max={row['ratio_max']} (grid {shortest:.2f} m, C-space {build_s:.2f} s)",
            flush=True,
        )
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer seeds, shorter budgets")
    args = parser.parse_args(argv)
    seeds = list(range(1, 4 if args.quick else 11))
    budget = 1.0 if args.quick else 3.0
    planners = [
        ("RRTConnect", 10.0, seeds),
        ("BITstar", budget, seeds[:3]),
        ("InformedRRTstar", budget, seeds[:3]),
    ]
    RESULTS.mkdir(parents=True, exist_ok=True)
    rows: list[dict[str, Any]] = []
    start, goal = (1.5, 1.0, 0.5), (6.5, 3.0, -1.0)
    rows += run_case("two rooms, 0.9 m door", two_rooms(0.9), start, goal, NARROW, planners)
    rows += run_case("two rooms, 0.9 m door", two_rooms(0.9), start, goal, BASE, planners)
    rows += run_case("two rooms, 1.2 m door", two_rooms(1.2), start, goal, BASE, planners)
    rows += run_case("flat, 0.9 m doors", flat(), (2.0, 1.5, 0.0), (12.0, 7.0, 1.57), BASE, planners)
    carry = []
    for seed in seeds:
        timer = Timer()
        plan = plan_with_carry_modes(two_rooms(0.9), start, goal, WIDE, NARROW, NavSettings(seed=seed))
        carry.append(
            {
                "seed": seed,
                "ok": plan.ok,
                "mode": plan.mode,
                "wall_s": round(timer.elapsed(), 3),
                "narrow_length_m": round(plan.extra.get("narrow_length_m", 0.0), 3),
                "path_length_m": round(plan.path.length_m, 3),
            }
        )
    print("carry modes (1.2 m panel, 0.9 m door):", json.dumps(carry[:3]), "...", flush=True)
    duplex: dict[str, Any] = {"available": False}
    found = duplex_level1()
    if found is not None:
        grid, s, g = found
        duplex = {
            "available": True,
            "start": s,
            "goal": g,
            "cells": list(grid.shape),
            "occupied_fraction": round(1 - grid.free_fraction, 3),
        }
        rows += run_case("Duplex Level 1", grid, s, g, BASE, planners)
    out = {
        "machine": machine_info(),
        "quick": args.quick,
        "rows": rows,
        "carry_modes": carry,
        "duplex": duplex,
    }
    write_json(RESULTS / "navigation.json", out, sort_keys=True)
    print(f"wrote {RESULTS / 'navigation.json'}")
    return 0 if all(r["solved"] == r["runs"] for r in rows if r["planner"] == "RRTConnect") else 1


if __name__ == "__main__":
    sys.exit(main())
