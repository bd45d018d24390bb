"""CPU seconds of the phases of one ``kbplanner simulate`` run, in its own process (issue 14, session 12):
the imports of the command, ``Project.load``, ``build_world``, ``plan_task`` (B1-B3), ``storey_map``,
``refine_kept`` (B4 or the kept plan), ``executor.simulate`` and its run loop (``_Run.run``); what the
command spends outside them is ``total`` minus their sum. Run with ``PYTHONPATH`` at the sources of
the tree to measure (a baseline's exported tree, or this one).

Usage: PYTHONPATH=TREE/src .venv/bin/python benchmarks/simulate_phases.py OUT.json [warm|cold] \\
       simulate TREE/data/case_study --scenario S --seed 7 --out DIR --force
(``cold``: a refined plan kept by an earlier command is not read, B4 runs.) Writes OUT.json.
"""

from __future__ import annotations

import time

_T0 = time.process_time()

import importlib  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
from collections.abc import Callable  # noqa: E402
from typing import Any  # noqa: E402

T: dict[str, float] = {}
#: B4's pose search and IK (a warm command, its refined plan kept, needs none of them; issue 14)
B4_SEARCH = ("kbplanner.planning.manipulation", "kbplanner.planning.pose_search", "kbplanner.robot.arm_ik")


def _timed(label: str, f: Callable[..., Any]) -> Callable[..., Any]:
    def wrapped(*a: Any, **k: Any) -> Any:
        c = time.process_time()
        try:
            return f(*a, **k)
        finally:
            T[label] = T.get(label, 0.0) + time.process_time() - c
    return wrapped


def main(argv: list[str]) -> int:
    out, mode, command = argv[0], argv[1], argv[2:]
    c = time.process_time()
    # the command's own imports, as cli/simulate.run makes them
    import rich.console
    import rich.progress
    import rich.table  # noqa: F401

    import kbplanner.planning.planner
    import kbplanner.planning.refine_cache as rc
    import kbplanner.project
    import kbplanner.simulation.executor as ex
    import kbplanner.world.build
    import kbplanner.world.maps
    from kbplanner.cli import main as cli_main
    T["imports"] = time.process_time() - c
    if mode == "cold":
        rc._read = lambda _path: None  # type: ignore[attr-defined]
    project_cls = kbplanner.project.Project
    load = project_cls.load.__func__  # type: ignore[attr-defined]
    project_cls.load = classmethod(_timed("Project.load", load))  # type: ignore[method-assign,assignment]
    for mod, attr in (("kbplanner.world.build", "build_world"), ("kbplanner.planning.planner", "plan_task"),
                      ("kbplanner.world.maps", "storey_map"),
                      ("kbplanner.planning.refine_cache", "refine_kept"),
                      ("kbplanner.simulation.executor", "simulate")):
        m = importlib.import_module(mod)
        setattr(m, attr, _timed(attr, getattr(m, attr)))
    ex._Run.run = _timed("run loop", ex._Run.run)  # type: ignore[method-assign]
    code = cli_main(command)
    T["total"] = time.process_time() - _T0
    with open(out, "w", encoding="utf-8") as f:
        json.dump({"phases_cpu_s": {k: round(v, 3) for k, v in T.items()}, "exit": code, "mode": mode,
                   "command": command, "modules": len(sys.modules),
                   "b4_search_imported": sorted(m for m in B4_SEARCH if m in sys.modules)}, f, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
