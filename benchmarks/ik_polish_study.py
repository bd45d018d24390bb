"""B4's numeric IK polish (issue 14, item 2): could an exact reach bound or a memo skip it? A study.

B4 asks the closed-form IK (``RefineSettings.ik_method = "closed_form"``); a pose just out of its reach
(the stretched arm within ``arm_ik.POLISH_RANGE`` position tolerances) is polished by PyBullet's numeric
IK from the stretched poses, about a third of B4's CPU. A sound test that no joint angles put the tool
within the tolerances (1 cm and 3 degrees; 5 mm and 1 degree for the place pose) would let B4 skip the
polish exactly where it decides; a memo of IK results would skip queries asked again. This script runs B4
on the case study (both storage scenarios, seed 7), counts the IK queries and those asked before with the
same base pose, target and arguments, and, at every polish, records:

- whether the polish found a pose (``reachable``) and its CPU seconds;
- the exact reach gap: the distance of the shoulder point (DH frame 1's origin) from the circle the origin
  of DH frame 4 lies on for this flange pose (radius ``d5`` around the wrist centre, across the tool axis),
  less the farthest frame 4 can be from the shoulder (``hypot(d2 + d3 + d4, |a2| + |a3| + |a4|) + |a1|``).
  Positive: the pose itself is out of reach by at least that much. The bound decides "no pose within the
  tolerances" when the gap exceeds the slack the tolerances give: ``pos_tol + rot_tol * (|wrist - TCP| +
  d5)`` (the circle moves with the tool: at most the position tolerance, plus the rotation tolerance times
  the lever from the tool point);
- whether a pose within the tolerances exists (found by the closed form on targets turned by 0.98 of the
  rotation tolerance about random axes and moved by 0.98 of the position tolerance, and checked as
  ``arm_ik._check`` checks: PyBullet's forward kinematics, the tolerances, the arm clear of the base).
  Where one exists no sound bound can skip the polish.

Usage: .venv/bin/python benchmarks/ik_polish_study.py [--scenario S ...] [--trials N]
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


def exact_reach_gap_m(arm: Any, target: np.ndarray) -> float:
    """How far frame 4's circle stays beyond the farthest frame 4 can be from the shoulder (m)."""
    from kbplanner.robot.arm_analytic_ik import _inv, dh_matrix

    t06 = target @ _inv(dh_matrix(0.0, 0.0, arm.a[5], arm.alpha[5]))
    axis = t06[:3, 2]
    centre = t06[:3, 3] - arm.d[5] * axis
    v = np.array([0.0, 0.0, arm.d[0]]) - centre
    along = float(v @ axis)
    across = float(np.linalg.norm(v - along * axis))
    planar = abs(arm.a[1]) + abs(arm.a[2]) + abs(arm.a[3])
    far = math.hypot(arm.d[1] + arm.d[2] + arm.d[3], planar) + abs(arm.a[0])
    return math.hypot(along, across - abs(arm.d[4])) - far


def study(scenario: str, seed: int, trials: int) -> dict[str, Any]:
    import kbplanner.robot.arm_ik as ai
    from kbplanner.planning.manipulation import refine_plan
    from kbplanner.planning.planner import plan_task
    from kbplanner.project import Project
    from kbplanner.robot.arm_analytic_ik import closed_form, place_nearest, wrist_centre
    from kbplanner.world.build import build_world
    from kbplanner.world.maps import storey_map

    project = Project.load(REPO / "data" / "case_study", scenario=scenario)
    world = build_world(project, project.world_date(None), None)
    plan = plan_task(project, world=world)
    grid = storey_map(world).grid
    rows: list[dict[str, Any]] = []
    numeric = ai._solve_numeric
    rng = np.random.default_rng(0)

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
        target = ai._rigid_inv(at) @ ai._matrix(xyz, orn) @ ai._rigid_inv(model.tool_in_flange)
        tcp = (target @ model.tool_in_flange)[:3, 3]
        lever = float(np.linalg.norm(tcp - wrist_centre(model.arm, target)))
        gap = exact_reach_gap_m(model.arm, target)
        slack = pos_tol + rot_tol * (lever + abs(model.arm.d[4]))
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
        rows.append({"reachable": result.reachable, "cpu_s": round(cpu, 4), "pos_tol_m": pos_tol,
                     "gap_m": round(gap, 5), "slack_m": round(slack, 5), "decided": gap > slack,
                     "pose_within_tolerances": exists, "numeric_error_m": round(result.position_error_m, 5)})
        return result

    queries: dict[tuple[Any, ...], int] = {}
    solve = ai.solve_ik

    def counted(robot: Any, target_xyz: Any, target_rpy: Any = None, **kwargs: Any) -> Any:
        key = (robot.base_pose(), robot.floor_z, tuple(target_xyz), target_rpy,
               tuple(sorted((k, repr(v)) for k, v in kwargs.items())))
        queries[key] = queries.get(key, 0) + 1
        return solve(robot, target_xyz, target_rpy, **kwargs)

    modules = [m for m in list(sys.modules.values()) if getattr(m, "__name__", "").startswith("kbplanner")
               and getattr(m, "solve_ik", None) is solve]
    ai._solve_numeric = polish
    for m in modules:
        m.solve_ik = counted  # type: ignore[attr-defined]
    try:
        c0 = time.process_time()
        refine_plan(plan, world, seed=seed, grid=grid)
        b4_cpu = time.process_time() - c0
    finally:
        ai._solve_numeric = numeric
        for m in modules:
            m.solve_ik = solve  # type: ignore[attr-defined]
    failed = [r for r in rows if not r["reachable"]]
    return {"scenario": scenario, "seed": seed, "trials": trials, "b4_cpu_s_with_study": round(b4_cpu, 2),
            "ik_queries": sum(queries.values()),
            "ik_queries_asked_before": sum(queries.values()) - len(queries),
            "polishes": len(rows), "polish_cpu_s": round(sum(r["cpu_s"] for r in rows), 3),
            "found_a_pose": sum(r["reachable"] for r in rows),
            "decided_by_the_bound": sum(r["decided"] for r in rows),
            "wrongly_decided": sum(r["decided"] and r["reachable"] for r in rows),
            "failed_with_a_pose_within_tolerances": sum(r["pose_within_tolerances"] for r in failed),
            "failed": len(failed), "rows": rows}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", action="append", help="scenario(s) (default: both storage scenarios)")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--trials", type=int, default=300, help="perturbed targets tried per failed polish")
    ap.add_argument("--out", type=Path, default=RESULTS_DIR / "ik_polish_study.json")
    args = ap.parse_args(argv)
    scenarios = args.scenario or ["storage-outside", "storage-inside"]
    results = [study(s, args.seed, args.trials) for s in scenarios]
    write_json(args.out, {"machine": machine_info(("python", "cpus", "platform")), "scenarios": results})
    for r in results:
        sys.stdout.write(
            f"{r['scenario']}: {r['ik_queries']} IK queries, {r['ik_queries_asked_before']} asked before "
            f"with the same base pose, target and arguments; {r['polishes']} polishes "
            f"({r['polish_cpu_s']} s CPU), {r['found_a_pose']} "
            f"found a pose; the exact reach bound decides {r['decided_by_the_bound']} (wrongly: "
            f"{r['wrongly_decided']}); {r['failed_with_a_pose_within_tolerances']} of the {r['failed']} "
            "failed have a pose within the tolerances\n")
    sys.stdout.write(f"wrote {args.out}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
