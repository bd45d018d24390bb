"""CPU split of B4 on a first run (issue 14, session 13, b4cold13): inside ``refine_kept``, the CPU seconds
of the configuration-space parts, their free maps and labels, the IK, the carry modes, the kernels and
the base-pose checks, each inclusive (a part called inside another counts in both; a part that calls
itself counts once), with the number of calls. Only calls made inside B4 are counted.

Run with ``PYTHONPATH`` at the sources of the tree to measure. B4 runs cold: a refined plan kept by an
earlier command is not read; remove ``PROJECT/.kbplanner-cache/cspace`` first for kept spaces not to be
read either (a user's first run of a scenario).

Usage: PYTHONPATH=TREE/src .venv/bin/python benchmarks/b4_cold_split.py OUT.json \\
       plan TREE/data/case_study --scenario S --seed 7          (or ``simulate ...``)
Writes OUT.json: {"parts_cpu_s": {name: [seconds, calls]}, "exit": code, "command": [...]}.
"""

from __future__ import annotations

import importlib
import json
import sys
import time
from collections.abc import Callable
from typing import Any

T: dict[str, float] = {}
N: dict[str, int] = {}
_inside: dict[str, bool] = {}

# (module, attribute, label): functions, replaced in every kbplanner module that holds them
FUNCTIONS = (
    ("kbplanner.planning.refine_cache", "refine_kept", "B4 (refine_kept)"),
    ("kbplanner.robot.arm_ik", "solve_ik", "IK (solve_ik)"),
    ("kbplanner.planning.carry", "carry_modes", "carry modes"),
    ("kbplanner.planning.carry", "rpy_of", "rpy_of"),
    ("kbplanner.world.cspace_join", "part_free", "parts' free maps (FFT)"),
    ("kbplanner.world.cspace_fft", "free_maps", "whole spaces' free maps (FFT)"),
    ("kbplanner.world.cspace_fft", "rasterised_kernel", "kernels (memoised look-ups)"),
    ("kbplanner.planning.base_poses", "escapes", "escapes"),
)
# (module, class, method, label)
METHODS = (
    ("kbplanner.planning.grasp_poses", "PickSearch", "pick", "pick search"),
    ("kbplanner.planning.install_poses", "InstallSearch", "install", "install search"),
    ("kbplanner.planning.carry_reach", "CarryReach", "way", "carry leg (CarryReach.way)"),
    ("kbplanner.world.cspace_join", "PartJoin", "__init__", "parts (PartJoin)"),
    ("kbplanner.world.footprint", "ConfigurationSpace", "_labels_and_roots", "labels"),
    ("kbplanner.planning.base_poses", "PoseChecker", "free", "PoseChecker.free"),
    ("kbplanner.planning.pose_search", "PoseSearch", "candidates", "seeded base poses"),
    ("kbplanner.planning.pose_search", "PoseSearch", "closest_free", "closest free base poses"),
)
B4 = FUNCTIONS[0][2]


def _wrap(label: str, f: Callable[..., Any]) -> Callable[..., Any]:
    def wrapped(*a: Any, **k: Any) -> Any:
        if _inside.get(label) or (label != B4 and not _inside.get(B4)):
            return f(*a, **k)
        _inside[label] = True
        c = time.process_time()
        try:
            return f(*a, **k)
        finally:
            T[label] = T.get(label, 0.0) + time.process_time() - c
            N[label] = N.get(label, 0) + 1
            _inside[label] = False
    return wrapped


def main(argv: list[str]) -> int:
    out, command = argv[0], argv[1:]
    import kbplanner.cli
    import kbplanner.planning.refine_cache as rc

    rc._read = lambda _path: None  # type: ignore[attr-defined]
    for mod, cls, meth, label in METHODS:
        owner = getattr(importlib.import_module(mod), cls)
        setattr(owner, meth, _wrap(label, owner.__dict__[meth]))
    for mod, attr, label in FUNCTIONS:
        orig = getattr(importlib.import_module(mod), attr)
        wrapped = _wrap(label, orig)
        for m in [m for n, m in list(sys.modules.items()) if n.startswith("kbplanner")]:
            if getattr(m, attr, None) is orig:
                setattr(m, attr, wrapped)
    code = kbplanner.cli.main(command)
    parts = {k: [round(v, 3), N[k]] for k, v in sorted(T.items(), key=lambda kv: -kv[1])}
    with open(out, "w", encoding="utf-8") as f:
        json.dump({"parts_cpu_s": parts, "exit": code, "command": command}, f, indent=1)
    for k, (v, n) in parts.items():
        print(f"{k:32} {v:7.3f} s {n:7d} calls")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
