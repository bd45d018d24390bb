"""B4's IK near misses (issue 14, item 2): the closed form within the tolerances against the numeric polish.

B4 asks the closed-form IK (``RefineSettings.ik_method = "closed_form"``). A pose just out of its reach
is searched within the tolerances (``arm_analytic_ik.near_reach``: the closed form on the pose moved
towards the arm's reach, each solution checked as ``arm_ik._check`` checks: PyBullet's forward
kinematics, the tolerances, the arm clear of the base). Session 9's code polished such poses with
PyBullet's numeric IK instead (now off: ``arm_ik.POLISH``). This script runs B4 on the case study (both
storage scenarios, seed 7) with the polish switched on *after* the search, so that it counts:

- the searches (``near``) and how many found a pose, with their CPU seconds;
- the polishes (where the search found none and the stretched arm lands within ``POLISH_RANGE``
  position tolerances) and how many found a pose the search did not (what dropping the polish loses),
  with their CPU seconds;
- for each polish that found nothing either, whether a pose within the tolerances exists (the
  closed form on targets turned by 0.98 of the rotation tolerance about random axes and moved by 0.98
  of the position tolerance, ``--trials`` per pose, checked as ``arm_ik._check`` checks): what both
  miss.

The run with the polish on is not B4's plan (the polish finds poses the plan does not use); the counts
are of that run.

Usage: .venv/bin/python benchmarks/ik_polish_study.py [--scenario S ...] [--trials N] [--branches N]
Prints the counts and writes benchmarks/results/ik_polish_study.json (or --out).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from _common import REPO, RESULTS_DIR, machine_info, write_json


def study(scenario: str, seed: int, trials: int, branches: int) -> dict[str, Any]:
    import kbplanner.robot.arm_analytic_ik as aa
    import kbplanner.robot.arm_ik as ai
    from kbplanner.planning.manipulation import refine_plan
    from kbplanner.planning.planner import plan_task
    from kbplanner.project import Project
    from kbplanner.robot.arm_analytic_ik import closed_form, place_nearest
    from kbplanner.world.build import build_world
    from kbplanner.world.maps import storey_map

    project = Project.load(REPO / "data" / "case_study", scenario=scenario)
    world = build_world(project, project.world_date(None), None)
    plan = plan_task(project, world=world)
    grid = storey_map(world).grid
    near_rows: list[dict[str, Any]] = []
    polish_rows: list[dict[str, Any]] = []
    numeric = ai._solve_numeric
    near = ai._Analytic.near
    rng = np.random.default_rng(0)

    def searched(self: Any, *args: Any) -> Any:
        c0 = time.process_time()
        result = near(self, *args)
        near_rows.append({"found": bool(result is not None and result.reachable),
                          "cpu_s": time.process_time() - c0})
        return result

    def polish(robot: Any, xyz: Any, orn: Any, seeds: Any, pos_tol: float, rot_tol: float, collide: bool,
               refinements: int) -> Any:
        c0 = time.process_time()
        result = numeric(robot, xyz, orn, seeds, pos_tol, rot_tol, collide, refinements)
        cpu = time.process_time() - c0
        if refinements != 2 or orn is None:  # not the polish (the numeric fallback IK)
            return result
        model = ai.analytic_arm(robot)
        saved = robot.arm_positions()
        at = ai._matrix(*robot.link_pose(robot.links["arm_base_link"])) @ model.base_in_arm_base
        exists = result.reachable
        tool = ai._matrix(xyz, orn)
        for _ in range(trials if not exists else 0):
            axis = rng.normal(size=3)
            axis /= np.linalg.norm(axis)
            k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
            turn = 0.98 * rot_tol
            moved = tool.copy()
            moved[:3, :3] = tool[:3, :3] @ (np.eye(3) + math.sin(turn) * k + (1 - math.cos(turn)) * k @ k)
            shift = rng.normal(size=3)
            moved[:3, 3] = tool[:3, 3] + 0.98 * pos_tol * shift / np.linalg.norm(shift)
            flange = ai._rigid_inv(at) @ moved @ ai._rigid_inv(model.tool_in_flange)
            for q in place_nearest(model.arm, closed_form(model.arm, flange, seeds[0]), seeds[0]):
                if ai._check(robot, q, xyz, orn, pos_tol, rot_tol, collide).reachable:
                    exists = True
                    break
            if exists:
                break
        robot.set_arm(saved)
        polish_rows.append({"found": result.reachable, "cpu_s": round(cpu, 4), "pos_tol_m": pos_tol,
                            "pose_within_tolerances": exists,
                            "numeric_error_m": round(result.position_error_m, 5)})
        return result

    was, was_branches = ai.POLISH, aa.NEAR_BRANCHES
    aa.NEAR_BRANCHES = branches
    ai._solve_numeric = polish
    ai._Analytic.near = searched  # type: ignore[method-assign]
    ai.POLISH = True
    try:
        c0 = time.process_time()
        refine_plan(plan, world, seed=seed, grid=grid)
        b4_cpu = time.process_time() - c0
    finally:
        ai._solve_numeric = numeric
        ai._Analytic.near = near  # type: ignore[method-assign]
        ai.POLISH, aa.NEAR_BRANCHES = was, was_branches
    failed = [r for r in polish_rows if not r["found"]]
    return {"scenario": scenario, "seed": seed, "trials": trials, "branches": branches,
            "b4_cpu_s_with_study": round(b4_cpu, 2),
            "searches": len(near_rows), "search_found": sum(r["found"] for r in near_rows),
            "search_cpu_s": round(sum(r["cpu_s"] for r in near_rows), 3),
            "polishes": len(polish_rows), "polish_found": sum(r["found"] for r in polish_rows),
            "polish_cpu_s": round(sum(r["cpu_s"] for r in polish_rows), 3),
            "neither_found_but_a_pose_within_tolerances": sum(r["pose_within_tolerances"] for r in failed),
            "neither_found": len(failed), "polish_rows": polish_rows}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", action="append", help="scenario(s) (default: both storage scenarios)")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--trials", type=int, default=300, help="perturbed targets tried per pose neither found")
    ap.add_argument("--branches", type=int, default=1,
                    help="branches of the stretched arm the search follows (arm_analytic_ik.NEAR_BRANCHES)")
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "ik_polish_study.json")
    args = ap.parse_args(argv)
    scenarios = args.scenario or ["storage-outside", "storage-inside"]
    results = [study(s, args.seed, args.trials, args.branches) for s in scenarios]
    write_json(args.out, {"machine": machine_info(("python", "cpus", "platform")), "scenarios": results})
    for r in results:
        sys.stdout.write(
            f"{r['scenario']}: {r['searches']} searches within the tolerances ({r['search_cpu_s']} s CPU), "
            f"{r['search_found']} found a pose; the numeric polish after the {r['polishes']} near misses "
            f"left ({r['polish_cpu_s']} s CPU) found {r['polish_found']} more; of the {r['neither_found']} "
            f"neither found, {r['neither_found_but_a_pose_within_tolerances']} have a pose within the "
            "tolerances (random search)\n")
    sys.stdout.write(f"wrote {args.out}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
