"""Task planning (paper: steps B1-B4): skill inputs by SPARQL from the bindings, element order, the
action-level plan with its robot, and arm/base poses plus carry modes refined by inverse kinematics.
"""

import importlib
from typing import Any

# The modules that held 0.1's flat ``kbplanner.planning`` module (planner.py, then split along its steps).
_FLAT = ("planner", "task_and_robot", "plan_steps", "plan_elements")


def __getattr__(name: str) -> Any:
    """``from kbplanner.planning import X`` as with 0.1's flat module: X of :mod:`.planner` (or the
    modules split from it)."""
    if name.startswith("__"):
        raise AttributeError(name)
    for short in _FLAT:
        module = importlib.import_module(f"kbplanner.planning.{short}")
        if hasattr(module, name):
            return getattr(module, name)
    raise AttributeError(f"module 'kbplanner.planning' has no attribute {name!r}")
