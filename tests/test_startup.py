"""Start-up (issue 14): registering the commands imports no heavy library; the project cache."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

HEAVY = ("rdflib", "pyshacl", "pybullet", "ifcopenshell", "matplotlib", "trimesh", "numpy", "scipy",
         "ompl", "pyoxigraph", "rich")


def _modules_after(code: str) -> set[str]:
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1] / "src")}
    probe = code + "\nimport sys, json; print(json.dumps(sorted(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True, env=env)
    return set(json.loads(out.stdout.splitlines()[-1]))


def test_building_the_parser_imports_no_graph_simulation_or_plot_library() -> None:
    loaded = _modules_after("import kbplanner.cli as c; c.build_parser()")
    assert "kbplanner.cli.simulate" in loaded  # every command registered ...
    assert not {m for m in loaded if m.split(".")[0] in HEAVY}  # ... without a heavy import


def test_help_of_a_command_imports_no_heavy_library() -> None:
    loaded = _modules_after("from kbplanner.cli import main\nassert main(['query', '--help']) == 0")
    assert not {m for m in loaded if m.split(".")[0] in HEAVY}


#: B4's pose search and IK: what ``kbplanner simulate`` runs only when no refined plan is kept
#: (``planning/refine_cache.py`` imports ``manipulation`` when B4 runs; ``carry`` and the fasten skill
#: import the IK where they call it).
B4_SEARCH = ("kbplanner.planning.manipulation", "kbplanner.planning.grasp_poses",
             "kbplanner.planning.install_poses", "kbplanner.planning.pose_search",
             "kbplanner.planning.carry_reach", "kbplanner.planning.install_order",
             "kbplanner.robot.arm_ik", "kbplanner.robot.arm_analytic_ik")


def test_the_simulate_command_imports_no_b4_search_or_ik(tmp_path: Path) -> None:
    # the command's own imports (the top of cli/simulate.run) are made, then the unknown project stops it
    words = ["simulate", str(tmp_path / "no-project"), "--out", str(tmp_path / "run")]
    loaded = _modules_after(f"from kbplanner.cli import main\nassert main({words!r}) == 2")
    assert {"kbplanner.simulation.executor", "kbplanner.planning.refine_cache",
            "kbplanner.planning.step_kinds"} <= loaded  # the command's modules were imported ...
    assert not [m for m in B4_SEARCH if m in loaded]  # ... and B4's search and IK were not

