"""B4's IK queries of a first run, recorded and replayed (issue 14, session 14, b4first14): the CPU of
``solve_ik`` alone and whether a tree gives the very results another recorded.

``record`` runs a command with B4 cold (a refined plan kept earlier is not read) and keeps every
``solve_ik`` call: the robot, the arguments of the base's last placing, the arm's angles, the call's
arguments and its result. ``replay`` loads the robot once and makes the calls again in order (base
placed as it was, arm set as it was), ``--rounds`` times, and counts results whose ``repr`` differs.

Usage: PYTHONPATH=TREE/src .venv/bin/python benchmarks/ik_replay.py record CALLS.pkl \\
           plan TREE/data/case_study --scenario S --seed 7
       PYTHONPATH=TREE/src .venv/bin/python benchmarks/ik_replay.py replay CALLS.pkl [--rounds 3] [--out J]
(the pickle is a local file this script wrote; ``replay`` prints and optionally writes JSON.)
"""

from __future__ import annotations

import argparse
import json
import pickle
import sys
import time
from typing import Any


def record(out: str, command: list[str]) -> int:
    import kbplanner.planning.grasp_poses
    import kbplanner.planning.install_poses
    import kbplanner.planning.manipulation
    import kbplanner.planning.pose_search
    import kbplanner.planning.refine_cache as rc
    import kbplanner.robot.arm_ik as ai
    from kbplanner.cli import main as cli_main
    from kbplanner.robot.robot_model import RobotModel

    _ = (kbplanner.planning.grasp_poses, kbplanner.planning.install_poses, kbplanner.planning.manipulation,
         kbplanner.planning.pose_search)
    rc._read = lambda _path: None  # type: ignore[attr-defined]
    reset = RobotModel._reset_base

    def reset_kept(self: Any, x: float, y: float, yaw: float, z: float) -> None:
        self._last_base = (x, y, yaw, z)
        reset(self, x, y, yaw, z)

    RobotModel._reset_base = reset_kept  # type: ignore[method-assign]
    calls: list[Any] = []
    orig = ai.solve_ik

    def kept(robot: Any, *a: Any, **k: Any) -> Any:
        base, arm = robot._last_base, robot.arm_positions()
        r = orig(robot, *a, **k)
        calls.append((robot.spec.name, base, arm, a, k, r))
        return r

    for name, m in list(sys.modules.items()):
        if name.startswith("kbplanner") and getattr(m, "solve_ik", None) is orig:
            m.solve_ik = kept  # type: ignore[attr-defined]
    code = cli_main(command)
    with open(out, "wb") as f:
        pickle.dump(calls, f)
    print(f"{len(calls)} solve_ik calls recorded (exit {code})")
    return 0


def replay(path: str, rounds: int, out: str | None) -> int:
    from kbplanner.robot.arm_ik import solve_ik
    from kbplanner.robot.robot_model import RobotModel

    with open(path, "rb") as f:
        calls = pickle.load(f)  # a file record() wrote
    robot = RobotModel.load(calls[0][0])
    cpu: list[float] = []
    differ = 0
    for _ in range(rounds):
        differ = 0
        c = time.process_time()
        for _name, base, arm, a, k, r in calls:
            robot._reset_base(*base)
            robot.set_arm(arm)
            if repr(solve_ik(robot, *a, **k)) != repr(r):
                differ += 1
        cpu.append(time.process_time() - c)
        print(f"{len(calls)} calls, {differ} differ, {cpu[-1]:.3f} s CPU")
    robot.close()
    if out:
        with open(out, "w", encoding="utf-8") as f:
            json.dump({"calls": len(calls), "differ": differ, "cpu_s": [round(c, 3) for c in cpu],
                       "best_cpu_s": round(min(cpu), 3), "recorded": path}, f, indent=1)
    return 1 if differ else 0


def main(argv: list[str]) -> int:
    if argv and argv[0] == "record":
        return record(argv[1], argv[2:])
    ap = argparse.ArgumentParser()
    ap.add_argument("mode", choices=["replay"])
    ap.add_argument("calls")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--out")
    ns = ap.parse_args(argv)
    return replay(ns.calls, ns.rounds, ns.out)


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
